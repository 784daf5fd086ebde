r"""The batch path of :class:`~fts_calib.robot.kinematics.Kinematics`: N readings at once.

Private to :class:`Kinematics`, which stays the only forward kinematics of fts-calib: it
builds a :class:`Chain` from its model and calls it for batches (one reading goes through
Pinocchio instead). The chain from the root to the sensor frame S is walked once for all N
readings, from the model's joint placements and axes:

.. math::

    R_k = R_{k-1} M_k R_{u_k}(q_k), \quad
    \omega_k = \omega_{k-1} + z_k \dot q_k, \quad
    \alpha_k = \alpha_{k-1} + \omega_{k-1} \times z_k \dot q_k + z_k \ddot q_k,

    a_k = a_{k-1} + \alpha_{k-1} \times r_k + \omega_{k-1} \times (\omega_{k-1} \times r_k)

with ``z_k`` the joint axis and ``r_k`` the offset of joint k from its parent, both in the
world frame (prismatic joints add their velocity and Coriolis terms). Joint readings in
[rad] or [m], (N, n_joints) in the order of :attr:`Kinematics.joint_names`; positions in
[m]; results in the world frame or, where the name says so, in S.

A stack of N rotations is stored by columns, ``cols`` of shape (3, N, 3) with
``cols[j, n] = R[n][:, j]``: a joint rotation then mixes two contiguous arrays, and a
product with a constant matrix is one (3, 3N) matrix product.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from ..core.arrays import cross
from .joints import JointInfo


def _skew_columns(axis: np.ndarray) -> tuple[int, int, float] | None:
    """For an axis equal to +-e_i: the two other column indices (cyclic) and the sign."""
    for i in range(3):
        if abs(abs(axis[i]) - 1.0) < 1e-12 and np.allclose(np.delete(axis, i), 0.0, atol=1e-12):
            return (i + 1) % 3, (i + 2) % 3, float(np.sign(axis[i]))
    return None


def _compose(cols: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Columns of ``R[n] @ C`` for every n; C (3, 3) constant."""
    return (C.T @ cols.reshape(3, -1)).reshape(cols.shape)


def _apply(cols: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``R[n] @ x`` for every n, shape (N, 3); x (3,) constant."""
    return (x @ cols.reshape(3, -1)).reshape(cols.shape[1], 3)


def _transpose_apply(cols: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``R[n].T @ x[n]`` for every n, shape (N, 3); x (N, 3) or (3,)."""
    if x.ndim == 1:
        return (cols.reshape(-1, 3) @ x).reshape(3, -1).T
    return np.einsum("jni,ni->nj", cols, x)


def _matrices(cols: np.ndarray) -> np.ndarray:
    """The stack of rotation matrices (N, 3, 3) from its columns."""
    return np.ascontiguousarray(np.transpose(cols, (1, 2, 0)))


def _identity(n: int) -> np.ndarray:
    """Columns of N identity rotations, shape (3, N, 3)."""
    cols = np.zeros((3, n, 3))
    for j in range(3):
        cols[j, :, j] = 1.0
    return cols


class _ChainLink:
    """One joint of the root-to-sensor chain."""

    __slots__ = ("R_parent", "p_parent", "axis", "kind", "reading", "aligned", "skew")

    def __init__(self, placement: pin.SE3, axis: np.ndarray, kind: str, reading: int):
        self.R_parent = placement.rotation.copy()
        self.p_parent = placement.translation.copy()
        self.axis = axis
        self.kind = kind
        self.reading = reading
        self.aligned = _skew_columns(axis)
        self.skew = pin.skew(np.asarray(axis, dtype=float))

    def rotate(self, cols: np.ndarray, angle: np.ndarray) -> np.ndarray:
        """Columns of ``R[n] @ rot(axis, angle[n])`` for every n."""
        c, s = np.cos(angle)[:, None], np.sin(angle)[:, None]
        if self.aligned is not None:
            j, k, sign = self.aligned
            s = sign * s
            out = cols.copy()
            out[j] = c * cols[j] + s * cols[k]
            out[k] = c * cols[k] - s * cols[j]
            return out
        # Rodrigues: R rot = c R + s R [u]x + (1 - c) (R u) u^T
        Rk, Ru, u = _compose(cols, self.skew), _apply(cols, self.axis), self.axis
        return np.stack([c * cols[m] + s * Rk[m] + (1.0 - c) * u[m] * Ru for m in range(3)])


class Chain:
    """The joints from the root to the sensor frame, walked for N readings at once.

    Args:
        model: Pinocchio model holding the sensor frame.
        joints: Its actuated joints, in the order of the readings (joint id - 1).
        sensor_frame_id: Id of the sensor frame S in ``model``.
    """

    def __init__(self, model: pin.Model, joints: Sequence[JointInfo], sensor_frame_id: int):
        frame = model.frames[sensor_frame_id]
        self._links = []
        for jid in list(model.supports[frame.parentJoint])[1:]:
            info = joints[jid - 1]
            self._links.append(_ChainLink(model.jointPlacements[jid], np.asarray(info.axis), info.kind, jid - 1))
        self._R_last_sensor = frame.placement.rotation.copy()
        self._p_last_sensor = frame.placement.translation.copy()

    def _forward(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Columns of R_world_sensor (3, N, 3) and p_world_sensor (N, 3)."""
        cols = _identity(len(theta))
        p = np.zeros((len(theta), 3))
        for link in self._links:
            p += _apply(cols, link.p_parent)
            cols = _compose(cols, link.R_parent)
            q = theta[:, link.reading]
            if link.kind == "prismatic":
                p += _apply(cols, link.axis) * q[:, None]
            else:
                cols = link.rotate(cols, q)
        return _compose(cols, self._R_last_sensor), p + _apply(cols, self._p_last_sensor)

    def poses(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(R_world_sensor (N, 3, 3), p_world_sensor (N, 3))`` for readings (N, n_joints)."""
        cols, p = self._forward(theta)
        return _matrices(cols), p

    def rotations(self, theta: np.ndarray) -> np.ndarray:
        """``R_world_sensor`` for readings (N, n_joints), shape (N, 3, 3)."""
        return _matrices(self._forward(theta)[0])

    def in_sensor(self, theta: np.ndarray, x_world: np.ndarray) -> np.ndarray:
        """``R_world_sensor[n].T @ x_world``: a world vector (3,) in S at each reading, shape (N, 3)."""
        return _transpose_apply(self._forward(theta)[0], x_world)

    def motion(self, theta: np.ndarray, dtheta: np.ndarray, ddtheta: np.ndarray) -> tuple[np.ndarray, ...]:
        """Velocity and classical acceleration of S, expressed in S, for N readings.

        Args:
            theta: Joint positions [rad or m]. Shape (N, n_joints).
            dtheta: Joint velocities [rad/s or m/s]. Shape (N, n_joints).
            ddtheta: Joint accelerations [rad/s^2 or m/s^2]. Shape (N, n_joints).

        Returns:
            ``(omega, alpha, v, a)``, each (N, 3), in [rad/s, rad/s^2, m/s, m/s^2], and
            ``R_world_sensor`` (N, 3, 3).
        """
        n = len(theta)
        cols = _identity(n)
        omega, al, v, a = (np.zeros((n, 3)) for _ in range(4))
        for link in self._links:
            r = _apply(cols, link.p_parent)  # offset of this joint from its parent, world frame
            v += cross(omega, r)
            a += cross(al, r) + cross(omega, cross(omega, r))
            cols = _compose(cols, link.R_parent)
            k = link.reading
            z = _apply(cols, link.axis)  # joint axis in the world (unchanged by the joint's own rotation)
            qd, qdd = dtheta[:, k, None], ddtheta[:, k, None]
            if link.kind == "prismatic":
                d = z * theta[:, k, None]
                a += cross(al, d) + cross(omega, cross(omega, d)) + 2.0 * cross(omega, z * qd) + z * qdd
                v += cross(omega, d) + z * qd
            else:
                cols = link.rotate(cols, theta[:, k])
                al += cross(omega, z * qd) + z * qdd
                omega = omega + z * qd
        r = _apply(cols, self._p_last_sensor)
        v += cross(omega, r)
        a += cross(al, r) + cross(omega, cross(omega, r))
        cols = _compose(cols, self._R_last_sensor)
        return (
            _transpose_apply(cols, omega),
            _transpose_apply(cols, al),
            _transpose_apply(cols, v),
            _transpose_apply(cols, a),
            _matrices(cols),
        )

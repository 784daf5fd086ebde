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

The motion of the sensor frame: its velocity and classical acceleration, expressed in the sensor frame.

:meth:`fts_calib.robot.kinematics.Kinematics.sensor_motion` computes it from joint readings,
rates and accelerations (it is re-exported from :mod:`fts_calib.robot.kinematics`); the tool's
dynamic load is computed from it.

Robot kinematics with Pinocchio: the sensor frame's pose, velocity and acceleration.

One class, :class:`Kinematics`, owns Pinocchio's ``model`` and ``data`` and is the only
place in fts-calib that runs forward kinematics.

Frames: the world frame is the URDF's root; the sensor frame S is added to the model at
the robot definition's mount. ``R_world_sensor`` rotates vectors from S into the world;
``T_world_sensor`` is the pose of S in the world (Pinocchio's ``oMf``). Gravity in S is
``g_sensor = R_world_sensor.T @ g_world``.

Joint readings are angles in [rad] (or positions in [m] for prismatic joints), one per
actuated joint, in the order of :attr:`Kinematics.joint_names`, or a mapping joint name ->
value (see :mod:`fts_calib.robot.joints`); continuous joints take a plain angle.

Two paths compute the same thing: one reading goes through Pinocchio
(``forwardKinematics``); a batch of N readings goes through a vectorised recursion over the
chain from the root to the sensor (:mod:`fts_calib.robot.kinematics`, private to this class).
Tests check the two paths against each other and against the URDF's transforms multiplied
by hand.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from ..core.arrays import cross
from ..core.deprecation import renamed, renamed_method
from ..core.exceptions import ConfigError, FileFormatError, ShapeError
from .definition import MOUNT_FRAME_TYPES, RobotDefinition, SensorMount, build_model, frame_id, require_sweep_joints
from .joints import (
    JointInfo,
    ReadingCheck,
    find_problems,
    joint_infos,
    known_joints,
    locked_configuration,
    reading_array,
    reduced_model,
    resolve_limits,
    warn_problems,
)


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
            spin = cross(omega, r)
            v += spin
            a += cross(al, r) + cross(omega, spin)
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
        spin = cross(omega, r)
        v += spin
        a += cross(al, r) + cross(omega, spin)
        cols = _compose(cols, self._R_last_sensor)
        return (
            _transpose_apply(cols, omega),
            _transpose_apply(cols, al),
            _transpose_apply(cols, v),
            _transpose_apply(cols, a),
            _matrices(cols),
        )


@dataclass(frozen=True)
class SensorMotion:
    """Velocity and classical acceleration of the sensor frame, expressed in the sensor frame.

    Attributes:
        omega: Angular velocity [rad/s]. Shape (3,) or (N, 3).
        alpha: Angular acceleration [rad/s^2]. Shape (3,) or (N, 3).
        v: Linear velocity of the origin of S [m/s]. Shape (3,) or (N, 3).
        a: Classical linear acceleration of the origin of S [m/s^2]. Shape (3,) or (N, 3).
        R_world_sensor: Orientation of S. Shape (3, 3) or (N, 3, 3).
    """

    omega: np.ndarray
    alpha: np.ndarray
    v: np.ndarray
    a: np.ndarray
    R_world_sensor: np.ndarray


class Kinematics:
    """Forward kinematics of a robot definition, for one reading or a batch.

    Three ways to build one, from what a user already holds::

        kin = Kinematics(load_robot("ur5"))                       # a shipped name or a robot YAML
        kin = Kinematics.from_urdf("arm.urdf", parent_frame="tool0", xyz=(0, 0, 0.02))  # [m]
        kin = Kinematics.from_model(model, parent_frame="tool0")  # an existing pin.Model (copied)

    Args:
        robot: A robot definition (see :func:`fts_calib.robot.definition.load_robot`).
        model: A Pinocchio model of the robot to use instead of reading ``robot.urdf``
            (copied: the sensor frame is added to the copy); None reads the URDF.

    Attributes:
        full_model: The URDF's model, every joint included (the locked ones too).
        model: The model of the actuated joints, holding the sensor frame.
        continuous: Which actuated joints are continuous (their readings wrap at 2 pi), in
            :attr:`joint_names` order; the one continuous-joint mask. Shape (n_joints,) bool.

    Raises:
        FrameNotFound: The sensor's parent frame is not in the URDF (names the closest, lists the frames).
            A name the URDF gives a link and a joint alike is the link.
        JointError: A locked, sweep, home or limit joint name is not in the URDF.
        UnsupportedJoint: A joint is neither revolute, continuous nor prismatic.
    """

    def __init__(self, robot: RobotDefinition, model: pin.Model | None = None):
        self.robot = robot
        full = build_model(robot) if model is None else pin.Model(model)
        self.full_model = full
        lock_ids, q_lock = locked_configuration(full, robot.locked_joints)
        model = reduced_model(full, lock_ids, q_lock) if lock_ids else full
        self.model = model
        self.joints = tuple(joint_infos(model))
        self.joint_names = tuple(j.name for j in self.joints)
        require_sweep_joints(robot, self.joint_names)
        self._index = {name: i for i, name in enumerate(self.joint_names)}
        self.sensor_frame_id = self._add_sensor_frame(model, robot)
        self.data = model.createData()
        self.sweep_joints = self._check_names(list(robot.sweep_joints or self.joint_names[-2:]), "sweep joint")
        if robot.home is not None:
            self._check_names(list(robot.home), "home joint")
        self.limits = resolve_limits(self.joints, robot.limits)
        self._chain = Chain(model, self.joints, self.sensor_frame_id)
        self._plain_q = all(j.kind != "continuous" for j in self.joints) and model.nq == len(self.joints)
        self.continuous = np.array([j.kind == "continuous" for j in self.joints], dtype=bool)  # a mask: stays bool
        self.continuous.setflags(write=False)
        self._bounded = np.array([j.kind == "revolute" for j in self.joints])
        self._g_cache: dict[float | None, np.ndarray] = {}

    # -- construction -------------------------------------------------------------------

    @classmethod
    def from_urdf(
        cls, urdf: str | Path, parent_frame: str, xyz=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0), name: str | None = None, **fields: Any
    ) -> Kinematics:
        """Kinematics of a URDF with the sensor mounted on one of its frames, no robot YAML needed.

        Args:
            urdf: The URDF file.
            parent_frame: The URDF frame the sensor is attached to (e.g. 'tool0'); a link when a
                link and a joint share the name.
            xyz: Origin of the sensor frame S in the parent frame [m]. Shape (3,).
            rpy: Roll, pitch, yaw from the parent frame to S [rad]. Shape (3,).
            name: The robot's name; the URDF's file name when None.
            **fields: Other :class:`~fts_calib.robot.definition.RobotDefinition` fields
                (``sweep_joints``, ``home``, ``locked_joints``, ``limits``, ``accuracy``...).

        Raises:
            FileFormatError: The URDF does not exist.
            FrameNotFound: ``parent_frame`` is not in the URDF (lists the frames).
        """
        path = Path(urdf)
        if not path.is_file():
            raise FileFormatError(path, None, "URDF file not found")
        mount = SensorMount(parent_frame=parent_frame, xyz=np.asarray(xyz, dtype=float), rpy=np.asarray(rpy, dtype=float))
        fields.setdefault("package_dirs", (path.resolve().parent,))
        return cls(RobotDefinition(name=name or path.stem, urdf=path, sensor=mount, urdf_spec=str(path), **fields))

    @classmethod
    def from_model(
        cls, model: pin.Model, parent_frame: str, xyz=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0), name: str | None = None, **fields: Any
    ) -> Kinematics:
        """Kinematics of an existing Pinocchio model with the sensor mounted on one of its frames.

        The model is copied (the sensor frame is added to the copy). Without a URDF there is
        no collision geometry: planning (:mod:`fts_calib.planning`) needs :meth:`from_urdf`
        or a robot YAML; calibrating, the budget and the service path do not.

        Args:
            model: The robot's model (revolute, continuous and prismatic joints).
            parent_frame: The model frame the sensor is attached to.
            xyz: Origin of the sensor frame S in the parent frame [m]. Shape (3,).
            rpy: Roll, pitch, yaw from the parent frame to S [rad]. Shape (3,).
            name: The robot's name; the model's when None.
            **fields: Other :class:`~fts_calib.robot.definition.RobotDefinition` fields.

        Raises:
            ConfigError: ``model`` is not a ``pin.Model`` (a path or a name: say which entry point takes it).
            FrameNotFound: ``parent_frame`` is not in the model (lists the frames).
        """
        if not isinstance(model, pin.Model):
            raise ConfigError("model", model, "a pin.Model (a URDF: Kinematics.from_urdf; a robot file: Kinematics(load_robot(path)))")
        mount = SensorMount(parent_frame=parent_frame, xyz=np.asarray(xyz, dtype=float), rpy=np.asarray(rpy, dtype=float))
        robot = RobotDefinition(name=name or model.name or "robot", urdf=Path(), sensor=mount, urdf_spec="(a pin.Model)", **fields)
        return cls(robot, model=model)

    @staticmethod
    def _add_sensor_frame(model: pin.Model, robot: RobotDefinition) -> int:
        mount = robot.sensor
        parent_id = frame_id(model, mount.parent_frame, MOUNT_FRAME_TYPES, robot.where("sensor.parent_frame"))
        parent = model.frames[parent_id]
        T_parent_sensor = pin.SE3(pin.rpy.rpyToMatrix(*mount.rpy), np.asarray(mount.xyz, dtype=float))
        frame = pin.Frame(mount.name, parent.parentJoint, parent_id, parent.placement * T_parent_sensor, pin.FrameType.OP_FRAME)
        return model.addFrame(frame)

    def _check_names(self, names: list[str], what: str) -> tuple[str, ...]:
        return known_joints(names, self.joint_names, what)

    # -- collision geometry: placed by forward kinematics --------------------------------

    @renamed(reading="joints")
    def distances(self, joints, geometry: pin.GeometryModel, geometry_data: pin.GeometryData) -> int:
        """Distances of every collision pair of ``geometry`` at one reading.

        Fills ``geometry_data.distanceResults`` and returns the index of the closest pair.
        """
        theta, single = self.joint_array(joints)
        if not single:
            raise ShapeError(f"distances takes one reading; got {len(theta)}")
        q = theta[0] if self._plain_q else self._q(theta)[0]
        return int(pin.computeDistances(self.model, self.data, geometry, geometry_data, q))

    @renamed(reading="joints")
    def jacobian(self, joints) -> np.ndarray:
        """Jacobian of the sensor frame at one reading, axes of the world, origin of S.

        ``[v; omega] = J qdot``: linear velocity of the origin of S and angular velocity, in
        the world frame, from joint velocities in :attr:`joint_names` order.

        Returns:
            Shape (6, n_joints).
        """
        theta, single = self.joint_array(joints)
        if not single:
            raise ShapeError(f"jacobian takes one reading; got {len(theta)}")
        q = theta[0] if self._plain_q else self._q(theta)[0]
        return pin.computeFrameJacobian(self.model, self.data, q, self.sensor_frame_id, pin.LOCAL_WORLD_ALIGNED)

    @renamed(reading="joints")
    def joint_axis_world(self, joints, joint_name: str) -> np.ndarray:
        """Unit axis of a joint in the world frame at one reading. Shape (3,)."""
        self._check_names([joint_name], "joint")
        self.sensor_pose(joints)  # runs forwardKinematics on this reading
        jid = self.model.getJointId(joint_name)
        return self.data.oMi[jid].rotation @ self.joints[self._index[joint_name]].axis

    def chain_joints(self, joint_name: str) -> list[str]:
        """Actuated joints from the root down to ``joint_name`` (inclusive), in order."""
        jid = self.model.getJointId(joint_name)
        return [self.model.names[j] for j in list(self.model.supports[jid])[1:]]

    # -- readings -----------------------------------------------------------------------

    @property
    def n_joints(self) -> int:
        """Number of actuated joints (one reading each)."""
        return len(self.joints)

    def joint_array(self, joints) -> tuple[np.ndarray, bool]:
        """Joint readings as a float array (N, n_joints), and whether it was one reading.

        Args:
            joints: An array (n_joints,) or (N, n_joints) in :attr:`joint_names` order, or
                a mapping joint name -> value or -> array (N,).

        Raises:
            JointError: Unknown or missing joint names, or the wrong number of values; the
                message lists the expected joints.
        """
        if type(joints) is np.ndarray and joints.dtype == np.float64 and joints.shape == (self.n_joints,):
            return joints[None, :], True  # the common single reading, without further checks
        return reading_array(joints, self.joint_names)

    readings = renamed_method("readings", joint_array)

    @renamed(readings="joints")
    def q_from_joints(self, joints) -> np.ndarray:
        """Pinocchio's configuration vector q from joint readings (continuous joints -> cos, sin).

        Args:
            joints: Joint readings [rad], (n_joints,) or (N, n_joints), or a mapping.

        Returns:
            q, shape (nq,) for one reading or (N, nq) for a batch.
        """
        theta, single = self.joint_array(joints)
        q = self._q(theta)
        return q[0] if single else q

    configuration = renamed_method("configuration", q_from_joints)

    def _q(self, theta: np.ndarray) -> np.ndarray:
        if self._plain_q:
            return np.array(theta, dtype=float, order="C")
        q = np.empty((len(theta), self.model.nq))
        for k, joint in enumerate(self.joints):
            if joint.kind == "continuous":
                q[:, joint.idx_q] = np.cos(theta[:, k])
                q[:, joint.idx_q + 1] = np.sin(theta[:, k])
            else:
                q[:, joint.idx_q] = theta[:, k]
        return q

    def reading_problems(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
        """Soft problems of readings (N, n_joints), without warnings.

        Returns:
            ``(outside (N, n_joints) bool: outside the limits, outside_rows (N,) bool,
            joints whose readings look like degrees)``.
        """
        return find_problems(theta, self.joint_names, self.limits, self._bounded)

    @renamed(readings="joints")
    def check_readings(self, joints) -> ReadingCheck:
        """Warn about readings outside the joint limits or that look like degrees.

        Emits one :class:`FtsCalibWarning` per kind of problem and returns the counts.
        """
        theta, _ = self.joint_array(joints)
        return warn_problems(theta, self.joint_names, self.limits, self._bounded, stacklevel=2)

    # -- one reading: Pinocchio ---------------------------------------------------------

    @renamed(readings="joints")
    def sensor_pose(self, joints) -> pin.SE3:
        """``T_world_sensor`` for one reading, through Pinocchio.

        Args:
            joints: One reading [rad], (n_joints,) or a mapping joint name -> value.
        """
        theta, single = self.joint_array(joints)
        if not single:
            raise ShapeError(f"sensor_pose takes one reading; got {len(theta)} (use sensor_poses for a batch)")
        return self._pose_one(theta[0])

    def _pose_one(self, theta: np.ndarray) -> pin.SE3:
        q = theta if self._plain_q else self._q(theta[None, :])[0]
        pin.forwardKinematics(self.model, self.data, q)
        return pin.updateFramePlacement(self.model, self.data, self.sensor_frame_id)

    # -- batches: vectorised recursion --------------------------------------------------

    @renamed(readings="joints")
    def sensor_poses(self, joints) -> tuple[np.ndarray, np.ndarray]:
        """Poses of S in the world for a batch, by the vectorised recursion.

        Args:
            joints: Joint readings [rad], (N, n_joints) or a mapping joint name -> (N,).

        Returns:
            ``(R_world_sensor (N, 3, 3), p_world_sensor (N, 3))`` in [m].
        """
        theta, _ = self.joint_array(joints)
        return self._chain.poses(theta)

    @renamed(readings="joints")
    def R_world_sensor(self, joints) -> np.ndarray:
        """Orientation of the sensor frame in the world.

        Args:
            joints: One reading [rad] (n_joints,) or a batch (N, n_joints), or a mapping.

        Returns:
            ``R_world_sensor``, shape (3, 3) or (N, 3, 3).
        """
        theta, single = self.joint_array(joints)
        if single:
            return self._pose_one(theta[0]).rotation
        return self._chain.rotations(theta)

    def g_world(self, gravity: float | None = None) -> np.ndarray:
        """Gravity in the world frame [m/s^2]: the model's direction, with magnitude ``gravity`` if given."""
        cached = self._g_cache.get(gravity)
        if cached is None:
            g = np.asarray(self.model.gravity.linear, dtype=float).copy()
            if gravity is not None:
                g *= gravity / np.linalg.norm(g)
            g.setflags(write=False)
            cached = self._g_cache[gravity] = g
        return cached

    @renamed(readings="joints")
    def g_sensor(self, joints, gravity: float | None = None) -> np.ndarray:
        """Gravity in the sensor frame, ``R_world_sensor.T @ g_world``, in [m/s^2].

        Args:
            joints: One reading or a batch [rad] (see :meth:`joint_array`).
            gravity: Magnitude of gravity [m/s^2] (e.g. the tool file's); the model's when None.

        Returns:
            Shape (3,) or (N, 3).
        """
        g = self.g_world(gravity)
        theta, single = self.joint_array(joints)
        if single:
            return self._pose_one(theta[0]).rotation.T.dot(g)
        return self._chain.in_sensor(theta, g)

    @renamed(readings="joints")
    def sensor_motion(self, joints, velocities, accelerations) -> SensorMotion:
        """Spatial velocity and classical acceleration of S, expressed in S.

        Args:
            joints: Joint positions [rad], one (n_joints,) or a batch (N, n_joints), or a mapping.
            velocities: Joint velocities [rad/s or m/s], same shape as ``joints``.
            accelerations: Joint accelerations [rad/s^2 or m/s^2], same shape.

        Returns:
            :class:`SensorMotion` with arrays (3,) for one reading or (N, 3) for a batch.
        """
        theta, single = self.joint_array(joints)
        dtheta, _ = self.joint_array(velocities)
        ddtheta, _ = self.joint_array(accelerations)
        if dtheta.shape != theta.shape or ddtheta.shape != theta.shape:
            raise ShapeError(f"positions {theta.shape}, velocities {dtheta.shape} and accelerations {ddtheta.shape} must match")
        if single:
            q = self._q(theta)[0]
            pin.forwardKinematics(self.model, self.data, q, dtheta[0], ddtheta[0])
            pin.updateFramePlacement(self.model, self.data, self.sensor_frame_id)
            vel = pin.getFrameVelocity(self.model, self.data, self.sensor_frame_id, pin.LOCAL)
            acc = pin.getFrameClassicalAcceleration(self.model, self.data, self.sensor_frame_id, pin.LOCAL)
            R = self.data.oMf[self.sensor_frame_id].rotation.copy()
            return SensorMotion(vel.angular.copy(), acc.angular.copy(), vel.linear.copy(), acc.linear.copy(), R)
        return SensorMotion(*self._chain.motion(theta, dtheta, ddtheta))

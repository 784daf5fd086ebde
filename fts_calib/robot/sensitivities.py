r"""How the tool's known wrench goes wrong: its sensitivity to every error source of the budget.

The known wrench of sample i is ``W_i = M_c g_i`` (paper eqs 17-18, ``M_c = [m I; m [c]x]``
of its configuration c, ``g_i`` gravity in the sensor frame S from the joint readings). Each
source perturbs it as ``dW_i = B_i u`` (:class:`fts_calib.model.budget.ErrorSource`):

- tool mass, one error ``dm`` for every configuration: ``B = W_i / m_c``;
- tool centre of mass, one error ``dc`` (3,) for every configuration: ``dW = [0; m dc x g]``;
- sensor mount, a rotation ``dphi`` (3,) of S: the wrench is computed with gravity
  ``g_i + dphi x g_i``, so ``B = -M_c [g_i]x``;
- joint encoders, a reading error ``dq`` per joint: ``B = M_c dg/dq`` with
  ``dg/dq_k = g x (R_world_sensor^T J_omega,k)``; the error of a joint that moves is a new
  draw at every stop (its reading holds while the arm is still), that of a joint that never
  moves is one draw for the whole run;
- stream latency ``tau`` (one constant) and timing jitter (a draw per sample): the readings
  are ``-tau qdot`` off, ``B = -M_c (dg/dq) qdot``.

Tolerances are bounds of uniform errors (standard deviation bound / sqrt(3)); the encoder's
error is uniform within half a step (resolution / sqrt(12)); jitter is a standard deviation.
Frames: S; units: N, N m, rad, s.
"""

from __future__ import annotations

import numpy as np

from ..model.budget import ErrorSource
from .definition import RobotAccuracy
from .kinematics import Kinematics
from .tool import Tool

#: The names of the sources :func:`load_error_sources` returns, in order.
SOURCE_NAMES = ("tool mass", "tool centre of mass", "sensor mount", "joint encoders", "stream latency", "timing jitter")

_JACOBIAN_GRID = 1e-4  # [rad] readings this close share one Jacobian (it changes by ~1e-4 relative)


def gravity_jacobian(kin: Kinematics, joints: np.ndarray, g_sensor: np.ndarray) -> np.ndarray:
    """``dg_sensor / dq``: how gravity in S moves with each joint reading.

    Args:
        kin: Kinematics.
        joints: Joint readings [rad]. Shape (N, n_joints).
        g_sensor: Gravity in S at those readings [m/s^2]. Shape (N, 3).

    Returns:
        [m/s^2 per rad], shape (N, 3, n_joints).
    """
    keys, first, where = np.unique(np.round(joints / _JACOBIAN_GRID), axis=0, return_index=True, return_inverse=True)
    R = kin.R_world_sensor(joints[first]).reshape(len(first), 3, 3)
    omega_sensor = np.stack([R[k].T @ kin.jacobian(joints[i])[3:] for k, i in enumerate(first)])  # (U, 3, n_joints)
    return np.cross(g_sensor[:, :, None], omega_sensor[where.reshape(-1)], axis=1)


def stops(time: np.ndarray, configuration: np.ndarray, gap_s: float) -> np.ndarray:
    """Index of the still stretch of each sample: a new one after a gap longer than ``gap_s`` [s] or a tool change."""
    if not len(time):
        return np.zeros(0, dtype=np.int64)
    new = np.concatenate([[True], (np.diff(time) > gap_s) | (np.diff(configuration) != 0)])
    return np.cumsum(new) - 1


def load_error_sources(
    kin: Kinematics,
    tool: Tool,
    joints: np.ndarray,
    configuration: np.ndarray,
    joint_velocity: np.ndarray,
    stop: np.ndarray | None,
    accuracy: RobotAccuracy,
) -> list[ErrorSource]:
    """The sources of the budget that perturb the known wrench (see the module docstring).

    Args:
        kin: Kinematics.
        tool: The tool (its tolerance: no tool terms when None).
        joints: Joint readings of the calibration's samples [rad]. Shape (N, n_joints).
        configuration: Tool configuration index of each sample. Shape (N,) int.
        joint_velocity: Joint velocities at those samples [rad/s]. Shape (N, n_joints).
        stop: Still stretch of each sample (:func:`stops`), shape (N,) int; None when every
            sample moves (a moving joint's encoder error is then a new draw at every reading).
        accuracy: The robot's encoder resolution, timing and mount tolerance.

    Returns:
        Named sources: 'tool mass', 'tool centre of mass', 'sensor mount', 'joint encoders',
        'stream latency', 'timing jitter'.
    """
    joints = np.asarray(joints, dtype=float)
    n = len(joints)
    codes = np.asarray(configuration, dtype=np.int64)
    g = kin.g_sensor(joints, tool.gravity).reshape(n, 3)
    g_cross = np.cross(g[:, None, :], np.eye(3)[None]).transpose(0, 2, 1)  # [g]x per sample, (N, 3, 3)
    matrices = np.stack([c.wrench_matrix for c in tool.configurations])[codes]  # (N, 6, 3)
    mass = np.array([c.mass for c in tool.configurations])[codes]
    common = np.zeros(n, dtype=np.int64)
    sources = []
    if tool.tolerance is not None:
        W = np.einsum("nij,nj->ni", matrices, g)
        com = np.zeros((n, 6, 3))
        com[:, 3:, :] = -mass[:, None, None] * g_cross
        sources += [
            ErrorSource("tool mass", (W / mass[:, None])[:, :, None], np.array([[tool.tolerance.mass**2 / 3.0]]), common),
            ErrorSource("tool centre of mass", com, np.eye(3) * tool.tolerance.com**2 / 3.0, common),
        ]
    sources.append(ErrorSource("sensor mount", -matrices @ g_cross, np.eye(3) * accuracy.mount_rotation**2 / 3.0, common))
    dg_dq = gravity_jacobian(kin, joints, g)
    B = matrices @ dg_dq  # (N, 6, n_joints)
    moving = np.ptp(joints, axis=0) > accuracy.encoder_resolution if n else np.zeros(kin.n_joints, dtype=bool)
    step = accuracy.encoder_resolution**2 / 12.0
    for mask, groups in ((moving, stop), (~moving, common)):
        if mask.any():
            sources.append(ErrorSource("joint encoders", B[:, :, mask], np.eye(int(mask.sum())) * step, groups))
    rate = -np.einsum("nij,nj->ni", B, np.asarray(joint_velocity, dtype=float))[:, :, None]
    sources.append(ErrorSource("stream latency", rate, np.array([[accuracy.latency_s**2 / 3.0]]), common))
    sources.append(ErrorSource("timing jitter", rate, np.array([[accuracy.jitter_s**2]])))
    return sources

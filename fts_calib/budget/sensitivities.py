"""How the tool's known wrench goes wrong: its sensitivity to every error source of the budget.

The known wrench of sample i is ``W_i = M_c g_i`` (paper eqs 17-18, ``M_c = [m I; m [c]x]``
of its configuration c, ``g_i`` gravity in the sensor frame S from the joint readings). Each
source perturbs it as ``dW_i = B_i u`` (:class:`fts_calib.budget.propagation.ErrorSource`):

- tool mass, one error ``dm`` for every configuration and one ``dm_c`` of each configuration's
  own (:class:`fts_calib.robot.tool.ToolTolerance`): ``B = W_i / m_c``;
- tool centre of mass, one error ``dc`` (3,) for every configuration and one ``dc_c`` (3,) of
  each configuration's own: ``dW = [0; m dc x g]``;
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

How the moving tool's known wrench goes wrong: the dynamic terms of the accuracy budget.

A moving sample's known wrench is the Newton-Euler wrench of the tool
(:func:`fts_calib.robot.tool.dynamic_wrench`), ``W(q, qdot, qddot)`` with the joint
velocities and accelerations estimated from the joint readings. Beside the static sources
(:mod:`fts_calib.budget.sensitivities`) it goes wrong through (each a
:class:`fts_calib.budget.propagation.ErrorSource`, ``dW_i = B_i u``):

- **tool inertia**: each of the 6 elements of a configuration's inertia about its centre of
  mass is off by a uniform error within +- ``inertia`` times its largest principal moment,
  one draw per configuration for the whole run: ``dM = -(dI alpha + omega x dI omega)``;
- **joint noise**: white noise of standard deviation ``sigma_q`` on each reading at
  ``joint_rate_hz``, through the zero-phase estimate of ``q, qdot, qddot`` the dynamic filter
  makes (a least-squares cubic through a centred window: kernels exact on the smooth motion);
  ``B = [dW/dq, dW/dqdot, dW/dqddot]`` per moving joint, propagated through the kernels
  (:func:`fts_calib.budget.propagation.filtered_sensitivity`): over a smooth motion the noise of the
  rate and acceleration estimates averages out but where the samples begin and end; what it costs one sample is
  :meth:`MotionUncertainty.estimate_covariance`;
- **stream latency**: what remains of the latency after the estimated one is applied, one
  draw of standard deviation ``latency_s`` for the run: the state used is that of
  ``t - dtau``, ``B = -dW/dt = -(dW/dq qdot + dW/dqdot qddot + dW/dqddot jerk)``;
- **timing jitter**: the same ``B``, a draw per sample of the robot's ``jitter_s``.

Derivatives with respect to the joints are central differences of :func:`tool_load`.
Frames: S; units: N, N m, rad, s, Hz.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core import arrays as validation
from ..filters.joint_rates import rate_kernels
from ..robot.definition import RobotAccuracy
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool, tool_load
from .propagation import ErrorSource

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
        tolerance = tool.tolerance
        for draws, bound_mass, bound_com in (
            (common, tolerance.mass, tolerance.com),
            (codes, tolerance.configuration_mass, tolerance.configuration_com),
        ):
            sources += [  # one draw for every configuration, then one per configuration (its own)
                ErrorSource("tool mass", (W / mass[:, None])[:, :, None], np.array([[bound_mass**2 / 3.0]]), draws),
                ErrorSource("tool centre of mass", com, np.eye(3) * bound_com**2 / 3.0, draws),
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


#: The names of the sources :func:`dynamic_error_sources` returns.
DYNAMIC_SOURCE_NAMES = ("tool inertia", "joint noise", "stream latency", "timing jitter")

_STEP = {"q": 1e-6, "qd": 1e-4, "qdd": 1e-3}  # [rad, rad/s, rad/s^2] central-difference steps (W is smooth)
_INERTIA_BASIS = np.array(
    [np.diag(e) for e in np.eye(3)]
    + [np.outer(np.eye(3)[i], np.eye(3)[j]) + np.outer(np.eye(3)[j], np.eye(3)[i]) for i, j in ((0, 1), (0, 2), (1, 2))]
)  # (6, 3, 3): Ixx, Iyy, Izz, Ixy, Ixz, Iyz


@dataclass(frozen=True)
class MotionUncertainty:
    """How well the moving tool's wrench is known, for the dynamic terms of the budget.

    Attributes:
        inertia: Bound of the error of each inertia element, as a fraction of the
            configuration's largest principal moment (uniform +-; 0.1: known to 10 %).
        joint_noise: Standard deviation of each joint reading's noise, [rad].
        joint_rate_hz: Rate of the joint readings, [Hz].
        window_s: Width of the centred window of the velocity and acceleration estimate, [s].
        order: Degree of the local polynomial fitted over the window (3 or 5).
        latency_s: Standard deviation of the stream-latency estimate once applied, [s].
        jitter_s: Standard deviation of each sample's timing error, [s].
        max_error_ratio: A sample whose systematic error (inertia, latency) exceeds this many
            times the strain noise on some axis is dropped (the trust rule).
    """

    inertia: float = 0.1
    joint_noise: float = 1e-5
    joint_rate_hz: float = 1000.0
    window_s: float = 0.3
    latency_s: float = 1e-4
    jitter_s: float = 1e-4
    order: int = 5
    max_error_ratio: float = 3.0

    def __post_init__(self):
        for name, unit in (("inertia", ""), ("joint_noise", "rad"), ("latency_s", "s"), ("jitter_s", "s")):
            object.__setattr__(self, name, validation.non_negative(name, getattr(self, name), unit))
        for name, unit in (("joint_rate_hz", "Hz"), ("window_s", "s"), ("max_error_ratio", "")):
            object.__setattr__(self, name, validation.positive(name, getattr(self, name), unit))
        if self.order not in (3, 5):
            raise ValueError(f"order={self.order} but expected 3 or 5 (the degree of the local polynomial)")

    def kernels(self) -> np.ndarray:
        """The centred polynomial's kernels of ``(q, qdot, qddot)`` at the window's middle, shape (3, 2h + 1).

        ``estimate_i = sum_k K[k] q_{i+k}``, k = -h .. h, at the readings' period; [1, 1/s, 1/s^2]
        (the dynamic filter's: :func:`fts_calib.filters.joint_rates.rate_kernels`).
        """
        dt = 1.0 / self.joint_rate_hz
        return rate_kernels(max(2, int(round(self.window_s / 2 / dt))), dt, 0.0, self.order)

    def estimate_covariance(self) -> np.ndarray:
        """Covariance of the errors of one joint's ``(q, qdot, qddot)`` estimates, [rad, rad/s, rad/s^2]^2. Shape (3, 3).

        ``sigma_q^2 K K^T`` with ``K`` the :meth:`kernels`; zero for ``q``-``qdot`` (odd and even kernels).
        """
        K = self.kernels()
        return self.joint_noise**2 * K @ K.T


def wrench_derivatives(kin: Kinematics, tool: Tool, q, qd, qdd, codes, joints: np.ndarray) -> np.ndarray:
    """``dW/dq, dW/dqdot, dW/dqddot`` of the moving wrench for some joints, by central differences.

    Args:
        kin: Kinematics.
        tool: The tool.
        q: Joint positions [rad], shape (N, n_joints); ``qd``, ``qdd`` the same in [rad/s, rad/s^2].
        qd: See ``q``.
        qdd: See ``q``.
        codes: Configuration index of each sample, shape (N,) int.
        joints: Indices of the joints to differentiate, shape (J,) int.

    Returns:
        Shape (N, 6, 3, J): axis 2 is (q, qdot, qddot); [N or N m per rad, rad/s, rad/s^2].
    """
    state = [np.asarray(a, dtype=float) for a in (q, qd, qdd)]
    out = np.zeros((len(state[0]), 6, 3, len(joints)))
    for which, key in enumerate(("q", "qd", "qdd")):
        for col, k in enumerate(joints):
            signed = []
            for sign in (1.0, -1.0):
                moved = [a.copy() for a in state]
                moved[which][:, k] += sign * _STEP[key]
                signed.append(tool_load(kin, tool, moved[0], codes, moved[1], moved[2]).w_sensor)
            out[:, :, which, col] = (signed[0] - signed[1]) / (2.0 * _STEP[key])
    return out


def dynamic_error_sources(kin: Kinematics, tool: Tool, time, q, qd, qdd, jerk, codes, uncertainty: MotionUncertainty) -> list[ErrorSource]:
    """The dynamic sources of the budget (see the module docstring).

    Args:
        kin: Kinematics.
        tool: The tool (each configuration's inertia; none: no inertia term for it).
        time: Sample times [s], shape (N,) (the joint-noise stretches are cut from it).
        q: Joint positions [rad], shape (N, n_joints).
        qd: Joint velocities [rad/s], shape (N, n_joints).
        qdd: Joint accelerations [rad/s^2], shape (N, n_joints).
        jerk: Joint jerks [rad/s^3], shape (N, n_joints).
        codes: Configuration index of each sample, shape (N,) int.
        uncertainty: The tolerances and noises.

    Returns:
        Named sources: 'tool inertia' (when a configuration has an inertia), 'joint noise',
        'stream latency', 'timing jitter'.
    """
    q, qd, qdd, jerk = (np.asarray(a, dtype=float) for a in (q, qd, qdd, jerk))
    codes = np.asarray(codes, dtype=np.int64)
    n = len(q)
    common = np.zeros(n, dtype=np.int64)
    sources = []
    motion = kin.sensor_motion(q, qd, qdd)
    omega, alpha = motion.omega.reshape(n, 3), motion.alpha.reshape(n, 3)
    for c, config in enumerate(tool.configurations):
        if config.inertia_com is None or uncertainty.inertia == 0:
            continue
        mine = (codes == c)[:, None]
        B = np.zeros((n, 6, 6))
        for k, E in enumerate(_INERTIA_BASIS):
            B[:, 3:, k] = -(alpha @ E.T + np.cross(omega, omega @ E.T)) * mine
        bound = uncertainty.inertia * float(np.max(np.linalg.eigvalsh(config.inertia_com)))
        sources.append(ErrorSource("tool inertia", B, np.eye(6) * bound**2 / 3.0, common))
    moving = np.nonzero(np.ptp(q, axis=0) > 0)[0] if n else np.zeros(0, dtype=np.int64)
    derivative = wrench_derivatives(kin, tool, q, qd, qdd, codes, moving)  # (N, 6, 3, J)
    noise = np.eye(len(moving)) * uncertainty.joint_noise**2
    B = derivative.reshape(n, 6, 3 * len(moving))  # (value, rate, second rate) parts, each over the moving joints
    period = 1.0 / uncertainty.joint_rate_hz
    sources.append(ErrorSource("joint noise", B, noise, codes, np.asarray(time, dtype=float), period, uncertainty.kernels()))
    rates = np.stack([qd[:, moving], qdd[:, moving], jerk[:, moving]], axis=1)  # (N, 3, J)
    dW_dt = np.einsum("njwk,nwk->nj", derivative, rates)[:, :, None]
    sources.append(ErrorSource("stream latency", -dW_dt, np.array([[uncertainty.latency_s**2]]), common))
    sources.append(ErrorSource("timing jitter", -dW_dt, np.array([[uncertainty.jitter_s**2]])))
    return sources

"""A short motion that shows a payload's inertia: jerk-limited moves of the three wrist joints together.

For :mod:`fts_calib.payload.moving`: the inertia is seen only through angular
acceleration about each axis of the sensor frame, and the centre of mass and mass through
gravity seen from several directions. The three last joints (on a 6-axis arm, the wrist)
move together from stop to stop, rest to rest, without dwelling, along ruckig segments within
the robot definition's velocity, acceleration and jerk limits
(:func:`fts_calib.planning.motion.sample_motion`): every start and stop is a burst of angular
acceleration about a different axis. :func:`payload_excitation` makes no collision check;
:func:`plan_payload_motion` (``fts-calib trajectory --motion payload``) plans it from the
calibration's home, checks the joint limits and the clearance with the payload's shape, and
predicts the standard errors of the mass, centre of mass and inertia it gives. Angles in [rad],
times in [s].
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.exceptions import TrajectoryError
from ..planning.motion import sample_motion
from ..planning.planner import plan_base
from ..planning.sweeps import SweepPattern
from ..robot import inertial
from ..robot.collision import Clearance, CollisionChecker
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool, default_shape
from .estimate import PAIRS
from .moving import _derived_jacobian

#: Stops of the moving joints, in units of the amplitude: every pair of joints turns both ways.
PATTERN = np.array(
    [
        [1.0, -1.0, 1.0],
        [-1.0, 1.0, 1.0],
        [1.0, 1.0, -1.0],
        [-1.0, -1.0, -1.0],
        [0.0, 1.0, 1.0],
        [1.0, -1.0, 0.0],
        [-1.0, 0.0, 1.0],
        [0.0, 0.0, 0.0],
    ]
)


def payload_excitation(
    kin: Kinematics, home, seconds: float = 8.0, amplitude: float = 0.6, rate_hz: float = 1000.0, joints=None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A jerk-limited multi-joint motion from ``home`` of at most ``seconds`` (see the module docstring).

    Args:
        kin: Kinematics (joint names and limits).
        home: Start and end pose [rad]. Shape (n_joints,).
        seconds: Longest duration [s]; the pattern's stops are taken in order while they fit.
        amplitude: Swing of each moving joint about home [rad].
        rate_hz: Sample rate [Hz].
        joints: Names of the three moving joints; the last three of the robot when None.

    Returns:
        ``(time (N,), q, qd, qdd (N, n_joints))`` in [s, rad, rad/s, rad/s^2].

    Raises:
        TrajectoryError: Not even the first stop fits in ``seconds``, or ruckig refusing a segment.
    """
    names = list(kin.joint_names[-3:] if joints is None else joints)
    if len(names) != PATTERN.shape[1]:
        raise TrajectoryError(f"joints={names} but expected {PATTERN.shape[1]} joint names", "invalid joints")
    home = np.asarray(home, dtype=float)
    index = [kin.joint_names.index(name) for name in names]
    best = None
    for count in range(1, len(PATTERN) + 1):
        stops = home[index] + amplitude * PATTERN[:count]
        motion = sample_motion(kin, home, names, stops, 0.0, rate_hz)
        if motion[0][-1] > seconds:
            break
        best = motion
    if best is None:
        raise TrajectoryError(f"no stop of the pattern fits in {seconds:g} s at an amplitude of {amplitude:g} rad", "too short")
    return best


@dataclass(frozen=True)
class PayloadPlan:
    """A payload motion planned and checked before the robot moves (:func:`plan_payload_motion`).

    Attributes:
        time: Sample times [s], shape (N,).
        q: Joint positions [rad], shape (N, n_joints); ``qd``, ``qdd`` their rates [rad/s, rad/s^2].
        joints: The three joints that move.
        configuration: The payload's configuration name (the trajectory file's ``tool``).
        peak_ratio: Per moving joint, the largest |velocity|, |acceleration| over its limit.
        clearance: The smallest distance along the motion [m] and its pair (:class:`~fts_calib.robot.collision.Clearance`).
        stderr_mass: Predicted standard error of the mass [kg] from the wrench noise alone.
        stderr_com: Of the centre of mass [m], shape (3,).
        stderr_inertia: Of the inertia about the centre of mass [kg m^2], shape (3, 3).
        wrench_noise: The wrench noise per sample it assumes [N, N m], shape (6,).
        problems: Failed checks, in words (empty: the motion may run).
    """

    time: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    joints: tuple[str, ...]
    configuration: str
    peak_ratio: dict[str, dict[str, float]]
    clearance: Clearance
    stderr_mass: float
    stderr_com: np.ndarray
    stderr_inertia: np.ndarray
    wrench_noise: np.ndarray
    problems: list[str] = field(default_factory=list)


def predicted_payload_stderr(
    kin: Kinematics, tool: Tool, configuration: str, q, qd, qdd, wrench_noise
) -> tuple[float, np.ndarray, np.ndarray]:
    """Standard errors of the mass, centre of mass and inertia a motion gives, from white wrench noise alone.

    The identification's least squares (:func:`fts_calib.payload.moving.fit_payload_regressor`):
    ``W = Y pi + D`` with six constant offsets, each axis weighted by its noise; the
    covariance ``(Aᵀ A)⁻¹`` of the ten parameters (offsets eliminated) carried to mass, centre of
    mass and inertia about it at the payload's nominal values.

    Args:
        kin: Kinematics.
        tool: The payload's tool file (its nominal mass, centre of mass, inertia).
        configuration: Which of its configurations.
        q: Joint positions [rad], shape (N, n_joints).
        qd: Joint velocities [rad/s], shape (N, n_joints).
        qdd: Joint accelerations [rad/s^2], shape (N, n_joints).
        wrench_noise: Wrench noise per sample [N, N, N, N m, N m, N m], shape (6,).

    Returns:
        ``(mass [kg], centre of mass [m] (3,), inertia [kg m^2] (3, 3))``; inf where the motion
        does not determine the parameter.
    """
    config = tool.configuration(configuration)
    state = kin.sensor_motion(np.asarray(q, float), np.asarray(qd, float), np.asarray(qdd, float))
    g = np.einsum("nji,j->ni", state.R_world_sensor, kin.g_world(tool.gravity))
    Y = inertial.body_regressor(g, state.omega, state.alpha, state.a)
    sigma = np.asarray(wrench_noise, dtype=float).reshape(6)
    A = np.concatenate([Y, np.broadcast_to(np.eye(6), (len(Y), 6, 6))], axis=2) / sigma[None, :, None]
    normal = np.einsum("nij,nik->jk", A, A)
    scale = 1.0 / np.sqrt(np.maximum(np.diag(normal), 1e-300))
    scaled = normal * scale[:, None] * scale[None, :]
    eigenvalues = np.linalg.eigvalsh(scaled)
    if eigenvalues.min() <= 1e-12 * eigenvalues.max():
        return np.inf, np.full(3, np.inf), np.full((3, 3), np.inf)
    cov = (np.linalg.inv(scaled) * scale[:, None] * scale[None, :])[:10, :10]
    inertia = config.inertia_com if config.inertia_com is not None else np.zeros((3, 3))
    G = _derived_jacobian(inertial.parameters(config.mass, config.p_sensor_com, inertia))
    stderr = np.sqrt(np.maximum(np.diag(G @ cov @ G.T), 0.0))
    stderr_inertia = np.zeros((3, 3))
    for k, (i, j) in enumerate(PAIRS):
        stderr_inertia[i, j] = stderr_inertia[j, i] = stderr[4 + k]
    return float(stderr[0]), stderr[1:4], stderr_inertia


def plan_payload_motion(
    kin: Kinematics,
    tool: Tool,
    wrench_noise,
    rate_hz: float = 500.0,
    min_clearance: float = 0.02,
    seconds: float = 8.0,
    amplitude: float = 0.6,
) -> PayloadPlan:
    """The payload motion of :func:`payload_excitation` from the calibration's home, checked and with its predicted precision.

    The home is the calibration sweeps' (:func:`fts_calib.planning.planner.plan_base`: the
    robot file's, or one chosen clear of the robot); the motion stays within the joint limits
    (ruckig); every sample whose joints moved 0.05 rad since the last checked is checked for
    collisions with the payload's shape (its envelope in the tool file).

    Args:
        kin: Kinematics.
        tool: The payload's tool file (first configuration; its shape, mass, centre of mass, inertia).
        wrench_noise: Wrench noise per sample [N, N m], shape (6,), for the predicted standard errors.
        rate_hz: Sample rate [Hz].
        min_clearance: Smallest distance allowed [m].
        seconds: Longest duration [s].
        amplitude: Swing of each moving joint about home [rad].

    Raises:
        TrajectoryError: No home clear of the robot, or no stop of the pattern fits in ``seconds``.
    """
    joints = tuple(kin.joint_names[-3:])
    checker = CollisionChecker(kin, tool.shape or default_shape(tool.configurations), joints[0])
    report, _ = plan_base(kin, checker, SweepPattern(), min_clearance)
    time, q, qd, qdd = payload_excitation(kin, report.home, seconds, amplitude, rate_hz, joints)
    limits, ratio, problems = kin.limits, {}, []
    for name in joints:
        k = kin.joint_names.index(name)
        ratio[name] = {
            "velocity": float(np.abs(qd[:, k]).max() / limits.velocity[k]),
            "acceleration": float(np.abs(qdd[:, k]).max() / limits.acceleration[k]),
        }
        if np.any(q[:, k] < limits.lower[k]) or np.any(q[:, k] > limits.upper[k]):
            problems.append(f"{name} leaves its position limits [{limits.lower[k]:+.3f}, {limits.upper[k]:+.3f}] rad")
    moved = np.concatenate([[0.0], np.cumsum(np.max(np.abs(np.diff(q, axis=0)), axis=1))])
    checked = np.unique(np.concatenate([np.unique(np.floor(moved / 0.05).astype(int), return_index=True)[1], [len(q) - 1]]))
    found = checker.clearance(q[checked], "all")
    clearance = Clearance(found.distance, found.pair, int(checked[found.index]) if found.index >= 0 else -1)
    if clearance.distance < min_clearance:
        when = f" at t = {time[clearance.index]:.2f} s" if clearance.index >= 0 else ""
        problems.append(
            f"collision: '{clearance.pair[0]}' and '{clearance.pair[1]}' are {clearance.distance:.3f} m apart{when} "
            f"(at least {min_clearance} m needed): a smaller --amplitude of the payload motion, or another home in the robot file"
        )
    name = tool.configurations[0].name
    mass, com, inertia = predicted_payload_stderr(kin, tool, name, q, qd, qdd, wrench_noise)
    noise = np.asarray(wrench_noise, dtype=float).reshape(6)
    return PayloadPlan(time, q, qd, qdd, joints, name, ratio, clearance, mass, com, inertia, noise, problems)

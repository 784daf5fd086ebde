"""The sampled calibration motion: jerk-limited ruckig segments from home through the stops.

Between stops the moving joints travel together along one ruckig state-to-state segment,
from rest to rest, within the velocity, acceleration and jerk limits of the robot
definition (and its position limits when they are finite); at each stop the arm dwells
still for ``dwell`` seconds, which gives the quasi-static samples the calibration keeps.
The motion starts and ends at home, where the tool configuration is changed. The other
joints hold their home readings.

Angles in [rad], times in [s], rates in [Hz]; samples are evenly spaced at the rate, the
sample axis first, joints in :attr:`Kinematics.joint_names` order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import ruckig

from ..core.arrays import frozen
from ..core.exceptions import TrajectoryError
from ..robot.joints import JointLimits
from ..robot.kinematics import Kinematics
from .sweeps import SweepPattern, raster
from .trajectory_files import TrajectoryFile


@dataclass(frozen=True)
class Plan:
    """A sampled calibration motion (the same for every tool configuration).

    Attributes:
        robot: Robot name.
        joint_names: Actuated joints, in order.
        sweep_joints: The two sweep joints.
        home: Base pose, [rad]. Shape (n_joints,).
        ranges: Range swept by each sweep joint, [rad]. Shape (2, 2), rows (low, high).
        waypoints: Stops of the sweep joints, in visiting order, [rad]. Shape (W, 2).
        pattern: The raster.
        limits: Limits of every joint used for planning.
        rate: Sample rate in [Hz].
        time: Sample times in [s]. Shape (N,).
        q: Joint positions, [rad]. Shape (N, n_joints).
        qd: Joint velocities, [rad/s]. Shape (N, n_joints).
        qdd: Joint accelerations, [rad/s^2]. Shape (N, n_joints).
    """

    robot: str
    joint_names: tuple[str, ...]
    sweep_joints: tuple[str, str]
    home: np.ndarray
    ranges: np.ndarray
    waypoints: np.ndarray
    pattern: SweepPattern
    limits: JointLimits
    rate: float
    time: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray

    def __post_init__(self):
        for name in ("home", "ranges", "waypoints", "time", "q", "qd", "qdd"):
            object.__setattr__(self, name, frozen(getattr(self, name)))

    @property
    def duration(self) -> float:
        """Length of the motion in [s]."""
        return float(self.time[-1])

    def trajectory(self, configuration: str) -> TrajectoryFile:
        """The motion as the trajectory of one tool configuration (what a trajectory file holds)."""
        return TrajectoryFile(self.joint_names, self.time, self.q, self.qd, self.qdd, configuration)


def plan_sweeps(kin: Kinematics, home: np.ndarray, ranges: np.ndarray, pattern: SweepPattern, rate: float) -> Plan:
    """Plan and sample the sweep motion from home, through every stop, back to home.

    Args:
        kin: Robot kinematics (sweep joints and limits).
        home: Base pose, [rad]. Shape (n_joints,).
        ranges: Range of each sweep joint, [rad]. Shape (2, 2).
        pattern: The raster of stops.
        rate: Sample rate in [Hz], > 0.

    Raises:
        TrajectoryError: Bad rate, or ruckig refusing a segment.
    """
    home = np.asarray(home, dtype=float)
    stops = raster(kin, home, ranges, pattern)
    passing = passing_velocities(kin, home, kin.sweep_joints, stops) if pattern.continuous else None
    time, q, qd, qdd = sample_motion(kin, home, kin.sweep_joints, stops, pattern.dwell, rate, passing)
    first, second = kin.sweep_joints  # two of them: raster has already unpacked them the same way
    return Plan(kin.robot.name, kin.joint_names, (first, second), home, ranges, stops, pattern, kin.limits, rate, time, q, qd, qdd)


def sample_motion(kin: Kinematics, home: np.ndarray, joints, stops: np.ndarray, dwell: float, rate: float, velocities=None):
    """Ruckig segments of some joints from home, through stops, back to home (rest to rest unless ``velocities``).

    Args:
        kin: Kinematics (limits).
        home: Base pose [rad], shape (n_joints,); the other joints stay there.
        joints: Names of the joints that move.
        stops: Their positions at each stop [rad], shape (W, len(joints)).
        dwell: Time still at each stop [s].
        rate: Sample rate [Hz], > 0.
        velocities: Velocity of the joints as they pass each stop [rad/s], shape (W, len(joints));
            None to stop at each (the motion starts and ends at rest at home either way).

    Returns:
        ``(time (N,), q, qd, qdd (N, n_joints))`` in [s, rad, rad/s, rad/s^2].

    Raises:
        TrajectoryError: Bad rate, or ruckig refusing a segment.
    """
    if not (math.isfinite(rate) and rate > 0):
        raise TrajectoryError(f"rate={rate} Hz but expected a finite rate > 0", "invalid rate")
    home = np.asarray(home, dtype=float)
    index = [kin.joint_names.index(name) for name in joints]
    start = home[index]
    # (start time, duration, trajectory or None for a hold, held position)
    pieces: list[tuple[float, float, ruckig.Trajectory | None, np.ndarray]] = []
    t = 0.0
    position, speed = start, np.zeros(len(index))
    passing = np.zeros((len(stops), len(index))) if velocities is None else np.asarray(velocities, dtype=float)
    for target, target_speed in zip([*stops, start], [*passing, np.zeros(len(index))], strict=True):
        segment = _segment(position, target, kin.limits, index, speed, target_speed)
        pieces.append((t, segment.duration, segment, target))
        t += segment.duration
        position, speed = target, target_speed
        if dwell > 0 and target is not start:
            pieces.append((t, dwell, None, target))
            t += dwell
    # the last sample at or after the end (the time rounded up to the sample grid): rows past it hold the end at rest
    n = int(math.ceil(t * rate - 1e-9)) + 1
    time = np.arange(n) / rate
    q = np.repeat(home[None, :], n, axis=0)
    qd = np.zeros((n, len(home)))
    qdd = np.zeros((n, len(home)))
    starts = np.array([p[0] for p in pieces])
    which = np.clip(np.searchsorted(starts, time, side="right") - 1, 0, len(pieces) - 1)
    for k, (t0, duration, trajectory, held) in enumerate(pieces):
        rows = np.nonzero(which == k)[0]
        if trajectory is None:
            q[np.ix_(rows, np.asarray(index, dtype=np.intp))] = held
            continue
        for row in rows:
            p, v, a = trajectory.at_time(min(time[row] - t0, duration))
            q[row, index], qd[row, index], qdd[row, index] = p, v, a
    done = time >= t - 1e-9 / rate  # at or past the end: home at rest exactly (not ruckig's end state, off by round-off)
    q[np.ix_(done, np.asarray(index, dtype=np.intp))] = start
    qd[done], qdd[done] = 0.0, 0.0
    return time, q, qd, qdd


def segment_durations(kin: Kinematics, home: np.ndarray, stops: np.ndarray, continuous: bool = False) -> list[float]:
    """Durations [s] of the ruckig segments of the sweep joints from home, through ``stops`` (W, 2), back home (no sampling).

    With ``continuous`` the stops are passed at :func:`passing_velocities`, else at rest.
    """
    index = [kin.joint_names.index(name) for name in kin.sweep_joints]
    start = np.asarray(home, dtype=float)[index]
    points = [start, *np.asarray(stops, dtype=float), start]
    rest = np.zeros(len(index))
    speeds = [rest, *(passing_velocities(kin, home, kin.sweep_joints, stops) if continuous else [rest] * len(stops)), rest]
    pairs = zip(points[:-1], points[1:], speeds[:-1], speeds[1:], strict=True)
    return [_segment(a, b, kin.limits, index, va, vb).duration for a, b, va, vb in pairs]


#: Fraction of the speed a joint could reach in the shorter of its two moves that it passes a stop at.
PASSING_FRACTION = 0.8


def passing_velocities(kin: Kinematics, home: np.ndarray, joints, stops: np.ndarray) -> np.ndarray:
    """Velocities [rad/s] at which a continuous motion passes its stops, shape (W, len(joints)).

    A joint that moves on in the same direction passes the stop at :data:`PASSING_FRACTION` of
    the speed it could reach over the shorter of its moves in and out (``sqrt(a d)`` for an
    acceleration limit a and a distance d, within its velocity limit); one that turns back or
    holds passes it at rest. The motion starts and ends at rest at home.
    """
    index = [kin.joint_names.index(name) for name in joints]
    points = np.vstack([np.asarray(home, dtype=float)[index], np.asarray(stops, dtype=float), np.asarray(home, dtype=float)[index]])
    before, after = np.diff(points, axis=0)[:-1], np.diff(points, axis=0)[1:]
    same = np.sign(before) * np.sign(after) > 0
    reach = np.sqrt(kin.limits.acceleration[index] * np.minimum(np.abs(before), np.abs(after)))
    speed = PASSING_FRACTION * np.minimum(kin.limits.velocity[index], reach)
    return np.where(same, np.sign(after) * speed, 0.0)


def _segment(start: np.ndarray, target: np.ndarray, limits: JointLimits, index: list[int], v0=None, v1=None) -> ruckig.Trajectory:
    """One ruckig segment from ``start`` at velocity ``v0`` to ``target`` at ``v1`` (at rest when None), zero acceleration at both."""
    dofs = len(index)
    inp = ruckig.InputParameter(dofs)
    inp.current_position = [float(v) for v in start]
    inp.current_velocity = [0.0] * dofs if v0 is None else [float(v) for v in v0]
    inp.current_acceleration = [0.0] * dofs
    inp.target_position = [float(v) for v in target]
    inp.target_velocity = [0.0] * dofs if v1 is None else [float(v) for v in v1]
    inp.target_acceleration = [0.0] * dofs
    inp.max_velocity = [float(limits.velocity[k]) for k in index]
    inp.max_acceleration = [float(limits.acceleration[k]) for k in index]
    inp.max_jerk = [float(limits.jerk[k]) for k in index]
    lower = [float(limits.lower[k]) for k in index]
    upper = [float(limits.upper[k]) for k in index]
    if all(math.isfinite(v) for v in lower + upper):
        inp.min_position, inp.max_position = lower, upper
    otg = ruckig.Ruckig(dofs)
    where = f"segment from {np.round(start, 4).tolist()} to {np.round(target, 4).tolist()} rad"
    trajectory = ruckig.Trajectory(dofs)
    try:
        otg.validate_input(inp, True, True)
        result = otg.calculate(inp, trajectory)
    except (RuntimeError, ruckig.RuckigError) as exc:
        message = str(exc).strip().replace("[ruckig] ", "")
        raise TrajectoryError(f"ruckig rejected the {where}: {message}", "ErrorInvalidInput") from None
    if result not in (ruckig.Result.Working, ruckig.Result.Finished):
        raise TrajectoryError(f"ruckig could not plan the {where}: {result.name}", result.name)
    return trajectory

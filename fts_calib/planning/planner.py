"""Calibration trajectories: jerk-limited sweeps of the last two joints with ruckig.

The arm holds a base pose (``home``) while its two sweep joints visit a raster of stops: the
first sweep joint steps through ``levels`` positions across its range and, at each, the
second visits ``stops`` positions across its range, back and forth (paper Fig. 3: about
+-180 deg, or the joint limits when narrower). Between stops the two joints move together
along one ruckig state-to-state segment, from rest to rest, within the velocity,
acceleration and jerk limits of the robot definition; at each stop the arm dwells still for
``dwell`` seconds, which gives the quasi-static samples the calibration keeps. The motion
starts and ends at home, where the tool configuration is changed.

Gravity sweeps the whole sphere in the sensor frame when the first sweep joint's axis is
horizontal and the second's is not parallel to it. When the robot definition gives no
home, one is chosen: among deterministic candidate poses of the joints above the sweep
joints, the joint nearest the first sweep joint that can tilt its axis is set so that the
axis is horizontal, and the pose whose sweep keeps the largest clearance from the robot and
the floor wins.

Angles in [rad], times in [s]; every result is deterministic for the same inputs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import ruckig

from ..core.arrays import frozen
from ..core.exceptions import TrajectoryError
from ..robot.collision import Clearance, CollisionChecker
from ..robot.kinematics import JointLimits, Kinematics
from .excitation import coverage_angle

#: A home whose first sweep axis is tilted more than this from the horizontal is poor.
MAX_AXIS_TILT_DEG = 20.0
#: The two sweep axes must be at least this far from parallel.
MIN_AXES_ANGLE_DEG = 30.0
#: Default smallest distance [m] allowed between the robot, the tool and the floor.
MIN_CLEARANCE = 0.02

_HOME_CANDIDATES = 48  # random candidate poses for the automatic home (fixed seed)
_TILT_SCAN = 72  # grid of the tilt joint before bisection
_LIMIT_RTOL = 1e-6  # sampled values may exceed a limit by this fraction (floating point)


@dataclass(frozen=True)
class SweepPattern:
    """The raster of stops of the two sweep joints.

    Attributes:
        levels: Positions of the first sweep joint across its range (>= 2).
        stops: Positions of the second sweep joint per level (>= 2).
        dwell: Time held still at each stop, in [s] (>= 0).
        margin: Distance kept from the position limits, in [rad] (>= 0).
    """

    levels: int = 4
    stops: int = 6
    dwell: float = 0.5
    margin: float = 0.02

    def __post_init__(self):
        if self.levels < 2 or self.stops < 2:
            raise TrajectoryError(f"levels={self.levels} and stops={self.stops} but expected at least 2 each", "invalid pattern")
        if not (math.isfinite(self.dwell) and self.dwell >= 0):
            raise TrajectoryError(f"dwell={self.dwell} s but expected a finite value >= 0", "invalid pattern")
        if not (math.isfinite(self.margin) and self.margin >= 0):
            raise TrajectoryError(f"margin={self.margin} rad but expected a finite value >= 0", "invalid pattern")


@dataclass(frozen=True)
class HomeReport:
    """The base pose and how good it is for calibration.

    Attributes:
        home: Joint readings of the base pose, [rad]. Shape (n_joints,).
        source: 'robot definition' or 'automatic'.
        axis_tilt_deg: Angle of the first sweep joint's axis from the horizontal plane, [deg].
        axes_angle_deg: Angle between the two sweep axes, [deg] (0 to 90).
        tilt_joint: The joint above the sweep joints that tilts the first sweep axis, or None.
    """

    home: np.ndarray
    source: str
    axis_tilt_deg: float
    axes_angle_deg: float
    tilt_joint: str | None

    def __post_init__(self):
        object.__setattr__(self, "home", frozen(self.home))


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

    def still(self, max_speed: float, max_acceleration: float) -> np.ndarray:
        """Quasi-static samples: every joint slower than ``max_speed`` [rad/s].

        And accelerating less than ``max_acceleration`` [rad/s^2]. Shape (N,) bool.
        """
        return np.all(np.abs(self.qd) <= max_speed, axis=1) & np.all(np.abs(self.qdd) <= max_acceleration, axis=1)


@dataclass(frozen=True)
class LimitCheck:
    """Peaks of the sampled motion against the limits, per sweep joint.

    Attributes:
        peaks: joint -> {'velocity', 'acceleration', 'jerk'}: peak absolute value over the
            samples (jerk from finite differences of the accelerations), in rad/s^k.
        ratios: joint -> the same peaks divided by their limits (<= 1 within limits).
        position_ok: Every sample of every joint within its position limits.
    """

    peaks: dict[str, dict[str, float]]
    ratios: dict[str, dict[str, float]]
    position_ok: bool

    @property
    def ok(self) -> bool:
        """Every limit respected (to floating-point precision)."""
        return self.position_ok and all(r <= 1.0 + _LIMIT_RTOL for joint in self.ratios.values() for r in joint.values())


def _angle_between_axes(u: np.ndarray, v: np.ndarray) -> float:
    return math.degrees(math.acos(min(1.0, abs(float(np.dot(u, v))))))


def _tilt(kin: Kinematics, reading: np.ndarray) -> float:
    """Sine of the first sweep axis's angle from the horizontal plane."""
    axis = kin.joint_axis_world(reading, kin.sweep_joints[0])
    g = kin.g_world()
    return float(np.dot(axis, g / np.linalg.norm(g)))


def _tilt_joints(kin: Kinematics) -> list[str]:
    """Revolute joints above the first sweep joint, nearest first: those that can tilt its axis."""
    upstream = kin.chain_joints(kin.sweep_joints[0])[:-1]
    return [name for name in reversed(upstream) if kin.joints[kin.joint_names.index(name)].kind != "prismatic"]


def _horizontal(kin: Kinematics, reading: np.ndarray) -> tuple[str | None, list[np.ndarray]]:
    """Readings from this one, varying one joint, where the first sweep axis is horizontal.

    Returns the nearest joint above the first sweep joint that can do it, and the readings.
    """
    for joint in _tilt_joints(kin):
        roots = _tilt_roots(kin, reading, joint)
        if roots:
            return joint, roots
    return None, []


def home_report(kin: Kinematics, home: np.ndarray, source: str) -> HomeReport:
    """Measure a base pose: tilt of the first sweep axis and angle between the sweep axes."""
    a, b = kin.sweep_joints
    za, zb = kin.joint_axis_world(home, a), kin.joint_axis_world(home, b)
    tilt = math.degrees(math.asin(min(1.0, abs(_tilt(kin, home)))))
    return HomeReport(home, source, tilt, _angle_between_axes(za, zb), _horizontal(kin, home)[0])


def check_home(kin: Kinematics, report: HomeReport, max_tilt_deg: float = MAX_AXIS_TILT_DEG) -> None:
    """Refuse a base pose that cannot make gravity sweep the sphere in the sensor frame.

    Raises:
        TrajectoryError: Outside the joint limits, first sweep axis too far from horizontal
            (gravity would stay near one circle), or sweep axes nearly parallel; the message
            says what to change.
    """
    lim = kin.limits
    outside = [
        f"{n} = {v:+.4f} rad not in [{lo:+.4f}, {hi:+.4f}]"
        for n, v, lo, hi in zip(kin.joint_names, report.home, lim.lower, lim.upper, strict=True)
        if not lo <= v <= hi
    ]
    if outside:
        raise TrajectoryError(f"home outside the joint limits: {'; '.join(outside)}", "home outside limits")
    a, b = kin.sweep_joints
    if report.axes_angle_deg < MIN_AXES_ANGLE_DEG:
        raise TrajectoryError(
            f"poor home: the axes of {a} and {b} are {report.axes_angle_deg:.1f}° apart (at least {MIN_AXES_ANGLE_DEG:.0f}° "
            "needed): the two sweeps would turn the sensor about nearly the same axis. Choose other sweep_joints.",
            "poor home",
        )
    if report.axis_tilt_deg > max_tilt_deg:
        fix = f"change {report.tilt_joint}" if report.tilt_joint else "change the joints above it"
        raise TrajectoryError(
            f"poor home: the axis of {a} is {report.axis_tilt_deg:.1f}° from horizontal (at most {max_tilt_deg:.0f}°): "
            f"gravity would stay near one circle in the sensor frame and the sweep cannot determine every coefficient. "
            f"{fix.capitalize()} so that the axis of {a} is horizontal, or remove 'home' from the robot definition to have "
            "one planned.",
            "poor home",
        )


def sweep_ranges(kin: Kinematics, home: np.ndarray, margin: float) -> np.ndarray:
    """Range of each sweep joint: home +- 180 deg, within the limits less the margin. Shape (2, 2)."""
    out = []
    for name in kin.sweep_joints:
        k = kin.joint_names.index(name)
        lo = max(kin.limits.lower[k] + margin, home[k] - math.pi)
        hi = min(kin.limits.upper[k] - margin, home[k] + math.pi)
        if not hi - lo > 1e-3:
            raise TrajectoryError(f"{name} cannot sweep: range [{lo:+.4f}, {hi:+.4f}] rad after a margin of {margin} rad", "empty range")
        out.append((lo, hi))
    return np.array(out)


@dataclass(frozen=True)
class RangeReport:
    """Ranges of the sweep joints, and why the first was narrowed, if it was.

    Attributes:
        ranges: Range of each sweep joint, [rad]. Shape (2, 2), rows (low, high).
        full: The ranges before narrowing (home +- 180 deg within the limits). Shape (2, 2).
        note: Why the first range was narrowed, or ''.
    """

    ranges: np.ndarray
    full: np.ndarray
    note: str = ""


_WRIST_STEP = math.radians(2.5)  # grid of the first sweep joint when narrowing its range
_WRIST_SECOND = 12  # grid of the second sweep joint when narrowing
_MIN_SWEEP = math.radians(60.0)  # a narrowed first range shorter than this is refused


def wrist_ranges(kin: Kinematics, checker: CollisionChecker, reading: np.ndarray, full: np.ndarray, min_clearance: float) -> RangeReport:
    """Narrow the first sweep joint's range to where the tool and last links clear the wrist.

    The largest interval where they stay clear for every angle of the second sweep joint (a
    check that does not depend on the home pose).

    Raises:
        TrajectoryError: The clear interval is shorter than 60 deg; names the pair of bodies.
    """
    index = [kin.joint_names.index(name) for name in kin.sweep_joints]
    first = np.linspace(full[0, 0], full[0, 1], max(2, int(math.ceil((full[0, 1] - full[0, 0]) / _WRIST_STEP)) + 1))
    second = np.linspace(full[1, 0], full[1, 1], _WRIST_SECOND)
    worst = []
    for value in first:
        grid = np.repeat(reading[None, :], len(second), axis=0)
        grid[:, index[0]] = value
        grid[:, index[1]] = second
        worst.append(checker.clearance(grid, "wrist"))
    # half a grid step of slack on each side of a clear cell: the distance changes little in between
    ok = np.array([c.distance >= 1.5 * min_clearance for c in worst])
    if ok.all():
        return RangeReport(full.copy(), full.copy())
    best_start, best_len, start = 0, 0, None
    for k, good in enumerate([*ok, False]):
        if good and start is None:
            start = k
        elif not good and start is not None:
            if k - start > best_len:
                best_start, best_len = start, k - start
            start = None
    closest = min(worst, key=lambda c: c.distance)
    if best_len < 2 or first[best_start + best_len - 1] - first[best_start] < _MIN_SWEEP:
        raise TrajectoryError(
            f"'{closest.pair[0]}' and '{closest.pair[1]}' come {closest.distance:.3f} m apart during the sweep of "
            f"{kin.sweep_joints[0]} whatever the home, leaving no interval of at least {math.degrees(_MIN_SWEEP):.0f}° with "
            f"{1.5 * min_clearance:.3f} m of clearance (the required {min_clearance} m plus half for the grid): "
            "use a smaller tool shape.",
            "collision",
        )
    ranges = full.copy()
    ranges[0] = (first[best_start], first[best_start + best_len - 1])
    note = (
        f"{kin.sweep_joints[0]} narrowed from [{full[0, 0]:+.3f}, {full[0, 1]:+.3f}] to [{ranges[0, 0]:+.3f}, "
        f"{ranges[0, 1]:+.3f}] rad: beyond, '{closest.pair[0]}' and '{closest.pair[1]}' "
        + ("overlap" if closest.distance <= 0 else f"come within {closest.distance:.3f} m")
    )
    return RangeReport(ranges, full.copy(), note)


def _positions(lo: float, hi: float, count: int) -> np.ndarray:
    """``count`` stops across [lo, hi]; on a full turn the end that repeats the start is dropped."""
    if hi - lo >= 2.0 * math.pi - 1e-9:
        return np.linspace(lo, hi, count + 1)[:-1]
    return np.linspace(lo, hi, count)


_LEVEL_GRID = 241  # grid of the first sweep joint when placing its levels


def latitude_levels(kin: Kinematics, home: np.ndarray, span: np.ndarray, count: int) -> np.ndarray:
    """Positions of the first sweep joint that spread gravity's latitude evenly, sorted.

    The latitude is about the second sweep axis.

    At a level where gravity is along the second sweep axis, every stop of that joint shows
    the sensor the same gravity direction; levels evenly spaced in latitude, from the
    attainable minimum to the maximum (mid-points of equal bands), make the stops cover the
    sphere instead. The levels lie on one monotone stretch of the latitude, which also keeps
    the moves of the first joint short.

    Args:
        kin: Kinematics.
        home: Base pose [rad], shape (n_joints,).
        span: Range of the first sweep joint [rad], (low, high).
        count: Number of levels.
    """
    a, b = kin.sweep_joints
    ia = kin.joint_names.index(a)
    grid = np.linspace(span[0], span[1], _LEVEL_GRID)
    g = kin.g_world()
    g = g / np.linalg.norm(g)
    sine = []
    for value in grid:
        reading = home.copy()
        reading[ia] = value
        sine.append(float(np.dot(kin.joint_axis_world(reading, b), g)))
    sine = np.clip(np.array(sine), -1.0, 1.0)
    i, j = sorted((int(np.argmin(sine)), int(np.argmax(sine))))
    stretch = np.arange(i, j + 1)
    low, high = np.arcsin(sine[i : j + 1].min()), np.arcsin(sine[i : j + 1].max())
    targets = np.sin(low + (np.arange(count) + 0.5) * (high - low) / count)
    levels = [grid[stretch[np.argmin(np.abs(sine[stretch] - t))]] for t in targets]
    return np.sort(np.array(levels))


def raster(kin: Kinematics, home: np.ndarray, ranges: np.ndarray, pattern: SweepPattern) -> np.ndarray:
    """The stops in visiting order, shape (W, 2).

    At each level of the first sweep joint (:func:`latitude_levels`), the second joint's
    stops, back and forth. On a full turn of the second joint, odd levels shift its stops by
    half a step (the directions interleave).
    """
    first = latitude_levels(kin, home, ranges[0], pattern.levels)
    second = _positions(ranges[1, 0], ranges[1, 1], pattern.stops)
    full_turn = ranges[1, 1] - ranges[1, 0] >= 2.0 * math.pi - 1e-9
    half = (second[1] - second[0]) / 2 if full_turn else 0.0
    rows = []
    for i, level in enumerate(first):
        values = second + (half if i % 2 else 0.0)
        for value in values if i % 2 == 0 else values[::-1]:
            rows.append((level, value))
    return np.array(rows)


def _segment(start: np.ndarray, target: np.ndarray, limits: JointLimits, index: list[int]) -> ruckig.Trajectory:
    dofs = len(index)
    inp = ruckig.InputParameter(dofs)
    inp.current_position = [float(v) for v in start]
    inp.current_velocity = [0.0] * dofs
    inp.current_acceleration = [0.0] * dofs
    inp.target_position = [float(v) for v in target]
    inp.target_velocity = [0.0] * dofs
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
    time, q, qd, qdd = sample_motion(kin, home, kin.sweep_joints, stops, pattern.dwell, rate)
    first, second = kin.sweep_joints  # two of them: raster has already unpacked them the same way
    return Plan(kin.robot.name, kin.joint_names, (first, second), home, ranges, stops, pattern, kin.limits, rate, time, q, qd, qdd)


def sample_motion(kin: Kinematics, home: np.ndarray, joints, stops: np.ndarray, dwell: float, rate: float):
    """Rest-to-rest ruckig segments of some joints from home, through stops, back to home.

    Args:
        kin: Kinematics (limits).
        home: Base pose [rad], shape (n_joints,); the other joints stay there.
        joints: Names of the joints that move.
        stops: Their positions at each stop [rad], shape (W, len(joints)).
        dwell: Time still at each stop [s].
        rate: Sample rate [Hz], > 0.

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
    position = start
    for target in [*stops, start]:
        segment = _segment(position, target, kin.limits, index)
        pieces.append((t, segment.duration, segment, target))
        t += segment.duration
        position = target
        if dwell > 0 and target is not start:
            pieces.append((t, dwell, None, target))
            t += dwell
    n = int(math.floor(t * rate + 1e-9)) + 1
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
    return time, q, qd, qdd


def check_limits(plan: Plan) -> LimitCheck:
    """Peaks of velocity, acceleration and jerk of every sweep joint against the limits."""
    lim = plan.limits
    peaks, ratios = {}, {}
    for name in plan.sweep_joints:
        k = plan.joint_names.index(name)
        jerk = np.abs(np.diff(plan.qdd[:, k])) * plan.rate if len(plan.time) > 1 else np.zeros(1)
        peak = {
            "velocity": float(np.max(np.abs(plan.qd[:, k]))),
            "acceleration": float(np.max(np.abs(plan.qdd[:, k]))),
            "jerk": float(np.max(jerk)),
        }
        peaks[name] = peak
        ratios[name] = {
            "velocity": peak["velocity"] / lim.velocity[k],
            "acceleration": peak["acceleration"] / lim.acceleration[k],
            "jerk": peak["jerk"] / lim.jerk[k],
        }
    tol = 1e-9
    position_ok = bool(np.all((plan.q >= lim.lower - tol) & (plan.q <= lim.upper + tol)))
    return LimitCheck(peaks, ratios, position_ok)


def collision_samples(plan: Plan, step: float = 0.05) -> np.ndarray:
    """Indices of samples to check for collisions.

    Every stop, and along the motion so that no joint moves more than ``step`` [rad]
    between two checked samples.
    """
    moved = np.concatenate([[0.0], np.cumsum(np.max(np.abs(np.diff(plan.q, axis=0)), axis=1))])
    marks = np.unique(np.floor(moved / step).astype(int), return_index=True)[1]
    ends = np.nonzero(np.all(plan.qd == 0.0, axis=1))[0]
    return np.unique(np.concatenate([marks, ends[:: max(1, int(plan.rate * 0.25))], [len(plan.time) - 1]]))


def _sweep_grid(kin: Kinematics, home: np.ndarray, ranges: np.ndarray, pattern: SweepPattern) -> np.ndarray:
    """Readings at every stop and half-way between neighbouring stops (for scoring homes)."""
    index = [kin.joint_names.index(name) for name in kin.sweep_joints]
    stops = raster(kin, home, ranges, pattern)
    points = np.vstack([stops, (stops[1:] + stops[:-1]) / 2])  # the stops come first
    grid = np.repeat(home[None, :], len(points), axis=0)
    grid[:, index] = points
    return grid


def _base_reading(kin: Kinematics) -> np.ndarray:
    """Middle of each joint's limits when they span at most a turn, else 0 (within the limits)."""
    lim = kin.limits
    bounded = np.isfinite(lim.lower) & np.isfinite(lim.upper)
    lower, upper = np.where(bounded, lim.lower, 0.0), np.where(bounded, lim.upper, 0.0)
    middle = (lower + upper) / 2
    return np.where(bounded & (upper - lower <= 2.0 * math.pi), middle, np.clip(0.0, lim.lower, lim.upper))


def _tilt_roots(kin: Kinematics, reading: np.ndarray, joint: str) -> list[np.ndarray]:
    """Readings, varying only ``joint``, where the first sweep axis is horizontal."""
    k = kin.joint_names.index(joint)
    lo, hi = max(kin.limits.lower[k], -math.pi), min(kin.limits.upper[k], math.pi)
    grid = np.linspace(lo, hi, _TILT_SCAN)

    def f(value: float) -> float:
        r = reading.copy()
        r[k] = value
        return _tilt(kin, r)

    values = [f(v) for v in grid]
    roots = []
    for left, right, fl, fr in zip(grid[:-1], grid[1:], values[:-1], values[1:], strict=True):
        if fl == 0.0 or fl * fr < 0:
            for _ in range(40):  # bisection to ~1e-12 rad
                mid = 0.5 * (left + right)
                fm = f(mid)
                if fl * fm <= 0:
                    right = mid
                else:
                    left, fl = mid, fm
            r = reading.copy()
            r[k] = 0.5 * (left + right)
            roots.append(r)
    return roots


def choose_home(
    kin: Kinematics, checker: CollisionChecker, ranges: np.ndarray, pattern: SweepPattern, min_clearance: float = MIN_CLEARANCE
) -> HomeReport:
    """Choose a base pose automatically (see the module docstring).

    A candidate is acceptable when its home pose and a grid of its sweep keep every pair at
    least ``min_clearance`` apart. Among them, the best coverage of the sphere by the
    gravity directions at the stops wins (to the degree: where the first sweep joint cannot
    turn fully, the home decides which latitudes it reaches), then the sweep that stays
    farthest from the arm and the floor (the pairs that depend on the pose). The sweep
    joints start at the middle of their ranges.

    Raises:
        TrajectoryError: No candidate gives a horizontal first sweep axis with the required
            clearance; names the closest pair of bodies of the best candidate.
    """
    base = _base_reading(kin)
    index = [kin.joint_names.index(name) for name in kin.sweep_joints]
    base[index] = ranges.mean(axis=1)
    upstream = [kin.joint_names.index(n) for n in kin.chain_joints(kin.sweep_joints[0])[:-1]]
    rng = np.random.default_rng(0)
    lim = kin.limits
    lo, hi = np.maximum(lim.lower, -math.pi), np.minimum(lim.upper, math.pi)
    candidates = [base]
    for _ in range(_HOME_CANDIDATES):
        c = base.copy()
        c[upstream] = rng.uniform(lo[upstream], hi[upstream])
        candidates.append(c)
    best: tuple[tuple[float, float], np.ndarray] | None = None
    closest: Clearance | None = None
    found_horizontal = False
    for candidate in candidates:
        for home in _horizontal(kin, candidate)[1]:
            found_horizontal = True
            grid = _sweep_grid(kin, home, ranges, pattern)
            along = checker.clearance(grid, "sweep")
            at_home = checker.clearance(home, "home")
            worst = along if along.distance <= at_home.distance else at_home
            if worst.distance < min_clearance:
                if closest is None or worst.distance > closest.distance:
                    closest = worst
                continue
            score = (-round(coverage_angle(kin.g_sensor(grid[: len(grid) // 2 + 1])), 0), along.distance)
            if best is None or score > best[0]:
                best = (score, home)
    if best is None:
        # closest is None exactly when no horizontal home was found: each one found was either
        # too close (and updated closest) or scored (and set best)
        if not found_horizontal or closest is None:
            raise TrajectoryError(
                f"no joint above {kin.sweep_joints[0]} can make its axis horizontal within the joint "
                "limits: give 'home' in the robot definition",
                "no home",
            )
        raise TrajectoryError(
            f"no collision-free home found: the best candidate leaves {closest.distance:.3f} m between '{closest.pair[0]}' "
            f"and '{closest.pair[1]}' (at least {min_clearance} m needed). Give 'home' in the robot definition, a smaller "
            "tool shape, or fewer levels.",
            "no home",
        )
    return home_report(kin, best[1], "automatic")


@dataclass(frozen=True)
class PlanResult:
    """A plan with every check made before the robot moves.

    Attributes:
        plan: The sampled motion.
        home: The base pose and its quality.
        ranges: The sweep ranges, and why the first was narrowed.
        limits: Peaks against the limits.
        clearance: Smallest distance along the motion (sweep pairs).
        home_clearance: Smallest distance at the home pose (the other pairs).
        min_clearance: Required clearance, [m].
        problems: What failed, in words; empty when the plan is safe to run.
        checked_samples: Number of samples checked for collisions.
    """

    plan: Plan
    home: HomeReport
    ranges: RangeReport
    limits: LimitCheck
    clearance: Clearance
    home_clearance: Clearance
    min_clearance: float
    problems: list[str] = field(default_factory=list)
    checked_samples: int = 0


def plan_calibration(
    kin: Kinematics, checker: CollisionChecker, pattern: SweepPattern, rate: float, min_clearance: float = MIN_CLEARANCE
) -> PlanResult:
    """Plan the sweeps and verify them: limits on every sample, clearance along the motion.

    The home is the robot definition's, checked (:func:`check_home`), or chosen
    (:func:`choose_home`).

    Raises:
        TrajectoryError: Invalid input (rate, pattern, home outside limits, poor home) or
            ruckig refusing a segment. Failed checks of the result are listed in
            ``problems`` instead, so that the report can still be printed.
    """
    if not (math.isfinite(rate) and rate > 0):
        raise TrajectoryError(f"rate={rate} Hz but expected a finite rate > 0", "invalid rate")
    given = kin.robot.home is not None
    home = _base_reading(kin)
    for name, value in (kin.robot.home or {}).items():
        home[kin.joint_names.index(name)] = value
    if given:
        check_home(kin, home_report(kin, home, "robot definition"))
    ranges = wrist_ranges(kin, checker, home, sweep_ranges(kin, home, pattern.margin), min_clearance)
    report = home_report(kin, home, "robot definition") if given else choose_home(kin, checker, ranges.ranges, pattern, min_clearance)
    plan = plan_sweeps(kin, report.home, ranges.ranges, pattern, rate)
    limits = check_limits(plan)
    samples = collision_samples(plan)
    clearance = checker.clearance(plan.q[samples], "all")
    clearance = Clearance(clearance.distance, clearance.pair, int(samples[clearance.index]) if clearance.index >= 0 else -1)
    home_clearance = checker.clearance(report.home, "home")
    problems = []
    if not limits.ok:
        worst = max(((j, k, r) for j, d in limits.ratios.items() for k, r in d.items()), key=lambda x: x[2])
        problems.append(
            f"limits exceeded: {worst[0]} {worst[1]} reaches {worst[2]:.3f} of its limit"
            + ("" if limits.position_ok else "; positions outside the joint limits")
        )
    for what, c in (("along the sweep", clearance), ("at home", home_clearance)):
        if c.distance < min_clearance:
            when = f" at t = {plan.time[c.index]:.2f} s" if what == "along the sweep" else ""
            problems.append(
                f"collision {what}: '{c.pair[0]}' and '{c.pair[1]}' are {c.distance:.3f} m apart{when} (at least {min_clearance} m needed)"
            )
    return PlanResult(plan, report, ranges, limits, clearance, home_clearance, min_clearance, problems, len(samples))

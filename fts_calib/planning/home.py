"""The home pose: the base pose the arm holds while it sweeps, checked or chosen.

Gravity sweeps the whole sphere in the sensor frame when the first sweep joint's axis is
horizontal and the second's is not parallel to it. When the robot definition gives no
home, one is chosen: among deterministic candidate poses of the joints above the sweep
joints, the joint nearest the first sweep joint that can tilt its axis is set so that the
axis is horizontal, and the pose whose sweep keeps the largest clearance from the robot and
the floor wins.

Axes are unit vectors in the world frame, "horizontal" is normal to the model's gravity;
angles in [rad] (reports in [deg] where the name says so), distances in [m]. Every result
is deterministic for the same inputs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.arrays import frozen
from ..core.exceptions import TrajectoryError
from ..robot.collision import Clearance, CollisionChecker
from ..robot.kinematics import Kinematics
from .excitation import coverage_angle
from .sweeps import MIN_CLEARANCE, SweepPattern, default_sweep_note, raster

#: A home whose first sweep axis is tilted more than this from the horizontal is poor.
MAX_AXIS_TILT_DEG = 20.0
#: The two sweep axes must be at least this far from parallel.
MIN_AXES_ANGLE_DEG = 30.0

_HOME_CANDIDATES = 48  # random candidate poses for the automatic home (fixed seed)
_TILT_SCAN = 72  # grid of the tilt joint before bisection


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


def base_reading(kin: Kinematics) -> np.ndarray:
    """Middle of each joint's limits when they span at most a turn, else 0 (within the limits)."""
    lim = kin.limits
    bounded = np.isfinite(lim.lower) & np.isfinite(lim.upper)
    lower, upper = np.where(bounded, lim.lower, 0.0), np.where(bounded, lim.upper, 0.0)
    middle = (lower + upper) / 2
    return np.where(bounded & (upper - lower <= 2.0 * math.pi), middle, np.clip(0.0, lim.lower, lim.upper))


def _sweep_grid(kin: Kinematics, home: np.ndarray, ranges: np.ndarray, pattern: SweepPattern) -> np.ndarray:
    """Readings at every stop and half-way between neighbouring stops (for scoring homes)."""
    index = [kin.joint_names.index(name) for name in kin.sweep_joints]
    stops = raster(kin, home, ranges, pattern)
    points = np.vstack([stops, (stops[1:] + stops[:-1]) / 2])  # the stops come first
    grid = np.repeat(home[None, :], len(points), axis=0)
    grid[:, index] = points
    return grid


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
    base = base_reading(kin)
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
                f"limits: give 'home' in the robot definition{default_sweep_note(kin)}",
                "no home",
            )
        otherwise = "give 'home' in the robot definition, a smaller tool shape, or fewer levels"
        raise TrajectoryError(
            f"no collision-free home found: the best candidate leaves {closest.distance:.3f} m between '{closest.pair[0]}' "
            f"and '{closest.pair[1]}' (at least {min_clearance} m needed): {checker.advice(closest.pair, otherwise)}.",
            "no home",
        )
    return home_report(kin, best[1], "automatic")

"""Where the two sweep joints go: their ranges, the levels of the first, the raster of stops.

The arm holds a base pose (``home``) while its two sweep joints visit a raster of stops: the
first sweep joint steps through ``levels`` positions across its range and, at each, the
second visits ``stops`` positions across its range, back and forth (paper Fig. 3: about
+-180 deg, or the joint limits when narrower). The first joint's range is narrowed where the
tool and the last links would not clear the wrist, and its levels spread the latitude of
gravity about the second sweep axis evenly, so that the stops cover the sphere in the
sensor frame.

Angles in [rad], distances in [m]; every result is deterministic for the same inputs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.exceptions import TrajectoryError
from ..robot.collision import CollisionChecker
from ..robot.kinematics import Kinematics

#: Default smallest distance [m] allowed between the robot, the tool and the floor.
MIN_CLEARANCE = 0.02

_WRIST_STEP = math.radians(2.5)  # grid of the first sweep joint when narrowing its range
_WRIST_SECOND = 12  # grid of the second sweep joint when narrowing
_MIN_SWEEP = math.radians(60.0)  # a narrowed first range shorter than this is refused
_LEVEL_GRID = 241  # grid of the first sweep joint when placing its levels


@dataclass(frozen=True)
class SweepPattern:
    """The raster of stops of the two sweep joints.

    Attributes:
        levels: Positions of the first sweep joint across its range (>= 2).
        stops: Positions of the second sweep joint per level (>= 2; a continuous motion may
            have 1: the second joint crosses its span, end to end, as the first moves to the
            next level, both at once).
        dwell: Time held still at each stop, in [s] (>= 0).
        margin: Distance kept from the position limits, in [rad] (>= 0).
        span: Fraction of the second sweep joint's range its stops cover, about the
            middle of the range (0 < span <= 1; 1: the whole range).
        return_pass: After the raster, visit its stops again in reverse order, back to the
            first: every direction is seen at two times placed symmetrically about the
            middle of the sweep, so a drift of the offsets linear or quadratic in time is
            separable from the orientation (the drift model then costs no precision of C);
            the sweep takes about twice as long.
        continuous: Pass through the stops without stopping (``dwell`` must be 0): a joint
            that keeps its direction through a stop passes it at speed, one that turns back
            stops there for an instant; every sample moves, for the ``dynamic`` filter mode.
        smooth: With ``continuous``: no raster, the smooth excitation of
            :mod:`fts_calib.planning.smooth` instead (every joint on a sinusoid, ramped in and
            out at home); levels, stops and span are then unused.
    """

    levels: int = 4
    stops: int = 6
    dwell: float = 0.5
    margin: float = 0.02
    span: float = 1.0
    return_pass: bool = False
    continuous: bool = False
    smooth: bool = False

    def __post_init__(self):
        if self.levels < 2 or self.stops < (1 if self.continuous else 2):
            least = "at least 2 levels and 1 stop (continuous)" if self.continuous else "at least 2 each"
            raise TrajectoryError(f"levels={self.levels} and stops={self.stops} but expected {least}", "invalid pattern")
        if not (math.isfinite(self.dwell) and self.dwell >= 0):
            raise TrajectoryError(f"dwell={self.dwell} s but expected a finite value >= 0", "invalid pattern")
        if not (math.isfinite(self.margin) and self.margin >= 0):
            raise TrajectoryError(f"margin={self.margin} rad but expected a finite value >= 0", "invalid pattern")
        if not (math.isfinite(self.span) and 0 < self.span <= 1):
            raise TrajectoryError(f"span={self.span} but expected a fraction of the range in (0, 1]", "invalid pattern")
        if self.smooth and not self.continuous:
            raise TrajectoryError("a smooth motion is continuous: expected continuous=True with smooth=True", "invalid pattern")
        if self.continuous and self.dwell > 0:
            raise TrajectoryError(f"dwell={self.dwell} s but a continuous motion does not stop: expected 0", "invalid pattern")


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


def default_sweep_note(kin: Kinematics) -> str:
    """'' when the robot file names the sweep joints; else a clause saying they were chosen by default, and how to choose."""
    if kin.robot.sweep_joints is not None:
        return ""
    a, b = kin.sweep_joints
    return f" ({a} and {b} sweep by default, the last two actuated joints: name others with the robot file's 'sweep_joints')"


def sweep_ranges(kin: Kinematics, home: np.ndarray, margin: float) -> np.ndarray:
    """Range of each sweep joint: home +- 180 deg, within the limits less the margin. Shape (2, 2)."""
    out = []
    for name in kin.sweep_joints:
        k = kin.joint_names.index(name)
        lo = max(kin.limits.lower[k] + margin, home[k] - math.pi)
        hi = min(kin.limits.upper[k] - margin, home[k] + math.pi)
        if not hi - lo > 1e-3:
            raise TrajectoryError(
                f"{name} cannot sweep: range [{lo:+.4f}, {hi:+.4f}] rad after a margin of {margin} rad{default_sweep_note(kin)}",
                "empty range",
            )
        out.append((lo, hi))
    return np.array(out)


def wrist_ranges(kin: Kinematics, checker: CollisionChecker, joints: np.ndarray, full: np.ndarray, min_clearance: float) -> RangeReport:
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
        grid = np.repeat(joints[None, :], len(second), axis=0)
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
            + checker.advice(closest.pair, "use a smaller tool shape (the tool file's shape.radius and shape.length)")
            + f"{default_sweep_note(kin)}.",
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


def spanned(ranges: np.ndarray, span: float) -> np.ndarray:
    """The ranges with the second sweep joint's narrowed to ``span`` of it, about its middle. Shape (2, 2)."""
    out = np.array(ranges, dtype=float)
    if span < 1.0:
        middle, half = out[1].mean(), span * (out[1, 1] - out[1, 0]) / 2
        out[1] = (middle - half, middle + half)
    return out


def _positions(lo: float, hi: float, count: int) -> np.ndarray:
    """``count`` stops across [lo, hi]; on a full turn the end that repeats the start is dropped."""
    if hi - lo >= 2.0 * math.pi - 1e-9:
        return np.linspace(lo, hi, count + 1)[:-1]
    return np.linspace(lo, hi, count)


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
    half a step (the directions interleave). With ``pattern.return_pass`` the stops are then
    visited again in reverse order, back to the first.
    """
    first = latitude_levels(kin, home, ranges[0], pattern.levels)
    if pattern.stops == 1:  # continuous, both joints at once: the second joint from one end to the other at each level
        rows = [(level, ranges[1, i % 2]) for i, level in enumerate(first)]
        return np.array(rows + (rows[-2::-1] if pattern.return_pass else []))
    second = _positions(ranges[1, 0], ranges[1, 1], pattern.stops)
    full_turn = ranges[1, 1] - ranges[1, 0] >= 2.0 * math.pi - 1e-9
    half = (second[1] - second[0]) / 2 if full_turn else 0.0
    rows = []
    for i, level in enumerate(first):
        values = second + (half if i % 2 else 0.0)
        for value in values if i % 2 == 0 else values[::-1]:
            rows.append((level, value))
    if pattern.return_pass:
        rows += rows[-2::-1]  # back through every stop to the first (the last is not held twice)
    return np.array(rows)

"""Calibration trajectories: plan the jerk-limited sweeps of the last two joints, then verify them.

:func:`plan_calibration` is the whole job: the home pose (the robot definition's, checked,
or chosen: :mod:`fts_calib.planning.home`), the ranges and the raster of stops of the two
sweep joints (:mod:`fts_calib.planning.sweeps`), the sampled ruckig motion through them
(:mod:`fts_calib.planning.motion`), then the checks made before the robot moves: every
sample within the velocity, acceleration and jerk limits, and the clearance between the
robot, the tool and the floor along the motion and at home.

Angles in [rad], times in [s], distances in [m]; every result is deterministic for the same
inputs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..core.exceptions import TrajectoryError
from ..robot.collision import Clearance, CollisionChecker
from ..robot.kinematics import Kinematics
from .home import HomeReport, base_reading, check_home, choose_home, home_report
from .motion import Plan, plan_sweeps
from .sweeps import MIN_CLEARANCE, RangeReport, SweepPattern, spanned, sweep_ranges, wrist_ranges

_LIMIT_RTOL = 1e-6  # sampled values may exceed a limit by this fraction (floating point)


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


def check_limits(plan: Plan) -> LimitCheck:
    """Peaks of velocity, acceleration and jerk of every sweep joint (and any other joint that moves) against the limits."""
    lim = plan.limits
    peaks, ratios = {}, {}
    moving = [n for k, n in enumerate(plan.joint_names) if n not in plan.sweep_joints and np.ptp(plan.q[:, k]) > 0]
    for name in (*plan.sweep_joints, *moving):
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


def plan_base(
    kin: Kinematics, checker: CollisionChecker, pattern: SweepPattern, min_clearance: float = MIN_CLEARANCE
) -> tuple[HomeReport, RangeReport]:
    """The base pose and the sweep ranges: the robot definition's home, checked (:func:`check_home`), or one chosen (:func:`choose_home`).

    Raises:
        TrajectoryError: A home outside the limits or a poor one, or no clear range.
    """
    given = kin.robot.home is not None
    reading = base_reading(kin)
    for name, value in (kin.robot.home or {}).items():
        reading[kin.joint_names.index(name)] = value
    if given:
        check_home(kin, home_report(kin, reading, "robot definition"))
    ranges = wrist_ranges(kin, checker, reading, sweep_ranges(kin, reading, pattern.margin), min_clearance)
    report = home_report(kin, reading, "robot definition") if given else choose_home(kin, checker, ranges.ranges, pattern, min_clearance)
    return report, ranges


def plan_calibration(
    kin: Kinematics,
    checker: CollisionChecker,
    pattern: SweepPattern,
    rate: float,
    min_clearance: float = MIN_CLEARANCE,
    base: tuple[HomeReport, RangeReport] | None = None,
) -> PlanResult:
    """Plan the sweeps and verify them: limits on every sample, clearance along the motion.

    The base pose and ranges are ``base`` when given (already found, e.g. while sizing a
    plan), else :func:`plan_base`'s. The second sweep joint's stops cover ``pattern.span``
    of its range.

    Raises:
        TrajectoryError: Invalid input (rate, pattern, home outside limits, poor home) or
            ruckig refusing a segment. Failed checks of the result are listed in
            ``problems`` instead, so that the report can still be printed.
    """
    if not (math.isfinite(rate) and rate > 0):
        raise TrajectoryError(f"rate={rate} Hz but expected a finite rate > 0", "invalid rate")
    report, ranges = base if base is not None else plan_base(kin, checker, pattern, min_clearance)
    plan = plan_sweeps(kin, report.home, spanned(ranges.ranges, pattern.span), pattern, rate)
    return check_plan(checker, plan, (report, ranges), min_clearance)


def check_plan(
    checker: CollisionChecker, plan: Plan, base: tuple[HomeReport, RangeReport], min_clearance: float = MIN_CLEARANCE
) -> PlanResult:
    """The checks made before the robot moves: every sample within the limits, the clearance along the motion and at home."""
    report, ranges = base
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
            advice = checker.advice(c.pair, "")
            problems.append(
                f"collision {what}: '{c.pair[0]}' and '{c.pair[1]}' are {c.distance:.3f} m apart{when} (at least {min_clearance} m needed)"
                + (f": {advice}" if advice else "")
            )
    return PlanResult(plan, report, ranges, limits, clearance, home_clearance, min_clearance, problems, len(samples))

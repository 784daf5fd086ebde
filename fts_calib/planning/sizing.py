"""Plans sized to a stated accuracy: the shortest raster whose predicted budget meets a target.

Robot time is what a calibration costs. :func:`size_plan` searches the raster's levels,
stops, dwell and span of the second sweep joint (the joints always move at the robot
definition's limits: slower only takes longer), in order of the motion's duration, and
keeps the first pattern whose predicted accuracy budget (:mod:`fts_calib.planning.accuracy`)
has every axis's total within the target, in % of full scale. That plan is then checked as
any other (limits on every sample, clearance along the motion). Terms no plan can shrink
(the tool's tolerance, the sensor mount: :data:`~fts_calib.planning.accuracy.SYSTEMATIC`)
may alone exceed the target: the search then stops and names the term.

Durations in [s], errors in % of full scale.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from ..core.exceptions import TrajectoryError
from ..model.budget import AccuracyBudget
from ..pipeline.settings import FilterConfig
from ..robot.collision import CollisionChecker
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool
from .accuracy import SYSTEMATIC, plan_budget, predicted_still
from .motion import plan_sweeps, segment_durations
from .planner import PlanResult, plan_base, plan_calibration
from .sweeps import MIN_CLEARANCE, SweepPattern, raster, spanned

#: The rasters searched: levels, stops, dwell [s] and span, every combination.
LEVELS = (2, 3, 4)
STOPS = (2, 3, 4, 6)
DWELLS_S = (0.3, 0.5, 1.0, 2.0)
SPANS = (0.35, 0.5, 0.75, 1.0)

_SCREEN_RATE_HZ = 50.0  # [Hz] rate of the candidate motions (their budget, not their files)
_FINAL_TRIES = 4  # candidates checked for limits and collisions before giving up


@dataclass(frozen=True)
class SizedPlan:
    """The outcome of sizing a plan to a target.

    Attributes:
        target_percent: The target, [% of full scale].
        pattern: The raster chosen.
        budget: Its predicted budget.
        candidates: Patterns whose budget was computed before this one was found.
        floor_percent: The largest total of the terms no plan can shrink, [% FS].
    """

    target_percent: float
    pattern: SweepPattern
    budget: AccuracyBudget
    candidates: int
    floor_percent: float

    def summary(self) -> str:
        """One line: what was chosen, how it meets the target, what dominates."""
        term, axis = self.budget.dominant()
        p = self.pattern
        return (
            f"sized to the target {self.target_percent:g} % of full scale: {p.levels} levels × {p.stops} stops, dwell "
            f"{p.dwell:g} s, span {p.span:g} of the second joint's range (the shortest of {self.candidates} rasters whose "
            f"budget was computed, on motions screened at {_SCREEN_RATE_HZ:g} Hz): {self.budget.largest_percent:.4f} % on {axis} "
            f"there, dominated by {term}; "
            f"no plan goes below {self.floor_percent:.4f} % (tool tolerance and mount)"
        )


def check_target(target_percent: float) -> None:
    """Refuse a target that is not a finite value > 0 [% of full scale] (inf would size to a plan that meets nothing).

    Raises:
        TrajectoryError: The target is not finite or not > 0.
    """
    if not (math.isfinite(target_percent) and target_percent > 0):
        raise TrajectoryError(
            f"target error {target_percent} % of full scale (--target-error) but expected a finite value > 0", "invalid target"
        )


def floor_refusal(floor: AccuracyBudget, target_percent: float, screened: bool = False) -> TrajectoryError:
    """The refusal of a target below what the terms no plan shrinks give (tool tolerance and mount).

    Args:
        floor: The budget's systematic terms (:data:`fts_calib.planning.accuracy.SYSTEMATIC`) on a plan.
        target_percent: The target [% of full scale].
        screened: ``floor`` is the smallest over the motions screened (the message says "at least").
    """
    term, axis = floor.dominant()
    least = "at least " if screened else ""
    return TrajectoryError(
        f"no plan meets the target of {target_percent:g} % of full scale: {term} alone gives {least}"
        f"{floor.largest_percent:.4f} % on {axis} (tool tolerance and sensor mount: {', '.join(SYSTEMATIC)}). "
        "State a larger --target-error, or know the tool and the mount better.",
        "target unreachable",
    )


def size_plan(
    kin: Kinematics,
    checker: CollisionChecker,
    tool: Tool,
    nominal: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    filter_config: FilterConfig,
    target_percent: float,
    rate: float,
    sample_rate_hz: float,
    min_clearance: float = MIN_CLEARANCE,
    margin: float = 0.02,
) -> tuple[PlanResult, SizedPlan]:
    """The shortest checked plan whose predicted budget meets ``target_percent`` on every axis.

    Args:
        kin: Kinematics.
        checker: Collision checker with the tool's envelope.
        tool: The tool (its tolerance enters the budget).
        nominal: ``(C_bar (6, 6), D (6,), sigma_w (6,), full_scale (6,))``: the nominal
            sensor, its strain noise through C [N, N m] and its full scale.
        filter_config: Quasi-static filter thresholds (which samples count).
        target_percent: Largest budget total allowed, [% of full scale], > 0.
        rate: Sample rate of the plan returned [Hz].
        sample_rate_hz: The channels' sample rate [Hz].
        min_clearance: Required clearance [m].
        margin: Distance kept from the position limits [rad].

    Raises:
        TrajectoryError: A target <= 0, a target below what the tool and mount allow (names
            the dominant term), or no raster that meets it.
    """
    check_target(target_percent)
    C_bar, D, sigma_w, full_scale = nominal
    base = plan_base(kin, checker, SweepPattern(2, 2, DWELLS_S[0], margin), min_clearance)
    home, ranges = base[0], base[1].ranges
    durations = {}
    for levels, stops, span in itertools.product(LEVELS, STOPS, SPANS):
        pattern = SweepPattern(levels, stops, 0.0, margin, span)
        durations[levels, stops, span] = sum(segment_durations(kin, home.home, raster(kin, home.home, spanned(ranges, span), pattern)))
    order = sorted(
        (
            (durations[lv, st, sp] + dw * lv * st, SweepPattern(lv, st, dw, margin, sp))
            for (lv, st, sp), dw in itertools.product(durations, DWELLS_S)
        ),
        key=lambda item: item[0],
    )
    floor = None
    tried, finals = 0, 0
    for _, pattern in order:
        plan = plan_sweeps(kin, home.home, spanned(ranges, pattern.span), pattern, _SCREEN_RATE_HZ)
        budget = plan_budget(kin, tool, plan, predicted_still(plan, filter_config), C_bar, D, sigma_w, full_scale, sample_rate_hz)
        tried += 1
        if floor is None and np.isfinite(budget.largest_percent):
            floor = budget.without([k for k in budget.terms if k not in SYSTEMATIC])
            if floor.largest_percent > target_percent:
                raise floor_refusal(floor, target_percent)
        if budget.largest_percent > target_percent:
            continue
        result = plan_calibration(kin, checker, pattern, rate, min_clearance, base=base)
        if not result.problems:
            return result, SizedPlan(target_percent, pattern, budget, tried, floor.largest_percent if floor else float("nan"))
        finals += 1
        if finals >= _FINAL_TRIES:
            raise TrajectoryError(f"the shortest rasters that meet the target fail their checks: {result.problems[0]}", "checks")
    raise TrajectoryError(
        f"no raster of up to {LEVELS[-1]} levels × {STOPS[-1]} stops and {DWELLS_S[-1]} s dwell meets the target of "
        f"{target_percent:g} % of full scale; state a larger --target-error",
        "target unreachable",
    )

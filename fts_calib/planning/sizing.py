"""Plans sized to a stated accuracy: the shortest raster whose predicted budget meets a target.

Robot time is what a calibration costs. :func:`size_plan` searches the raster's levels,
stops, dwell and span of the second sweep joint (the joints always move at the robot
definition's limits: slower only takes longer), in order of the motion's duration, and
keeps the first pattern whose predicted accuracy budget (:mod:`fts_calib.budget.predicted`)
has every axis's total within the target, in % of full scale. That plan is then checked as
any other (limits on every sample, clearance along the motion). Terms no plan can shrink
(the tool's tolerance, the sensor mount: :data:`~fts_calib.budget.predicted.SYSTEMATIC`)
may alone exceed the target: the search then stops and names the term.

Durations in [s], errors in % of full scale.

Continuous plans sized to a stated accuracy: no dwell, every sample calibrates (the ``dynamic`` filter mode).

:func:`size_continuous` is :func:`fts_calib.planning.sizing.size_plan` for continuous motions
(:attr:`~fts_calib.planning.sweeps.SweepPattern.continuous`): it searches the levels, stops
and span of the raster, in order of the motion's duration, and keeps the first whose
predicted budget (:func:`fts_calib.budget.predicted.dynamic_plan_budget`, all
samples with the moving tool's wrench and the dynamic terms) meets the target on every axis.
The joints move at the robot definition's limits (velocity, acceleration, jerk).

With fewer than three configurations the target may be out of reach whatever the motion:
with one centre of mass only the inertial torques separate the two directions eqs 19-20
leave unseen (two with one configuration, one with two), and those are known only to the
inertia's tolerance. The search then refuses and names what each number of configurations
reaches at best. Durations in [s], errors in % of full scale.

Smooth continuous plans sized to a stated accuracy (``trajectory --motion smooth``).

:func:`size_smooth` is :func:`fts_calib.planning.sizing.size_continuous` for the smooth
excitation of :mod:`fts_calib.planning.smooth`: it tries the durations of :data:`DURATIONS_S`,
shortest first (until the budget stops falling: less than 5 % twice running), and keeps the
first whose predicted budget (:func:`fts_calib.budget.predicted.dynamic_plan_budget`:
the samples the dynamic filter's trust rule keeps, weighed as it weighs them, with the dynamic
terms) meets the target
on every axis and whose samples pass the checks of every plan (limits, clearance). With fewer
configurations than the target needs it refuses, naming what each number reaches.
Durations in [s], errors in % of full scale.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace

import numpy as np

from ..budget.predicted import SYSTEMATIC, dynamic_plan_budget, plan_budget, predicted_still
from ..budget.propagation import AccuracyBudget
from ..budget.sensitivities import MotionUncertainty
from ..core.exceptions import TrajectoryError
from ..filters.settings import FilterConfig
from ..robot.collision import CollisionChecker
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool
from .motion import Plan, plan_sweeps, segment_durations
from .planner import PlanResult, check_plan, plan_base, plan_calibration
from .smooth import smooth_plan
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
        floor: The budget's systematic terms (:data:`fts_calib.budget.predicted.SYSTEMATIC`) on a plan.
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


#: The continuous rasters searched: levels, stops and span, every combination.
CONTINUOUS_LEVELS = (2, 3, 4, 5)
CONTINUOUS_STOPS = (1, 2, 3)
CONTINUOUS_SPANS = (0.2, 0.35, 0.5, 0.75, 1.0)

CONTINUOUS_SCREEN_HZ = 25.0  # [Hz] rate of the candidate motions (their budget, not their files)
_CONTINUOUS_FINAL_TRIES = 4  # candidates checked for limits and collisions before giving up


@dataclass(frozen=True)
class ContinuousSizing:
    """The outcome of sizing a continuous plan to a target.

    Attributes:
        target_percent: The target, [% of full scale].
        pattern: The raster chosen.
        budget: Its predicted budget.
        candidates: Patterns whose budget was computed before this one was found.
        floor_percent: The largest total of the terms no plan can shrink, [% FS].
        configurations: The number of tool configurations planned for.
        duration_s: Motion per configuration of a smooth plan [s] (0 for a raster).
    """

    target_percent: float
    pattern: SweepPattern
    budget: AccuracyBudget
    candidates: int
    floor_percent: float
    configurations: int
    duration_s: float = 0.0

    def summary(self) -> str:
        """One line: what was chosen, how it meets the target, what dominates."""
        term, axis = self.budget.dominant()
        p = self.pattern
        if p.smooth:
            return (
                f"sized to the target {self.target_percent:g} % of full scale: smooth excitation (every joint on a sinusoid, "
                f"ramped in and out at home), {self.duration_s:g} s, {self.configurations} "
                f"configuration{'s' if self.configurations > 1 else ''} "
                f"(the shortest of {self.candidates} durations whose budget was computed, screened at {CONTINUOUS_SCREEN_HZ:g} Hz): "
                f"{self.budget.largest_percent:.4f} % on {axis} there, dominated by {term}; "
                f"the tool tolerance and mount alone give at least {self.floor_percent:.4f} % on the motions screened"
            )
        return (
            f"sized to the target {self.target_percent:g} % of full scale: continuous, {p.levels} levels × {p.stops} "
            f"stop{'s' if p.stops > 1 else ''} passed without stopping, span {p.span:g} of the second joint's range, "
            f"{self.configurations} configuration{'s' if self.configurations > 1 else ''} "
            f"(the shortest of {self.candidates} motions whose budget was computed, "
            f"screened at {CONTINUOUS_SCREEN_HZ:g} Hz): {self.budget.largest_percent:.4f} % on {axis} there, dominated by {term}; "
            f"the tool tolerance and mount alone give at least {self.floor_percent:.4f} % on the motions screened"
        )


def with_configurations(tool: Tool, count: int | None) -> Tool:
    """The tool with its first ``count`` configurations (all when None).

    Raises:
        TrajectoryError: ``count`` outside 1 .. the number the tool file has.
    """
    if count is None:
        return tool
    if not 1 <= count <= len(tool.configurations):
        raise TrajectoryError(
            f"--configurations {count} but tool '{tool.name}' has {len(tool.configurations)} "
            f"({', '.join(tool.names)}): expected 1 to {len(tool.configurations)}",
            "invalid configurations",
        )
    return replace(tool, configurations=tool.configurations[:count])


def _budget(kin, tool, plan: Plan, nominal, sample_rate_hz, uncertainty) -> AccuracyBudget:
    C_bar, D, sigma_w, full_scale = nominal
    return dynamic_plan_budget(kin, tool, plan, C_bar, D, sigma_w, full_scale, sample_rate_hz, uncertainty)


def size_continuous(
    kin: Kinematics,
    checker: CollisionChecker,
    tool: Tool,
    nominal: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    target_percent: float,
    rate: float,
    sample_rate_hz: float,
    uncertainty: MotionUncertainty | None = None,
    min_clearance: float = MIN_CLEARANCE,
    margin: float = 0.02,
    full_tool: Tool | None = None,
) -> tuple[PlanResult, ContinuousSizing]:
    """The shortest checked continuous plan whose predicted budget meets ``target_percent`` on every axis.

    Args:
        kin: Kinematics.
        checker: Collision checker with the tool's envelope.
        tool: The tool, with the configurations to plan for.
        nominal: ``(C_bar (6, 6), D (6,), sigma_w (6,), full_scale (6,))``: the nominal
            sensor, its strain noise through C [N, N m] and its full scale.
        target_percent: Largest budget total allowed, [% of full scale], > 0.
        rate: Sample rate of the plan returned [Hz].
        sample_rate_hz: The channels' sample rate [Hz].
        uncertainty: Inertia tolerance, joint noise, latency and jitter (defaults when None).
        min_clearance: Required clearance [m].
        margin: Distance kept from the position limits [rad].
        full_tool: The tool with all its configurations, to name what other numbers of
            configurations reach when the target is out of reach; ``tool`` when None.

    Raises:
        TrajectoryError: A target <= 0, a target below what the tool and mount allow, or
            one no continuous plan meets with these configurations (the message names what
            one, two, ... configurations reach at best).
    """
    check_target(target_percent)
    full_tool = tool if full_tool is None else full_tool
    base = plan_base(kin, checker, SweepPattern(2, 2, 0.0, margin, continuous=True), min_clearance)
    home, ranges = base[0].home, base[1].ranges
    order = []
    for levels, stops, span in itertools.product(CONTINUOUS_LEVELS, CONTINUOUS_STOPS, CONTINUOUS_SPANS):
        pattern = SweepPattern(levels, stops, 0.0, margin, span, continuous=True)
        order.append((sum(segment_durations(kin, home, raster(kin, home, spanned(ranges, span), pattern), True)), pattern))
    order.sort(key=lambda item: item[0])
    screened = Screened()
    finals = 0
    for _, pattern in order:
        plan = plan_sweeps(kin, home, spanned(ranges, pattern.span), pattern, CONTINUOUS_SCREEN_HZ)
        budget = screened.add(plan, _budget(kin, tool, plan, nominal, sample_rate_hz, uncertainty))
        if budget.largest_percent > target_percent:
            continue
        result = plan_calibration(kin, checker, pattern, rate, min_clearance, base=base)
        if not result.problems:
            sizing = ContinuousSizing(target_percent, pattern, budget, screened.tried, screened.floor_percent, len(tool.configurations))
            return result, sizing
        finals += 1
        if finals >= _CONTINUOUS_FINAL_TRIES:
            raise TrajectoryError(f"the shortest continuous plans that meet the target fail their checks: {result.problems[0]}", "checks")
    raise screened.refusal(kin, tool, full_tool, nominal, sample_rate_hz, uncertainty, target_percent, "continuous")


class Screened:
    """The candidate motions screened so far: the best budget, and the smallest total of the terms no plan shrinks."""

    def __init__(self) -> None:
        self.tried = 0
        self.best: tuple[Plan, AccuracyBudget] | None = None
        self.floor: AccuracyBudget | None = None

    @property
    def floor_percent(self) -> float:
        """The floor's largest total [% FS] (NaN before any candidate)."""
        return math.nan if self.floor is None else self.floor.largest_percent

    def add(self, plan: Plan, budget: AccuracyBudget) -> AccuracyBudget:
        """Count a candidate and its budget; returns the budget."""
        self.tried += 1
        if self.best is None or budget.largest_percent < self.best[1].largest_percent:
            self.best = (plan, budget)
        systematic = budget.without([k for k in budget.terms if k not in SYSTEMATIC])
        if self.floor is None or systematic.largest_percent < self.floor.largest_percent:
            self.floor = systematic
        return budget

    def refusal(self, kin, tool: Tool, full_tool: Tool, nominal, sample_rate_hz, uncertainty, target_percent, kind) -> TrajectoryError:
        """No candidate met the target: the tool and mount alone (all configurations), or what each number reaches."""
        assert self.best is not None and self.floor is not None  # at least one candidate was screened
        if len(tool.configurations) == len(full_tool.configurations) and self.floor.largest_percent > target_percent:
            return floor_refusal(self.floor, target_percent, screened=True)
        message = unreachable(kin, tool, full_tool, self.best, nominal, sample_rate_hz, uncertainty, target_percent, kind)
        return TrajectoryError(message, "target unreachable")


def reachable(kin: Kinematics, full_tool: Tool, plan: Plan, nominal, sample_rate_hz: float, uncertainty) -> dict[int, AccuracyBudget]:
    """The predicted budget of ``plan`` with the first 1, 2, ... configurations of the tool: count -> budget."""
    return {
        n: _budget(kin, with_configurations(full_tool, n), plan, nominal, sample_rate_hz, uncertainty)
        for n in range(1, len(full_tool.configurations) + 1)
    }


def unreachable(
    kin, tool: Tool, full_tool: Tool, best, nominal, sample_rate_hz, uncertainty, target_percent: float, kind: str = "continuous"
) -> str:
    """The refusal: what this number of configurations reaches at best, what the others reach on the same motion.

    ``kind`` names the plans searched ('continuous', 'smooth').
    """
    plan, budget = best
    count = len(tool.configurations)
    others = reachable(kin, full_tool, plan, nominal, sample_rate_hz, uncertainty)
    others[count] = budget

    def words(n: int) -> str:
        value = others[n].largest_percent
        reach = f"{value:.3g} %" if math.isfinite(value) else "nothing (rank < 7)"
        return f"{n} configuration{'s' if n > 1 else ''} reach{'es' if n == 1 else ''} {reach}"  # predicted, k = 2

    term, axis = budget.dominant()
    enough = [n for n in sorted(others) if n > count and others[n].largest_percent <= target_percent]
    ask = f"ask --target-error {_round_up(budget.largest_percent):g}" if math.isfinite(budget.largest_percent) else "plan more"
    mount = f" or mount {enough[0]} configurations (--configurations {enough[0]})" if enough else " or mount more configurations"
    return (
        f"no {kind} plan of {count} configuration{'s' if count > 1 else ''} meets the target of {target_percent:g} % of full "
        f"scale: by the predicted budget, {words(count)} at best ({plan.duration:.1f} s of motion, dominated by {term} on {axis}); "
        "on the same motion " + "; ".join(words(n) for n in sorted(others) if n != count) + f". {ask.capitalize()}{mount}."
    )


def _round_up(value: float) -> float:
    """``value`` rounded up to two significant digits (a target that the plan then meets)."""
    if value <= 0:
        return value
    digits = 1 - int(math.floor(math.log10(value)))
    return math.ceil(value * 10**digits) / 10**digits


#: Motion per configuration tried [s], shortest first.
DURATIONS_S = (4.0, 5.0, 6.0, 7.0, 8.0, 10.0, 13.0, 16.0, 20.0, 25.0, 30.0, 40.0, 60.0)
_STALL = 0.05  # a budget less than this fraction below the best so far, twice running, ends the search


def size_smooth(
    kin: Kinematics,
    checker: CollisionChecker,
    tool: Tool,
    nominal: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    target_percent: float,
    rate: float,
    sample_rate_hz: float,
    uncertainty: MotionUncertainty | None = None,
    min_clearance: float = MIN_CLEARANCE,
    margin: float = 0.02,
    full_tool: Tool | None = None,
) -> tuple[PlanResult, ContinuousSizing]:
    """The shortest checked smooth plan whose predicted budget meets ``target_percent`` on every axis.

    Args: as :func:`fts_calib.planning.sizing.size_continuous` (nominal: ``(C_bar (6, 6),
    D (6,), sigma_w (6,), full_scale (6,))``; rates in [Hz]; clearance and margin in [m], [rad]).

    Raises:
        TrajectoryError: A target <= 0, one below what the tool and mount allow, one no smooth
            plan meets with these configurations (naming what each number reaches), or the
            plans that meet it failing their checks.
    """
    check_target(target_percent)
    full_tool = tool if full_tool is None else full_tool
    base = plan_base(kin, checker, SweepPattern(2, 2, 0.0, margin, continuous=True), min_clearance)
    home, ranges = base[0].home, base[1].ranges
    screened, problem, stalled = Screened(), None, 0
    for tried, duration in enumerate(DURATIONS_S, start=1):
        try:
            plan = smooth_plan(kin, home, ranges, duration, CONTINUOUS_SCREEN_HZ, margin)
        except TrajectoryError:
            continue  # too short for the ramps within this robot's limits
        budget = _budget(kin, tool, plan, nominal, sample_rate_hz, uncertainty)
        best = screened.best
        improving = best is None or budget.largest_percent < (1 - _STALL) * best[1].largest_percent
        stalled = 0 if improving else stalled + 1
        screened.add(plan, budget)
        if budget.largest_percent > target_percent:
            if stalled >= 2:
                break  # the budget has stopped falling: longer motions would not meet it either
            continue
        result = check_plan(checker, smooth_plan(kin, home, ranges, duration, rate, margin), base, min_clearance)
        if not result.problems:
            count = len(tool.configurations)
            return result, ContinuousSizing(target_percent, plan.pattern, budget, tried, screened.floor_percent, count, duration)
        problem = result.problems[0]
        break  # a longer smooth motion swings the same joints as far: its checks fail alike
    if problem is not None:
        raise TrajectoryError(f"the shortest smooth plan that meets the target fails its checks: {problem}", "checks")
    if screened.best is None:
        raise TrajectoryError(f"no smooth motion of at most {DURATIONS_S[-1]:g} s fits {kin.robot.name}'s limits", "too short")
    raise screened.refusal(kin, tool, full_tool, nominal, sample_rate_hz, uncertainty, target_percent, "smooth")

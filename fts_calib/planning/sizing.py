"""Plans sized to a stated accuracy: the shortest motion of a kind whose predicted budget meets a target.

Robot time is what a calibration costs. :func:`size_motion` tries the candidate motions of one
kind (:data:`MOTION_KINDS`, ``trajectory --motion``), shortest first, and keeps the first whose
predicted accuracy budget (:mod:`fts_calib.budget.predicted`) has every axis's total within the
target, in % of full scale, and whose plan passes the checks of every plan (limits on every
sample, clearance along the motion). The kinds differ in data only, not in the search:

- ``stop``: rasters of levels, stops, dwell and span of the second sweep joint (the joints
  always move at the robot definition's limits: slower only takes longer), their still samples
  as the quasi-static filter keeps them (:func:`~fts_calib.budget.predicted.plan_budget`);
- ``continuous``: the rasters passed without stopping (no dwell,
  :attr:`~fts_calib.planning.sweeps.SweepPattern.continuous`): every sample calibrates in the
  ``dynamic`` filter mode (:func:`~fts_calib.budget.predicted.dynamic_plan_budget`: the samples
  the dynamic filter's trust rule keeps, weighed as it weighs them, the moving tool's wrench and
  the dynamic terms);
- ``smooth``: the smooth excitation of :mod:`fts_calib.planning.smooth`, its durations shortest
  first, until the budget stops falling (less than 5 % twice running), budgeted as ``continuous``.

Terms no plan can shrink (the tool's tolerance, the sensor mount:
:data:`~fts_calib.budget.predicted.SYSTEMATIC`) may alone exceed the target. On still samples
they barely move from raster to raster: the first finite candidate's are the floor, and a target
below it is refused at once, naming the term. On moving samples the floor is the least over the
motions screened, and a target below :data:`MOVING_FLOOR_SHARE` of the least so far is refused
at once (on the UR5 with the paper's tool the least over the 60 continuous candidates is 0.70 of
the first finite one's: 0.0301 and 0.0427 % FS; Panda 0.618, Kinova 0.831:
``bench/bench_moving_floor.py``); a target between is refused once no candidate met it.

A continuous motion whose samples the dynamic filter's trust rule drops (a latency uncertainty
or an inertia tolerance so large that no expected wrench is trusted) determines nothing: the
refusal names the stated term that drops them (:data:`TRUST_TERMS`), not the budget's terms,
which are then all infinite.

With fewer than three configurations (moving samples only) the target may be out of reach
whatever the motion: with one centre of mass only the inertial torques separate the two
directions eqs 19-20 leave unseen (two with one configuration, one with two), and those are
known only to the inertia's tolerance. The search then refuses and names what each number of
configurations reaches at best.

Durations in [s], rates in [Hz], errors in % of full scale.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..budget.predicted import SYSTEMATIC, dynamic_plan_budget, filter_weights, plan_budget, predicted_still
from ..budget.propagation import AccuracyBudget
from ..budget.sensitivities import MotionUncertainty
from ..core.exceptions import TrajectoryError
from ..filters.settings import FilterConfig
from ..robot.collision import CollisionChecker
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool
from .motion import Plan, plan_sweeps, segment_durations
from .planner import PlanResult, check_plan, plan_base
from .smooth import smooth_plan
from .sweeps import MIN_CLEARANCE, SweepPattern, raster, spanned

#: On moving samples, the terms no plan shrinks are taken to stay above this share of the least
#: screened so far: a target below it is refused without screening the rest (module docstring).
MOVING_FLOOR_SHARE = 0.5
#: The stated terms of the dynamic filter's trust rule: MotionUncertainty's field, its name, its option, its unit.
TRUST_TERMS = (
    ("latency_s", "latency uncertainty", "--latency-uncertainty", " s"),
    ("inertia", "inertia tolerance", "--inertia-tolerance", ""),
    ("joint_noise", "joint noise", "--joint-noise", " rad"),
)


@dataclass(frozen=True)
class MotionKind:
    """The candidates one kind of motion offers the sizer, and how they are screened.

    Attributes:
        name: ``stop``, ``continuous`` or ``smooth`` (``trajectory --motion``).
        noun: What its refusals call one of its plans ("raster", "continuous plan").
        continuous: Its samples move (the ``dynamic`` filter mode); else still samples.
        screen_rate_hz: Rate of the candidate motions [Hz] (their budget, not their files).
        levels: Levels of the rasters searched (every combination with stops, spans, dwells).
        stops: Stops per level of the rasters searched.
        spans: Spans of the rasters searched (fraction of the second sweep joint's range).
        dwells_s: Dwells of the rasters searched [s] (0 for a continuous raster).
        durations_s: Motion per configuration of the smooth excitations searched [s]
            (instead of rasters when not empty).
        final_tries: Candidates that meet the target checked for limits and collisions before
            giving up (1: a longer smooth motion swings the same joints as far).
        stall: A budget less than this fraction below the best so far, twice running, ends the
            search (longer motions would not meet the target either); None: never.
    """

    name: str
    noun: str
    continuous: bool
    screen_rate_hz: float
    levels: tuple[int, ...] = ()
    stops: tuple[int, ...] = ()
    spans: tuple[float, ...] = ()
    dwells_s: tuple[float, ...] = (0.0,)
    durations_s: tuple[float, ...] = ()
    final_tries: int = 4
    stall: float | None = None


#: Every kind of motion the sizer searches, by ``trajectory --motion`` name.
MOTION_KINDS = {
    "stop": MotionKind(
        name="stop",
        noun="raster",
        continuous=False,
        screen_rate_hz=50.0,  # [Hz]
        levels=(2, 3, 4),
        stops=(2, 3, 4, 6),
        spans=(0.35, 0.5, 0.75, 1.0),
        dwells_s=(0.3, 0.5, 1.0, 2.0),  # [s]
    ),
    "continuous": MotionKind(
        name="continuous",
        noun="continuous plan",
        continuous=True,
        screen_rate_hz=25.0,  # [Hz]
        levels=(2, 3, 4, 5),
        stops=(1, 2, 3),
        spans=(0.2, 0.35, 0.5, 0.75, 1.0),
    ),
    "smooth": MotionKind(
        name="smooth",
        noun="smooth plan",
        continuous=True,
        screen_rate_hz=25.0,  # [Hz]
        durations_s=(4.0, 5.0, 6.0, 7.0, 8.0, 10.0, 13.0, 16.0, 20.0, 25.0, 30.0, 40.0, 60.0),  # [s]
        final_tries=1,
        stall=0.05,
    ),
}


@dataclass(frozen=True)
class Sizing:
    """The outcome of sizing a plan to a target.

    Attributes:
        kind: The motion searched: ``stop``, ``continuous`` or ``smooth``.
        target_percent: The target, [% of full scale].
        pattern: The raster chosen (of a smooth plan, its pattern: levels, stops and span unused).
        budget: Its predicted budget.
        candidates: Candidates tried up to this one (their budget computed, or their motion
            beyond the robot's limits).
        floor_percent: The largest total of the terms no plan can shrink, [% FS] (of a
            continuous motion: the least over the motions screened).
        configurations: The number of tool configurations planned for.
        screen_rate_hz: Rate the candidate motions were screened at [Hz].
        duration_s: Motion per configuration of a smooth plan [s] (0 for a raster).
    """

    kind: str
    target_percent: float
    pattern: SweepPattern
    budget: AccuracyBudget
    candidates: int
    floor_percent: float
    configurations: int
    screen_rate_hz: float
    duration_s: float = 0.0

    def summary(self) -> str:
        """One line: what was chosen, how it meets the target, what dominates."""
        term, axis = self.budget.dominant()
        p, n = self.pattern, self.configurations
        configurations = f"{n} configuration{'s' if n > 1 else ''}"
        floor = f"the tool tolerance and mount alone give at least {self.floor_percent:.4f} % on the motions screened"
        screened = "screened"
        if self.kind == "smooth":
            what = f"smooth excitation (every joint on a sinusoid, ramped in and out at home), {self.duration_s:g} s, {configurations}"
            searched = "durations"
        elif self.kind == "continuous":
            what = (
                f"continuous, {p.levels} levels × {p.stops} stop{'s' if p.stops > 1 else ''} passed without stopping, "
                f"span {p.span:g} of the second joint's range, {configurations}"
            )
            searched = "motions"
        else:
            what = f"{p.levels} levels × {p.stops} stops, dwell {p.dwell:g} s, span {p.span:g} of the second joint's range"
            searched, screened = "rasters", "on motions screened"
            floor = f"no plan goes below {self.floor_percent:.4f} % (tool tolerance and mount)"
        return (
            f"sized to the target {self.target_percent:g} % of full scale: {what} (the shortest of {self.candidates} {searched} "
            f"whose budget was computed, {screened} at {self.screen_rate_hz:g} Hz): {self.budget.largest_percent:.4f} % on {axis} "
            f"there, dominated by {term}; {floor}"
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


def floor_refusal(floor: AccuracyBudget, target_percent: float, screened: bool = False, share: float = 1.0) -> TrajectoryError:
    """The refusal of a target below what the terms no plan shrinks give (tool tolerance and mount).

    Args:
        floor: The budget's systematic terms (:data:`fts_calib.budget.predicted.SYSTEMATIC`) on a plan.
        target_percent: The target [% of full scale].
        screened: ``floor`` is the smallest over the motions screened (the message says "at least").
        share: The target was compared with this share of ``floor`` (:data:`MOVING_FLOOR_SHARE`
            during a search of moving motions; the message says so).
    """
    term, axis = floor.dominant()
    least = "at least " if screened and share == 1.0 else ""
    rest = (
        ""
        if share == 1.0
        else f" on the motions screened so far, and no moving motion takes those terms below {share:g} of that "
        f"({share * floor.largest_percent:.4f} %)"
    )
    return TrajectoryError(
        f"no plan meets the target of {target_percent:g} % of full scale: {term} alone gives {least}"
        f"{floor.largest_percent:.4f} % on {axis}{rest} (tool tolerance and sensor mount: {', '.join(SYSTEMATIC)}). "
        "State a larger --target-error, or know the tool and the mount better.",
        "target unreachable",
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


@dataclass(frozen=True)
class _Budgeting:
    """What a candidate's budget needs besides the plan and the tool (the same for every candidate of a search)."""

    kin: Kinematics
    nominal: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    sample_rate_hz: float
    filter_config: FilterConfig
    uncertainty: MotionUncertainty | None

    def budget(self, tool: Tool, plan: Plan) -> AccuracyBudget:
        """The predicted budget of ``plan``: its still samples, or of a continuous plan all of them with the dynamic terms."""
        C_bar, D, sigma_w, full_scale = self.nominal
        if plan.pattern.continuous:
            return dynamic_plan_budget(self.kin, tool, plan, C_bar, D, sigma_w, full_scale, self.sample_rate_hz, self.uncertainty)
        still = predicted_still(plan, self.filter_config)
        return plan_budget(self.kin, tool, plan, still, C_bar, D, sigma_w, full_scale, self.sample_rate_hz)


class Screening:
    """The candidate motions screened so far: how many, the best budget, the floor, and how long the budget has stalled.

    The floor (the terms no plan shrinks) is the first finite candidate's on still samples, the
    least over the candidates on moving ones (see the module docstring).
    """

    def __init__(self, kind: MotionKind) -> None:
        self.kind = kind
        self.tried = 0
        self.stalled = 0
        self.best: tuple[Plan, AccuracyBudget] | None = None
        self.floor: AccuracyBudget | None = None
        self.last: Plan | None = None

    @property
    def floor_percent(self) -> float:
        """The floor's largest total [% FS] (NaN before any candidate)."""
        return math.nan if self.floor is None else self.floor.largest_percent

    def add(self, plan: Plan, budget: AccuracyBudget) -> None:
        """Record a candidate's budget."""
        best = self.best
        if self.kind.stall is not None:
            improving = best is None or budget.largest_percent < (1 - self.kind.stall) * best[1].largest_percent
            self.stalled = 0 if improving else self.stalled + 1
        if best is None or budget.largest_percent < best[1].largest_percent:
            self.best = (plan, budget)
        self.last = plan
        if self.kind.continuous:
            systematic = _systematic(budget)  # infinite when no sample is trusted: no floor then
            if np.isfinite(systematic.largest_percent) and (self.floor is None or systematic.largest_percent < self.floor.largest_percent):
                self.floor = systematic
        elif self.floor is None and np.isfinite(budget.largest_percent):
            self.floor = _systematic(budget)

    def below_floor(self, target_percent: float, final: bool = True) -> TrajectoryError | None:
        """The refusal of a target below the floor so far (the tool and mount alone), or None.

        Args:
            target_percent: The target [% FS].
            final: Every candidate was screened; False: during the search, where a moving
                motion's target is refused only below :data:`MOVING_FLOOR_SHARE` of the floor.
        """
        share = MOVING_FLOOR_SHARE if self.kind.continuous and not final else 1.0
        if self.floor is None or share * self.floor.largest_percent <= target_percent:
            return None
        return floor_refusal(self.floor, target_percent, screened=self.kind.continuous, share=share)

    def refusal(self, robot: str, tool: Tool, full_tool: Tool, budgeting: _Budgeting, target_percent: float) -> TrajectoryError:
        """No candidate met the target: none fits the robot, the tool and mount alone, or what each number of configurations reaches."""
        kind = self.kind
        if self.best is None:
            return TrajectoryError(f"no {kind.name} motion {_extent(kind)} fits {robot}'s limits", "too short")
        every = len(tool.configurations) == len(full_tool.configurations)  # fewer: what each number reaches, below
        if kind.continuous and every and self.floor is None and self.last is not None:  # no motion had a finite budget
            return TrajectoryError(_untrusted(kind, tool, self.last, budgeting), "target unreachable")
        if every and (below := self.below_floor(target_percent)) is not None:
            return below
        if not kind.continuous:  # still samples of fewer configurations are refused before any search
            return TrajectoryError(
                f"no {kind.noun} {_extent(kind)} meets the target of {target_percent:g} % of full scale; state a larger --target-error",
                "target unreachable",
            )
        return TrajectoryError(self._unreachable(self.best, tool, full_tool, budgeting, target_percent), "target unreachable")

    def _unreachable(
        self, best: tuple[Plan, AccuracyBudget], tool: Tool, full_tool: Tool, budgeting: _Budgeting, target_percent: float
    ) -> str:
        """What this number of configurations reaches at best (``best``), what the others reach on the same motion."""
        plan, budget = best
        count = len(tool.configurations)
        others = {n: budgeting.budget(with_configurations(full_tool, n), plan) for n in range(1, len(full_tool.configurations) + 1)}
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
            f"no {self.kind.noun} of {count} configuration{'s' if count > 1 else ''} meets the target of {target_percent:g} % of "
            f"full scale: by the predicted budget, {words(count)} at best ({plan.duration:.1f} s of motion, dominated by {term} "
            f"on {axis}); on the same motion " + "; ".join(words(n) for n in sorted(others) if n != count) + f". {ask.capitalize()}{mount}."
        )


def _untrusted(kind: MotionKind, tool: Tool, plan: Plan, budgeting: _Budgeting) -> str:
    """Why no moving motion determines the calibration: the trust rule keeps too few samples, and the stated term that drops them."""
    uncertainty = MotionUncertainty() if budgeting.uncertainty is None else budgeting.uncertainty
    sigma_w = budgeting.nominal[2]

    def kept(stated: MotionUncertainty) -> int:
        return int(np.count_nonzero(filter_weights(budgeting.kin, tool, plan, sigma_w, stated)))

    now, total = kept(uncertainty), len(plan.time) * len(tool.configurations)

    def kept_without(field: str) -> int:  # the term set to 0
        changes: dict[str, Any] = {field: 0.0}
        return kept(replace(uncertainty, **changes))

    without = {term: kept_without(term[0]) for term in TRUST_TERMS}
    term = max(without, key=lambda t: without[t])
    field, name, option, unit = term
    head = (
        f"no {kind.noun} {_extent(kind)} determines the calibration: the dynamic filter's trust rule keeps {now:,} of the "
        f"{total:,} samples of the longest motion screened ({plan.duration:.1f} s per configuration), their expected wrench's "
        f"predicted error above {uncertainty.max_error_ratio:g}x the strain noise"
    )
    if without[term] <= now:
        return head + "; plan still samples (--motion stop)"
    return (
        f"{head}, set by the {name} ({option} {getattr(uncertainty, field):g}{unit}; {without[term]:,} kept without it). "
        f"State a smaller {option} (know it better), or plan still samples (--motion stop)"
    )


def _systematic(budget: AccuracyBudget) -> AccuracyBudget:
    """The terms of ``budget`` no plan shrinks (:data:`~fts_calib.budget.predicted.SYSTEMATIC`)."""
    return budget.without([k for k in budget.terms if k not in SYSTEMATIC])


def _extent(kind: MotionKind) -> str:
    """The longest candidate of a kind, in words."""
    if kind.durations_s:
        return f"of at most {kind.durations_s[-1]:g} s"
    dwell = "" if kind.continuous else f" and {kind.dwells_s[-1]} s dwell"
    return f"of up to {kind.levels[-1]} levels × {kind.stops[-1]} stops{dwell}"


def _round_up(value: float) -> float:
    """``value`` rounded up to two significant digits (a target that the plan then meets)."""
    if value <= 0:
        return value
    digits = 1 - int(math.floor(math.log10(value)))
    return math.ceil(value * 10**digits) / 10**digits


def candidates(kind: MotionKind, kin: Kinematics, home: np.ndarray, ranges: np.ndarray, margin: float) -> list[tuple[float, SweepPattern]]:
    """A kind's candidate motions, shortest first: ``(motion per configuration [s], pattern)``.

    A raster's duration is its ruckig segments' (joints at their limits, no sampling) plus its
    dwells; a smooth excitation's is the one asked.

    Args:
        kind: The kind of motion.
        kin: Kinematics.
        home: Base pose [rad], shape (n_joints,).
        ranges: Range of each sweep joint [rad], shape (2, 2).
        margin: Distance kept from the position limits [rad].
    """
    if kind.durations_s:
        smooth = SweepPattern(2, 1, 0.0, margin, 1.0, continuous=True, smooth=True)  # the pattern smooth_plan gives its plans
        return [(duration, smooth) for duration in kind.durations_s]
    moving = {}
    for levels, stops, span in itertools.product(kind.levels, kind.stops, kind.spans):
        pattern = SweepPattern(levels, stops, 0.0, margin, span, continuous=kind.continuous)
        stops_q = raster(kin, home, spanned(ranges, span), pattern)
        moving[levels, stops, span] = sum(segment_durations(kin, home, stops_q, kind.continuous))
    return sorted(
        (
            (moving[lv, st, sp] + dw * lv * st, SweepPattern(lv, st, dw, margin, sp, continuous=kind.continuous))
            for (lv, st, sp), dw in itertools.product(moving, kind.dwells_s)
        ),
        key=lambda item: item[0],
    )


def _motion(kin: Kinematics, home: np.ndarray, ranges: np.ndarray, candidate: tuple[float, SweepPattern], rate_hz: float) -> Plan:
    """A candidate's motion sampled at ``rate_hz``."""
    duration_s, pattern = candidate
    if pattern.smooth:
        return smooth_plan(kin, home, ranges, duration_s, rate_hz, pattern.margin)
    return plan_sweeps(kin, home, spanned(ranges, pattern.span), pattern, rate_hz)


def size_motion(
    kind: str,
    kin: Kinematics,
    checker: CollisionChecker,
    tool: Tool,
    nominal: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    filter_config: FilterConfig,
    target_percent: float,
    rate_hz: float,
    sample_rate_hz: float,
    uncertainty: MotionUncertainty | None = None,
    min_clearance: float = MIN_CLEARANCE,
    margin: float = 0.02,
    full_tool: Tool | None = None,
) -> tuple[PlanResult, Sizing]:
    """The shortest checked plan of a kind whose predicted budget meets ``target_percent`` on every axis.

    Args:
        kind: The motion: ``stop``, ``continuous`` or ``smooth`` (a key of :data:`MOTION_KINDS`).
        kin: Kinematics.
        checker: Collision checker with the tool's envelope.
        tool: The tool (its tolerance enters the budget), with the configurations to plan for.
        nominal: ``(C_bar (6, 6), D (6,), sigma_w (6,), full_scale (6,))``: the nominal
            sensor, its strain noise through C [N, N m] and its full scale.
        filter_config: Quasi-static filter thresholds (which still samples count).
        target_percent: Largest budget total allowed, [% of full scale], > 0.
        rate_hz: Sample rate of the plan returned [Hz].
        sample_rate_hz: The channels' sample rate [Hz].
        uncertainty: A continuous motion's inertia tolerance, joint noise, latency and jitter
            (defaults when None).
        min_clearance: Required clearance [m].
        margin: Distance kept from the position limits [rad].
        full_tool: The tool with all its configurations, to name what other numbers of
            configurations reach when the target is out of reach; ``tool`` when None.

    Raises:
        TrajectoryError: An unknown kind, a target <= 0, a target below what the tool and mount
            allow (names the dominant term), one no plan of the kind meets (of a continuous
            motion, naming what one, two, ... configurations reach at best), no candidate
            within the robot's limits, or the plans that meet it failing their checks.
    """
    check_target(target_percent)
    if kind not in MOTION_KINDS:
        raise TrajectoryError(f"motion {kind!r} but expected one of {', '.join(MOTION_KINDS)}", "invalid motion")
    motion = MOTION_KINDS[kind]
    full_tool = tool if full_tool is None else full_tool
    base = plan_base(kin, checker, SweepPattern(2, 2, motion.dwells_s[0], margin, continuous=motion.continuous), min_clearance)
    home, ranges = base[0].home, base[1].ranges
    budgeting = _Budgeting(kin, nominal, sample_rate_hz, filter_config, uncertainty)
    screening, finals = Screening(motion), 0
    for candidate in candidates(motion, kin, home, ranges, margin):
        screening.tried += 1
        try:
            plan = _motion(kin, home, ranges, candidate, motion.screen_rate_hz)
        except TrajectoryError:
            continue  # beyond this robot's limits (a smooth motion too short for its ramps)
        budget = budgeting.budget(tool, plan)
        screening.add(plan, budget)
        every = len(tool.configurations) == len(full_tool.configurations)  # fewer: refused naming what each number reaches
        if (every or not motion.continuous) and (below := screening.below_floor(target_percent, final=False)) is not None:
            raise below  # still samples: the floor is known from the first finite candidate on; moving ones: below a share of it
        if budget.largest_percent > target_percent:
            if screening.stalled >= 2:
                break  # the budget has stopped falling: longer motions would not meet it either
            continue
        result = check_plan(checker, _motion(kin, home, ranges, candidate, rate_hz), base, min_clearance)
        if not result.problems:
            duration_s, pattern = candidate
            sizing = Sizing(
                kind,
                target_percent,
                pattern,
                budget,
                screening.tried,
                screening.floor_percent,
                len(tool.configurations),
                motion.screen_rate_hz,
                duration_s if pattern.smooth else 0.0,
            )
            return result, sizing
        finals += 1
        if finals >= motion.final_tries:
            which = (
                f"{motion.noun}s that meet the target fail their"
                if motion.final_tries > 1
                else f"{motion.noun} that meets the target fails its"
            )
            raise TrajectoryError(f"the shortest {which} checks: {result.problems[0]}", "checks")
    raise screening.refusal(kin.robot.name, tool, full_tool, budgeting, target_percent)

"""Smooth continuous plans sized to a stated accuracy (``trajectory --motion smooth``).

:func:`size_smooth` is :func:`fts_calib.planning.continuous.size_continuous` for the smooth
excitation of :mod:`fts_calib.planning.smooth`: it tries the durations of :data:`DURATIONS_S`,
shortest first (until the budget stops falling: less than 5 % twice running), and keeps the
first whose predicted budget (:func:`fts_calib.planning.dynamic_accuracy.dynamic_plan_budget`:
the samples the dynamic filter's trust rule keeps, weighed as it weighs them, with the dynamic
terms) meets the target
on every axis and whose samples pass the checks of every plan (limits, clearance). With fewer
configurations than the target needs it refuses, naming what each number reaches.
Durations in [s], errors in % of full scale.
"""

from __future__ import annotations

import numpy as np

from ..core.exceptions import TrajectoryError
from ..robot.collision import CollisionChecker
from ..robot.dynamic_sensitivities import MotionUncertainty
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool
from .continuous import CONTINUOUS_SCREEN_HZ, ContinuousSizing, Screened, _budget
from .planner import PlanResult, check_plan, plan_base
from .sizing import check_target
from .smooth import smooth_plan
from .sweeps import MIN_CLEARANCE, SweepPattern

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

    Args: as :func:`fts_calib.planning.continuous.size_continuous` (nominal: ``(C_bar (6, 6),
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

"""The ``trajectory`` job: plan, check and write calibration sweeps for a robot and a tool.

Steps: plan the sweeps (:mod:`fts_calib.planning.planner`), verify limits and clearance, predict
the excitation (:mod:`fts_calib.planning.excitation`) from the quasi-static samples the filter of
``configs/pipeline.yaml`` would keep, then write one trajectory file per tool
configuration, ``plan.yaml`` (what was planned and checked, without absolute paths or
times, so that planning again gives the same file) and ``plan.png``. When a check fails,
the report and the plot are still written, the trajectory files are not.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..budget.predicted import dynamic_plan_budget, filter_weights, plan_budget, predicted_still
from ..budget.propagation import AccuracyBudget, wrench_noise
from ..budget.sensitivities import MotionUncertainty
from ..core.exceptions import ConfigError, TrajectoryError
from ..filters.settings import FilterConfig
from ..model.sensor_config import SensorSpec
from ..robot.collision import CollisionChecker
from ..robot.definition import load_robot
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool
from .excitation import TOOL_CHANGE_S, ExcitationReport, predict_excitation
from .planner import PlanResult, plan_calibration
from .sizing import Sizing, size_motion, with_configurations
from .sweeps import MIN_CLEARANCE, SweepPattern


@dataclass(frozen=True)
class TrajectoryRun:
    """Everything the ``trajectory`` job planned, checked and wrote.

    Attributes:
        result: The plan and its checks.
        excitation: The predicted quality of the calibration.
        still: Samples the filter would keep (of a continuous plan: for some configuration), shape (N,) bool.
        g_sensor: Gravity in the sensor frame at every sample [m/s^2], shape (N, 3).
        tool: The tool.
        problems: Every failed check, in words (empty: safe to run).
        files: The files written.
        strain_unit: Unit of the strain noise (the sensor's).
        budget: The predicted accuracy budget, or None.
        sized: How the plan was sized to a target, or None for a raster given as it is.
        uncertainty: The dynamic terms' tolerances of a continuous plan, or None (stop and go).
        full_configurations: How many configurations the tool file has (``tool`` holds the
            first of them the plan is for).
        sweep_joints_default: The robot file names no ``sweep_joints``: the last two actuated
            joints sweep.
        purpose: 'calibration', or 'validation': a motion for ``validate`` (any tool), with no
            rank or accuracy requirement (its excitation and budget are not checks).
    """

    result: PlanResult
    excitation: ExcitationReport
    still: np.ndarray
    g_sensor: np.ndarray
    tool: Tool
    problems: list[str]
    files: list[Path]
    strain_unit: str = "raw"
    budget: AccuracyBudget | None = None
    sized: Sizing | None = None
    uncertainty: MotionUncertainty | None = None
    full_configurations: int = 0
    sweep_joints_default: bool = False
    purpose: str = "calibration"


def plan_trajectories(
    robot_path: str | Path,
    tool: Tool,
    sensor: SensorSpec,
    filter_config: FilterConfig,
    noise_std,
    pattern: SweepPattern,
    rate: float,
    min_clearance: float = MIN_CLEARANCE,
    target_percent: float | None = None,
    configurations: int | None = None,
    uncertainty: MotionUncertainty | None = None,
) -> TrajectoryRun:
    """Plan and check (nothing written); see the module docstring.

    Args:
        robot_path: Robot definition file.
        tool: Calibration tool (its shape is the collision envelope).
        sensor: Sensor configuration with a nominal model (``simulation`` section) for the
            excitation prediction.
        filter_config: Quasi-static filter thresholds.
        noise_std: Noise per channel for the prediction, raw units (one number or n).
        pattern: Raster of stops; with ``target_percent``, only its margin is used.
        rate: Sample rate [Hz].
        min_clearance: Required clearance [m].
        target_percent: Size the motion of ``pattern``'s kind (stop, continuous or smooth) to
            this accuracy, [% of full scale] (:func:`fts_calib.planning.sizing.size_motion`);
            None to plan ``pattern`` as it is (not a smooth one).
        configurations: Plan for the tool's first this many configurations (fewer tool
            changes; continuous motion only, the inertial torques then carry what eqs 19-20
            leave unseen); None for all.
        uncertainty: The dynamic terms' tolerances of a continuous plan (defaults when None).

    Raises:
        ConfigError: The sensor configuration has no nominal model (checked before planning).
        TrajectoryError: No raster meets ``target_percent`` (the message names the term, and
            for fewer configurations what each number of them reaches), or fewer
            configurations asked of a stop-and-go plan.
    """
    if sensor.simulated is None:
        message = "the sensor configuration needs a 'simulation' section (a nominal C) for the excitation report"
        raise ConfigError("sensor.simulated", None, "a nominal sensor model", message=message)
    kin = Kinematics(load_robot(robot_path))
    if tool.shape is None:  # never: Tool.__post_init__ fills in the default envelope
        raise ValueError(f"tool '{tool.name}' has no shape for the collision checks")
    checker = CollisionChecker(kin, tool.shape, kin.sweep_joints[0])
    sim = sensor.simulated
    nominal = (sim.C_bar, sim.D, wrench_noise(sim.C, noise_std), sensor.full_scale)
    full_tool, n_full = tool, len(tool.configurations)
    if configurations is not None and configurations < n_full and not pattern.continuous:
        raise TrajectoryError(
            f"--configurations {configurations} with a stop-and-go plan: still samples of fewer than 3 centres of mass leave the "
            "estimator rank 4 (one) or 6 (two) of 7 (paper eqs 19-20); plan --motion continuous (the inertial torques then carry "
            "the rest) or mount all configurations",
            "too few configurations",
        )
    tool = with_configurations(tool, configurations)
    sized: Sizing | None = None
    if pattern.smooth and target_percent is None:
        raise TrajectoryError("a smooth plan is sized to a target: expected --target-error, not a raster", "invalid target")
    if not pattern.continuous:
        uncertainty = None  # stop and go: the still samples have no dynamic terms
    elif uncertainty is None:
        uncertainty = motion_uncertainty(filter_config, sensor.rate_hz)
    if target_percent is None:
        result = plan_calibration(kin, checker, pattern, rate, min_clearance)
    else:
        kind = "smooth" if pattern.smooth else "continuous" if pattern.continuous else "stop"
        result, sized = size_motion(
            kind,
            kin,
            checker,
            tool,
            nominal,
            filter_config,
            target_percent,
            rate,
            sensor.rate_hz,
            uncertainty,
            min_clearance,
            pattern.margin,
            full_tool,
        )
    if uncertainty is not None:  # a continuous plan: the samples the dynamic filter's trust rule keeps
        kept = filter_weights(kin, tool, result.plan, nominal[2], uncertainty).reshape(len(tool.configurations), -1) > 0
        still = np.asarray(kept.any(axis=0))
        budget = dynamic_plan_budget(kin, tool, result.plan, *nominal, sample_rate_hz=sensor.rate_hz, uncertainty=uncertainty)
    else:
        still = predicted_still(result.plan, filter_config)
        kept = np.repeat(still[None, :], len(tool.configurations), axis=0)
        budget = plan_budget(kin, tool, result.plan, still, *nominal, sample_rate_hz=sensor.rate_hz)
    g_all = kin.g_sensor(result.plan.q, tool.gravity)
    excitation = predict_excitation(
        {c.name: g_all[kept[k]] for k, c in enumerate(tool.configurations)},
        tool,
        sensor.simulated.C_bar,
        sensor.simulated.D,
        noise_std,
        layout=sensor.layout,
        time_s={c.name: result.plan.time[kept[k]] + k * (result.plan.duration + TOOL_CHANGE_S) for k, c in enumerate(tool.configurations)},
    )
    problems = list(result.problems)
    if excitation.rank < 7 and not (pattern.continuous and np.isfinite(budget.largest_percent)):
        problems.append(excitation.advice)  # a continuous plan's inertial torques may lift the static rank
    default = kin.robot.sweep_joints is None
    return TrajectoryRun(
        result, excitation, still, g_all, tool, problems, [], sensor.strain_unit, budget, sized, uncertainty, n_full, default
    )


#: The joint noise [rad] and latency uncertainty [s] a continuous plan's budget assumes when the
#: pipeline settings leave them ``auto`` (measured from the stream, fitted with the calibration).
DEFAULT_JOINT_NOISE, DEFAULT_LATENCY_STD_S = 1e-5, 1e-4


def motion_uncertainty(filter_config: FilterConfig, joint_rate_hz: float, **overrides) -> MotionUncertainty:
    """The dynamic terms' tolerances from the dynamic filter's settings (``filter.*``), some overridden.

    Args:
        filter_config: The filter settings: ``inertia_tolerance``, ``joint_noise``,
            ``latency_uncertainty_s`` (``auto``: :data:`DEFAULT_JOINT_NOISE`,
            :data:`DEFAULT_LATENCY_STD_S`), ``dynamic_window_s``, ``dynamic_order``, ``max_error_ratio``.
        joint_rate_hz: Rate of the joint readings [Hz].
        overrides: Fields of :class:`MotionUncertainty` to set instead (None: the setting's).
    """
    f = filter_config
    latency = DEFAULT_LATENCY_STD_S if f.latency_uncertainty_s is None else f.latency_uncertainty_s
    values: dict[str, Any] = {
        "inertia": f.inertia_tolerance,
        "joint_noise": DEFAULT_JOINT_NOISE if f.joint_noise is None else f.joint_noise,
        "joint_rate_hz": joint_rate_hz,
        "window_s": f.dynamic_window_s,
        "latency_s": latency,
        "jitter_s": latency,
        "order": f.dynamic_order,
        "max_error_ratio": f.max_error_ratio,
    }
    values.update({k: v for k, v in overrides.items() if v is not None})
    return MotionUncertainty(**values)


def plan_summary(run: TrajectoryRun, files: list[str]) -> dict:
    """What was planned and checked, as plain data (deterministic: no paths, no times)."""
    result, plan, ex = run.result, run.result.plan, run.excitation
    return {
        **({"purpose": "validation"} if run.purpose == "validation" else {}),
        "robot": plan.robot,
        "tool": run.tool.name,
        "configurations": [c.name for c in run.tool.configurations],
        "rate_hz": plan.rate,
        "pattern": {
            "levels": plan.pattern.levels,
            "stops": plan.pattern.stops,
            "dwell_s": plan.pattern.dwell,
            "margin_rad": plan.pattern.margin,
            "span": plan.pattern.span,
            **({"return_pass": True} if plan.pattern.return_pass else {}),
            **({"continuous": True} if plan.pattern.continuous else {}),
            **({"smooth": True} if plan.pattern.smooth else {}),
        },
        **(
            {
                "motion": "continuous",
                "configurations_of_tool": run.full_configurations,
                "motion_uncertainty": {
                    "inertia_fraction": run.uncertainty.inertia,
                    "joint_noise_rad": run.uncertainty.joint_noise,
                    "joint_rate_hz": run.uncertainty.joint_rate_hz,
                    "window_s": run.uncertainty.window_s,
                    "polynomial_order": run.uncertainty.order,
                    "max_error_ratio": run.uncertainty.max_error_ratio,
                    "latency_std_s": run.uncertainty.latency_s,
                    "jitter_std_s": run.uncertainty.jitter_s,
                },
            }
            if run.uncertainty is not None
            else {}
        ),
        "target_error_percent_fs": run.sized.target_percent if run.sized else None,
        "home": {
            "source": result.home.source,
            "joints_rad": dict(zip(plan.joint_names, np.round(plan.home, 9).tolist(), strict=True)),
            "first_axis_tilt_deg": round(result.home.axis_tilt_deg, 6),
            "axes_angle_deg": round(result.home.axes_angle_deg, 6),
        },
        "sweep_ranges_rad": {j: np.round(r, 9).tolist() for j, r in zip(plan.sweep_joints, plan.ranges, strict=True)},
        "levels_rad": np.round(np.unique(plan.waypoints[:, 0]), 9).tolist(),
        "range_note": result.ranges.note,
        "duration_s": round(plan.duration, 6),
        "limits": {
            j: {k: round(float(getattr(plan.limits, k)[plan.joint_names.index(j)]), 9) for k in ("velocity", "acceleration", "jerk")}
            for j in plan.sweep_joints
        },
        "peaks": {j: {k: round(v, 9) for k, v in d.items()} for j, d in result.limits.peaks.items()},
        "clearance": {
            "distance_m": round(result.clearance.distance, 6),
            "pair": list(result.clearance.pair),
            "time_s": round(float(plan.time[result.clearance.index]), 6) if result.clearance.index >= 0 else None,
        },
        "home_clearance": {"distance_m": round(result.home_clearance.distance, 6), "pair": list(result.home_clearance.pair)},
        "excitation": {
            "noise_std": ex.noise_std.tolist(),
            "quasi_static_samples": dict(ex.samples) if run.uncertainty is None else {c.name: 0 for c in run.tool.configurations},
            **({"dynamic_samples": dict(ex.samples)} if run.uncertainty is not None else {}),
            "rank": ex.rank,
            "condition_number": round(ex.condition_number, 6) if math.isfinite(ex.condition_number) else None,
            "max_relative_stderr_C": float(f"{ex.max_relative_stderr:.6g}") if math.isfinite(ex.max_relative_stderr) else None,
            "coverage_deg": round(ex.coverage_deg, 3),
        },
        "accuracy_budget": run.budget.to_dict() if run.budget is not None else None,
        "problems": list(run.problems),
        "files": files,
        "software_version": __version__,
    }

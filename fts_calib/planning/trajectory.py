"""The ``trajectory`` job: plan, check and write calibration sweeps for a robot and a tool.

Steps: plan the sweeps (:mod:`fts_calib.planning.planner`), verify limits and clearance, predict
the excitation (:mod:`fts_calib.planning.excitation`) from the quasi-static samples the filter of
``configs/pipeline.yaml`` would keep, then write one trajectory file per tool
configuration, ``plan.yaml`` (what was planned and checked, without absolute paths or
times, so that planning again gives the same file) and ``plan.png``. When a check fails,
the report and the plot are still written, the trajectory files are not.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._version import __version__
from ..app.report import table
from ..core.fileio import atomic_write_text, dump_yaml
from ..model.sensor import WRENCH_AXES, WRENCH_UNITS
from ..model.sensor_config import SensorSpec
from ..pipeline.settings import FilterConfig
from ..robot.collision import CollisionChecker
from ..robot.definition import load_robot
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool
from .excitation import ExcitationReport, predict_excitation
from .planner import MIN_CLEARANCE, PlanResult, SweepPattern, plan_calibration
from .trajectory_io import write_trajectory


@dataclass(frozen=True)
class TrajectoryRun:
    """Everything the ``trajectory`` job planned, checked and wrote.

    Attributes:
        result: The plan and its checks.
        excitation: The predicted quality of the calibration.
        still: Samples the filter would keep, shape (N,) bool.
        g_sensor: Gravity in the sensor frame at every sample [m/s^2], shape (N, 3).
        tool: The tool.
        problems: Every failed check, in words (empty: safe to run).
        files: The files written.
        strain_unit: Unit of the strain noise (the sensor's).
    """

    result: PlanResult
    excitation: ExcitationReport
    still: np.ndarray
    g_sensor: np.ndarray
    tool: Tool
    problems: list[str]
    files: list[Path]
    strain_unit: str = "raw"


def quasi_static(result: PlanResult, filter_config: FilterConfig) -> np.ndarray:
    """Samples the quasi-static filter would keep.

    Joints slow and steady, and at least half a strain window away from any motion (the
    stationarity test needs the whole window).
    """
    plan = result.plan
    still = plan.still(filter_config.max_joint_speed, filter_config.max_joint_acceleration)
    half = int(math.ceil(filter_config.strain_window_s * plan.rate / 2))
    if half:
        moving = np.convolve((~still).astype(float), np.ones(2 * half + 1), mode="same") > 0
        still = still & ~moving
    return still


def plan_trajectories(
    robot_path: str | Path,
    tool: Tool,
    sensor: SensorSpec,
    filter_config: FilterConfig,
    noise_std,
    pattern: SweepPattern,
    rate: float,
    min_clearance: float = MIN_CLEARANCE,
) -> TrajectoryRun:
    """Plan and check (nothing written); see the module docstring.

    Args:
        robot_path: Robot definition file.
        tool: Calibration tool (its shape is the collision envelope).
        sensor: Sensor configuration with a nominal model (``simulation`` section) for the
            excitation prediction.
        filter_config: Quasi-static filter thresholds.
        noise_std: Strain noise per bridge for the prediction, raw units (one number or 8).
        pattern: Raster of stops.
        rate: Sample rate [Hz].
        min_clearance: Required clearance [m].
    """
    kin = Kinematics(load_robot(robot_path))
    if tool.shape is None:  # never: Tool.__post_init__ fills in the default envelope
        raise ValueError(f"tool '{tool.name}' has no shape for the collision checks")
    checker = CollisionChecker(kin, tool.shape, kin.sweep_joints[0])
    result = plan_calibration(kin, checker, pattern, rate, min_clearance)
    still = quasi_static(result, filter_config)
    g_all = kin.g_sensor(result.plan.q, tool.gravity)
    if sensor.simulated is None:
        raise ValueError("the sensor configuration needs a 'simulation' section (a nominal C) for the excitation report")
    excitation = predict_excitation(
        {c.name: g_all[still] for c in tool.configurations}, tool, sensor.simulated.C_bar, sensor.simulated.D, noise_std
    )
    problems = list(result.problems)
    if excitation.rank < 7:
        problems.append(excitation.advice)
    return TrajectoryRun(result, excitation, still, g_all, tool, problems, [], sensor.strain_unit)


def write_run(run: TrajectoryRun, out: str | Path, compress: bool = False, plot: bool = True) -> TrajectoryRun:
    """Write the trajectory files (only when every check passed), plan.yaml and plan.png."""
    from ..app import plots

    out = Path(out)
    plan = run.result.plan
    files = []
    if not run.problems:
        suffix = ".csv.gz" if compress else ".csv"
        for config in run.tool.configurations:
            files.append(
                write_trajectory(out / f"{config.name}{suffix}", plan.joint_names, plan.time, plan.q, plan.qd, plan.qdd, config.name)
            )
    files.append(atomic_write_text(out / "plan.yaml", dump_yaml(plan_summary(run, [f.name for f in files]))))
    if plot:
        index = [plan.joint_names.index(j) for j in plan.sweep_joints]
        files.append(
            plots.plot_plan(
                out / "plan.png",
                plan.time,
                plan.q[:, index],
                plan.sweep_joints,
                run.still,
                run.g_sensor,
                f"{plan.robot}: calibration sweep, {plan.duration:.1f} s per tool configuration",
            )
        )
    return dataclasses.replace(run, files=files)


def plan_summary(run: TrajectoryRun, files: list[str]) -> dict:
    """What was planned and checked, as plain data (deterministic: no paths, no times)."""
    result, plan, ex = run.result, run.result.plan, run.excitation
    return {
        "robot": plan.robot,
        "tool": run.tool.name,
        "configurations": [c.name for c in run.tool.configurations],
        "rate_hz": plan.rate,
        "pattern": {
            "levels": plan.pattern.levels,
            "stops": plan.pattern.stops,
            "dwell_s": plan.pattern.dwell,
            "margin_rad": plan.pattern.margin,
        },
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
            "quasi_static_samples": dict(ex.samples),
            "rank": ex.rank,
            "condition_number": round(ex.condition_number, 6) if math.isfinite(ex.condition_number) else None,
            "max_relative_stderr_C": float(f"{ex.max_relative_stderr:.6g}") if math.isfinite(ex.max_relative_stderr) else None,
            "coverage_deg": round(ex.coverage_deg, 3),
        },
        "problems": list(run.problems),
        "files": files,
        "software_version": __version__,
    }


def format_report(run: TrajectoryRun, robot_path: Path, tool_path: Path, compress: bool = False) -> str:
    """The printed report of the ``trajectory`` job, with units."""
    result, plan, ex = run.result, run.result.plan, run.excitation
    lines = [
        f"robot {plan.robot} ({robot_path}), tool '{run.tool.name}' ({tool_path}): configurations "
        f"{', '.join(c.name for c in run.tool.configurations)}"
    ]
    home = result.home
    how = (
        (
            "planned automatically: "
            + (f"{home.tilt_joint} set so that the axis of {plan.sweep_joints[0]} is horizontal" if home.tilt_joint else "")
        )
        if home.source == "automatic"
        else "from the robot definition"
    )
    lines.append(f"home ({how}):")
    lines.append("  " + ", ".join(f"{j} {v:+.4f}" for j, v in zip(plan.joint_names, plan.home, strict=True)) + " rad")
    lines.append(f"  axis of {plan.sweep_joints[0]} {home.axis_tilt_deg:.1f}° from horizontal; sweep axes {home.axes_angle_deg:.1f}° apart")
    a, b = plan.sweep_joints
    levels = np.unique(plan.waypoints[:, 0])
    lines.append(
        f"sweep: {a} at {len(levels)} levels {', '.join(f'{v:+.1f}' for v in np.degrees(levels))}° (chosen in "
        f"[{np.degrees(plan.ranges[0, 0]):+.1f}°, {np.degrees(plan.ranges[0, 1]):+.1f}°] to spread gravity's latitude "
        f"about the axis of {b}); {b} over [{np.degrees(plan.ranges[1, 0]):+.1f}°, {np.degrees(plan.ranges[1, 1]):+.1f}°] "
        f"in {plan.pattern.stops} stops per level; dwell {plan.pattern.dwell:.2f} s at each of {len(plan.waypoints)} stops"
    )
    if result.ranges.note:
        lines.append(f"  note: {result.ranges.note}")
    rows = []
    for j in plan.sweep_joints:
        k = plan.joint_names.index(j)
        peak, ratio = result.limits.peaks[j], result.limits.ratios[j]
        rows.append(
            [j]
            + [f"{peak[q]:.3f} / {getattr(plan.limits, q)[k]:.3f} ({100 * ratio[q]:.1f} %)" for q in ("velocity", "acceleration", "jerk")]
        )
    lines.append("limits used, peak / limit:")
    lines.append(table(["joint", "velocity [rad/s]", "acceleration [rad/s²]", "jerk [rad/s³]"], rows))
    n_conf = len(run.tool.configurations)
    lines.append(
        f"duration: {plan.duration:.1f} s per configuration ({n_conf} configurations: {n_conf * plan.duration:.1f} s "
        f"of motion, plus the tool changes at home), sampled at {plan.rate:g} Hz"
    )
    c, h = result.clearance, result.home_clearance
    when = f" at t = {plan.time[c.index]:.2f} s" if c.index >= 0 else ""
    lines.append(
        f"clearance: {c.distance:.3f} m between '{c.pair[0]}' and '{c.pair[1]}'{when} along the sweep "
        f"({result.checked_samples} samples checked); {h.distance:.3f} m between '{h.pair[0]}' and '{h.pair[1]}' "
        f"at home (at least {result.min_clearance:.3f} m required)"
    )
    noise = ex.noise_std
    noise_text = f"{noise[0]:.2g}" if np.all(noise == noise[0]) else str(noise.tolist())
    counts = ", ".join(f"{k}: {v}" for k, v in ex.samples.items())
    lines.append(f"excitation (strain noise {noise_text} {run.strain_unit} per bridge; quasi-static samples {counts}):")
    cond = f"{ex.condition_number:.1f}" if math.isfinite(ex.condition_number) else "inf"
    lines.append(
        f"  predicted rank {ex.rank} of 7, condition number {cond}; every direction within "
        f"{ex.coverage_deg:.1f}° of a gravity direction the sensor sees"
    )
    if ex.rank == 7:
        lines.append("  predicted standard error of C, in % of each row's largest coefficient:")
        rel = 100 * ex.relative_stderr_C
        lines.append(
            table(
                ["", *[f"Δ{k + 1}" for k in range(8)]],
                [[axis, *[f"{v:.5f}" for v in rel[i]]] for i, axis in enumerate(WRENCH_AXES)],
                "    ",
            )
        )
        lines.append(
            f"  largest: {100 * ex.max_relative_stderr:.5f} %; predicted standard error of D: "
            + ", ".join(f"{axis} {v:.2g} {u}" for axis, v, u in zip(WRENCH_AXES, ex.stderr_D, WRENCH_UNITS, strict=True))
        )
    for problem in run.problems:
        lines.append(f"CHECK FAILED: {problem}")
    if run.files:
        lines.append("wrote: " + ", ".join(str(f) for f in run.files))
    if run.problems:
        lines.append("trajectory files not written: fix the failed checks first")
    return "\n".join(lines)

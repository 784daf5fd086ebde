"""The ``trajectory`` command: plan and check the sweeps, write the files of the run, its plot and its report."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..budget.propagation import DEFAULT_TARGET_PERCENT
from ..core.exceptions import ConfigError, FileFormatError, TrajectoryError
from ..core.files import atomic_write_text, dump_yaml
from ..core.resources import resolve, shown
from ..core.tables import table
from ..model.channels import WRENCH_AXES, WRENCH_UNITS
from ..model.determination import Determination
from ..planning.excitation import DriftPrediction
from ..planning.jig import check_jig, suggest_jig
from ..planning.sweeps import SweepPattern
from ..planning.trajectory_files import TrajectoryFile, save_trajectory
from ..planning.trajectory_run import TrajectoryRun, motion_uncertainty, plan_summary, plan_trajectories
from ..report import plots
from ..robot.tool import Tool, save_tool
from .exit_codes import ExitCode, writing
from .report import format_budget
from .setup import Setup

if TYPE_CHECKING:
    from ..payload.inertia_motion import PayloadPlan


@dataclass(frozen=True)
class Sweeps:
    """What sweeps to plan: the motion, the raster (fixed, or sized to the target) and its checks.

    Attributes:
        motion: 'stop' (dwell at each stop: quasi-static samples), 'continuous' (no dwell:
            every sample calibrates in the ``dynamic`` filter mode, with the budget's dynamic
            terms) or 'smooth' (continuous: every joint on a sinusoid ramped in and out at
            home, always sized to the target).
        rate_hz: Sample rate of the trajectory files, in [Hz].
        levels: Positions of the first sweep joint (a fixed raster; 4 when only others are given).
        stops: Positions of the second sweep joint per level (fixed raster; default 6).
        dwell_s: Time held still at each stop, in [s] (fixed raster; default 0.5).
        span: Fraction of the second sweep joint's range the stops cover (fixed raster; default 1).
        return_pass: Visit the raster's stops again in reverse order (drift separable from the
            orientation; about twice the time); fixes the raster (no sizing to the target).
        configurations: Plan for the tool's first this many configurations (continuous only;
            refused, naming what each number reaches, when the target is out of reach); None for all.
        margin: Distance kept from the position limits, in [rad].
        min_clearance: Smallest distance allowed between links, in [m].
        validation: A validation motion for ``validate`` (any tool, one configuration too):
            the raster as given (the defaults for the rest), checked for limits and clearance,
            with no rank or accuracy requirement; fixes the raster.
    """

    motion: str = "stop"
    rate_hz: float = 500.0
    levels: int | None = None
    stops: int | None = None
    dwell_s: float | None = None
    span: float | None = None
    return_pass: bool = False
    configurations: int | None = None
    margin: float = 0.02
    min_clearance: float = 0.02
    validation: bool = False

    @property
    def fixed(self) -> bool:
        """Whether the raster is fixed (not sized): a raster option, the return pass or a validation motion; never smooth."""
        given = any(v is not None for v in (self.levels, self.stops, self.dwell_s, self.span)) or self.return_pass or self.validation
        return given and self.motion != "smooth"

    def pattern(self) -> SweepPattern:
        """The sweep pattern, the defaults in place of what is not given."""
        default = SweepPattern()
        continuous = self.motion in ("continuous", "smooth")
        return SweepPattern(
            levels=default.levels if self.levels is None else self.levels,
            stops=default.stops if self.stops is None else self.stops,
            dwell=(0.0 if continuous else default.dwell) if self.dwell_s is None else self.dwell_s,
            margin=self.margin,
            span=default.span if self.span is None else self.span,
            return_pass=self.return_pass,
            continuous=continuous,
            smooth=self.motion == "smooth",
        )


def run(
    setup: Setup,
    sweeps: Sweeps | None = None,
    *,
    output: str | Path,
    target_error_percent: float | None = None,
    compress: bool = False,
    plot: bool = True,
) -> int:
    """Plan and check the calibration sweeps, write them and print the report (``fts-calib trajectory``).

    Args:
        setup: The robot, the tool (its envelope: ``tool_radius``, ``tool_length``), the
            sensor file with a nominal model (for the excitation report; its noise per channel,
            or ``noise_std``, else the pipeline file's ``design.noise_std``), the pipeline
            settings (filter thresholds; a continuous motion's ``joint_noise``,
            ``latency_uncertainty_s`` and ``inertia_tolerance``) and ``model``, the sensor model
            the plan must determine ('linear' when None, 'quadratic' or 'cubic':
            :mod:`fts_calib.planning.jig`).
        sweeps: The motion, the raster and the checks (:class:`Sweeps`).
        output: Output folder: one CSV per tool configuration, plan.yaml and plan.png.
        target_error_percent: Size the raster: the shortest whose predicted accuracy budget
            is within this on every axis, in [% of full scale]; the default target
            (:data:`fts_calib.budget.propagation.DEFAULT_TARGET_PERCENT`) when None. With a fixed
            raster it is only compared.
        compress: Write .csv.gz files.
        plot: Write plan.png.

    Returns:
        0 when every check passed, 1 when one failed (the trajectory files are then not written),
        9 when the tool's configurations cannot determine the model (a jig that would is written
        to ``output/suggested_tool.yaml``).
    """
    sweeps = sweeps or Sweeps()
    if sweeps.motion == "payload":
        return _plan_payload(setup, sweeps, Path(output), compress)
    out, model = output, setup.model or "linear"
    robot_path, tool_path = setup.robot_path, setup.tool_path
    loaded = setup.tool
    spec = setup.sensor
    if spec.simulated is None:  # before anything is planned: the report needs the nominal model
        message = (
            "missing: the excitation report needs the sensor's nominal model (C or C_bar, D, noise_std); give --sensor "
            "a file with a 'simulation' section (e.g. the shipped 'sensor')"
        )
        raise FileFormatError(resolve(setup.sensor_file, "configs", "sensor"), "simulation", message)
    if model != "linear":
        found = check_jig(loaded, model)
        if not found.determined:
            return _suggest(loaded, model, found, spec.full_scale, Path(out))
    settings = setup.settings
    noise: float | np.ndarray | None = setup.noise_std
    if noise is None:  # the sensor's own channels first: the pipeline's design noise is in the paper sensor's mV/V
        noise = spec.simulated.noise_std if spec.simulated is not None else settings.noise_std
    if noise is None:
        noise = 0.0
    fixed, pattern = sweeps.fixed, sweeps.pattern()
    continuous, smooth = pattern.continuous, pattern.smooth
    _check_purpose(sweeps, loaded, model)
    configurations, rate_hz, min_clearance = sweeps.configurations, sweeps.rate_hz, sweeps.min_clearance
    uncertainty = motion_uncertainty(settings.filter, spec.rate_hz) if continuous else None
    default = SweepPattern()
    target = DEFAULT_TARGET_PERCENT if target_error_percent is None else target_error_percent
    count = len(loaded.configurations) if configurations is None else configurations
    kind = ("validation " if sweeps.validation else "") + ("smooth continuous " if smooth else "continuous " if continuous else "")
    robot = setup.kinematics.robot.name  # the robot file's name, as the report below says it (not the file's)
    print(f"planning {robot} {kind}sweeps for '{loaded.name}' ({count} configuration{'' if count == 1 else 's'})...", flush=True)
    planned = plan_trajectories(
        robot_path,
        loaded,
        spec,
        settings.filter,
        noise,
        pattern,
        rate_hz,
        min_clearance,
        None if fixed else target,
        configurations,
        uncertainty,
    )
    if model != "linear" and not plan_determines(planned, model).determined and not fixed:
        # the shortest raster meets the linear budget with few stops: each configuration needs enough orientations
        print(f"the sized raster's stops cannot determine a {model} model: planning the default raster instead", flush=True)
        raster = dataclasses.replace(pattern, levels=default.levels, stops=default.stops, dwell=default.dwell)
        planned = plan_trajectories(
            robot_path, loaded, spec, settings.filter, noise, raster, rate_hz, min_clearance, None, configurations, uncertainty
        )
    if model != "linear" and not (found := plan_determines(planned, model)).determined:
        planned.problems.append(f"the plan's stops cannot determine a {model} model: {found.lacks(loaded.names)}")
    if sweeps.validation:  # compared, never fitted: the rank and the budget are no checks of it
        kept = [p for p in planned.problems if p != planned.excitation.advice]
        planned = dataclasses.replace(planned, problems=kept, purpose="validation")
    with writing(out):
        planned = write_run(planned, out, compress=compress, plot=plot, model=model)
    print(format_report(planned, robot_path, tool_path, target_percent=target))
    if model != "linear" and not planned.problems:
        found = plan_determines(planned, model)
        print(
            f"model: {model}, determined by the plan's {len(loaded.configurations)} configurations ({found.masses} masses at "
            f"{found.centres} centres of mass): rank {found.rank} of the {found.achievable} a jig of weights reaches, "
            "each configuration predicted by the others; calibrate with --model auto or --model " + model
        )
    return ExitCode.CHECK_FAILED if planned.problems else ExitCode.OK


def _plan_payload(setup: Setup, sweeps: Sweeps, out: Path, compress: bool) -> int:
    """Plan, check and write the payload motion (``--motion payload``): its CSV and plan.yaml; 1 when a check failed."""
    from ..budget.propagation import wrench_noise
    from ..payload.inertia_motion import plan_payload_motion  # the payload stage: loaded only for this motion

    kin, tool, spec = setup.kinematics, setup.tool, setup.sensor
    if spec.simulated is None:
        message = (
            "missing: the predicted standard errors need the sensor's nominal model and noise; give --sensor a file with a "
            "'simulation' section"
        )
        raise FileFormatError(resolve(setup.sensor_file, "configs", "sensor"), "simulation", message)
    noise = wrench_noise(spec.simulated.C, spec.simulated.noise_std)
    name = tool.configurations[0].name
    print(f"planning {kin.robot.name} payload motion for '{tool.name}' (configuration {name})...", flush=True)
    plan = plan_payload_motion(kin, tool, noise, sweeps.rate_hz, sweeps.min_clearance)
    files = []
    with writing(out):
        if not plan.problems:
            trajectory = TrajectoryFile(kin.joint_names, plan.time, plan.q, plan.qd, plan.qdd, name)
            files.append(save_trajectory(out / f"{name}{'.csv.gz' if compress else '.csv'}", trajectory))
        files.append(atomic_write_text(out / "plan.yaml", dump_yaml(_payload_summary(kin.robot.name, tool, plan, [f.name for f in files]))))
    print("\n".join(_payload_lines(plan, setup.tool_path, files)))
    return ExitCode.CHECK_FAILED if plan.problems else ExitCode.OK


def _payload_summary(robot: str, tool: Tool, plan: PayloadPlan, files: list[str]) -> dict:
    """plan.yaml of a payload motion: what was planned and checked, and the predicted standard errors (plain data)."""
    return {
        "purpose": "payload",
        "robot": robot,
        "tool": tool.name,
        "configurations": [plan.configuration],
        "rate_hz": float(round(1.0 / (plan.time[1] - plan.time[0]), 9)),
        "moving_joints": list(plan.joints),
        "duration_s": float(plan.time[-1]),
        "peaks_over_limits": plan.peak_ratio,
        "clearance": {"distance_m": float(plan.clearance.distance), "pair": list(plan.clearance.pair)},
        "predicted_stderr": {
            "from": "the sensor's noise alone (white, per sample)",
            "mass_kg": plan.stderr_mass,
            "com_m": plan.stderr_com.tolist(),
            "inertia_kg_m2": plan.stderr_inertia.tolist(),
        },
        "problems": list(plan.problems),
        "files": files,
    }


def _payload_lines(plan: PayloadPlan, tool_path: Path, files: list[Path]) -> list[str]:
    """The printed report of a payload motion, with units."""
    peaks = ", ".join(f"{j} {100 * r['velocity']:.0f} % / {100 * r['acceleration']:.0f} %" for j, r in plan.peak_ratio.items())
    c = plan.clearance
    inertia = plan.stderr_inertia
    lines = [
        f"motion: {', '.join(plan.joints)} together, rest to rest from the calibration's home through the pattern's stops: "
        f"{plan.time[-1]:.1f} s at {1.0 / (plan.time[1] - plan.time[0]):g} Hz",
        f"limits: peak velocity / acceleration over the limit: {peaks}",
        f"clearance: {c.distance:.3f} m between '{c.pair[0]}' and '{c.pair[1]}' (the payload's shape from {shown(tool_path)})",
        "predicted standard errors (the sensor's noise alone; joint noise and latency add to them): "
        f"mass {plan.stderr_mass:.2g} kg, centre of mass "
        + ", ".join(f"{a} {v:.2g}" for a, v in zip("xyz", plan.stderr_com, strict=True))
        + " m, inertia Ixx "
        + f"{inertia[0, 0]:.2g}, Iyy {inertia[1, 1]:.2g}, Izz {inertia[2, 2]:.2g}, Ixy {inertia[0, 1]:.2g}, Ixz {inertia[0, 2]:.2g}, "
        + f"Iyz {inertia[1, 2]:.2g} kg·m²",
    ]
    lines += [f"CHECK FAILED: {problem}" for problem in plan.problems]
    lines.append("wrote: " + ", ".join(str(f) for f in files))
    if not plan.problems:
        lines.append(
            f"play {files[0].name} with the payload on, record (joints and strains), then: "
            "fts-calib payload RECORDING --calibration CALIBRATION --robot ROBOT --motion moving -o payload.yaml"
        )
    return lines


def _check_purpose(sweeps: Sweeps, tool: Tool, model: str) -> None:
    """Refuse, before planning, what cannot be planned.

    A stop-and-go calibration of fewer than 3 centres of mass would size for nothing (rank 4 or
    6 of 7): refused naming --validation. A validation motion is a raster (not smooth) of the linear model.

    Raises:
        ConfigError: ``--validation`` with ``--motion smooth`` or a ``--model`` other than linear.
        TrajectoryError: A stop-and-go calibration plan for a tool of one or two configurations.
    """
    if sweeps.validation and sweeps.motion == "smooth":
        raise ConfigError("--validation", "smooth", "--motion stop or continuous: a validation motion is a raster")
    if sweeps.validation and model != "linear":
        raise ConfigError("--validation", model, "the linear model: a validation motion determines nothing")
    n = len(tool.configurations)
    if not sweeps.validation and sweeps.motion == "stop" and n < 3:
        raise TrajectoryError(
            f"'{tool.name}' has {n} configuration{'' if n == 1 else 's'} ({', '.join(tool.names)}): still samples of fewer than 3 "
            f"centres of mass reach rank {4 if n == 1 else 6} of 7 (paper eqs 18-20), so no raster calibrates with it; plan "
            "its validation motion with --validation (checked for limits and clearance, no accuracy target), or a "
            "calibration with --motion continuous (the inertial torques carry the rest)"
        )


def _validation_lines(run: TrajectoryRun, kept: str, counts: str, tool: str) -> list[str]:
    """The end of a validation plan's report: what it shows the sensor, no rank or budget (it is compared, not fitted).

    ``tool``: the tool as ``--tool`` names it (a shipped name or the file).
    """
    lines = [
        f"validation motion ({kept} {counts}): gravity reaches every direction of the sensor frame within "
        f"{run.excitation.coverage_deg:.1f}° of one it sees; no rank or accuracy requirement (validate compares a "
        "calibration's wrench with this tool's known one; the fit never sees it)"
    ]
    lines += [f"CHECK FAILED: {problem}" for problem in run.problems]
    if run.files:
        lines.append("wrote: " + ", ".join(str(f) for f in run.files))
    if run.problems:
        lines.append("trajectory files not written: fix the failed checks first")
    else:
        names = " ".join(f"{c.name}.csv" for c in run.tool.configurations)
        lines.append(f"play {names}, record, then: fts-calib validate RECORDING --calibration CALIBRATION --tool {tool}")
    return lines


def plan_determines(run: TrajectoryRun, model: str) -> Determination:
    """What a plan's still samples (every configuration at the same stops) determine of ``model``."""
    return check_jig(run.tool, model, directions=run.g_sensor[run.still] if run.still.any() else run.g_sensor)


def _suggest(tool: Tool, model: str, found: Determination, full_scale: np.ndarray, out: Path) -> int:
    """Name and write a jig that determines ``model`` (the tool's configurations cannot): exit 9."""
    jig = suggest_jig(tool, model, full_scale)
    added = [c for c in jig.configurations if c.name not in tool.names]
    header = (
        f"A jig that determines a {model} sensor model (fts-calib trajectory --model {model}): the configurations of\n"
        f"'{tool.name}' and {len(added)} more. Check every mass, centre of mass and inertia against your hardware;\n"
        "the inertias of the added ones are scaled copies of the nearest configuration's (for the dynamic filter only)."
    )
    with writing(out):
        out.mkdir(parents=True, exist_ok=True)
        path = save_tool(jig, out / "suggested_tool.yaml", header)
    rows = [[c.name, f"{c.mass:g}", ", ".join(f"{v + 0.0:+.3f}" for v in c.p_sensor_com)] for c in added]
    forces = max(c.mass for c in jig.configurations) * jig.gravity
    print(
        f"NOT PLANNED: the configurations of '{tool.name}' cannot determine a {model} model beyond their own loads: "
        f"{found.lacks(tool.names)}.\n"
        f"A jig that does: its {len(tool.configurations)} configurations and these {len(added)} (loads to {forces:.3g} N, "
        f"{100 * forces / float(np.min(full_scale[:3])):.0f} % of the force full scale):\n"
        + table(["configuration", "mass [kg]", "centre of mass [m]"], rows, "  ")
        + f"\nwrote {path}: plan it with --tool {path} --model {model}"
    )
    return ExitCode.TRAJECTORY


def write_run(run: TrajectoryRun, out: str | Path, compress: bool = False, plot: bool = True, model: str = "linear") -> TrajectoryRun:
    """Write the trajectory files (only when every check passed), plan.yaml and plan.png.

    ``model``: the sensor model the plan determines (recorded in plan.yaml when not linear).
    """
    out = Path(out)
    plan = run.result.plan
    files = []
    if not run.problems:
        suffix = ".csv.gz" if compress else ".csv"
        for config in run.tool.configurations:
            files.append(save_trajectory(out / f"{config.name}{suffix}", plan.trajectory(config.name)))
    summary = plan_summary(run, [f.name for f in files])
    if model != "linear":
        summary["model"] = {"family": model, **plan_determines(run, model).as_dict()}
    files.append(atomic_write_text(out / "plan.yaml", dump_yaml(summary)))
    if plot:
        index = [plan.joint_names.index(j) for j in plan.sweep_joints]
        labels = {}
        if plan.pattern.continuous:  # the shaded samples: those the dynamic filter's trust rule keeps
            labels["kept"] = "samples the dynamic filter trusts"
        if plan.pattern.smooth:
            labels["motion"] = "planned smooth motion (sinusoids ramped in and out)"
        files.append(
            plots.plot_plan(
                out / "plan.png",
                plan.time,
                plan.q[:, index],
                plan.sweep_joints,
                run.still,
                run.g_sensor,
                f"{plan.robot}: {run.purpose} sweep, {plan.duration:.1f} s per tool configuration",
                **labels,
            )
        )
    return dataclasses.replace(run, files=files)


def format_drift_prediction(drift: DriftPrediction, constant: float) -> str:
    """The excitation under the drift offset model, in words, beside the constant-offset figure (relative)."""
    head = f"  under the drift offset model ({', '.join(drift.columns)}): predicted rank {drift.rank} of {drift.full_rank}"
    if drift.rank < drift.full_rank:
        return head + ": the plan cannot separate the drift from the orientation (revisit directions later in the run)"
    return (
        f"{head}, condition number {drift.condition_number:.1f}; largest standard error of C {100 * drift.max_relative_stderr:.5f} % "
        f"({drift.max_relative_stderr / constant:.2f}x the constant-offset figure); of D at the end: "
        + ", ".join(f"{axis} {v:.2g} {u}" for axis, v, u in zip(WRENCH_AXES, drift.stderr_D, WRENCH_UNITS, strict=True))
    )


def format_report(
    run: TrajectoryRun, robot_path: Path, tool_path: Path, compress: bool = False, target_percent: float | None = None
) -> str:
    """The printed report of the ``trajectory`` job, with units."""
    result, plan, ex = run.result, run.result.plan, run.excitation
    lines = [
        f"robot {plan.robot} ({shown(robot_path)}), tool '{run.tool.name}' ({shown(tool_path)}): configurations "
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
    how_stops = (
        f"passed without stopping (continuous: every sample calibrates in the dynamic filter mode) at each of {len(plan.waypoints)} stops"
        if plan.pattern.continuous
        else f"dwell {plan.pattern.dwell:.2f} s at each of {len(plan.waypoints)} stops"
    )
    lines.append(
        f"sweep: {a} at {len(levels)} levels {', '.join(f'{v:+.1f}' for v in np.degrees(levels))}° (chosen in "
        f"[{np.degrees(plan.ranges[0, 0]):+.1f}°, {np.degrees(plan.ranges[0, 1]):+.1f}°] to spread gravity's latitude "
        f"about the axis of {b}); {b} over [{np.degrees(plan.ranges[1, 0]):+.1f}°, {np.degrees(plan.ranges[1, 1]):+.1f}°] "
        f"in {plan.pattern.stops} stop{'s' if plan.pattern.stops > 1 else ''} per level; {how_stops}"
    )
    if run.sweep_joints_default:
        lines.append(
            f"  sweep joints {a} and {b}: by default, the last two actuated joints (name others with the robot file's sweep_joints)"
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
    if run.full_configurations and n_conf < run.full_configurations:
        lines.append(
            f"configurations: the first {n_conf} of the tool's {run.full_configurations} ({', '.join(run.tool.names)}): "
            f"{run.full_configurations - n_conf} tool change{'s' if run.full_configurations - n_conf > 1 else ''} fewer"
        )
    if run.uncertainty is not None:
        u = run.uncertainty
        lines.append(
            f"dynamic terms: inertia known to {100 * u.inertia:g} % of its largest principal moment per element, joint noise "
            f"{u.joint_noise:.2g} rad at {u.joint_rate_hz:g} Hz (rates from a {1e3 * u.window_s:g} ms centred polynomial of "
            f"degree {u.order}), latency "
            f"estimate ±{1e3 * u.latency_s:.2g} ms (1σ), jitter {1e3 * u.jitter_s:.2g} ms"
        )
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
    kept = "quasi-static samples" if run.uncertainty is None else "moving samples the dynamic filter trusts"  # as plan.yaml says
    if run.purpose == "validation":
        tool_arg = Path(tool_path).stem if shown(tool_path).startswith("shipped ") else str(tool_path)
        return "\n".join([*lines, *_validation_lines(run, kept, counts, tool_arg)])
    lines.append(f"excitation (noise {noise_text} {run.strain_unit} per channel; {kept} {counts}):")
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
                ["", *[f"Δ{k + 1}" for k in range(ex.stderr_C.shape[1])]],
                [[axis, *[f"{v:.5f}" for v in rel[i]]] for i, axis in enumerate(WRENCH_AXES)],
                "    ",
            )
        )
        lines.append(
            f"  largest from strain noise alone: {100 * ex.max_relative_stderr:.5f} %; predicted standard error of D: "
            + ", ".join(f"{axis} {v:.2g} {u}" for axis, v, u in zip(WRENCH_AXES, ex.stderr_D, WRENCH_UNITS, strict=True))
        )
    if ex.drift is not None and ex.rank == 7:
        lines.append(format_drift_prediction(ex.drift, ex.max_relative_stderr))
    if run.budget is not None:
        lines += format_budget(run.budget, "predicted")
        if run.sized is not None:
            lines.append("  " + run.sized.summary())
        elif target_percent is not None:
            verdict = "meets" if run.budget.largest_percent <= target_percent else "does NOT meet"
            lines.append(f"  this fixed raster {verdict} the target of {target_percent:g} % of full scale (--target-error)")
    for problem in run.problems:
        lines.append(f"CHECK FAILED: {problem}")
    if run.files:
        lines.append("wrote: " + ", ".join(str(f) for f in run.files))
    if run.problems:
        lines.append("trajectory files not written: fix the failed checks first")
    return "\n".join(lines)

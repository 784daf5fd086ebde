"""The demo's drifting sensor (``fts-calib demo --drift``): offsets that move, calibrated right.

The simulated sensor's offsets drift (:meth:`fts_calib.sim.drift.OffsetDrift.typical`:
forces up to 1 N/min, moments 0.05 N m/min, a warm-up with its temperature channel, a jump
of up to 1 N at each tool change). The calibration models them (``offsets: auto``); this
module compares its offset trajectory with the truth, calibrates the same recording with
the paper's constant offsets for contrast, plots both, and gives the sensor as it is at
the end of the run, which the validation then reads.

The demo: the whole loop in simulation on the built-in UR5, with the paper's figures.

1. Plan the calibration sweeps for the shipped tool (:mod:`fts_calib.planning.trajectory_run`).
2. Simulate the recording: the moving tool's full wrench through the simulated sensor of
   ``configs/sensor.yaml`` (true C = Table 1 of the paper, offsets, noise, 24-bit ADC).
3. Calibrate with the quasi-static filter (:mod:`fts_calib.session.calibration_run`).
4. Follow the estimate of C_bar_11 sample by sample (the paper's Fig. 7).
5. Validate on another motion (ruckig through seeded waypoints of the wrist, no dwell) with
   another tool (``configs/validation_tool.yaml``): the paper's third stage; and compare
   the paper's Table 1 with its Table 2 over the same motion, as the paper did.

Everything goes into one folder (``out/`` by default): trajectories, recordings, the
calibration, the plots of the paper's Figs 5-6, 7 and 9-10, and the calibration's one-page
HTML report ``report.html`` (:mod:`fts_calib.report.html`) with the validation as its
held-out error.

With ``drift`` the simulated sensor's offsets move during the run (a drift, a warm-up
with a temperature channel, jumps at tool changes: :mod:`fts_calib.app.demo`); the
calibration models them, and the plot ``offsets_drift.png`` shows the estimated against
the true offsets over time. The validation then reads the sensor as it is at the end.
"""

from __future__ import annotations

import dataclasses
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import numpy as np

from ..core.exceptions import FtsCalibError, TrajectoryError
from ..core.resources import resolve
from ..core.tables import table
from ..filters.settings import PipelineConfig, load_pipeline_config
from ..model.calibration import Calibration, load_calibration, save_calibration
from ..model.channels import WRENCH_AXES, WRENCH_UNITS
from ..model.estimator import OnlineEstimator
from ..model.offset_models import OffsetBasis, evaluate_offsets
from ..model.sensor_config import load_sensor_config
from ..planning.motion import sample_motion
from ..planning.sweeps import SweepPattern
from ..planning.trajectory_files import TrajectoryFile
from ..planning.trajectory_run import plan_trajectories
from ..report.content import KeptCollector, calibrate_content, held_out
from ..report.html import render_report, write_report
from ..robot.collision import CollisionChecker
from ..robot.definition import load_robot
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool, load_tool, tool_load
from ..service.validation import AxisErrors, ValidationResult, validate_recording
from ..session.calibration_run import calibrate_recording
from ..sim.drift import OffsetDrift
from ..sim.runs import simulate_recording
from ..sim.sensor import SimulatedSensor, simulated_sensor
from ..sources.batch import SampleBatch
from ..sources.recording import RecordingReader
from .calibrate import format_counts
from .exit_codes import ExitCode, writing
from .trajectory import write_run


@dataclasses.dataclass(frozen=True)
class DriftReport:
    """What the drifting demo found.

    Attributes:
        sensor_at_end: The simulated sensor with its offsets as at the end of the run.
        constant: The calibration of the same recording with constant offsets (the paper's).
        max_error: Largest |estimated - true| offset over the run per axis, [N, N m]. Shape (6,).
        plot: The PNG of the offsets over time.
    """

    sensor_at_end: SimulatedSensor
    constant: Calibration
    max_error: np.ndarray
    plot: Path


def drift_stage(
    out: Path,
    kin: Kinematics,
    tool: Tool,
    recording: Path,
    calibration: Calibration,
    sensor: SimulatedSensor,
    drift: OffsetDrift,
    settings: PipelineConfig,
    say: Callable[[str], None],
) -> DriftReport:
    """Compare the calibration's offset trajectory with the truth, plot it, and report in words.

    Args:
        out: The demo's folder.
        kin: The robot's kinematics.
        tool: The calibration tool; the recording runs its configurations in order (the k-th
            follows k tool changes).
        recording: The drifting calibration recording (with its temperature column).
        calibration: Its calibration (with an offset model).
        sensor: The simulated sensor (offsets at the start).
        drift: How its offsets moved.
        settings: The pipeline settings of the calibration.
        say: Prints a line.
    """
    from ..report import plots

    with RecordingReader(recording, kin.joint_names, tool.names) as reader:
        samples = SampleBatch.concatenate(list(reader))
    step = max(1, len(samples) // 5_000)
    t, codes = samples.time[::step], samples.configuration[::step]
    heat = None if samples.temperature is None else samples.temperature[::step]
    true = sensor.D + drift.offsets(t - samples.time[0], codes)
    estimated = evaluate_offsets(calibration.offset_model or {}, t, codes, heat)
    constant = calibrate_recording(recording, kin, tool, settings.with_offsets("constant"), accept_poor_fit=True).calibration
    if constant is None:  # never: the same recording determines C with constant offsets too
        raise RuntimeError("the demo's constant-offset calibration gave no result")
    starts = np.flatnonzero(np.r_[True, codes[1:] != codes[:-1]])
    changes = [(float(t[k] - t[0]), tool.names[codes[k]]) for k in starts if codes[k] >= 0]
    plot = plots.plot_offsets(
        out / "offsets_drift.png",
        t - t[0],
        estimated,
        true,
        constant.D,
        "offsets over the calibration run (demo --drift): the estimated offsets against the simulated sensor's",
        changes,
    )
    error = np.abs(estimated - true).max(axis=0)
    model = calibration.offset_model or {}
    moved = true[-1] - true[0]
    say(f"      offsets: {model.get('model')} model ({', '.join(model.get('columns', []))}), chosen by BIC")
    say(
        "      true drift over the run: " + ", ".join(f"{a} {m:+.3f} {u}" for a, m, u in zip(WRENCH_AXES, moved, WRENCH_UNITS, strict=True))
    )
    say("      largest |estimated - true| offset over the run: " + _axes(error, signed=False))
    say("      constant offsets (the paper's model) on the same data: D - true at the end " + _axes(constant.D - true[-1]))
    return DriftReport(dataclasses.replace(sensor, D=true[-1]), constant, error, plot)


def _axes(values: np.ndarray, signed: bool = True) -> str:
    form = "+.2e" if signed else ".2e"
    return ", ".join(f"{a} {v:{form}} {u}" for a, v, u in zip(WRENCH_AXES, values, WRENCH_UNITS, strict=True))


#: The paper's validation: "the measurement error of the force Fx is less than 10%".
PAPER_ERROR_PERCENT = 10.0

_VALIDATION_JOINTS = ("wrist_1_joint", "wrist_2_joint", "wrist_3_joint")


@dataclass(frozen=True)
class DemoResult:
    """What the demo measured and wrote.

    Attributes:
        calibration: The estimated calibration.
        true_C: The simulated sensor's C. Shape (6, 8).
        true_D: Its offsets (at the end of the run, with drift), [N, N, N, N m, N m, N m]. Shape (6,).
        relative_error: |C estimate - true| / max |true| of its row. Shape (6, 8).
        convergence: (samples used, relative error of C_bar_11) after each step, (K, 2).
        changes: (samples used when it started, configuration) for each configuration.
        validation: Errors over the validation recording (estimate, then true).
        files: Every file written.
        seconds: Wall-clock time per stage [s].
    """

    calibration: Calibration
    true_C: np.ndarray
    true_D: np.ndarray
    relative_error: np.ndarray
    convergence: np.ndarray
    changes: list[tuple[int, str]]
    validation: ValidationResult
    files: list[Path]
    seconds: dict[str, float]


def convergence(
    W: np.ndarray, strain: np.ndarray, true_c11: float, steps: int = 300, time=None, codes=None, n_configurations: int = 1
) -> np.ndarray:
    """Relative error of C_bar_11 as the samples come in (minimum-norm while rank deficient).

    Args:
        W: Known wrenches of the kept samples, in order, shape (n, 6).
        strain: Their strains, shape (n, 8).
        true_c11: The true C_bar_11.
        steps: Number of points of the curve.
        time: Their times [s], shape (n,), for the offset model; None for none.
        codes: Their configuration indices, shape (n,); None for all 0.
        n_configurations: The tool's configurations (one offset column each).

    Returns:
        Shape (K, 2): samples used, relative error.
    """
    est = OnlineEstimator(basis=OffsetBasis(n_configurations, temperature=False))
    edges = np.unique(np.linspace(0, len(W), steps + 1).astype(int))
    out = []
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        part = slice(a, b)
        est.update_batch(W[part], strain[part], None, *(None if v is None else v[part] for v in (time, codes)))
        if est.samples_used >= 2:
            c11 = est.solve(min_norm=True).C_bar[0, 0]
            out.append((b, abs(c11 / true_c11 - 1.0)))
    return np.array(out)


def _validation_motion(kin: Kinematics, checker: CollisionChecker, home: np.ndarray, rate: float, count: int, rng: np.random.Generator):
    """Waypoints of the last three joints around home, collision-free, as one ruckig motion."""
    index = [kin.joint_names.index(j) for j in _VALIDATION_JOINTS]
    stops: list[np.ndarray] = []
    while len(stops) < count:
        candidate = home[index] + rng.uniform(-1.2, 1.2, 3)
        reading = home.copy()
        reading[index] = candidate
        if checker.clearance(reading, "all").distance >= 0.05 and checker.clearance(reading, "home").distance >= 0.02:
            stops.append(candidate)
    time_, q, qd, qdd = sample_motion(kin, home, _VALIDATION_JOINTS, np.array(stops), 0.0, rate)
    clearance = checker.clearance(q[:: max(1, int(rate / 20))], "all")
    return time_, q, qd, qdd, clearance


def _wrench_series(path: Path, kin: Kinematics, tool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Time, static tool wrench and configuration of a recording's samples (thinned to 20,000)."""
    with RecordingReader(path, kin.joint_names, tool.names) as reader:
        samples = SampleBatch.concatenate(list(reader))
    step = max(1, len(samples) // 20_000)
    t, q, k = samples.time[::step], samples.joints[::step], samples.configuration[::step]
    return t, tool_load(kin, tool, q, k).static, k


def run_demo(out: str | Path = "out", seed: int = 0, quick: bool = False, stream: TextIO | None = None, drift: bool = False) -> DemoResult:
    """Run the demo (see the module docstring) and print what it finds.

    Args:
        out: Folder for everything written.
        seed: Seed of the sensor noise and of the validation motion.
        quick: A smaller run (3 levels x 4 stops at 100 Hz) for tests.
        stream: Where to print (standard output by default).
        drift: The sensor's offsets drift (see the module docstring).
    """
    from ..report import plots

    stream = stream or sys.stdout
    out = Path(out)

    def say(text: str = "") -> None:
        print(text, file=stream, flush=True)

    seconds: dict[str, float] = {}
    clock = time.perf_counter()

    def lap(name: str) -> None:
        nonlocal clock
        seconds[name] = time.perf_counter() - clock
        clock = time.perf_counter()

    robot_path = resolve("ur5", "robots")
    kin = Kinematics(load_robot(robot_path))
    tool = load_tool(resolve("paper_tool", "configs"))
    vtool = load_tool(resolve("validation_tool", "configs"))
    sensor_path = resolve("sensor", "configs")
    spec = load_sensor_config(sensor_path)
    sensor = simulated_sensor(spec, sensor_path)
    pipeline = load_pipeline_config(resolve("pipeline", "configs"))
    rate = 100.0 if quick else 500.0
    pattern = SweepPattern(levels=3, stops=4, dwell=0.4) if quick else SweepPattern()
    say(
        f"fts-calib demo: in-situ calibration of the paper's sensor on a simulated UR5 ({'quick' if quick else 'full'} run, "
        f"seed {seed}{'; offsets that drift' if drift else ''}); writing into {out}/"
    )

    say("[1/5] planning the calibration sweeps (ruckig) ...")
    run = plan_trajectories(robot_path, tool, spec, pipeline.filter, sensor.noise_std, pattern, rate)
    if run.problems:
        raise TrajectoryError(f"the demo's plan failed its checks: {run.problems}")
    run = write_run(run, out / "trajectories")
    plan = run.result.plan
    say(
        f"      {len(plan.waypoints)} stops, {plan.duration:.1f} s per configuration at {rate:g} Hz, clearance "
        f"{run.result.clearance.distance:.3f} m, predicted rank {run.excitation.rank}, predicted max stderr "
        f"{100 * run.excitation.max_relative_stderr:.5f} % of row max"
    )
    lap("plan")

    drifting = ", drifting offsets with a temperature channel" if drift else ""
    say(f"[2/5] simulating the calibration recording (moving tool, noise, 24-bit ADC{drifting}) ...")
    trajectories = [plan.trajectory(name) for name in tool.names]
    rng = np.random.default_rng(seed)
    moving = OffsetDrift.typical() if drift else None
    recording = simulate_recording(out / "recordings" / "calibration.csv", kin, tool, trajectories, sensor, rng, drift=moving)
    lap("simulate")

    say("[3/5] calibrating with the quasi-static filter ...")
    collector = KeptCollector()
    result = calibrate_recording(recording, kin, tool, pipeline, on_kept=collector)
    if result.calibration is None:
        raise result.error or FtsCalibError("the demo's calibration failed")  # InsufficientExcitation or PoorFit
    calibration = result.calibration
    cal_path = save_calibration(calibration, out / "calibration.yaml")
    for line in format_counts(result.session):
        say("      " + line.replace("\n", "\n      "))
    say("      " + result.session.fit_check().summary())
    report = None if moving is None else drift_stage(out, kin, tool, recording, calibration, sensor, moving, pipeline, say)
    sensor = sensor if report is None else report.sensor_at_end  # the validation reads the sensor as it is at the end
    lap("calibrate")

    say("[4/5] following the estimate sample by sample (paper Fig. 7) ...")
    times, W, S, codes = collector.arrays()
    curve = convergence(W, S, sensor.C_bar[0, 0], 120 if quick else 300, times, codes, len(tool.names))
    starts = [
        (int(np.nonzero(codes == c)[0][0]), tool.configurations[c].name) for c in range(len(tool.configurations)) if np.any(codes == c)
    ]
    lap("convergence")

    say("[5/5] validating on another motion with another tool ...")
    if vtool.shape is None:  # never: Tool.__post_init__ fills in the default envelope
        raise RuntimeError(f"the demo's validation tool '{vtool.name}' has no shape")
    checker = CollisionChecker(kin, vtool.shape, kin.sweep_joints[0])
    v_time, v_q, v_qd, v_qdd, v_clearance = _validation_motion(
        kin, checker, plan.home, rate, 8 if quick else 16, np.random.default_rng(seed + 1)
    )
    v_recording = simulate_recording(
        out / "recordings" / "validation.csv",
        kin,
        vtool,
        [TrajectoryFile(kin.joint_names, v_time, v_q, v_qd, v_qdd, vtool.names[0])],
        sensor,
        np.random.default_rng(seed + 2),
    )
    true = Calibration(sensor.C_bar, sensor.D, provenance={"method": "simulated sensor's truth (Table 1 of the paper)"})
    validation = validate_recording(v_recording, kin, vtool, [calibration, true], spec.full_scale)
    tables = [load_calibration(resolve(f"paper_table{k}_calibration", "configs")) for k in (1, 2)]
    paper = validate_recording(v_recording, kin, vtool, tables, spec.full_scale).between  # the paper's comparison
    if paper is None:  # never: two calibrations are compared
        raise RuntimeError("the demo's comparison of the paper's two tables gave no result")
    say(
        f"      {v_time[-1]:.1f} s of motion through {8 if quick else 16} waypoints of the wrist, tool "
        f"'{vtool.name}' ({vtool.configurations[0].mass} kg), clearance {v_clearance.distance:.3f} m"
    )
    lap("validate")

    files = list(run.files) + [recording, cal_path, v_recording] + ([] if report is None else [report.plot])
    t, wrench, k = _wrench_series(recording, kin, tool)
    files.append(
        plots.plot_wrench(
            out / "calibration_wrench.png", t, wrench, k, tool.names, "tool wrench on the sensor during the calibration sweeps"
        )
    )
    if calibration.quality is None:  # never: CalibrationSession.solve always measures the fit
        raise RuntimeError("the demo's calibration has no fit quality")
    final_se = calibration.quality.stderr_C_bar[0, 0] / abs(sensor.C_bar[0, 0])
    files.append(
        plots.plot_convergence(
            out / "convergence_c11.png",
            curve[:, 0],
            curve[:, 1],
            starts,
            final_se,
            "online estimate of C̄₁₁ as quasi-static samples come in (paper Fig. 7)",
        )
    )
    files.append(
        plots.plot_validation(
            out / "validation_fx.png",
            validation.time,
            validation.expected[:, 0],
            [m[:, 0] for m in validation.measured],
            ["this calibration", "true C (Table 1)"],
            float(spec.full_scale[0]),
            "validation on another motion with another tool",
        )
    )
    lap("plots")

    inputs = {"the robot file": robot_path, "the tool file": tool.source, "the sensor file": sensor_path, "the pipeline file": "pipeline"}
    content = calibrate_content(result, collector, {"the recording": recording, **inputs, "the calibration": cal_path})
    label = f"{v_recording.name}: another motion, tool '{vtool.name}'"
    content = dataclasses.replace(content, held_out=held_out(validation.errors[0], label))
    with writing(out / "report.html"):
        files.append(write_report(out / "report.html", render_report(content)))
    lap("report")

    rel = np.abs(calibration.C - sensor.C) / np.max(np.abs(sensor.C), axis=1, keepdims=True)
    found = DemoResult(calibration, sensor.C, sensor.D, rel, curve, starts, validation, files, seconds)
    _report(say, found, final_se, paper)
    return found


def _report(say, result: DemoResult, final_se: float, paper: AxisErrors) -> None:
    """Print what the demo found beside the truth and the targets (``final_se``: C_bar_11's final standard error)."""
    calibration, rel, curve, starts = result.calibration, result.relative_error, result.convergence, result.changes
    validation, files, seconds = result.validation, result.files, result.seconds
    say()
    header = [""] + [f"Δ{k + 1}" for k in range(8)]
    say("estimated C (rows Fx Fy Fz in N, Mx My Mz in N·m, per mV/V), true C (Table 1 of the paper) below each row:")
    rows = []
    for i, axis in enumerate(WRENCH_AXES):
        rows.append([axis, *[f"{v:9.4f}" for v in calibration.C[i]]])
        rows.append(["  true", *[f"{v:9.4f}" for v in result.true_C[i]]])
    say(table(header, rows))
    worst = np.unravel_index(np.argmax(rel), rel.shape)
    say(
        f"largest relative coefficient error: {100 * rel.max():.4f} % (C[{WRENCH_AXES[worst[0]]}, Δ{worst[1] + 1}], relative to "
        f"its row's largest coefficient; target <= 0.05 %)"
    )
    say(
        "offset error D - true: "
        + ", ".join(f"{a} {d - t:+.2e} {u}" for a, d, t, u in zip(WRENCH_AXES, calibration.D, result.true_D, WRENCH_UNITS, strict=True))
    )
    marks = ", ".join(f"{name} at sample {start}" for start, name in starts)
    at_change = [curve[np.searchsorted(curve[:, 0], start, side="left") - 1, 1] if start > 0 else float("nan") for start, _ in starts[1:]]
    say(
        f"Fig. 7: configurations {marks}; C̄₁₁ error just before each change "
        f"{', '.join(f'{e:.1e}' for e in at_change)}, at the end {curve[-1, 1]:.1e} (final standard error {final_se:.1e})"
    )
    e, t = validation.errors
    say(
        f"validation over {validation.samples:,} samples of another motion with another tool (error of the measured wrench, "
        "% of full scale: 50 N, 5 N·m):"
    )
    rows = [
        [axis, f"{e.max_abs[i]:.4f} {u}", f"{e.max_percent[i]:.4f} %", f"{e.rms_percent[i]:.4f} %", f"{t.max_percent[i]:.4f} %"]
        for i, (axis, u) in enumerate(zip(WRENCH_AXES, WRENCH_UNITS, strict=True))
    ]
    say(table(["axis", "max error", "max, % FS", "RMS, % FS", "max with true C"], rows, "  "))
    say(
        f"largest validation error {e.max_percent.max():.4f} % of full scale (target <= 0.2 %; the paper: less than "
        f"{PAPER_ERROR_PERCENT:.0f} % on Fx, most of it uncompensated dynamics, which the expected wrench here includes)"
    )
    say(
        "the paper's Table 1 against its Table 2 over the same motion, largest difference per axis in % of full scale: "
        + ", ".join(f"{a} {v:.2f} %" for a, v in zip(WRENCH_AXES, paper.max_percent, strict=True))
    )
    say("wrote:")
    for path in files:
        say(f"  {path}")
    say("time: " + ", ".join(f"{name} {s:.1f} s" for name, s in seconds.items()) + f"; total {sum(seconds.values()):.1f} s")


def run(*, output: str | Path = "out", seed: int = 0, quick: bool = False, drift: bool = False) -> int:
    """Run the demo and print what it finds (``fts-calib demo``); see :func:`run_demo`.

    Args:
        output: Folder for everything written.
        seed: Seed of the sensor noise and of the validation motion.
        quick: A smaller run (3 levels x 4 stops at 100 Hz).
        drift: The sensor's offsets drift during the run, and the calibration models them.

    Returns:
        0.
    """
    with writing(output):
        run_demo(output, seed, quick, drift=drift)
    return ExitCode.OK

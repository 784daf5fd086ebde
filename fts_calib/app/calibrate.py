"""The ``calibrate`` command: calibrate from a recording, with a progress bar and a printed summary, with units."""

from __future__ import annotations

import dataclasses
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TextIO

import numpy as np

from ..core.exceptions import FtsCalibError, PoorFit
from ..core.paths import check_outputs
from ..core.text import table
from ..feeds.bag_log import BagTopics
from ..feeds.source import open_recording, recording_paths
from ..model.budget import wrench_noise
from ..model.calibration import save_calibration
from ..model.prior import describe as describe_prior
from ..model.sensor import WRENCH_AXES, WRENCH_UNITS
from ..pipeline.calibrate import CalibrateResult, calibrate_recording
from ..pipeline.fit import FitCheck
from ..pipeline.latency import LatencyEstimate, estimate_latency
from ..pipeline.session import CalibrationSession
from ..planning.accuracy import KeptSamples, measured_budget
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool
from .exit_codes import ExitCode, writing
from .report import format_budget, format_model_selection, format_offsets
from .setup import load_prior, load_sensor, load_setup


def run(
    *,
    recording: str | Path | Sequence[str | Path],
    robot: str | Path,
    tool: str | Path = "paper_tool",
    pipeline: str | Path = "pipeline",
    output: str | Path = "calibration.yaml",
    use_filter: bool = True,
    checkpoint: str | Path | None = None,
    resume: bool = False,
    restart: bool = False,
    joints_in_degrees: bool = False,
    accept_poor_fit: bool = False,
    quiet: bool = False,
    sensor: str | Path = "sensor",
    joints_topic: str = BagTopics.joints,
    channels_topic: str = BagTopics.channels,
    configuration_topic: str = BagTopics.configuration,
    offsets: str | None = None,
    prior: str | Path | None = None,
    prior_weight: float = 1.0,
    model: str | None = None,
) -> int:
    """Calibrate from a recording, write the calibration and print the summary (``fts-calib calibrate``).

    Args:
        recording: Recording (CSV or CSV.gz): time, joints, strain_1..n, tool; or ROS 2 bags
            (``.mcap``, ``.db3``, bag folders), each optionally ``BAG:CONFIGURATION``.
        robot: Robot definition: a shipped name (e.g. 'ur5') or a YAML path.
        tool: Tool file: a shipped name or a YAML path.
        pipeline: Pipeline settings (filter thresholds).
        output: Calibration file to write.
        use_filter: Keep only the quasi-static samples (False: every valid one, for comparison).
        checkpoint: Checkpoint file, written every few seconds; None for none.
        resume: Continue from ``checkpoint`` (it must be of this recording).
        restart: Start afresh over an existing ``checkpoint``; without it or ``resume``, an
            existing checkpoint is refused (exit 3): its samples are never lost silently.
        joints_in_degrees: The joint columns are in degrees.
        accept_poor_fit: Write the calibration even when its fit check is poor (its quality
            records the verdict).
        quiet: No progress bar.
        sensor: Sensor configuration (shipped name or YAML path): its channel layout, which
            the recording's channels must match.
        joints_topic: A bag's sensor_msgs/msg/JointState topic.
        channels_topic: A bag's std_msgs/msg/Float64MultiArray or geometry_msgs/msg/WrenchStamped topic.
        configuration_topic: A bag's std_msgs/msg/String topic of the tool configuration.
        offsets: The offset model ('auto', 'constant', 'per-configuration', 'drift'); the
            pipeline file's (default auto) when None.
        prior: A calibration to shrink C_bar toward (fts-calib YAML or ATI ``.cal``, of the
            sensor's layout) when the excitation is weak; None for none.
        prior_weight: The prior's weight lambda, relative to the data (:mod:`fts_calib.model.prior`).
        model: The sensor model ('auto', 'linear', 'quadratic', 'cubic'); the sensor file's
            (default auto: chosen with the offset model by held-out error) when None.

    Returns:
        0 with a calibration written, 1 when the data cannot determine C, 15 when the fit
        check refused the calibration (nothing written).
    """
    paths = recording_paths(recording)
    inputs = {
        "the recording": paths[0],
        "the robot file": robot,
        "the tool file": tool,
        "the pipeline file": pipeline,
        "the sensor file": sensor,
        **({"the prior": prior} if prior is not None else {}),
    }
    inputs.update({f"recording {k + 1}": p for k, p in enumerate(paths[1:], 1)})
    check_outputs({"-o": output, "--checkpoint": checkpoint}, inputs)  # before any work: nothing lost, nothing wasted
    kin, loaded, settings = load_setup(robot, tool, pipeline)
    settings = settings.with_offsets(offsets)
    spec = load_sensor(sensor)
    layout = spec.layout
    shrink = load_prior(prior, prior_weight, layout)
    kept = KeptSamples()
    bar = None if quiet else ProgressBar(1, "rows")  # its total is the recording's size, set once it is open
    result = calibrate_recording(
        paths,
        kin,
        loaded,
        settings,
        use_filter=use_filter,
        checkpoint=checkpoint,
        resume=resume,
        restart=restart,
        joints_in_degrees=joints_in_degrees,
        progress=bar,
        accept_poor_fit=accept_poor_fit,
        topics=BagTopics(joints_topic, channels_topic, configuration_topic),
        layout=layout,
        on_kept=kept,
        prior=shrink,
        model=model or spec.model,
        full_channels=spec.full_channels,
        full_scale=spec.full_scale,
    )
    written = None
    if result.calibration is not None:
        topics = BagTopics(joints_topic, channels_topic, configuration_topic)
        latency = recording_latency(paths, kin, loaded, result.calibration, spec.full_scale, topics, joints_in_degrees)
        result = with_budget(result, kin, loaded, kept, spec.full_scale, latency)
    if result.calibration is not None:
        with writing(output):
            written = save_calibration(result.calibration, output)
    print(format_summary(result, " ".join(map(str, paths)), written))
    if result.calibration is not None:
        return ExitCode.OK
    return ExitCode.POOR_FIT if isinstance(result.error, PoorFit) else ExitCode.CHECK_FAILED


#: Rows read again for the latency estimate, at most: 100 s at 1 kHz (a whole sized run of three configurations
#: holds about 60,000) has dozens of moves, enough for a spread of microseconds, and bounds the memory and time
#: of the second read (2 million rows took 1.4 GB and 20 s).
_LATENCY_ROWS = 100_000


def recording_latency(paths, kin: Kinematics, tool: Tool, calibration, full_scale, topics: BagTopics, joints_in_degrees: bool):
    """The latency of the joint stream from the recording's moving samples (read again), or None.

    See :func:`fts_calib.pipeline.latency.estimate_latency`; the first :data:`_LATENCY_ROWS` rows at most.
    """
    parts, rows = [], 0
    with open_recording(paths, kin.joint_names, tool.names, topics=topics, continuous=kin.continuous) as reader:
        for batch in reader:
            joints = np.radians(batch.joints) if joints_in_degrees else batch.joints
            parts.append((batch.time, joints, batch.channels, batch.configuration))
            rows += len(batch)
            if rows >= _LATENCY_ROWS:
                break
    if not parts:
        return None
    time, joints, channels, codes = (np.concatenate(column) for column in zip(*parts, strict=True))
    order = np.argsort(time, kind="stable")
    return estimate_latency(kin, tool, calibration, time[order], joints[order], channels[order], codes[order], full_scale)


def with_budget(
    result: CalibrateResult, kin: Kinematics, tool: Tool, kept: KeptSamples, full_scale, latency: LatencyEstimate | None = None
) -> CalibrateResult:
    """The result with the measured accuracy budget in its calibration's quality.

    Strain noise as the data show it (the filter's noise floor, else the fit's residual
    through C), the tool's tolerance, the robot's encoders, timing and mount
    (:func:`fts_calib.planning.accuracy.measured_budget`), the model error (the held-out
    residual of the chosen model, or the fit's residual, beyond the noise), and the latency of
    the joint stream estimated from the moving samples, when there are any.
    """
    cal = result.calibration
    if cal is None or cal.quality is None or len(kept) != int(result.session.kept.sum()):
        return result  # resumed from a checkpoint: the samples before it are not at hand, no budget from a part
    floor = None if result.session.filter is None else result.session.filter.noise_floor
    # without a noise floor the residual stands for the noise (an upper bound: it holds every random error)
    sigma_w = cal.quality.residual_rms if floor is None else wrench_noise(cal.C, floor)
    selection = cal.model_selection
    chosen = [c for c in selection["candidates"] if c["chosen"]] if selection else []
    residual = np.asarray(chosen[0]["heldout_rms"]) if chosen else cal.quality.residual_rms  # held out when chosen so
    prior_weight = None if cal.quality.prior is None else float(cal.quality.prior["weight"])
    budget = measured_budget(kin, tool, kept, cal, sigma_w, full_scale, residual_rms=residual, prior_weight=prior_weight)
    record = budget.to_dict()
    if latency is not None:
        record["stream_latency_estimate"] = latency.as_dict()
    quality = dataclasses.replace(cal.quality, budget=record)
    return dataclasses.replace(result, calibration=dataclasses.replace(cal, quality=quality), budget=budget, latency=latency)


class ProgressBar:
    """A progress bar on a terminal, or a line every quarter when the output is not one.

    Args:
        total: Units of the whole job (e.g. bytes of the file).
        label: What is counted, e.g. 'rows'.
        stream: Where to print (standard error by default).
    """

    def __init__(self, total: float, label: str = "rows", stream: TextIO | None = None):
        self.total = max(float(total), 1.0)
        self.label = label
        self.stream = stream or sys.stderr
        self.tty = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.start = time.perf_counter()
        self._last = 0.0
        self._quarter = 0

    def update(self, done: float, count: int) -> None:
        """Show ``done`` of ``total`` units, with ``count`` items processed."""
        now = time.perf_counter()
        fraction = min(1.0, done / self.total)
        rate = count / max(now - self.start, 1e-9)
        text = f"[{'#' * int(30 * fraction):<30}] {100 * fraction:5.1f} %  {count:,} {self.label}  {rate / 1000:,.0f}k {self.label}/s"
        if self.tty:
            if now - self._last >= 0.1 or fraction >= 1.0:
                self.stream.write("\r" + text)
                self.stream.flush()
                self._last = now
        elif int(4 * fraction) > self._quarter:
            self._quarter = int(4 * fraction)
            self.stream.write(text + "\n")
            self.stream.flush()

    def close(self) -> None:
        """End the bar's line."""
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()


def format_counts(session: CalibrationSession) -> list[str]:
    """Lines: samples seen and kept, per configuration, and skipped by reason."""
    p = session.progress()
    per = ", ".join(f"{name} {n:,}" for name, n in p.kept_by_configuration.items())
    lines = [f"samples: {p.seen:,} seen, {p.kept:,} kept ({100 * p.kept_fraction:.1f} %): {per}"]
    if p.skipped:
        lines.append("not kept, by reason (a filtered sample can fail several rules):")
        lines.append(table(["reason", "samples"], [[r, f"{n:,}"] for r, n in sorted(p.skipped.items(), key=lambda x: -x[1])], "  "))
    return lines


def format_fit(check: FitCheck) -> list[str]:
    """Lines: the fit verdict, and the residual RMS per configuration and axis beside the expected noise."""
    lines = [check.summary()]
    if check.residual_rms:
        rows = [[name, *[f"{v:.3g}" for v in rms]] for name, rms in check.residual_rms.items()]
        rows.append(["expected", *[f"{v:.3g}" for v in check.expected]])
        units = [f"{a} [{u}]" for a, u in zip(WRENCH_AXES, WRENCH_UNITS, strict=True)]
        lines.append("residual RMS per configuration, and the noise the data show (through C):")
        lines.append(table(["", *units], rows, "  "))
    return lines


def _unusable(session: CalibrationSession) -> str | None:
    """Why no sample reached the filter when every row was skipped by the checks, or None.

    "Hold the arm still" would send the user to the robot for a file whose every row is
    malformed (a text in the temperature column, a NaN strain).
    """
    p = session.progress()
    checks = {reason: n for reason, n in p.skipped.items() if not reason.startswith("filter:")}
    if p.kept or not p.seen or sum(checks.values()) < p.seen:
        return None
    counts = ", ".join(f"{reason}: {n:,}" for reason, n in sorted(checks.items(), key=lambda x: -x[1]))
    return f"no usable sample: every row was skipped before the filter ({counts}); the notes above name the first"


def format_summary(result: CalibrateResult, recording: str | Path, output: Path | None) -> str:
    """The printed summary of the ``calibrate`` job, with units."""
    rate = result.rows / max(result.seconds, 1e-9)
    lines = [f"recording {recording}: {result.rows:,} rows in {result.seconds:.2f} s ({rate / 1000:,.0f}k rows/s)"]
    lines += format_counts(result.session)
    for problem in result.problems:
        lines.append(f"  note: {problem}")
    if isinstance(result.error, PoorFit):
        lines += format_fit(result.error.check)
    if result.calibration is None:
        if isinstance(result.error, PoorFit):
            lines.append("NO CALIBRATION written: the fit is poor (above); fix the cause, or accept it knowingly with --accept-poor-fit")
        else:
            lines.append(f"NO CALIBRATION: {_unusable(result.session) or result.error}")
        return "\n".join(lines)
    cal, q = result.calibration, result.calibration.quality
    if q is None:  # CalibrationSession.solve always measures the fit
        raise FtsCalibError("internal error: the calibration has no fit quality")
    lines.append(f"rank {q.rank} of {q.full_rank}, condition number {q.condition_number:.1f} (S_XX scaled to a unit diagonal)")
    if q.prior is not None:
        lines.append(describe_prior(dict(q.prior)))
    lines += format_model_selection(cal.model_selection, cal.quality)
    lines += format_offsets(cal.offset_model)
    if q.fit is not None and not isinstance(result.error, PoorFit):
        lines += format_fit(result.session.fit_check())
    rms = zip(WRENCH_AXES, q.residual_rms, WRENCH_UNITS, strict=True)
    lines.append("residual RMS: " + ", ".join(f"{a} {v:.3g} {u}" for a, v, u in rms))
    rel = 100 * q.relative_stderr_C(cal.C)
    lines.append("C (N or N·m per strain unit) ± standard error (% of its row's largest coefficient):")
    n = cal.layout.n_channels
    rows = [[axis, *[f"{cal.C[i, k]:9.4f} ±{rel[i, k]:.4f}%" for k in range(n)]] for i, axis in enumerate(WRENCH_AXES)]
    lines.append(table(["", *[f"Δ{k + 1}" for k in range(n)]], rows, "  "))
    lines.append(
        "D: " + ", ".join(f"{a} {d:+.5f} ± {s:.1g} {u}" for a, d, s, u in zip(WRENCH_AXES, cal.D, q.stderr_D, WRENCH_UNITS, strict=True))
    )
    if result.budget is not None:
        lines += format_budget(result.budget, "measured")
        if cal.model is not None:
            lines.append(
                f"  note: the budget is propagated through the {cal.family} model linearised at the centre of the data; "
                "its model error term holds the held-out residual beyond the noise"
            )
        elif q.full_rank != 7:
            lines.append(
                f"  note: the budget is propagated through a least squares with one constant offset; this calibration's "
                f"offset model has {q.full_rank - 6} offset columns, so the figures above are an approximation"
            )
    else:
        lines.append("accuracy budget: not measured (resumed from a checkpoint: the samples before it are not at hand; --restart for it)")
    if result.latency is not None:
        lines.append("stream latency: " + result.latency.summary())
        bound = result.session.kin.robot.accuracy.latency_s
        if abs(result.latency.latency_s) > bound:
            lines.append(
                f"  note: beyond the ±{1e3 * bound:g} ms the budget assumes (robot file accuracy.latency_s): add "
                f"{result.latency.latency_s:+.4f} s to live.latency_s of the pipeline file, or widen accuracy.latency_s"
            )
    if output is not None:
        lines.append(f"wrote {output}")
    return "\n".join(lines)

"""The ``calibrate`` command: calibrate from a recording, with a progress bar and a printed summary, with units."""

from __future__ import annotations

import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TextIO

from ..core.exceptions import FtsCalibError, PoorFit
from ..core.files import check_outputs
from ..core.tables import table
from ..filters.dynamic import DynamicFilter, nominal_c
from ..model.calibration import save_calibration
from ..model.channels import WRENCH_AXES, WRENCH_UNITS
from ..model.prior import describe as describe_prior
from ..report.content import KeptCollector, calibrate_content
from ..report.html import render_report, write_report
from ..session.calibration_run import CalibrateResult, calibrate_recording
from ..session.fit import MAX_RATIO, FitCheck
from ..session.session import CalibrationSession
from ..sources.bag import BagTopics
from ..sources.recording_set import describe_files
from ..sources.source import recording_paths
from ..sources.synchronizer import AFTER_JOINTS, BEFORE_JOINTS, JOINT_GAP
from .exit_codes import ExitCode, writing
from .report import format_budget, format_model_selection, format_offsets
from .setup import load_prior, load_sensor, load_setup


def run(
    *,
    recording: str | Path | Sequence[str | Path],
    robot: str | Path | None = None,
    tool: str | Path,
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
    joint_stamps: str = BagTopics.joint_stamps,
    pose_topic: str = BagTopics.pose,
    offsets: str | None = None,
    prior: str | Path | None = None,
    prior_weight: float = 1.0,
    model: str | None = None,
    report: str | Path | None = None,
    mount_rpy: Sequence[float] | None = None,
    filter_mode: str | None = None,
) -> int:
    """Calibrate from a recording, write the calibration and print the summary (``fts-calib calibrate``).

    Args:
        recording: Recording (CSV or CSV.gz): time, joints, strain_1..n, tool; or ROS 2 bags
            (``.mcap``, ``.db3``, bag folders), each optionally ``BAG:CONFIGURATION``.
        robot: Robot definition: a shipped name (e.g. 'ur5') or a YAML path; None for a
            recording that gives the sensor's orientation (:mod:`fts_calib.robot.orientation`).
        mount_rpy: Without ``robot``: roll, pitch, yaw [rad] from the frame the recording's
            orientation gives to the sensor; None for none.
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
        joint_stamps: A bag's joint times: 'header' (their header stamps) or 'log' (the bag's log time).
        pose_topic: Without ``robot``: a bag's geometry_msgs/msg/PoseStamped topic of the sensor's orientation.
        offsets: The offset model ('auto', 'constant', 'per-configuration', 'drift'); the
            pipeline file's (default auto) when None.
        prior: A calibration to shrink C_bar toward (fts-calib YAML or ATI ``.cal``, of the
            sensor's layout) when the excitation is weak; None for none.
        prior_weight: The prior's weight lambda, relative to the data (:mod:`fts_calib.model.prior`).
        model: The sensor model ('auto', 'linear', 'quadratic', 'cubic'); the sensor file's
            (default auto: chosen with the offset model by held-out error) when None.
        filter_mode: The sample filter's mode ('quasi-static', 'dynamic':
            :mod:`fts_calib.filters.dynamic`); the pipeline file's (default quasi-static) when None.
        report: HTML report to write (:mod:`fts_calib.report.html`), also when the
            calibration is refused (its diagnosis first); None for none.

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
    check_outputs({"-o": output, "--checkpoint": checkpoint, "--report": report}, inputs)  # before any work: nothing lost, nothing wasted
    kin, loaded, settings = load_setup(robot, tool, pipeline, mount_rpy)
    spec = load_sensor(sensor)
    settings = settings.with_offsets(offsets).with_filter_mode(filter_mode).with_nominal_c(nominal_c(spec))
    layout = spec.layout
    shrink = load_prior(prior, prior_weight, layout)
    bar = None if quiet else ProgressBar(1, "rows")  # its total is the recording's size, set once it is open
    collector = None if report is None else KeptCollector()
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
        topics=BagTopics(joints_topic, channels_topic, configuration_topic, joint_stamps, pose_topic),
        layout=layout,
        prior=shrink,
        full_scale=spec.full_scale,
        limits=spec.limits,
        model=model or spec.model,
        full_channels=spec.full_channels,
        on_kept=collector,
    )
    written = None
    if result.calibration is not None:
        with writing(output):
            written = save_calibration(result.calibration, output)
    print(format_summary(result, describe_files(paths), written))
    if report is not None:
        diagnosis = "" if result.calibration is not None else refusal(result)
        content = calibrate_content(result, collector, {**inputs, "the calibration (-o)": written}, diagnosis)
        with writing(report):
            print(f"wrote {write_report(report, render_report(content))}")
    if result.calibration is not None:
        return ExitCode.OK
    return ExitCode.POOR_FIT if isinstance(result.error, PoorFit) else ExitCode.EXCITATION


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
    lines += [f"  {line}" for line in ([] if session.checks.rails is None else session.checks.rails.lines(session.tool.names))]
    return lines


def format_fit(check: FitCheck) -> list[str]:
    """Lines: the fit verdict, and the residual RMS per configuration and axis beside the expected residual and its parts."""
    lines = [check.summary()]
    if check.residual_rms:
        rows = [[name, *[f"{v:.3g}" for v in rms]] for name, rms in check.residual_rms.items()]
        rows.append(["expected", *[f"{v:.3g}" for v in check.expected]])
        heading = "residual RMS per configuration, and the noise the data show (through C):"
        if check.noise is not None and check.tolerance is not None and max(check.tolerance) > 0:
            rows += [["  noise", *[f"{v:.3g}" for v in check.noise]], ["  tolerances", *[f"{v:.3g}" for v in check.tolerance]]]
        if check.floor is not None and any(MAX_RATIO * e <= f * (1.0 + 1e-9) for e, f in zip(check.expected, check.floor, strict=True)):
            floor = [f"{v / MAX_RATIO:.3g}" for v in check.floor]  # the least expected: a residual below fit.floor never refuses
            rows.append([f"  fit.floor/{MAX_RATIO:g}", *floor])
            heading = "residual RMS per configuration, and the expected: the noise (through C) and the declared tolerances, in quadrature:"
        units = [f"{a} [{u}]" for a, u in zip(WRENCH_AXES, WRENCH_UNITS, strict=True)]
        lines.append(heading)
        lines.append(table(["", *units], rows, "  "))
    return lines


def _unusable(session: CalibrationSession, problems: list[str]) -> str | None:
    """Why no sample reached the filter when every row was skipped by the checks, or None.

    "Hold the arm still" would send the user to the robot for a file whose every row is
    malformed (a text in the temperature column, a NaN strain). When the joint and channel
    streams did not overlap (every channel sample before, after or between joint readings
    too far apart), that is the cause, said in words; notes are referred to only when printed.
    """
    p = session.progress()
    checks = {reason: n for reason, n in p.skipped.items() if not reason.startswith("filter:")}
    if p.kept or not p.seen or sum(checks.values()) < p.seen:
        return None
    counts = ", ".join(f"{reason}: {n:,}" for reason, n in sorted(checks.items(), key=lambda x: -x[1]))
    text = f"no usable sample: every row was skipped before the filter ({counts})"
    if max(checks, key=lambda reason: checks[reason]) in (BEFORE_JOINTS, AFTER_JOINTS, JOINT_GAP):
        return (
            f"{text}: no channel sample falls between two joint readings, so the two streams' stamps are on different "
            "clocks or do not overlap in time (a bag: read the joints at its log time with --joint-stamps log)"
        )
    return f"{text}; the notes above name the first" if problems else text


def refusal(result: CalibrateResult) -> str:
    """Why a run wrote no calibration, in one sentence (its fit diagnosis, or what the data cannot determine)."""
    if isinstance(result.error, PoorFit):
        return result.error.check.summary()
    return f"{_unusable(result.session, result.problems) or result.error}"


def format_summary(result: CalibrateResult, recording: str | Path, output: Path | None) -> str:
    """The printed summary of the ``calibrate`` job, with units."""
    rate = result.rows / max(result.seconds, 1e-9)
    lines = [f"recording {recording}: {result.rows:,} rows in {result.seconds:.2f} s ({rate / 1000:,.0f}k rows/s)"]
    lines += format_counts(result.session)
    if result.detected:
        lines.append(f"detected in the data, not declared in the sensor file: {', '.join(result.detected)}; calibrated again with it")
    for problem in result.problems:
        lines.append(f"  note: {problem}")
    if isinstance(result.error, PoorFit):
        lines += format_fit(result.error.check)
    if result.calibration is None:
        if isinstance(result.error, PoorFit):
            lines.append("NO CALIBRATION written: the fit is poor (above); fix the cause, or accept it knowingly with --accept-poor-fit")
        else:
            lines.append(f"NO CALIBRATION: {refusal(result)}")
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
    dynamic = result.session.filter
    if isinstance(dynamic, DynamicFilter):  # what the dynamic filter applied: the latency it fitted with the calibration
        lines.append(
            f"dynamic filter: joint readings taken as {1e3 * dynamic.latency_s:.3f} ms late (filter.latency_s, or fitted when auto)"
        )
    if output is not None:
        lines.append(f"wrote {output}")
    return "\n".join(lines)

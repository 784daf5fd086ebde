"""The ``calibrate`` command: calibrate from a recording (a progress bar) or a live feed (a status line); the summary, with units."""

from __future__ import annotations

import contextlib
import dataclasses
import sys
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any, TextIO

from ..core.exceptions import ConfigError, FeedTimeout, FtsCalibError, InsufficientExcitation, PoorFit, UnknownToolConfiguration
from ..core.files import check_outputs
from ..core.tables import table
from ..filters.dynamic import DynamicFilter, nominal_c
from ..filters.settings import AUTO_FILTER
from ..model.calibration import save_calibration
from ..model.channels import WRENCH_AXES, WRENCH_UNITS
from ..model.prior import describe as describe_prior
from ..report.content import KeptCollector, calibrate_content, check_target, with_target
from ..report.html import render_report, write_report
from ..session.calibration_run import CalibrateResult, LiveRunner, calibrate_recording, format_stats
from ..session.checkpoint import check_start, live_source
from ..session.fit import MAX_RATIO, FitCheck
from ..session.plan_progress import load_plan_progress
from ..session.session import CalibrationSession
from ..sources.live_feed import LiveFeed, StreamEnd, stop_signals
from ..sources.recording_set import describe_files
from ..sources.source import live_address, open_source
from ..sources.synchronizer import AFTER_JOINTS, BEFORE_JOINTS, JOINT_GAP
from ..sources.udp import listen_host
from ..sources.ur import RtdePoller
from .exit_codes import ExitCode, using_udp, writing
from .report import format_budget, format_model_selection, format_offsets
from .setup import OutputOptions, Setup, SourceOptions, channel_device

#: What ``--joint-unit`` says of the joint columns: degrees, rad, or None: decided from the data.
JOINTS_IN_DEGREES = {"deg": True, "rad": False, "auto": None}
#: The calibration file written when -o is not given.
DEFAULT_OUTPUT = "calibration.yaml"


def run(
    setup: Setup,
    source: SourceOptions,
    outputs: OutputOptions | None = None,
    *,
    accept_poor_fit: bool = False,
    plan: str | Path | None = None,
    target_error_percent: float | None = None,
) -> int:
    """Calibrate from a recording or a live feed, write the calibration and print the summary (``fts-calib calibrate``).

    Args:
        setup: The robot, the calibration tool (required), the sensor file (its channel layout,
            which the data's channels must match; its model and full scale) and the pipeline
            settings, with the filter, the models and a prior (:class:`~fts_calib.app.setup.Setup`).
        source: The recording (CSV or CSV.gz: time, joints, strain_1..n, tool; or ROS 2 bags,
            each optionally ``BAG:CONFIGURATION``), or a live feed: ``udp://HOST:PORT`` and/or
            ``ur://HOST`` (:mod:`fts_calib.sources.source`), with a bag's topics and a live
            feed's timeouts.
        outputs: The calibration file (``calibration.yaml`` when None), an HTML report (also
            when the calibration is refused: its diagnosis first), the checkpoint (a live
            run's: ``OUTPUT.checkpoint.json`` when None), ``resume``/``restart`` (an existing
            checkpoint is refused without one: its samples are never lost silently) and
            ``quiet`` (no progress bar or status line).
        accept_poor_fit: Write the calibration even when its fit check is poor (its quality
            records the verdict).
        plan: A live feed: ``plan.yaml`` of the sized trajectories being run (the status line
            then shows the motion left and the configuration to mount next).
        target_error_percent: The accuracy target the plan was sized to, in [%] of full scale:
            recorded in the file's budget, the target its report (and ``validate --report``,
            ``report``) judges the budget against; 0.05 when None.

    Returns:
        0 with a calibration written, 8 when the data cannot determine C (1: a live run that
        received nothing, no checkpoint kept), 15 when the fit check refused the calibration
        (nothing written; a live run keeps its checkpoint), 18 when a UR controller does not
        answer within ``source.ur_timeout_s``.
    """
    outputs = outputs or OutputOptions()
    if setup.tool_file is None:
        raise ConfigError("tool", None, "the calibration tool mounted", message="calibrate needs the tool mounted: give --tool")
    target = check_target(target_error_percent)
    if source.live:
        return _calibrate_live(setup, source, outputs, accept_poor_fit, plan, target)
    if plan is not None:
        raise ConfigError("plan", str(plan), "a live source", message="--plan shows the motion left of a live run: give udp:// or ur://")
    output = outputs.output or DEFAULT_OUTPUT
    paths = source.paths()
    inputs = {"the recording": paths[0], **setup.inputs()}
    inputs.update({f"recording {k + 1}": p for k, p in enumerate(paths[1:], 1)})
    report, checkpoint = outputs.report, outputs.checkpoint
    check_outputs({"-o": output, "--checkpoint": checkpoint, "--report": report}, inputs)  # before any work: nothing lost, nothing wasted
    spec = setup.sensor
    settings = setup.settings.with_nominal_c(nominal_c(spec)).with_repeatability(spec.repeatability)
    bar = None if outputs.quiet else ProgressBar(1, "rows")  # its total is the recording's size, set once it is open
    collector = None if report is None else KeptCollector()
    result = calibrate_recording(
        paths,
        setup.kinematics,
        setup.tool,
        settings,
        use_filter=setup.use_filter,
        checkpoint=checkpoint,
        resume=outputs.resume,
        restart=outputs.restart,
        joints_in_degrees=JOINTS_IN_DEGREES[source.joint_unit],
        progress=bar,
        accept_poor_fit=accept_poor_fit,
        topics=source.topics,
        layout=spec.layout,
        prior=setup.prior,
        full_scale=spec.full_scale,
        limits=spec.limits,
        model=setup.sensor_model,
        full_channels=spec.full_channels,
        on_kept=collector,
    )
    written = None
    if result.calibration is not None:
        calibration = with_target(result.calibration, target)
        result = dataclasses.replace(result, calibration=calibration)
        with writing(output):
            written = save_calibration(calibration, output)
    print(format_verdict(result, written) if outputs.quiet else format_summary(result, describe_files(paths), written))
    if report is not None:
        diagnosis = "" if result.calibration is not None else refusal(result)
        content = calibrate_content(result, collector, {**inputs, "the calibration (-o)": written}, diagnosis)
        with writing(report):
            print(f"wrote {write_report(report, render_report(content))}")
    if result.calibration is not None:
        return ExitCode.OK
    return ExitCode.POOR_FIT if isinstance(result.error, PoorFit) else ExitCode.EXCITATION


#: Size of a recording [bytes] from which a progress bar writes a line per quarter when its output is not a terminal
#: (a log of a run of minutes; 50 MB is about 200,000 rows): a shorter file shows none.
LOG_BYTES = 50e6


class ProgressBar:
    """A progress bar on a terminal, or a line every quarter of a file of :data:`LOG_BYTES` or more when the output is not one.

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
        elif self.total >= LOG_BYTES and int(4 * fraction) > self._quarter:
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


#: What the dynamic filter's per-configuration residuals are, beside the overall residual RMS (docs/method.md, fit check).
WEIGHTED_RESIDUALS = (
    "  (dynamic filter: each configuration's residual weights a sample 1/(1 + ρ²) by its trust rule and is scaled by "
    "√(Σw/n), so that it shows the strain noise alone; below the overall residual RMS, which weights every kept sample "
    "alike, by as much as the rule overstates the expected wrench's errors)"
)


def format_fit(check: FitCheck, weighted: bool = False) -> list[str]:
    """Lines: the fit verdict, and the residual RMS per configuration and axis beside the expected residual and its parts.

    ``weighted``: the check is the dynamic filter's (weighted residuals): a line says how they differ from the overall RMS.
    """
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
        if weighted:
            lines.append(WEIGHTED_RESIDUALS)
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


def format_verdict(result: CalibrateResult, output: Path | None) -> str:
    """What ``calibrate --quiet`` prints: the verdict (the fit check, or why nothing was written) and the file written."""
    if result.calibration is None:
        if isinstance(result.error, PoorFit):
            return f"{result.error.check.summary()}\nNO CALIBRATION written: the fit is poor; --accept-poor-fit writes it with the verdict"
        return f"NO CALIBRATION: {refusal(result)}"
    q = result.calibration.quality
    verdict = result.session.fit_check().summary() if q is not None and q.fit is not None else "fit unchecked"
    budget = "" if result.budget is None else f"; largest error {result.budget.largest_percent:.4f} % of full scale"
    return f"{verdict}{budget}\nwrote {output}"


def format_summary(result: CalibrateResult, recording: str | Path, output: Path | None) -> str:
    """The printed summary of the ``calibrate`` job, with units."""
    rate = result.rows / max(result.seconds, 1e-9)
    lines = [f"recording {recording}: {result.rows:,} rows in {result.seconds:.2f} s ({rate / 1000:,.0f}k rows/s)"]
    lines += list(result.decided)
    lines += format_counts(result.session)
    if result.detected:
        lines.append(f"detected in the data, not declared in the sensor file: {', '.join(result.detected)}; calibrated again with it")
    for problem in result.problems:
        lines.append(f"  note: {problem}")
    if isinstance(result.error, PoorFit):
        lines += format_fit(result.error.check, isinstance(result.session.filter, DynamicFilter))
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
    weighted = isinstance(result.session.filter, DynamicFilter)
    if q.fit is not None and not isinstance(result.error, PoorFit):
        lines += format_fit(result.session.fit_check(), weighted)
    rms = zip(WRENCH_AXES, q.residual_rms, WRENCH_UNITS, strict=True)
    every = " (every kept sample alike)" if weighted else ""
    lines.append(f"residual RMS{every}: " + ", ".join(f"{a} {v:.3g} {u}" for a, v, u in rms))
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


# --- a live feed ------------------------------------------------------------------------------------------------------

#: Signals that end a live run like Ctrl-C: checkpoint and calibration written (SIGHUP: the terminal closed).
LIVE_SIGNALS = stop_signals(("SIGINT", "SIGTERM", "SIGHUP"))


def _calibrate_live(
    setup: Setup, source: SourceOptions, outputs: OutputOptions, accept_poor_fit: bool, plan: str | Path | None, target: float | None = None
) -> int:
    """Calibrate from a live feed until its 'end' message, Ctrl-C, SIGTERM, SIGHUP or the idle timeout (see :func:`run`).

    The feed is :func:`fts_calib.sources.source.open_source`'s (``udp://``: the live protocol's
    datagrams; ``ur://``: a UR controller's joints through RTDE, with the strain datagrams of
    ``udp://`` or its built-in sensor's wrench), run by :class:`~fts_calib.session.calibration_run.LiveRunner`
    with a status line and checkpoints; then the calibration is written.
    """
    output = outputs.output or DEFAULT_OUTPUT
    checkpoint = Path(outputs.checkpoint or f"{output}.checkpoint.json")
    report, resume = outputs.report, outputs.resume
    ending = StreamEnd(idle_timeout_s=source.idle_timeout_s, signals=LIVE_SIGNALS)  # before any work: a wrong timeout wastes nothing
    live = source.live
    udp, ur = live.get("udp"), live.get("ur")
    device = channel_device(live, "calibrate")
    host, port = live_address(udp) if udp is not None else ("", 0)
    if udp is not None:
        host = listen_host(host, source.listen_any, port)  # before any work: a refused address wastes nothing
    inputs = {key: value for key, value in setup.inputs().items() if key != "the prior"}
    check_outputs({"-o": output, "--checkpoint": checkpoint, "--report": report}, inputs)  # before any work: nothing lost, nothing wasted
    check_start(checkpoint, resume, outputs.restart)
    if ur is not None and setup.robot_file is None:
        raise ConfigError("robot", None, "a robot definition", message=f"{ur} reads a UR's joints: give its robot definition with --robot")
    kin, loaded, spec = setup.kinematics, setup.tool, setup.sensor
    settings = setup.settings.with_nominal_c(nominal_c(spec)).with_limits(spec.limits).with_repeatability(spec.repeatability)
    layout, shrink = spec.layout, setup.prior
    expected = None if plan is None else load_plan_progress(plan, spec.rate_hz)
    if expected is not None and expected.robot is not None and expected.robot != kin.robot.name:
        message = f"--plan {plan} is a plan of the robot '{expected.robot}' but --robot is '{kin.robot.name}': give the plan of this robot"
        raise ConfigError("plan", str(plan), f"a plan of '{kin.robot.name}'", message=message)
    if expected is not None and set(expected.expected) != set(loaded.names):
        raise ConfigError("plan", sorted(expected.expected), f"the tool's configurations {loaded.names}", owner=str(plan))
    configuration = setup.configuration
    if configuration is not None and configuration not in loaded.names:
        raise UnknownToolConfiguration(configuration, loaded.names)
    ur_wrench = ur is not None and device is None and (source.ur_wrench or udp is None)  # ur:// alone: its built-in sensor's
    if source.ur_wrench and ur is None:
        raise ConfigError("ur_wrench", True, "", message="--ur-wrench reads a UR's built-in sensor: give the arm as the source ur://HOST")
    if ur_wrench and layout.n_channels != 6:
        alone = "" if source.ur_wrench else f" ({ur} without udp://HOST:PORT for strain datagrams)"
        message = (
            f"the channels are the UR's built-in 6-axis wrench{alone}: the sensor file '{setup.sensor_file}' has "
            f"{layout.n_channels} channels (e.g. --sensor factory_sensor)"
        )
        raise ConfigError("ur_wrench", True, "", message=message)
    described = f"live udp://{host}:{port}" if udp is not None else f"live {ur}"
    record = live_source(host, port) if udp is not None else {"kind": "live", "listen": ur}
    if device is not None:
        described = f"live {device} with {udp or ur}"
        record = {"kind": "live", "listen": f"{device} {udp or ur}"}
    models: dict[str, Any] = {"model": setup.sensor_model, "full_channels": spec.full_channels, "full_scale": spec.full_scale}
    collector = None if report is None or resume else KeptCollector()
    if resume:
        session = CalibrationSession.resume(
            checkpoint, kin, loaded, settings, source=described, source_record=record, layout=layout, **models
        )
        print(f"resumed from {checkpoint}: {session.progress().kept:,} samples kept so far", flush=True)
    else:
        session = CalibrationSession(
            kin, loaded, settings, checkpoint=checkpoint, source=described, source_record=record, layout=layout, **models, on_kept=collector
        )
    arm = None if ur is None else ur.split("://", 1)[1].rstrip("/")
    if arm is not None:
        print(f"connecting to the UR at {arm} (RTDE, waiting at most {source.ur_timeout_s:g} s)", flush=True)

    def listening(address: tuple[str, int]) -> None:
        print(
            f"listening on udp://{address[0]}:{address[1]} for {kin.robot.name} with '{loaded.name}'; "
            "Ctrl-C or an 'end' message writes the calibration",
            flush=True,
        )

    with using_udp(host, port) if udp is not None and ur is None else contextlib.nullcontext():
        feed = open_source(
            device or ur or udp or "",
            kin.joint_names,
            loaded.names,
            continuous=kin.continuous,
            max_gap_s=settings.live.max_gap_s,
            latency_s=settings.live.latency_s,
            n_channels=layout.n_channels,
            configuration=configuration,
            listen_any=source.listen_any,
            udp=udp if ur is not None and device is None else None,
            ur_wrench=ur_wrench,
            ur_timeout_s=source.ur_timeout_s,
            end=ending,
            on_listening=listening,
            joints=None if device is None else ur or udp,
        )
    if not isinstance(feed, LiveFeed):  # open_source opens a live feed for a live name: never
        raise FtsCalibError(f"internal error: {ur or udp} did not open a live feed")
    rtde = feed.rtde
    if rtde is not None:
        what = (
            "joints and the built-in sensor's wrench" if ur_wrench else "joints (strains: datagrams stamped with this host's time.time())"
        )
        print(f"reading the {what} of the UR at {arm} through RTDE", flush=True)
        if udp is None:
            print(f"no datagrams: Ctrl-C writes the calibration ({kin.robot.name} with '{loaded.name}')", flush=True)
    runner = LiveRunner(session, feed, status=None if outputs.quiet else sys.stderr, plan=expected)
    stats = runner.run()
    if rtde is not None and rtde.samples == 0 and isinstance(rtde.error, FeedTimeout):
        if not resume:  # a checkpoint of nothing would only stand in the way of the next run
            checkpoint.unlink(missing_ok=True)
        raise rtde.error
    drained = 0 if rtde is None else rtde.samples - rtde.dropped  # the RTDE samples among the joint (and strain) counts
    print(format_stats(stats, feed.sync, drained, rtde is not None and rtde.wrench))
    if rtde is not None:
        print(format_rtde(rtde))
    if runner.rebase_note is not None:
        print(runner.rebase_note)
    if setup.use_filter and settings.filter.mode == AUTO_FILTER:
        print("filter: quasi-static (--filter auto: a live feed is read once: its still samples; --filter dynamic for no stops)")
    print("\n".join(format_counts(session)))
    found = None if session.filter is None else session.checks.detected_limits(session.filter.grid.resolution)
    if found is not None:  # a live stream cannot be read again without them
        print(
            f"  note: {', '.join(found.detected)} (detected in the data): its samples went into the calibration; "
            "declare the channels' range in the sensor file (range, adc_bits) to refuse them"
        )
    try:
        calibration = session.solve(accept_poor_fit=accept_poor_fit, prior=shrink)
    except InsufficientExcitation as exc:
        if session.seen == 0 and not resume:  # a checkpoint of nothing would only stand in the way of the next run
            checkpoint.unlink(missing_ok=True)
            print(f"NO CALIBRATION: {exc}; no checkpoint kept (it would hold nothing): check the address the feeds send to")
            return ExitCode.CHECK_FAILED
        print(f"NO CALIBRATION: {exc}\ncheckpoint kept in {checkpoint}: run again with --resume to continue")
        _live_report(report, session, collector, None, exc, f"{exc}", inputs)
        return ExitCode.EXCITATION
    except PoorFit as exc:
        _live_report(report, session, collector, None, exc, exc.check.summary(), inputs)
        print("\n".join(format_fit(exc.check)))
        print(f"NO CALIBRATION written: the fit is poor (above); checkpoint kept in {checkpoint}")
        print("fix the cause, or run again with --resume --accept-poor-fit to write it with the verdict")
        return ExitCode.POOR_FIT
    print(session.fit_check().summary())
    calibration = with_target(calibration, target)
    with writing(output):
        path = save_calibration(calibration, output)
    quality = calibration.quality
    if quality is None:  # CalibrationSession.solve always measures the fit
        raise FtsCalibError("internal error: the calibration has no fit quality")
    if quality.prior is not None:
        print(describe_prior(dict(quality.prior)))
    print(f"rank {quality.rank} of {quality.full_rank}, condition number {quality.condition_number:.1f}; wrote {path}")
    _live_report(report, session, collector, calibration, None, "", {**inputs, "the calibration (-o)": path})
    return ExitCode.OK


def _live_report(report, session, collector, calibration, error, diagnosis: str, files) -> None:
    """Write a live run's HTML report when one was asked for (``--report``)."""
    if report is None:
        return
    content = calibrate_content(SimpleNamespace(calibration=calibration, session=session, error=error), collector, files, diagnosis)
    with writing(report):
        print(f"wrote {write_report(report, render_report(content))}")


def format_rtde(rtde: RtdePoller) -> str:
    """What was read through RTDE, on one line: samples, clock offset, losses, and why it stopped."""
    text = f"RTDE: {rtde.samples:,} controller samples"
    if rtde.host_clock is not None and rtde.samples:
        text += f", controller clock + {rtde.offset_s:.6f} s = this host's clock"
    if rtde.dropped:
        text += f", {rtde.dropped:,} dropped (read faster than paired)"
    if rtde.ignored:
        text += f", {rtde.ignored:,} datagrams ignored (RTDE gives their data)"
    if rtde.malformed:
        text += f", {rtde.malformed:,} skipped (not {len(rtde.joint_names)} joint angles)"
    if rtde.error is not None:
        text += f"; the connection was lost: {rtde.error}"
    return text

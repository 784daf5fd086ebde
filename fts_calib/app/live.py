"""The ``live`` command: calibrate from live UDP feeds of joints and strains (docs/formats.md), or a UR arm through RTDE."""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..core.exceptions import ConfigError, FeedTimeout, FtsCalibError, InsufficientExcitation, PoorFit, UnknownToolConfiguration
from ..core.files import check_outputs
from ..filters.dynamic import nominal_c
from ..model.calibration import save_calibration
from ..model.prior import describe as describe_prior
from ..report.content import KeptCollector
from ..session.calibration_run import LiveRunner, format_stats
from ..session.checkpoint import check_start, live_source
from ..session.plan_progress import load_plan_progress
from ..session.session import CalibrationSession
from ..sources.live_feed import LiveFeed, StreamEnd, stop_signals
from ..sources.synchronizer import Synchronizer
from ..sources.udp import UdpReceiver, listen_host
from ..sources.ur import TIMEOUT_S, RtdePoller, connect_ur
from .calibrate import format_counts, format_fit
from .exit_codes import ExitCode, using_udp, writing
from .setup import load_prior, load_sensor, load_setup

#: Signals that end a ``live`` run like Ctrl-C: checkpoint and calibration written (SIGHUP: the terminal closed).
LIVE_SIGNALS = stop_signals(("SIGINT", "SIGTERM", "SIGHUP"))


def run(
    *,
    robot: str | Path | None = None,
    tool: str | Path,
    pipeline: str | Path = "pipeline",
    listen: tuple[str, int] = ("127.0.0.1", 5005),
    output: str | Path = "calibration.yaml",
    checkpoint: str | Path | None = None,
    resume: bool = False,
    restart: bool = False,
    latency_s: float | None = None,
    max_gap_s: float | None = None,
    idle_timeout_s: float | None = None,
    accept_poor_fit: bool = False,
    quiet: bool = False,
    sensor: str | Path = "sensor",
    ur: str | None = None,
    ur_wrench: bool = False,
    ur_timeout_s: float = TIMEOUT_S,
    listen_any: bool = False,
    configuration: str | None = None,
    plan: str | Path | None = None,
    offsets: str | None = None,
    prior: str | Path | None = None,
    prior_weight: float = 1.0,
    model: str | None = None,
    report: str | Path | None = None,
    mount_rpy: Sequence[float] | None = None,
    filter_mode: str | None = None,
) -> int:
    """Calibrate from the live protocol until an 'end' message, Ctrl-C or the idle timeout (``fts-calib live``).

    Args:
        robot: Robot definition: a shipped name (e.g. 'ur5') or a YAML path; None for datagrams
            that give the sensor's orientation (``"R"`` or ``"quat"``, :mod:`fts_calib.sources.udp`).
        tool: Tool file: a shipped name or a YAML path.
        pipeline: Pipeline settings (filter thresholds, live settings).
        listen: (host, port) to bind; port 0 takes any free port.
        output: Calibration file to write.
        checkpoint: Checkpoint file; ``OUTPUT.checkpoint.json`` when None.
        resume: Continue from the checkpoint (one of a live run).
        restart: Start afresh over an existing checkpoint; without it or ``resume``, an
            existing checkpoint is refused (exit 3): its samples are never lost silently.
        latency_s: How late the joint stamps are, in [s]; the pipeline's when None.
        max_gap_s: Longest joint gap interpolated across, in [s]; the pipeline's when None.
        idle_timeout_s: Stop after this long without data, in [s]; None waits forever.
        accept_poor_fit: Write the calibration even when its fit check is poor (the file
            records the verdict).
        quiet: No status line.
        sensor: Sensor configuration (shipped name or YAML path): its channel layout; strain
            datagrams of another length are counted and skipped.
        ur: Host of a UR controller whose joints are read through RTDE (``ur_rtde``, the
            ``ur`` extra) instead of joint datagrams; None for none.
        ur_wrench: With ``ur``: the channels are the built-in sensor's raw wrench (a
            ``wrench-6`` sensor file), not strain datagrams.
        ur_timeout_s: With ``ur``: the longest wait for the controller (its RTDE handshake,
            the connection, the first sample), in [s]; beyond it the run stops with exit 16.
        listen_any: Allow ``listen`` to bind beyond loopback (every interface, or a network
            address): any host that reaches this one may then feed the calibration. Without
            it a wildcard address (0.0.0.0, ::, 0) is refused.
        configuration: The tool configuration mounted from the start (tool datagrams may
            change it); None: wait for a tool datagram.
        plan: ``plan.yaml`` of the sized trajectories being run: the status line then shows
            the motion left to reach its target and the configuration to mount next.
        offsets: The offset model ('auto', 'constant', 'per-configuration', 'drift'); the
            pipeline file's (default auto) when None.
        prior: A calibration to shrink C_bar toward (YAML or ATI ``.cal``, of the sensor's
            layout) when the excitation is weak; None for none.
        prior_weight: The prior's weight lambda, relative to the data (:mod:`fts_calib.model.prior`).
        model: The sensor model ('auto', 'linear', 'quadratic', 'cubic'); the sensor file's
            (default auto: chosen with the offset model by held-out error) when None.
        filter_mode: The sample filter's mode ('quasi-static', 'dynamic':
            :mod:`fts_calib.filters.dynamic`); the pipeline file's (default quasi-static) when None.

        report: HTML report of the run to write, also when no calibration is written (its
            diagnosis first; :mod:`fts_calib.report.html`); None for none. A resumed run's
            report has no pictures of the samples kept before the checkpoint.
        mount_rpy: Without ``robot``: roll, pitch, yaw [rad] from the frame the datagrams'
            orientation gives to the sensor; None for none.

    Returns:
        0 with a calibration written, 1 when the data cannot determine C, 15 when the fit check
        refused it (the checkpoint is kept in both cases); 16 (an error) when the UR
        controller does not answer within ``ur_timeout_s``.
        Ctrl-C, SIGTERM and SIGHUP end the run the same way: checkpoint and calibration written.
    """
    checkpoint = Path(checkpoint or f"{output}.checkpoint.json")
    ending = StreamEnd(idle_timeout_s=idle_timeout_s, signals=LIVE_SIGNALS)  # before any work: a wrong timeout wastes nothing
    host, port = listen
    host = listen_host(host, listen_any, port)  # before any work: a refused address wastes nothing
    inputs = {"the robot file": robot, "the tool file": tool, "the pipeline file": pipeline, "the sensor file": sensor}
    check_outputs({"-o": output, "--checkpoint": checkpoint, "--report": report}, inputs)  # before any work: nothing lost, nothing wasted
    check_start(checkpoint, resume, restart)
    if ur is not None and robot is None:
        raise ConfigError("robot", None, "a robot definition", message="--ur reads a UR's joints: give its robot definition with --robot")
    kin, loaded, settings = load_setup(robot, tool, pipeline, mount_rpy)
    spec = load_sensor(sensor)
    settings = settings.with_offsets(offsets).with_filter_mode(filter_mode).with_nominal_c(nominal_c(spec))
    settings = settings.with_limits(spec.limits)  # railed samples refused from the start, as the recording's
    layout = spec.layout
    shrink = load_prior(prior, prior_weight, layout)
    expected = None if plan is None else load_plan_progress(plan, spec.rate_hz)
    if expected is not None and expected.robot is not None and expected.robot != kin.robot.name:
        message = f"--plan {plan} is a plan of the robot '{expected.robot}' but --robot is '{kin.robot.name}': give the plan of this robot"
        raise ConfigError("plan", str(plan), f"a plan of '{kin.robot.name}'", message=message)
    if expected is not None and set(expected.expected) != set(loaded.names):
        raise ConfigError("plan", sorted(expected.expected), f"the tool's configurations {loaded.names}", owner=str(plan))
    if configuration is not None and configuration not in loaded.names:
        raise UnknownToolConfiguration(configuration, loaded.names)
    if ur_wrench and (ur is None or layout.n_channels != 6):
        why = "give the arm with --ur HOST" if ur is None else f"the sensor file '{sensor}' has {layout.n_channels} channels"
        raise ConfigError(
            "ur_wrench", True, "", message=f"--ur-wrench reads the built-in sensor's 6-axis wrench: {why} (e.g. --sensor factory_sensor)"
        )
    source, record = f"live udp://{host}:{port}", live_source(host, port)
    models: dict[str, Any] = {"model": model or spec.model, "full_channels": spec.full_channels, "full_scale": spec.full_scale}
    collector = None if report is None or resume else KeptCollector()
    if resume:
        session = CalibrationSession.resume(checkpoint, kin, loaded, settings, source=source, source_record=record, layout=layout, **models)
        print(f"resumed from {checkpoint}: {session.progress().kept:,} samples kept so far", flush=True)
    else:
        session = CalibrationSession(
            kin,
            loaded,
            settings,
            checkpoint=checkpoint,
            source=source,
            source_record=record,
            layout=layout,
            **models,
            on_kept=collector,
        )
    latency_s = settings.live.latency_s if latency_s is None else latency_s
    max_gap_s = settings.live.max_gap_s if max_gap_s is None else max_gap_s
    sync = Synchronizer(kin.joint_names, kin.continuous, max_gap_s, latency_s, configurations=loaded.names, n_channels=layout.n_channels)
    if configuration is not None:
        sync.add_tool(-math.inf, configuration)
    rtde = None
    if ur is not None:
        print(f"connecting to the UR at {ur} (RTDE, waiting at most {ur_timeout_s:g} s)", flush=True)
        receive = connect_ur(ur, ur_timeout_s)
        rtde = RtdePoller(receive, kin.joint_names, ur_wrench, host_clock=None if ur_wrench else time.time, timeout_s=ur_timeout_s)
        what = (
            "joints and the built-in sensor's wrench" if ur_wrench else "joints (strains: datagrams stamped with this host's time.time())"
        )
        print(f"reading the {what} of the UR at {ur} through RTDE", flush=True)
    with using_udp(host, port):
        receiver = UdpReceiver(host, port, listen_any)
    print(
        f"listening on udp://{receiver.address[0]}:{receiver.address[1]} for {kin.robot.name} with '{loaded.name}'; "
        "Ctrl-C or an 'end' message writes the calibration",
        flush=True,
    )
    with LiveFeed(receiver, sync, rtde, end=ending) as feed:
        stats = LiveRunner(session, feed, status=None if quiet else sys.stderr, plan=expected).run()
    if rtde is not None and rtde.samples == 0 and isinstance(rtde.error, FeedTimeout):
        if not resume:  # a checkpoint of nothing would only stand in the way of the next run
            checkpoint.unlink(missing_ok=True)
        raise rtde.error
    print(format_stats(stats, sync))
    if rtde is not None:
        print(format_rtde(rtde))
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
        _report(report, session, collector, None, exc, f"{exc}", inputs)
        return ExitCode.EXCITATION
    except PoorFit as exc:
        _report(report, session, collector, None, exc, exc.check.summary(), inputs)
        print("\n".join(format_fit(exc.check)))
        print(f"NO CALIBRATION written: the fit is poor (above); checkpoint kept in {checkpoint}")
        print("fix the cause, or run again with --resume --accept-poor-fit to write it with the verdict")
        return ExitCode.POOR_FIT
    print(session.fit_check().summary())
    with writing(output):
        path = save_calibration(calibration, output)
    quality = calibration.quality
    if quality is None:  # CalibrationSession.solve always measures the fit
        raise FtsCalibError("internal error: the calibration has no fit quality")
    if quality.prior is not None:
        print(describe_prior(dict(quality.prior)))
    print(f"rank {quality.rank} of {quality.full_rank}, condition number {quality.condition_number:.1f}; wrote {path}")
    _report(report, session, collector, calibration, None, "", {**inputs, "the calibration (-o)": path})
    return ExitCode.OK


def _report(report, session, collector, calibration, error, diagnosis: str, files) -> None:
    """Write the run's HTML report when one was asked for (``--report``)."""
    if report is None:
        return
    from types import SimpleNamespace

    from ..report.content import calibrate_content
    from ..report.html import render_report, write_report

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

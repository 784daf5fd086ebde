"""The ``calibrate`` job: a recording in, a calibration out, with progress.

The recording is read chunk by chunk (:mod:`fts_calib.sources.recording`) into a
:class:`fts_calib.session.session.CalibrationSession`, the same path live feeds take. Rows the
reader cannot use (malformed lines, unknown tool configurations) and samples the session
drops (time going backwards, non-finite values, readings outside the joint limits, the
filter's rules) are counted and reported; the run goes on where it safely can.

Samples with a channel at its rail are refused when the rail is known (declared in the
sensor file). A rail the sensor file does not declare is detected on the way
(:class:`fts_calib.model.channel_limits.RailWatch`), after its samples went in: the
recording is then calibrated again, with the rail, and the result says what was detected.

With ``filter.mode: auto`` (the shipped default) the recording is read with the quasi-static filter;
when it moves without stops (:func:`fts_calib.session.diagnosis.moving_words`) and its still samples
are too few for full rank, it is read again with the dynamic filter. ``CalibrateResult.decided``
says which, and why.

With ``filter.mode: dynamic`` and ``filter.latency_s: auto`` the first read applies no latency
and leaves the latency out of the trust rule, while the latency is fitted with the
calibration (:mod:`fts_calib.filters.latency`); the recording is then read again with
it applied and its standard error (at least :data:`fts_calib.filters.dynamic.MIN_LATENCY_SIGMA_S`) as the trust
rule's latency uncertainty.

The ``live`` job: calibrate from a live stream (joints and strains) until it ends.

The live source (:class:`fts_calib.sources.live_feed.LiveFeed`: datagrams read on a background
thread, decoded, paired by the synchronizer every 20 ms, with a UR controller's RTDE samples
when given) yields the paired samples; :class:`LiveRunner` feeds them to the session
(:mod:`fts_calib.session.session`) and prints a status line. The stream ends where every live
stream ends (an ``end`` message, Ctrl-C, SIGTERM, SIGHUP for ``live``: the terminal closed, an
optional idle timeout, a lost RTDE connection); then the calibration is written. Datagrams
lost on the way are counted from the protocol's optional ``seq`` numbers, per sender, and
shown in the status line and the summary. The session checkpoints every few seconds,
so ``--resume`` after a crash loses at most that interval. The socket binds to 127.0.0.1
unless told otherwise.
"""

from __future__ import annotations

import dataclasses
import json
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol, TextIO

import numpy as np

from ..budget.propagation import AccuracyBudget
from ..core.exceptions import FtsCalibError, InsufficientExcitation, PoorFit, ShapeError
from ..core.files import check_distinct
from ..core.resources import locate
from ..filters.clock import clock_checked
from ..filters.dynamic import nominal_c, settings_for_first_read, settings_with_latency
from ..filters.latency import LatencyEstimate
from ..filters.settings import AUTO_FILTER, DYNAMIC, QUASI_STATIC, PipelineConfig, load_pipeline_config
from ..model.calibration import Calibration
from ..model.channel_limits import ChannelLimits
from ..model.channels import MALTESE_CROSS_8, ChannelLayout
from ..model.prior import Prior
from ..model.sensor_config import SensorSpec, load_sensor_config
from ..robot.definition import RobotDefinition, load_robot
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool, load_tool
from ..sources.bag import BagTopics
from ..sources.batch import SampleBatch
from ..sources.live_feed import FeedStatus, LiveFeed
from ..sources.recording_set import RecordingSet, describe_files
from ..sources.source import ArraySource, open_recording, orientation_source, recording_paths
from ..sources.synchronizer import Synchronizer
from ..sources.udp import LiveStats
from .checkpoint import check_start, recording_source
from .plan_progress import PlanProgress
from .session import CalibrationSession, without_stops


class ProgressSink(Protocol):
    """Where a long job reports how far it is (the command line's progress bar is one)."""

    total: float

    def update(self, done: float, count: int) -> None:
        """``done`` of ``total`` units (bytes of the file), ``count`` items (rows) so far."""

    def close(self) -> None:
        """The job is over."""


@dataclass
class CalibrateResult:
    """What the ``calibrate`` job did.

    Attributes:
        calibration: The calibration, or None when the data cannot determine it.
        session: The session (counts, progress).
        problems: The first problems the reader found, with line and column.
        rows: Rows read.
        seconds: Wall-clock time of the run [s].
        error: Why there is no calibration, or None.
        budget: The measured accuracy budget (also in the calibration's quality), or None.
        latency: The joint stream's latency estimated from the moving samples, or None.
        detected: What the run detected of the channels' limits that the sensor file does
            not declare (e.g. 'high rail of strain_7 at 1023'): the recording was calibrated
            again with them.
        decided: What the defaults that adapt to the data decided, and why, one line each
            (``filter.mode: auto``, the joint unit).
    """

    calibration: Calibration | None
    session: CalibrationSession
    problems: list[str]
    rows: int
    seconds: float
    error: InsufficientExcitation | PoorFit | None = None
    budget: AccuracyBudget | None = None
    latency: LatencyEstimate | None = None
    detected: tuple[str, ...] = ()
    decided: tuple[str, ...] = ()


def calibrate_recording(
    path: str | Path | Sequence[str | Path],
    kin: Kinematics,
    tool: Tool,
    settings: PipelineConfig | None = None,
    use_filter: bool = True,
    checkpoint: str | Path | None = None,
    resume: bool = False,
    joints_in_degrees: bool | None = None,
    progress: ProgressSink | None = None,
    restart: bool = False,
    on_kept=None,
    accept_poor_fit: bool = False,
    topics: BagTopics | None = None,
    layout: ChannelLayout = MALTESE_CROSS_8,
    prior: Prior | None = None,
    model: str = "linear",
    full_channels: bool = False,
    full_scale=None,
    limits: ChannelLimits | None = None,
) -> CalibrateResult:
    """Calibrate from a recording (see the module docstring).

    Args:
        path: Recording (CSV or CSV.gz), or ROS 2 bags (``.mcap``, ``.db3``, bag folders),
            each optionally ``BAG:CONFIGURATION`` (:mod:`fts_calib.sources.source`).
        kin: Kinematics of the robot that made it.
        tool: The calibration tool.
        settings: Pipeline settings; the defaults when None.
        use_filter: Keep only quasi-static samples (True) or every valid one.
        checkpoint: Checkpoint file, or None.
        resume: Continue from ``checkpoint``; it must be of this recording (the same first
            MiB, at least as long).
        joints_in_degrees: The joint columns are in degrees (True: converted to rad) or rad (False);
            None: decided from the first rows (:func:`fts_calib.filters.clock.degrees_found`;
            the result's ``decided`` says when they were found in degrees).
        progress: A progress bar over the file's bytes, or None (its ``total`` is set here).
        accept_poor_fit: Keep a calibration whose fit check is poor (its quality records the
            verdict) instead of refusing it.
        on_kept: Passed to the session (see :class:`fts_calib.session.session.CalibrationSession`).
        restart: Start afresh over an existing ``checkpoint`` (overwriting it).
        topics: Topic names of a bag; the defaults when None.
        layout: The sensor's channel layout; a recording of another number of channels is
            refused (ShapeError naming both).
        prior: Shrink C_bar toward a known calibration (ridge, :mod:`fts_calib.model.prior`).
        model: The sensor model setting ('linear', 'quadratic', 'cubic' or 'auto', chosen by
            held-out error: :mod:`fts_calib.model.model_choice`).
        full_channels: Regress on the raw channels (a free 6 x n C) instead of ``P Delta``.
        full_scale: Full scale per wrench axis [N, N m], shape (6,), scaling the held-out errors and
            the measured budget in %; a sensor file's default when None.
        limits: The channels' declared resolution and rails (the sensor file's), in place of
            ``settings.checks.limits``; None: those.
            Rails not declared are detected (see the module docstring).

    Raises:
        RecordingError: The file cannot be read at all (missing, no data row, a missing
            column, a truncated .csv.gz; for a bag, a missing topic or joint: BagError), or its clock is not one in s for its joints
            (:mod:`fts_calib.filters.clock`): refused before anything is solved or written.
        ConfigError: ``checkpoint`` exists and neither ``resume`` nor ``restart`` is given,
            both are, ``resume`` without a checkpoint, or ``checkpoint`` is the recording.
        FileFormatError: ``resume`` with the checkpoint of another robot, tool or recording.
    """
    start = time.perf_counter()
    paths = recording_paths(path)
    check_start(checkpoint, resume, restart)
    check_distinct({"--checkpoint": checkpoint}, {("the recording" if k == 0 else f"recording {k + 1}"): p for k, p in enumerate(paths)})
    settings = settings or PipelineConfig()
    settings = settings if limits is None else settings.with_limits(limits)
    pending: list[tuple] = []  # the kept samples of a run that may be done again, for on_kept
    collect = None if on_kept is None else lambda *kept: pending.append(kept)
    models = {"model": model, "full_channels": full_channels, "full_scale": full_scale}
    run = _Run(paths, kin, tool, use_filter, checkpoint, topics, layout, joints_in_degrees, progress, models)
    auto = use_filter and settings.filter.mode == AUTO_FILTER
    if auto:  # the still samples first (a resumed run: the checkpoint's filter)
        settings = settings.with_filter_mode(_checkpoint_mode(checkpoint) if resume else QUASI_STATIC)
    first = settings_for_first_read(settings, resume)  # latency_s auto: the latency is fitted on the way
    session, problems, rows, lost = run.read(resume, first, on_kept=collect)
    decided = [] if not auto else [f"filter: {settings.filter.mode} (--filter auto: the checkpoint's)"] if resume else []
    if auto and not resume:
        moving, p = without_stops(session), session.progress()
        if moving and p.rank < p.full_rank:  # no stops, too few still samples: the moving ones calibrate
            settings = settings.with_filter_mode(DYNAMIC)
            first = settings_for_first_read(settings, resume)
            pending.clear()
            session, problems, rows, lost = run.read(False, first, on_kept=collect)
        decided.append(_filter_decided(settings.filter.mode, moving, p.rank, p.full_rank))
    found = None if resume or session.filter is None else session.checks.detected_limits(session.filter.grid.resolution)
    again = settings_with_latency(settings, session.filter) if first is not settings else None
    if found is not None or again is not None:  # a rail nobody declared, or the latency: calibrate again with them
        settings = (again or settings).with_limits(found) if found is not None else again or settings
        session, problems, rows, lost = run.read(False, settings, on_kept)
    elif on_kept is not None:
        for kept in pending:
            on_kept(*kept)
    if progress is not None:
        progress.close()
    # what is really missing comes first: a configuration all of whose rows were unreadable
    hint = "; ".join(lost)
    session.joints_in_degrees = run.degrees  # the diagnosis of a poor fit tries the joints in the other unit
    if run.degrees_found:
        decided.insert(0, f"joints: degrees (--joint-unit auto: {run.degrees_found}): converted to rad; --joint-unit rad forces rad")
    try:
        calibration, error = session.solve(accept_poor_fit=accept_poor_fit, hint=hint, prior=prior), None
    except (InsufficientExcitation, PoorFit) as exc:
        calibration, error = None, exc
    seconds, detected = time.perf_counter() - start, (() if found is None else found.detected)
    result = CalibrateResult(calibration, session, problems, rows, seconds, error, session.budget, session.latency, detected=detected)
    return dataclasses.replace(result, decided=tuple(decided))


def _filter_decided(mode: str, moving: str, rank: int, full_rank: int) -> str:
    """What ``filter.mode: auto`` decided for a recording, and why, in one line."""
    if mode == DYNAMIC:
        return (
            f"filter: dynamic (--filter auto: {moving}: too few still samples for the quasi-static filter, rank {rank} of "
            f"{full_rank}; the recording was read again with the dynamic filter; --filter quasi-static forces the still samples)"
        )
    why = f"{moving}, but its still samples determine C" if moving else "the arm holds still at its stops"
    return f"filter: quasi-static (--filter auto: {why}; --filter dynamic calibrates the moving samples too)"


def _checkpoint_mode(checkpoint: str | Path | None) -> str:
    """The filter a checkpoint was written with: dynamic when its filter state holds the latency sums, else quasi-static."""
    try:
        state = json.loads(Path(checkpoint).read_text(encoding="utf-8")) if checkpoint is not None else {}
    except (OSError, ValueError):  # resuming reads it again, and says what is wrong with it
        return QUASI_STATIC
    held = state.get("filter") if isinstance(state, dict) else None
    return DYNAMIC if isinstance(held, dict) and "latency_sums" in held else QUASI_STATIC


def calibrate(
    recording_or_arrays,
    *,
    robot,
    tool,
    sensor="sensor",
    settings=None,
    use_filter: bool = True,
    joints_in_degrees: bool | None = None,
    accept_poor_fit: bool = False,
    prior: Prior | None = None,
) -> Calibration:
    """Calibrate a sensor from a recording or from arrays in memory: the ``calibrate`` command, from Python.

    The calibration holds what the command writes (the fit check, the measured accuracy
    budget, the stream-latency estimate): ``calibrate(...).save(path)`` writes the same file.

    Args:
        recording_or_arrays: A recording (CSV or CSV.gz; time, joints, ``strain_1..n``,
            tool), ROS 2 bags, or a list of them; or arrays in memory: a
            :class:`~fts_calib.sources.batch.SampleBatch`, or a mapping with ``time`` [s] (N,),
            ``joints`` [rad] (N, n_joints) in the robot's joint order, ``channels`` (N, n)
            raw, ``configuration`` (one tool configuration name, or one per sample), and
            optionally ``temperature`` [°C] (N,).
        robot: A shipped robot name (``"ur5"``), a robot YAML path, a
            :class:`~fts_calib.robot.definition.RobotDefinition` or a
            :class:`~fts_calib.robot.kinematics.Kinematics`.
        tool: The calibration tool: a shipped name (``"paper_tool"``), a tool YAML path or a
            :class:`~fts_calib.robot.tool.Tool`. Required: a wrong tool gives a wrong C.
        sensor: The sensor: a shipped name (``"sensor"``: the paper's 8 bridges), a YAML
            path or a :class:`~fts_calib.model.sensor_config.SensorSpec` (its channel layout
            and full scale).
        settings: Pipeline settings: a :class:`~fts_calib.filters.settings.PipelineConfig`,
            a shipped name or a YAML path; the shipped ``pipeline`` when None.
        use_filter: Keep only the quasi-static samples (False: every valid one).
        joints_in_degrees: The joint readings are in degrees (True) or rad (False); None: a
            recording's are decided from its first rows (degrees converted), arrays are in rad.
        accept_poor_fit: Return a calibration whose fit check is poor instead of raising.
        prior: Shrink C_bar toward a known calibration (:mod:`fts_calib.model.prior`).

    Returns:
        The calibration.

    Raises:
        InsufficientExcitation: The data cannot determine C; the message says what is missing.
        PoorFit: The data do not fit the tool's model (and ``accept_poor_fit`` is False).
        RecordingError: A recording cannot be read (the message names file, line and column).
        ShapeError: Arrays of inconsistent lengths or a wrong number of channels.
        ResourceNotFound: A name that is neither a file nor shipped.

    Example::

        calibration = fts_calib.calibrate("recording.csv.gz", robot="ur5", tool="paper_tool")
        calibration.save("calibration.yaml")
    """
    kin = robot if isinstance(robot, Kinematics) else Kinematics(robot if isinstance(robot, RobotDefinition) else load_robot(robot))
    tool = tool if isinstance(tool, Tool) else load_tool(tool)
    spec = sensor if isinstance(sensor, SensorSpec) else load_sensor_config(sensor)
    if not isinstance(settings, PipelineConfig):
        settings = load_pipeline_config(locate("pipeline" if settings is None else settings, "configs"))
    settings = settings if settings.nominal_c is not None else settings.with_nominal_c(nominal_c(spec))
    settings = settings if settings.repeatability is not None else settings.with_repeatability(spec.repeatability)
    if isinstance(recording_or_arrays, (str, Path)) or (
        isinstance(recording_or_arrays, Sequence) and all(isinstance(p, (str, Path)) for p in recording_or_arrays)
    ):
        result = calibrate_recording(
            recording_or_arrays,
            kin,
            tool,
            settings,
            use_filter=use_filter,
            joints_in_degrees=joints_in_degrees,
            accept_poor_fit=accept_poor_fit,
            layout=spec.layout,
            prior=prior,
            full_scale=spec.full_scale,
            limits=spec.limits,
            model=spec.model,
            full_channels=spec.full_channels,
        )
        if result.calibration is None:
            raise result.error if result.error is not None else InsufficientExcitation(0, 7)
        return result.calibration
    session = CalibrationSession(
        kin,
        tool,
        settings.with_limits(spec.limits),
        use_filter=use_filter,
        source="arrays in memory",
        layout=spec.layout,
        full_scale=spec.full_scale,
        model=spec.model,
        full_channels=spec.full_channels,
    )
    if not isinstance(recording_or_arrays, (SampleBatch, Mapping)):
        raise ShapeError(
            f"recording_or_arrays is a {type(recording_or_arrays).__name__}: expected a recording path (or a list of them), "
            "a SampleBatch, or a mapping with time, joints, channels and configuration"
        )
    with ArraySource(recording_or_arrays, kin.joint_names, tool.names, "arrays in memory") as arrays:
        for batch in arrays:
            session.add_samples(dataclasses.replace(batch, joints=np.radians(batch.joints)) if joints_in_degrees else batch)
    session.flush()
    session.joints_in_degrees = bool(joints_in_degrees)
    return session.solve(accept_poor_fit=accept_poor_fit, prior=prior)


def _counting(files: RecordingSet, per_file: np.ndarray, on_kept):
    """``on_kept`` that first adds each kept sample to ``per_file`` [the index of its file in ``files``]."""

    def counted(time, *rest):
        index = files.file_of(time)
        per_file[:] += np.bincount(index[index >= 0], minlength=len(per_file))
        if on_kept is not None:
            on_kept(time, *rest)

    return counted


class _Run:
    """One read of a recording into a fresh (or resumed) session: what :func:`calibrate_recording` may do twice.

    Attributes:
        degrees: The joint columns were read as degrees (given, or found).
        degrees_found: Why the joint unit not given was found to be degrees ('' when not).
    """

    def __init__(self, paths, kin, tool, use_filter, checkpoint, topics, layout, joints_in_degrees, progress, models):
        self.paths, self.kin, self.tool = paths, kin, tool
        self.use_filter, self.checkpoint, self.topics, self.layout = use_filter, checkpoint, topics, layout
        self.joints_in_degrees, self.progress, self.models = joints_in_degrees, progress, models
        self.degrees, self.degrees_found = bool(joints_in_degrees), ""

    def _found(self, words: str) -> None:
        self.degrees, self.degrees_found = True, words

    def read(self, resume: bool, settings: PipelineConfig, on_kept) -> tuple[CalibrationSession, list[str], int, list[str]]:
        """The session after the whole recording (with these settings).

        Returns:
            The session, the reader's notes, the rows read and the configurations none of
            whose rows could be read.
        """
        paths, kin, tool, checkpoint, progress = self.paths, self.kin, self.tool, self.checkpoint, self.progress
        source = describe_files(paths)
        live = settings.live
        with open_recording(
            paths, kin.joint_names, tool.names, settings.checks.max_abs_channel, self.topics, kin.continuous, live.max_gap_s, live.latency_s
        ) as reader:
            if progress is not None:
                progress.total = max(float(reader.size), 1.0)
            record = None if checkpoint is None else recording_source(paths)
            layout = self.layout
            files = reader if isinstance(reader, RecordingSet) else None
            per_file = None if files is None else np.zeros(len(files.paths), dtype=np.int64)
            if files is not None and per_file is not None:  # count each file's kept samples, to name the files with none
                on_kept = _counting(files, per_file, on_kept)
            if resume and checkpoint is not None and Path(checkpoint).exists():
                per_file = None  # the samples before the checkpoint are not at hand
                session = CalibrationSession.resume(
                    checkpoint, kin, tool, settings, source=source, source_record=record, layout=layout, **self.models
                )
            else:
                session = CalibrationSession(
                    kin,
                    tool,
                    settings,
                    checkpoint,
                    self.use_filter,
                    source,
                    on_kept=on_kept,
                    source_record=record,
                    layout=layout,
                    **self.models,
                )
            session.orientation_source = orientation_source(reader, kin.joint_names)
            checked = settings.filter if self.use_filter else None
            for chunk in clock_checked(reader.path, reader, kin, checked, self.joints_in_degrees, self._found):
                session.add_samples(chunk)
                if progress is not None:
                    progress.update(reader.bytes_read, reader.rows_read)
            for reason, count in reader.skipped.items():
                session.note_skipped(reason, count)
            problems, rows = reader.notes(), reader.rows_read
            lost = reader.unusable_configurations()
            session.flush()
            if files is not None and per_file is not None and not per_file.all():
                empty = [files.paths[k].name for k in np.flatnonzero(per_file == 0)]
                listed = ", ".join(empty[:10]) + (f" and {len(empty) - 10} more" if len(empty) > 10 else "")
                problems.insert(
                    1, f"{len(empty)} of {len(per_file)} files with no still sample kept: {listed}; the run goes on without them"
                )
        if progress is not None:
            progress.update(progress.total, rows)
        session.checkpoint()
        return session, problems, rows, lost


#: Seconds between two status lines written to a file or a pipe (a terminal's line is rewritten in place).
LOG_INTERVAL_S = 5.0


class StatusLine:
    """A status line: rewritten in place (a carriage return) on a terminal; elsewhere (a file, a pipe) one line every few seconds.

    Args:
        stream: Where to write.
        interval_s: Seconds between two lines when ``stream`` is not a terminal [s].
        clock: Monotonic clock [s] (a test's own).
    """

    def __init__(self, stream: TextIO, interval_s: float = LOG_INTERVAL_S, clock=time.monotonic):
        self.stream, self.interval_s, self.clock = stream, interval_s, clock
        self.tty = hasattr(stream, "isatty") and stream.isatty()
        self._shown, self._last = 0, -np.inf

    def show(self, line: str, end: str = "") -> None:
        """Show ``line`` (at most 240 characters); ``end`` a newline: the last one, always written."""
        line = line[:240]
        if self.tty:
            self.stream.write("\r" + line.ljust(self._shown) + end)  # spaces clear a longer previous line
            self._shown = 0 if end else len(line)
        else:
            now = self.clock()
            if not end and now - self._last < self.interval_s:
                return
            self.stream.write(line + "\n")
            self._last = now
        self.stream.flush()

    def close(self) -> None:
        """End a terminal's line (a file's lines end as they are written)."""
        if self.tty and self._shown:
            self.stream.write("\n")
            self.stream.flush()
            self._shown = 0


#: A resumed live stream whose first sample is this much before the checkpoint's last has a restarted clock [s].
CLOCK_RESTART_S = 5.0
#: The time left between the checkpoint's last sample and a re-based stream's first [s].
REBASE_GAP_S = 1.0


class LiveRunner:
    """Runs a session on a live stream (see the module docstring).

    A resumed session skips the samples up to its checkpoint's last (already counted). A stream
    whose first sample comes more than :data:`CLOCK_RESTART_S` before that has a restarted clock
    (a UR controller rebooted during a tool change: its time starts again near 0): its times are
    re-based, put :data:`REBASE_GAP_S` after the checkpoint's last, instead of all being skipped,
    and :attr:`rebase_note` says so.

    Args:
        session: The calibration session (fresh or resumed).
        feed: The live stream, whose synchronizer was made with the session tool's
            ``configurations`` (so that its indices are the tool's). Its ``on_status`` shows
            the status line when ``status`` is given (every ``feed.status_interval_s``).
        status: Where to print the status line (None: no status).
        plan: What the sized plan expects (:mod:`fts_calib.session.plan_progress`): the status
            line then shows the motion left and the configuration to mount next.
    """

    def __init__(self, session: CalibrationSession, feed: LiveFeed, status: TextIO | None = None, plan: PlanProgress | None = None):
        if feed.sync.configurations != session.tool.names:
            raise FtsCalibError(
                f"the synchronizer indexes configurations {feed.sync.configurations}, the session's tool has {session.tool.names}: "
                "make it with Synchronizer(..., configurations=tool.names)"
            )
        self.session = session
        self.feed = feed
        self.status = status
        self.plan = plan
        self._line = None if status is None else StatusLine(status)
        if status is not None:
            feed.on_status = lambda counts: self._show(self.status_line(counts))
        self.rebased_s = 0.0  # added to the stream's times: its clock restarted since the checkpoint [s]
        self.rebase_note: str | None = None
        self._first: float | None = None

    def rebased(self, batch: SampleBatch) -> SampleBatch:
        """``batch`` with its times re-based when the stream's clock restarted since the checkpoint (see the class docstring)."""
        if self._first is None and len(batch):
            self._first = float(batch.time[0])
            resume = self.session.checks.resume_time
            if math.isfinite(resume) and self._first < resume - CLOCK_RESTART_S:
                self.rebased_s = resume + REBASE_GAP_S - self._first
                self.rebase_note = (
                    f"the stream's clock restarted since the checkpoint (its first sample at {self._first:.3f} s, the "
                    f"checkpoint's last at {resume:.3f} s: a controller rebooted?): its times re-based by "
                    f"{self.rebased_s:+.3f} s, so that its samples count instead of being skipped as before the checkpoint"
                )
        if not self.rebased_s:
            return batch
        return dataclasses.replace(batch, time=batch.time + self.rebased_s)

    @property
    def stats(self) -> LiveStats:
        """The stream's datagram counts."""
        return self.feed.stats

    def stream_rate_hz(self) -> float | None:
        """The channel rate the stream shows on its own clock [Hz] (samples over time), or None before 1 s of it."""
        return self.feed.stream_rate_hz()

    def status_line(self, counts: FeedStatus | None = None) -> str:
        """Rates, kept %, counts per configuration, rank and what is missing (``counts``: the feed's now when None)."""
        counts = counts or self.feed.status()
        p = self.session.progress()
        per = " ".join(f"{k} {v}" for k, v in p.kept_by_configuration.items())
        bad = counts.malformed + counts.oversized
        text = (
            f"elapsed {counts.elapsed_s:7.1f} s | joints {counts.joints_hz:6.0f} Hz "
            f"strain {counts.strain_hz:6.0f} Hz | kept {100 * p.kept_fraction:5.1f} % | {per} "
            f"| rank {p.rank} of {p.full_rank}"
        )
        if bad:
            text += f" | bad datagrams {bad}"
        if counts.lost:
            text += f" | lost datagrams {counts.lost}"
        if self.plan is not None:
            text += f" | {self.plan.at_rate(self.stream_rate_hz()).status(p)}"
        if p.missing:
            text += f" | missing: {p.missing}"
        return text

    def _show(self, line: str, end: str = "") -> None:
        if self._line is not None:  # the callers only show a line when there is a status stream
            self._line.show(line, end)

    def run(self) -> LiveStats:
        """Feed the session until the stream ends (:mod:`fts_calib.sources.live_feed`); then checkpoint; return the counts."""
        with self.feed:
            for batch in self.feed:
                self.session.add_samples(self.rebased(batch))
        self.session.flush()
        self.session.checkpoint()
        if self.status is not None:
            self._show(self.status_line(), end="\n")
        return self.feed.stats


def format_stats(stats: LiveStats, sync: Synchronizer, rtde_samples: int = 0, rtde_wrench: bool = False) -> str:
    """Message counts and CPU use of a live run, one line each.

    Args:
        stats: The run's counts (its ``joints`` and ``strain`` include the RTDE samples).
        sync: The run's synchronizer (its drops).
        rtde_samples: Samples of a UR controller through RTDE among them (counted apart from the datagrams).
        rtde_wrench: Whether those samples also gave the strains (the built-in sensor's wrench).
    """
    joints, strain = stats.joints - rtde_samples, stats.strain - (rtde_samples if rtde_wrench else 0)
    rtde = f" and {rtde_samples:,} RTDE controller samples (joints{' and wrench' if rtde_wrench else ''})" if rtde_samples else ""
    lines = [
        f"messages: {stats.received:,} datagrams ({joints:,} joints, {strain:,} strain, {stats.tool} tool){rtde}, "
        f"{stats.malformed} malformed and {stats.oversized} oversized skipped, {_lost(stats)}"
        f"{f', {stats.duplicates:,} duplicates dropped (a seq number received twice)' if stats.duplicates else ''}; "
        f"{'ended by the sender' if stats.ended else 'stopped'} after {stats.wall_s:.1f} s, CPU {stats.cpu_s:.1f} s "
        f"({100 * stats.cpu_s / max(stats.wall_s, 1e-9):.0f} % of one core)"
    ]
    if stats.first_malformed is not None:
        lines.append(f"  the first skipped: {stats.first_malformed}")
    if sync.dropped:
        lines.append("strain samples not paired: " + ", ".join(f"{r}: {n:,}" for r, n in sync.dropped.items()))
    return "\n".join(lines)


def _lost(stats: LiveStats) -> str:
    """The datagrams lost on the way, in words: counted from ``seq``, or not measurable without it."""
    if not stats.seq.sequenced:
        return "losses not counted (no datagram with a seq number)"
    return f"{stats.gaps:,} lost on the way (gaps in seq)"

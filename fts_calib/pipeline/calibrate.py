"""The ``calibrate`` job: a recording in, a calibration out, with progress.

The recording is read chunk by chunk (:mod:`fts_calib.feeds.recording`) into a
:class:`fts_calib.pipeline.session.CalibrationSession`, the same path live feeds take. Rows the
reader cannot use (malformed lines, unknown tool configurations) and samples the session
drops (time going backwards, non-finite values, readings outside the joint limits, the
filter's rules) are counted and reported; the run goes on where it safely can.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np

from ..core.exceptions import InsufficientExcitation, PoorFit
from ..core.paths import check_distinct
from ..feeds.bag_log import BagTopics
from ..feeds.source import open_recording, recording_paths
from ..model.budget import AccuracyBudget
from ..model.calibration import Calibration
from ..model.channels import MALTESE_CROSS_8, ChannelLayout
from ..model.prior import Prior
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool
from .checkpoint import check_start, recording_source
from .clock import clock_checked
from .latency import LatencyEstimate
from .session import CalibrationSession
from .settings import PipelineConfig


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
        budget: The measured accuracy budget (the ``calibrate`` command adds it), or None.
        latency: The joint stream's latency estimated from the moving samples, or None.
    """

    calibration: Calibration | None
    session: CalibrationSession
    problems: list[str]
    rows: int
    seconds: float
    error: InsufficientExcitation | PoorFit | None = None
    budget: AccuracyBudget | None = None
    latency: LatencyEstimate | None = None


def calibrate_recording(
    path: str | Path | Sequence[str | Path],
    kin: Kinematics,
    tool: Tool,
    settings: PipelineConfig | None = None,
    use_filter: bool = True,
    checkpoint: str | Path | None = None,
    resume: bool = False,
    joints_in_degrees: bool = False,
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
) -> CalibrateResult:
    """Calibrate from a recording (see the module docstring).

    Args:
        path: Recording (CSV or CSV.gz), or ROS 2 bags (``.mcap``, ``.db3``, bag folders),
            each optionally ``BAG:CONFIGURATION`` (:mod:`fts_calib.feeds.source`).
        kin: Kinematics of the robot that made it.
        tool: The calibration tool.
        settings: Pipeline settings; the defaults when None.
        use_filter: Keep only quasi-static samples (True) or every valid one.
        checkpoint: Checkpoint file, or None.
        resume: Continue from ``checkpoint``; it must be of this recording (the same first
            MiB, at least as long).
        joints_in_degrees: The joint columns are in degrees (converted to rad).
        progress: A progress bar over the file's bytes, or None (its ``total`` is set here).
        accept_poor_fit: Keep a calibration whose fit check is poor (its quality records the
            verdict) instead of refusing it.
        on_kept: Passed to the session (see :class:`fts_calib.pipeline.session.CalibrationSession`).
        restart: Start afresh over an existing ``checkpoint`` (overwriting it).
        topics: Topic names of a bag; the defaults when None.
        layout: The sensor's channel layout; a recording of another number of channels is
            refused (ShapeError naming both).
        prior: Shrink C_bar toward a known calibration (ridge, :mod:`fts_calib.model.prior`).
        model: The sensor model setting ('linear', 'quadratic', 'cubic' or 'auto', chosen by
            held-out error: :mod:`fts_calib.model.model_choice`).
        full_channels: Regress on the raw channels (a free 6 x n C) instead of ``P Delta``.
        full_scale: Per-axis full scale [N, N m] (6,) scaling the held-out errors, or None.

    Raises:
        RecordingError: The file cannot be read at all (missing, no data row, a missing
            column, a truncated .csv.gz; for a bag, a missing topic or joint: BagError), or its clock is not one in s for its joints
            (:mod:`fts_calib.pipeline.clock`): refused before anything is solved or written.
        ConfigError: ``checkpoint`` exists and neither ``resume`` nor ``restart`` is given,
            both are, ``resume`` without a checkpoint, or ``checkpoint`` is the recording.
        FileFormatError: ``resume`` with the checkpoint of another robot, tool or recording.
    """
    start = time.perf_counter()
    paths = recording_paths(path)
    source = " ".join(map(str, paths))
    check_start(checkpoint, resume, restart)
    check_distinct({"--checkpoint": checkpoint}, {("the recording" if k == 0 else f"recording {k + 1}"): p for k, p in enumerate(paths)})
    settings = settings or PipelineConfig()
    live = settings.live
    with open_recording(
        paths, kin.joint_names, tool.names, settings.checks.max_abs_channel, topics, kin.continuous, live.max_gap_s, live.latency_s
    ) as reader:
        if progress is not None:
            progress.total = max(float(reader.size), 1.0)
        record = None if checkpoint is None else recording_source(paths)
        models = {"model": model, "full_channels": full_channels, "full_scale": full_scale}
        if resume and checkpoint is not None and Path(checkpoint).exists():
            session = CalibrationSession.resume(
                checkpoint, kin, tool, settings, source=source, source_record=record, layout=layout, **models
            )
        else:
            session = CalibrationSession(
                kin, tool, settings, checkpoint, use_filter, source, on_kept=on_kept, source_record=record, layout=layout, **models
            )
        chunks = (dataclasses.replace(c, joints=np.radians(c.joints)) if joints_in_degrees else c for c in reader)
        for chunk in clock_checked(reader.path, chunks, kin, settings.filter if use_filter else None, joints_in_degrees):
            session.add_samples(chunk)
            if progress is not None:
                progress.update(reader.bytes_read, reader.rows_read)
        for reason, count in reader.skipped.items():
            session.note_skipped(reason, count)
        problems, rows = reader.notes(), reader.rows_read
    session.flush()
    if progress is not None:
        progress.update(progress.total, rows)
        progress.close()
    session.checkpoint()
    hint = "the joint columns may be in rad already: run without --joints-in-degrees" if joints_in_degrees else ""
    try:
        calibration, error = session.solve(accept_poor_fit=accept_poor_fit, hint=hint, prior=prior), None
    except (InsufficientExcitation, PoorFit) as exc:
        calibration, error = None, exc
    return CalibrateResult(calibration, session, problems, rows, time.perf_counter() - start, error)

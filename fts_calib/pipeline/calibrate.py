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
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np

from ..core.exceptions import InsufficientExcitation
from ..feeds.recording import RecordingReader
from ..model.calibration import Calibration
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool
from .session import CalibrationSession
from .settings import PipelineConfig


class Progress(Protocol):
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
    """

    calibration: Calibration | None
    session: CalibrationSession
    problems: list[str]
    rows: int
    seconds: float
    error: InsufficientExcitation | None = None


def calibrate_recording(
    path: str | Path,
    kin: Kinematics,
    tool: Tool,
    settings: PipelineConfig | None = None,
    use_filter: bool = True,
    checkpoint: str | Path | None = None,
    resume: bool = False,
    joints_in_degrees: bool = False,
    progress: Progress | None = None,
    on_kept=None,
) -> CalibrateResult:
    """Calibrate from a recording (see the module docstring).

    Args:
        path: Recording (CSV or CSV.gz).
        kin: Kinematics of the robot that made it.
        tool: The calibration tool.
        settings: Pipeline settings; the defaults when None.
        use_filter: Keep only quasi-static samples (True) or every valid one.
        checkpoint: Checkpoint file, or None.
        resume: Continue from ``checkpoint``.
        joints_in_degrees: The joint columns are in degrees (converted to rad).
        progress: A progress bar over the file's bytes, or None.
        on_kept: Passed to the session (see :class:`fts_calib.pipeline.session.CalibrationSession`).

    Raises:
        RecordingError: The file cannot be read at all (missing, empty, a missing column).
    """
    start = time.perf_counter()
    source = str(path)
    if resume and checkpoint is not None and Path(checkpoint).exists():
        session = CalibrationSession.resume(checkpoint, kin, tool, settings, source=source)
    else:
        session = CalibrationSession(kin, tool, settings, checkpoint=checkpoint, use_filter=use_filter, source=source, on_kept=on_kept)
    with RecordingReader(path, kin.joint_names, tool.names) as reader:
        for chunk in reader:
            session.add_samples(dataclasses.replace(chunk, joints=np.radians(chunk.joints)) if joints_in_degrees else chunk)
            if progress is not None:
                progress.update(reader.bytes_read, reader.rows_read)
        for reason, count in reader.skipped.items():
            session.note_skipped(reason, count)
        problems, rows = list(reader.problems), reader.rows_read
    session.flush()
    if progress is not None:
        progress.update(progress.total, rows)
        progress.close()
    session.checkpoint()
    try:
        calibration, error = session.solve(), None
    except InsufficientExcitation as exc:
        calibration, error = None, exc
    return CalibrateResult(calibration, session, problems, rows, time.perf_counter() - start, error)

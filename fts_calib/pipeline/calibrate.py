"""The ``calibrate`` job: a recording in, a calibration out, with progress and a summary.

The recording is read chunk by chunk (:mod:`fts_calib.feeds.recording`) into a
:class:`fts_calib.pipeline.session.CalibrationSession`, the same path live feeds take. Rows the
reader cannot use (malformed lines, unknown tool configurations) and samples the session
drops (time going backwards, non-finite values, readings outside the joint limits, the
filter's rules) are counted and reported; the run goes on where it safely can.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import numpy as np

from ..app.report import table
from ..core.exceptions import FtsCalibError, InsufficientExcitation
from ..feeds.recording import RecordingReader
from ..model.calibration import Calibration
from ..model.sensor import WRENCH_AXES, WRENCH_UNITS
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool
from .session import CalibrationSession
from .settings import PipelineConfig


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


def calibrate_recording(
    path: str | Path,
    kin: Kinematics,
    tool: Tool,
    config: PipelineConfig | None = None,
    use_filter: bool = True,
    checkpoint: str | Path | None = None,
    resume: bool = False,
    joints_in_degrees: bool = False,
    progress: ProgressBar | None = None,
    on_kept=None,
) -> CalibrateResult:
    """Calibrate from a recording (see the module docstring).

    Args:
        path: Recording (CSV or CSV.gz).
        kin: Kinematics of the robot that made it.
        tool: The calibration tool.
        config: Pipeline settings; the defaults when None.
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
        session = CalibrationSession.resume(checkpoint, kin, tool, config, source=source)
    else:
        session = CalibrationSession(kin, tool, config, checkpoint=checkpoint, use_filter=use_filter, source=source, on_kept=on_kept)
    with RecordingReader(path, kin.joint_names, tool.names) as reader:
        for chunk in reader:
            readings = np.radians(chunk.readings) if joints_in_degrees else chunk.readings
            session.add_batch(chunk.time, readings, chunk.strain, chunk.tool)
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


def format_counts(session: CalibrationSession) -> list[str]:
    """Lines: samples seen and kept, per configuration, and skipped by reason."""
    p = session.progress()
    per = ", ".join(f"{name} {n:,}" for name, n in p.kept_by_configuration.items())
    lines = [f"samples: {p.seen:,} seen, {p.kept:,} kept ({100 * p.kept_fraction:.1f} %): {per}"]
    if p.skipped:
        lines.append("not kept, by reason (a filtered sample can fail several rules):")
        lines.append(table(["reason", "samples"], [[r, f"{n:,}"] for r, n in sorted(p.skipped.items(), key=lambda x: -x[1])], "  "))
    return lines


def format_summary(result: CalibrateResult, recording: Path, output: Path | None) -> str:
    """The printed summary of the ``calibrate`` job, with units."""
    rate = result.rows / max(result.seconds, 1e-9)
    lines = [f"recording {recording}: {result.rows:,} rows in {result.seconds:.2f} s ({rate / 1000:,.0f}k rows/s)"]
    lines += format_counts(result.session)
    for problem in result.problems:
        lines.append(f"  note: {problem}")
    if result.calibration is None:
        lines.append(f"NO CALIBRATION: {result.error}")
        return "\n".join(lines)
    cal, q = result.calibration, result.calibration.quality
    if q is None:  # CalibrationSession.solve always measures the fit
        raise FtsCalibError("internal error: the calibration has no fit quality")
    lines.append(f"rank {q.rank} of 7, condition number {q.condition_number:.1f} (S_XX scaled to a unit diagonal)")
    rms = zip(WRENCH_AXES, q.residual_rms, WRENCH_UNITS, strict=True)
    lines.append("residual RMS: " + ", ".join(f"{a} {v:.3g} {u}" for a, v, u in rms))
    rel = 100 * q.relative_stderr_C(cal.C)
    lines.append("C (N or N·m per strain unit) ± standard error (% of its row's largest coefficient):")
    rows = [[axis, *[f"{cal.C[i, k]:9.4f} ±{rel[i, k]:.4f}%" for k in range(8)]] for i, axis in enumerate(WRENCH_AXES)]
    lines.append(table(["", *[f"Δ{k + 1}" for k in range(8)]], rows, "  "))
    lines.append(
        "D: " + ", ".join(f"{a} {d:+.5f} ± {s:.1g} {u}" for a, d, s, u in zip(WRENCH_AXES, cal.D, q.stderr_D, WRENCH_UNITS, strict=True))
    )
    if output is not None:
        lines.append(f"wrote {output}")
    return "\n".join(lines)

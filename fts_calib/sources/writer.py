"""Writing recordings (CSV or CSV.gz, the format of :mod:`fts_calib.sources.recording`), atomically.

Columns: ``time`` [s], one per joint [rad], ``strain_1`` ... ``strain_n`` [raw units], ``tool``.
"""

from __future__ import annotations

import gzip
import io
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..core.deprecation import renamed
from ..core.exceptions import ShapeError
from ..core.files import AtomicFile


def strain_columns(n_channels: int) -> tuple[str, ...]:
    """Names of the channel columns of an n-channel sensor: ``strain_1`` ... ``strain_n``."""
    return tuple(f"strain_{k}" for k in range(1, n_channels + 1))


class RecordingWriter:
    """Write a recording (see the module docstring), atomically: the file appears on close.

    Args:
        path: Destination (``.csv`` or ``.csv.gz``).
        joint_names: Joint columns, in order.
        n_channels: Channel columns ``strain_1`` ... ``strain_n``; 8 for the paper's sensor.
        temperature: Whether to write the ``temperature`` column [°C] (after the strains).
    """

    def __init__(self, path: str | Path, joint_names: Sequence[str], n_channels: int = 8, temperature: bool = False):
        self.path = Path(path)
        self.joint_names = list(joint_names)
        self.n_channels = int(n_channels)
        self.temperature = bool(temperature)
        self._file = AtomicFile(self.path)
        self._gzip: gzip.GzipFile | None = None
        heat = ["temperature"] if self.temperature else []
        self.rows = 0
        try:
            self._gzip = gzip.GzipFile(fileobj=self._file.handle, mode="wb") if self.path.suffix == ".gz" else None
            self._handle = io.TextIOWrapper(self._gzip or self._file.handle, encoding="utf-8", newline="")
            self._handle.write(",".join(["time", *self.joint_names, *strain_columns(self.n_channels), *heat, "tool"]) + "\n")
        except BaseException:
            self.abort()
            raise

    @renamed(readings="joints", strain="channels")
    def write(self, time, joints, channels, tool: str | Sequence[str], temperature=None) -> None:
        """Append rows.

        Args:
            time: Times [s], shape (n,).
            joints: Joint joints [rad], shape (n, n_joints).
            channels: Raw channels, shape (n, n_channels).
            tool: One configuration name for all rows, or one per row.
            temperature: Sensor temperatures [°C], shape (n,): required when the file has
                the column, refused otherwise.

        Raises:
            ShapeError: ``channels`` has another number of columns than ``n_channels``, or a
                temperature is missing or not expected.
        """
        time = np.asarray(time, dtype=float)
        if np.shape(channels)[-1] != self.n_channels:
            raise ShapeError(f"channels.shape={np.shape(channels)} but expected (n, {self.n_channels}): the file's channels columns")
        if (temperature is None) == self.temperature:
            has = "has a" if self.temperature else "has no"
            raise ShapeError(f"temperature {'missing' if temperature is None else 'given'}: the file {has} temperature column")
        heat = [] if temperature is None else [np.asarray(temperature, dtype=float).reshape(-1, 1)]
        table = np.column_stack([time, np.asarray(joints, dtype=float), np.asarray(channels, dtype=float), *heat])
        buffer = io.StringIO()
        fmt = ",".join(["%.6f"] + ["%.9f"] * len(self.joint_names) + ["%.9e"] * self.n_channels + ["%.4f"] * len(heat))
        if isinstance(tool, str):
            np.savetxt(buffer, table, fmt=fmt + "," + tool.replace("%", "%%"))
        else:
            for row, name in zip(table, tool, strict=True):
                buffer.write(fmt % tuple(row) + "," + name + "\n")
        self._handle.write(buffer.getvalue())
        self.rows += len(time)

    def close(self) -> Path:
        """Finish the file and move it into place (flushed and fsynced first)."""
        self._handle.flush()
        self._handle.detach()  # the atomic file closes the handle itself, after fsync
        if self._gzip is not None:
            self._gzip.close()  # writes the gzip trailer; the underlying file stays open
        return self._file.commit()

    def abort(self) -> None:
        """Drop the partial file (nothing is left behind, whatever fails on the way: a full disk, say)."""
        handle = getattr(self, "_handle", None)  # None: __init__ failed before making it
        try:
            if handle is not None and not handle.closed:
                handle.detach()  # flushes what is buffered: may fail on a full disk
        except (OSError, ValueError):  # ValueError: already detached by a close that failed
            pass
        try:
            if self._gzip is not None:
                self._gzip.close()
        except OSError:
            pass
        finally:
            self._file.abort()

    def __enter__(self) -> RecordingWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()

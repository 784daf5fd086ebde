"""Recordings (CSV): joint readings and raw strains of a calibration run, streamed in chunks.

Columns (header required): ``time`` [s, non-decreasing], one column per actuated joint
named exactly as in the URDF [rad], ``strain_1`` ... ``strain_8`` [raw units], ``tool`` (a
configuration name of the tool file). Extra columns are ignored with a notice; a missing
one is an error that names it. A name ending in ``.gz`` is read and written compressed.

The reader keeps one chunk in memory (65,536 rows by default) whatever the file's length.
A chunk is parsed by numpy in one call; only when that fails is it parsed line by line, so
that a malformed line (a bad number, a missing value, a truncated last line) is skipped,
counted and reported with its line and column while the run goes on.
"""

from __future__ import annotations

import gzip
import io
import itertools
import os
import tempfile
import warnings
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .exceptions import FtsCalibWarning, RecordingError
from .fileio import new_file_mode

#: Names of the strain columns.
STRAIN_COLUMNS = tuple(f"strain_{k}" for k in range(1, 9))

#: Rows per chunk.
CHUNK_ROWS = 1 << 16

#: Skip reasons counted by the reader.
MALFORMED = "malformed line"
UNKNOWN_TOOL = "unknown tool configuration"


@dataclass(frozen=True)
class RecordingChunk:
    """Consecutive valid rows of a recording.

    Attributes:
        first_line: Line number (1-based, the header is line 1) of the first row read.
        time: Sample times [s]. Shape (n,).
        readings: Joint readings [rad] in the robot's joint order. Shape (n, n_joints).
        strain: Raw strains. Shape (n, 8).
        tool: Index of each row's tool configuration in the tool's order. Shape (n,).
    """

    first_line: int
    time: np.ndarray
    readings: np.ndarray
    strain: np.ndarray
    tool: np.ndarray


class RecordingReader:
    """Read a recording chunk by chunk (see the module docstring).

    Args:
        path: The CSV file.
        joint_names: Joint columns to read, in the robot's order; None for every column that
            is not time, a strain or the tool, in file order.
        tool_names: Tool configuration names, in the tool's order; None to accept any name
            (indices in order of appearance, names in :attr:`tool_names`).
        chunk_rows: Rows per chunk.

    Raises:
        RecordingError: The file is missing or empty, or a required column is missing or
            repeated (the message names it).

    Attributes:
        skipped: Rows skipped so far, by reason.
        problems: The first problems found, each with its line and column, for reporting.
        extra_columns: Columns present but ignored.
    """

    def __init__(self, path: str | Path, joint_names: Sequence[str] | None, tool_names: Sequence[str] | None,
                 chunk_rows: int = CHUNK_ROWS):
        self.path = Path(path)
        self.tool_codes = {name: k for k, name in enumerate(tool_names or [])}
        self._open_tools = tool_names is None
        self.chunk_rows = int(chunk_rows)
        self.skipped: dict[str, int] = {}
        self.problems: list[str] = []
        self.unknown_tools: dict[str, int] = {}
        self.rows_read = 0
        try:
            self.size = self.path.stat().st_size
            self._raw = open(self.path, "rb")
        except FileNotFoundError:
            raise RecordingError(self.path, None, None, "file not found") from None
        except OSError as exc:
            raise RecordingError(self.path, None, None, f"cannot read: {exc.strerror}") from None
        stream = gzip.GzipFile(fileobj=self._raw) if self.path.suffix == ".gz" else self._raw
        self._handle = io.TextIOWrapper(stream, encoding="utf-8", newline="")
        try:
            header = self._handle.readline()
        except (OSError, UnicodeDecodeError) as exc:
            raise RecordingError(self.path, 1, None, f"cannot read the header: {exc}") from None
        self.columns = [c.strip() for c in header.strip().split(",")]
        if joint_names is None:
            joint_names = [c for c in self.columns if c not in ("time", "tool", *STRAIN_COLUMNS)]
        self.joint_names = list(joint_names)
        if not header.strip():
            raise RecordingError(self.path, 1, None, "empty file: expected a header line "
                                 f"'time,{','.join(self.joint_names) or '<joints>'},{','.join(STRAIN_COLUMNS)},tool'")
        required = ["time", *self.joint_names, *STRAIN_COLUMNS, "tool"]
        repeated = sorted({c for c in self.columns if self.columns.count(c) > 1 and c in required})
        if repeated:
            raise RecordingError(self.path, 1, repeated[0], f"column repeated: {repeated}")
        missing = [c for c in required if c not in self.columns]
        if missing:
            raise RecordingError(self.path, 1, missing[0], f"missing column(s) {missing}; the header has {self.columns}")
        self.extra_columns = [c for c in self.columns if c not in required]
        if self.extra_columns:
            warnings.warn(f"{self.path}: ignoring extra columns {self.extra_columns}", FtsCalibWarning, stacklevel=2)
        self._numeric = [self.columns.index(c) for c in ["time", *self.joint_names, *STRAIN_COLUMNS]]
        self._tool_col = self.columns.index("tool")
        self._tool_last = self._tool_col == len(self.columns) - 1
        self._line = 1

    @property
    def tool_names(self) -> list[str]:
        """Tool configuration names, by index."""
        return list(self.tool_codes)

    @property
    def bytes_read(self) -> int:
        """Bytes of the file read so far (for progress)."""
        try:
            return self._raw.tell()
        except (OSError, ValueError):
            return self.size

    def close(self) -> None:
        """Close the file."""
        self._handle.close()

    def __enter__(self) -> RecordingReader:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _skip(self, reason: str, line: int, detail: str) -> None:
        self.skipped[reason] = self.skipped.get(reason, 0) + 1
        if len(self.problems) < 10:
            self.problems.append(f"{self.path}, line {line}: {detail}")

    def __iter__(self) -> Iterator[RecordingChunk]:
        n_joints = len(self.joint_names)
        while True:
            lines = list(itertools.islice(self._handle, self.chunk_rows))
            if not lines:
                return
            first = self._line + 1
            self._line += len(lines)
            table, tools, line_numbers = self._parse_fast(lines, first)
            if table is None:
                table, tools, line_numbers = self._parse_slow(lines, first)
            self.rows_read += len(lines)
            if self._open_tools:
                for name in dict.fromkeys(tools):  # in order of appearance
                    self.tool_codes.setdefault(name, len(self.tool_codes))
            codes = np.array([self.tool_codes.get(name, -1) for name in tools], dtype=np.int64)
            unknown = codes < 0
            if unknown.any():
                for k in np.nonzero(unknown)[0]:
                    name = tools[k]
                    if name not in self.unknown_tools:
                        self._skip(UNKNOWN_TOOL, int(line_numbers[k]), f"column 'tool': unknown tool configuration '{name}' "
                                   f"(known: {', '.join(self.tool_codes)}); its rows are skipped")
                        self.skipped[UNKNOWN_TOOL] -= 1
                    self.unknown_tools[name] = self.unknown_tools.get(name, 0) + 1
                self.skipped[UNKNOWN_TOOL] = self.skipped.get(UNKNOWN_TOOL, 0) + int(unknown.sum())
                keep = ~unknown
                table, codes, line_numbers = table[keep], codes[keep], line_numbers[keep]
            if len(table):
                yield RecordingChunk(int(line_numbers[0]), table[:, 0], table[:, 1:1 + n_joints], table[:, 1 + n_joints:], codes)

    def _parse_fast(self, lines: list[str], first: int):
        if any(not line.endswith("\n") for line in lines[-1:]) or any(not line.strip() for line in lines):
            return None, None, None  # a truncated last line or blank lines: let the careful parser report them
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                table = np.loadtxt(lines, delimiter=",", usecols=self._numeric, dtype=float, ndmin=2)
        except ValueError:
            return None, None, None
        if table.shape[0] != len(lines):
            return None, None, None
        if self._tool_last:
            tools = [line[line.rfind(",") + 1:].strip() for line in lines]
        else:
            tools = [line.split(",")[self._tool_col].strip() for line in lines]
        if any(line.count(",") != len(self.columns) - 1 for line in (lines[0], lines[-1])):
            return None, None, None
        return table, tools, np.arange(first, first + len(lines))

    def _parse_slow(self, lines: list[str], first: int):
        rows, tools, numbers = [], [], []
        width = len(self.columns)
        for offset, line in enumerate(lines):
            number = first + offset
            text = line.rstrip("\r\n")
            if not text.strip():
                self._skip(MALFORMED, number, "empty line")
                continue
            cells = text.split(",")
            if len(cells) != width:
                what = "truncated (no line end)" if not line.endswith("\n") else "malformed"
                self._skip(MALFORMED, number, f"{what}: {len(cells)} values but the header has {width} columns")
                continue
            try:
                rows.append([float(cells[i]) for i in self._numeric])
            except ValueError:
                bad = next(i for i in self._numeric if not _is_number(cells[i]))
                self._skip(MALFORMED, number, f"column '{self.columns[bad]}': '{cells[bad]}' is not a number")
                continue
            tools.append(cells[self._tool_col].strip())
            numbers.append(number)
        return np.array(rows, dtype=float).reshape(-1, len(self._numeric)), tools, np.array(numbers, dtype=np.int64)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


class RecordingWriter:
    """Write a recording (see the module docstring), atomically: the file appears on close.

    Args:
        path: Destination (``.csv`` or ``.csv.gz``).
        joint_names: Joint columns, in order.
    """

    def __init__(self, path: str | Path, joint_names: Sequence[str]):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.joint_names = list(joint_names)
        fd, self._tmp = tempfile.mkstemp(prefix=f".{self.path.name}.", suffix=".tmp", dir=self.path.parent)
        os.close(fd)
        if self.path.suffix == ".gz":
            self._handle = gzip.open(self._tmp, "wt", encoding="utf-8", newline="")
        else:
            self._handle = open(self._tmp, "w", encoding="utf-8", newline="")
        self._handle.write(",".join(["time", *self.joint_names, *STRAIN_COLUMNS, "tool"]) + "\n")
        self.rows = 0

    def write(self, time, readings, strain, tool: str | Sequence[str]) -> None:
        """Append rows.

        Args:
            time: Times [s], shape (n,).
            readings: Joint readings [rad], shape (n, n_joints).
            strain: Raw strains, shape (n, 8).
            tool: One configuration name for all rows, or one per row.
        """
        time = np.asarray(time, dtype=float)
        table = np.column_stack([time, np.asarray(readings, dtype=float), np.asarray(strain, dtype=float)])
        buffer = io.StringIO()
        if isinstance(tool, str):
            np.savetxt(buffer, table, fmt=",".join(["%.6f"] + ["%.9f"] * len(self.joint_names) + ["%.9e"] * 8) + "," +
                       tool.replace("%", "%%"))
        else:
            fmt = ",".join(["%.6f"] + ["%.9f"] * len(self.joint_names) + ["%.9e"] * 8)
            for row, name in zip(table, tool, strict=True):
                buffer.write(fmt % tuple(row) + "," + name + "\n")
        self._handle.write(buffer.getvalue())
        self.rows += len(time)

    def close(self) -> Path:
        """Finish the file and move it into place."""
        self._handle.close()
        os.chmod(self._tmp, new_file_mode())
        os.replace(self._tmp, self.path)
        return self.path

    def abort(self) -> None:
        """Drop the partial file (nothing is left behind)."""
        self._handle.close()
        Path(self._tmp).unlink(missing_ok=True)

    def __enter__(self) -> RecordingWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()

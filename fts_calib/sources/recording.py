"""The problems a recording's reader reports with their line, and the row values it notes.

:class:`ProblemNotes` keeps the first :data:`MAX_NOTES` problems of a file, in line order,
and counts the rest, so that a report can end with "and N more".

:func:`value_problems` finds the rows the session's checks will skip: a non-finite value;
a channel beyond the plausible range; a time earlier than the latest valid time before it
(the checks' rules). The reader passes such rows on (the checks of
:mod:`fts_calib.filters.sample_checks` skip and count them, for every feed); it only names the
first of them, with line and column, so that a user can find them in the file.

Recordings (CSV): joint readings and raw strains of a calibration run, streamed in chunks.

Columns (header required): ``time`` [s, non-decreasing], one column per actuated joint
named exactly as in the URDF [rad], ``strain_1`` ... ``strain_n`` [raw units: n channels,
8 for the paper's sensor, 6 for a factory wrench], ``tool`` (a configuration name of the
tool file), optional ``temperature`` [°C] (the sensor's, for the drift offset model).
Extra columns are ignored with a notice; a missing one is an error that names it (with a
hint when the file is delimited by ';' or tabs). A name ending in ``.gz`` is written
compressed; a file is read compressed when its content is gzip, whatever its name (a
mismatch is warned about), and a UTF-8 byte-order mark before the header is ignored. A
compressed file that ends early (truncated) is refused: its last rows cannot be read.

The reader keeps one block of the file in memory (8 MiB, whole lines) whatever the file's
length. A block is parsed by pandas' C parser in one call (about five times faster than
numpy's loadtxt, which is what lets a 2-core machine calibrate from 250,000 rows a second);
only when that fails is it parsed line by line, so that a malformed line (a bad number, a
missing value, a truncated last line) is skipped, counted and reported with its line and
column while the run goes on. Rows with a non-finite value, a channel beyond
``max_abs_channel`` or a time earlier than a row before them are passed on (the session's
checks skip and count them) and noted with their line and column. The first problems
are kept in :attr:`RecordingReader.problems` (:mod:`fts_calib.sources.recording`);
:meth:`RecordingReader.notes` ends them with how many more were found.

A CSV recording that gives the sensor's orientation instead of joint angles (:mod:`fts_calib.robot.orientation`).
"""

from __future__ import annotations

import gzip
import io
import math
import warnings
import zlib
from collections import Counter
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from ..core.bounded import MAX_CHANNELS, MAX_COLUMNS
from ..core.exceptions import FtsCalibWarning, RecordingError
from ..core.files import is_number
from .batch import DUPLICATE, UNKNOWN_TOOL, SampleBatch, repeated_rows
from .writer import RecordingWriter, strain_columns

#: Problems kept with their line for reporting; the others are only counted.
MAX_NOTES = 10


class ProblemNotes:
    """The first problems of a file with their line, and how many more there are.

    Problems are noted chunk by chunk, each kind in line order; :meth:`flush` at the end of
    a chunk keeps the earliest lines of the chunk's notes.

    Args:
        path: The file, named in every note.

    Attributes:
        problems: The first :data:`MAX_NOTES` problems, each as ``"PATH, line N: detail"``.
        unlisted: Problems found beyond those.
    """

    def __init__(self, path: Path):
        self.path = path
        self.problems: list[str] = []
        self.unlisted = 0
        self._pending: list[tuple[int, str]] = []  # (line, text) of the current chunk
        self._kinds: Counter[str] = Counter()  # problems of the current chunk, by kind

    def note(self, line: int, detail: str, kind: str = "") -> None:
        """A problem of the current chunk, at ``line`` (1-based)."""
        self._kinds[kind] += 1
        if self._kinds[kind] <= MAX_NOTES:  # each kind arrives in line order: only its first can be listed
            self._pending.append((line, f"{self.path}, line {line}: {detail}"))

    def count(self, n: int, kind: str) -> None:
        """``n`` more problems of ``kind`` in the current chunk, not described."""
        self._kinds[kind] += n

    def flush(self) -> None:
        """End of a chunk: keep its earliest notes while there is room, count the others."""
        self._pending.sort()
        listed = [text for _, text in self._pending[: max(MAX_NOTES - len(self.problems), 0)]]
        self.problems += listed
        self.unlisted += sum(self._kinds.values()) - len(listed)
        self._pending = []
        self._kinds.clear()

    def lines(self) -> list[str]:
        """The problems kept, then how many more were found (when any): for a report."""
        more = [f"and {self.unlisted:,} more problem(s) not listed (the counts by reason are complete)"] if self.unlisted else []
        return [*self.problems, *more]


def value_problems(
    table: np.ndarray, names: Sequence[str], n_joints: int, max_abs_channel: float, last_time: float, limit: int
) -> tuple[list[tuple[int, str, str]], dict[str, int], float]:
    """The rows of a parsed block that the session's checks will skip, and why.

    Args:
        table: Numeric rows: time [s], joints [rad], channels [raw]. Shape (N, 1 + n_joints + n_channels).
        names: The column name of each entry of a row. Length 1 + n_joints + n_channels.
        n_joints: Number of joint columns.
        max_abs_channel: Largest plausible magnitude of a channel, in raw units.
        last_time: Latest time of a valid row before the block [s] (-inf: none).
        limit: Rows described per kind of problem (the others are only counted).

    Returns:
        ``(problems, counts, last_time)``: up to ``limit`` per kind of (row index, kind,
        description), in row order per kind; how many problems of each kind in all; the
        latest valid time after the block.
    """
    found: list[tuple[int, str, str]] = []
    finite = np.isfinite(table)
    finite_rows = finite.all(axis=1)
    bad = np.nonzero(~finite_rows)[0]
    for row in bad[:limit]:
        k = int(np.argmin(finite[row]))
        found.append((int(row), "non-finite", f"column '{names[k]}': {table[row, k]} is not a finite number; the sample is skipped"))
    with np.errstate(invalid="ignore"):
        beyond = np.abs(table[:, 1 + n_joints :]) > max_abs_channel
    large = np.nonzero(beyond.any(axis=1) & finite_rows)[0]
    for row in large[:limit]:
        k = 1 + n_joints + int(np.argmax(beyond[row]))
        found.append(
            (
                int(row),
                "out of range",
                f"column '{names[k]}': {table[row, k]:.3g} is beyond ±{max_abs_channel:.3g}, the plausible range of a channel "
                "(checks.max_abs_channel); the sample is skipped",
            )
        )
    # time order as the checks see it: valid rows only, each against the latest valid time before it
    time = np.where(finite_rows & ~beyond.any(axis=1), table[:, 0], -np.inf)
    latest = np.maximum.accumulate(np.concatenate([[last_time], time]))
    back = np.nonzero(np.isfinite(time) & (time < latest[:-1]))[0]
    for row in back[:limit]:
        found.append(
            (
                int(row),
                "backwards",
                f"column 'time': {table[row, 0]:.6g} s is earlier than {latest[row]:.6g} s before it (time going backwards); "
                "the sample is skipped",
            )
        )
    return found, {"non-finite": len(bad), "out of range": len(large), "backwards": len(back)}, float(latest[-1])


__all__ = ["MALFORMED", "UNKNOWN_TOOL", "RecordingReader", "RecordingWriter", "strain_columns", "unlogged_joints_hint"]


def unlogged_joints_hint(missing: Sequence[str]) -> str:
    """A clause for joints of the robot that a log does not hold: the robot file's ``locked_joints`` holds them fixed.

    Args:
        missing: The robot's joints the log has no column (or field) for; '' when empty.
    """
    if not missing:
        return ""
    them = "it" if len(missing) == 1 else "them"
    values = ", ".join(f"{name}: VALUE" for name in missing)
    return (
        f"; a joint the robot does not log (a gripper's fingers, a joint that never moves) is held fixed by the robot file's "
        f"locked_joints: lock {them} at the value the run holds (rad or m), 'locked_joints: {{{values}}}'"
    )


def _header_channels(columns: Sequence[str]) -> int:
    """n: the largest k of the header's ``strain_k`` columns (8 when there is none, for the message)."""
    found = [int(c[7:]) for c in columns if c.startswith("strain_") and c[7:].isdigit() and len(c) <= 12 and int(c[7:]) >= 1]
    return max(found) if found else 8


#: Bytes read at a time: about 36,000 rows of a six-joint recording.
BLOCK_BYTES = 8 << 20

_GZIP_MAGIC = b"\x1f\x8b"

#: Skip reasons counted by the reader.
MALFORMED = "malformed line"


class RecordingReader:
    """Read a recording chunk by chunk, as :class:`SampleBatch` es (see the module docstring).

    Args:
        path: The CSV file.
        joint_names: Joint columns to read, in the robot's order; None for every column that
            is not time, a strain or the tool, in file order.
        tool_names: Tool configuration names, in the tool's order; None to accept any name
            (indices in order of appearance, names in :attr:`tool_names`).
        block_bytes: Bytes read at a time (a chunk is the whole lines they hold).
        max_abs_channel: Largest plausible magnitude of a channel, in raw units: a row with
            a channel beyond it is noted (the session's checks skip it); None for no limit.

    Raises:
        RecordingError: The file is missing, empty, not text, or a required column is
            missing or repeated (the message names it); while iterating, the file has no
            data row, or its compressed stream ends early.

    Attributes:
        skipped: Rows skipped so far, by reason.
        extra_columns: Columns present but ignored.
        rows_by_tool: Rows read so far per tool configuration name (a malformed row whose
            tool cell can be read included).
        bad_cells: Rows skipped for a cell that is empty or not a number, per (tool
            configuration name, column): what :meth:`unusable_configurations` reports.
    """

    def __init__(
        self,
        path: str | Path,
        joint_names: Sequence[str] | None,
        tool_names: Sequence[str] | None,
        block_bytes: int = BLOCK_BYTES,
        max_abs_channel: float | None = None,
    ):
        self.path = Path(path)
        self.max_abs_channel = math.inf if max_abs_channel is None else float(max_abs_channel)
        self.tool_codes = {name: k for k, name in enumerate(tool_names or [])}
        self._open_tools = tool_names is None
        self.block_bytes = int(block_bytes)
        self.skipped: Counter[str] = Counter()
        self._notes = ProblemNotes(self.path)
        self._last_time = -math.inf  # latest time of a valid row so far [s]
        self.unknown_tools: Counter[str] = Counter()
        self.rows_by_tool: Counter[str] = Counter()
        self.bad_cells: Counter[tuple[str, str]] = Counter()
        self.rows_read = 0
        try:
            self.size = self.path.stat().st_size
            self._raw = open(self.path, "rb")
        except FileNotFoundError:
            raise RecordingError(self.path, None, None, "file not found") from None
        except OSError as exc:
            raise RecordingError(self.path, None, None, f"cannot read: {exc.strerror}") from None
        self.compressed = self._raw.read(2) == _GZIP_MAGIC  # the content decides, not the name
        self._raw.seek(0)
        if self.compressed != (self.path.suffix == ".gz"):
            actual = "gzip-compressed" if self.compressed else "not compressed"
            message = f"{self.path}: the file is {actual} although its name ends in '{self.path.suffix}'; read as such"
            warnings.warn(message, FtsCalibWarning, stacklevel=2)
        self._stream = gzip.GzipFile(fileobj=self._raw) if self.compressed else self._raw
        try:
            raw_header = self._stream.readline(1 << 20)
            header = raw_header.decode("utf-8").removeprefix("\ufeff")  # a byte-order mark (Excel's UTF-8 CSV)
        except UnicodeDecodeError as exc:
            byte = exc.object[exc.start : exc.start + 1].hex()
            message = f"not a text CSV file (byte 0x{byte} at offset {exc.start} is not UTF-8): expected a comma-separated recording"
            raise RecordingError(self.path, 1, None, message) from None
        except (OSError, EOFError, zlib.error) as exc:
            raise RecordingError(self.path, 1, None, f"cannot read the header: {exc}") from None
        if header.count(",") >= MAX_COLUMNS:  # before any work on the columns (a 1 MB header)
            message = (
                f"the header has more than {MAX_COLUMNS:,} columns, the most a recording may have (time, the joints, "
                f"at most {MAX_CHANNELS} strain columns, tool, temperature): not a recording's header"
            )
            raise RecordingError(self.path, 1, None, message)
        self.columns = [c.strip() for c in header.strip().split(",")]
        #: Number of channels: the header's strain_1 ... strain_n columns.
        self.n_channels = _header_channels(self.columns)
        too_many = next(
            (c for c in self.columns if c.startswith("strain_") and c[7:].isdigit() and (len(c) > 12 or int(c[7:]) > MAX_CHANNELS)), None
        )
        if too_many is not None:
            raise RecordingError(
                self.path, 1, too_many[:24], f"a channel number beyond {MAX_CHANNELS}, the most channels a sensor may have"
            )
        self.strain_columns = strain_columns(self.n_channels)
        #: Whether the file has the optional ``temperature`` column (sensor temperature, °C).
        self.has_temperature = "temperature" in self.columns
        if joint_names is None:
            joint_names = [c for c in self.columns if c not in ("time", "tool", "temperature", *self.strain_columns)]
        self.joint_names = list(joint_names)
        if not header.strip():
            expected = ",".join(["time", *(self.joint_names or ["<joints>"]), "strain_1", "...", "strain_n", "tool"])
            raise RecordingError(self.path, 1, None, f"empty file: expected a header line '{expected}'")
        required = ["time", *self.joint_names, *self.strain_columns, "tool"]
        counts = Counter(self.columns)  # linear in the columns: the header may be long
        repeated = sorted(c for c in set(required) if counts[c] > 1)
        if repeated:
            raise RecordingError(self.path, 1, repeated[0], f"column repeated: {repeated}")
        missing = [c for c in required if c not in counts]
        if missing:
            delimiter = next((name for d, name in ((";", "';'"), ("\t", "tabs")) if len(self.columns) == 1 and d in header), None)
            hint = (
                f": the file is delimited by {delimiter}, but a recording is comma-separated ('.' as the decimal mark)"
                if delimiter
                else f"; the header has {self.columns}"
            )
            hint += unlogged_joints_hint([c for c in missing if c in self.joint_names])
            raise RecordingError(self.path, 1, missing[0], f"missing column(s) {missing}{hint}")
        known = {*required, "temperature"}
        self.extra_columns = [c for c in self.columns if c not in known]
        if self.extra_columns:
            warnings.warn(f"{self.path}: ignoring extra columns {self.extra_columns}", FtsCalibWarning, stacklevel=2)
        self._numeric = [self.columns.index(c) for c in self._numeric_names]
        self._tool_col = self.columns.index("tool")
        # numeric columns as float, the rest as text (the parser then refuses a bad number)
        self._dtypes = {c: (np.float64 if k in self._numeric else str) for k, c in enumerate(self.columns)}
        self._line = 1
        self._previous_row: np.ndarray | None = None  # the last row read (numbers and configuration), for repeats

    @property
    def _numeric_names(self) -> list[str]:
        """The numeric columns, in the order of a parsed row: time, joints, strains, then temperature when present."""
        return ["time", *self.joint_names, *self.strain_columns, *(["temperature"] if self.has_temperature else [])]

    @property
    def tool_names(self) -> list[str]:
        """Tool configuration names, by index."""
        return list(self.tool_codes)

    @property
    def description(self) -> str:
        """The recording in words, for messages and provenance: its path."""
        return str(self.path)

    @property
    def bytes_read(self) -> int:
        """Bytes of the file read so far (for progress)."""
        try:
            return self._raw.tell()
        except (OSError, ValueError):
            return self.size

    def close(self) -> None:
        """Close the file."""
        self._stream.close()
        self._raw.close()

    def __enter__(self) -> RecordingReader:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def problems(self) -> list[str]:
        """The first problems found, each with its line and column."""
        return self._notes.problems

    @property
    def unlisted(self) -> int:
        """Problems found beyond those in :attr:`problems`."""
        return self._notes.unlisted

    def notes(self) -> list[str]:
        """The problems kept, then how many more were found (when any): for a report."""
        return self._notes.lines()

    def unusable_configurations(self) -> list[str]:
        """The tool configurations none of whose rows could be read, each in words with the column at fault.

        E.g. a ``temperature`` column left empty on every row of configuration B: the
        configuration is then missing from the calibration for that reason alone, not for
        a tool file or a motion that is wrong.
        """
        out = []
        for name, rows in self.rows_by_tool.items():
            bad = Counter({column: n for (tool, column), n in self.bad_cells.items() if tool == name})
            if not rows or sum(bad.values()) < rows:
                continue
            column, count = bad.most_common(1)[0]
            why = (
                "the temperature is needed on every row once the file has the column: fill it in, or remove the column"
                if column == "temperature"
                else "fix that column"
            )
            also = f" (and {rows - count:,} rows for other columns)" if count < rows else ""
            out.append(
                f"configuration {name} has no usable row in {self.path.name}: column '{column}' is empty or not a number on "
                f"{count:,} of its {rows:,} rows{also}, so it is missing from the calibration; {why}"
            )
        return out

    def _skip(self, reason: str, line: int, detail: str) -> None:
        self.skipped[reason] += 1
        self._notes.note(line, detail, reason)

    def _read(self, size: int) -> bytes:
        if not self.compressed:
            return self._stream.read(size)
        parts: list[bytes] = []  # read1 by read1: at a truncation, what came before is known
        try:
            while sum(map(len, parts)) < size and (part := self._stream.read1(size)):
                parts.append(part)
        except (EOFError, OSError, zlib.error):
            line = self._line + sum(p.count(b"\n") for p in parts)
            message = (
                f"the compressed stream ends before its end marker: the file is truncated or damaged after line {line}; "
                f"`gzip -dc {self.path.name} > recovered.csv` saves the rows before it"
            )
            raise RecordingError(self.path, None, None, message) from None
        return b"".join(parts)

    def __iter__(self) -> Iterator[SampleBatch]:
        n_joints = len(self.joint_names)
        rest = b""
        while True:
            data = self._read(self.block_bytes)
            if not data:
                if rest.strip():  # a last line without a line end: kept when it is complete
                    yield from self._chunks([rest.decode("utf-8", "replace")], n_joints, fast=False, final=True)
                if self.rows_read == 0:
                    raise RecordingError(self.path, 2, None, "no data rows: the file has a header line and nothing after it")
                return
            data = rest + data
            cut = data.rfind(b"\n") + 1
            block, rest = data[:cut], data[cut:]
            if block:
                yield from self._chunks(block, n_joints, fast=True, final=False)

    def _chunks(self, block, n_joints: int, fast: bool, final: bool) -> Iterator[SampleBatch]:
        first = self._line + 1
        table = None
        if fast:
            count = block.count(b"\n")
            self._line += count
            table, categories, index = self._parse_fast(block, count)
            if table is None:
                block = block.decode("utf-8", "replace").splitlines(keepends=True)
        else:
            self._line += len(block)
        if table is not None:
            numbers = np.arange(first, first + len(table))
        else:
            table, tools, numbers = self._parse_slow(block, first, final)
            categories, index = np.unique(np.array(tools, dtype=object), return_inverse=True) if tools else ([], np.zeros(0, int))
        self.rows_read += int(self._line - first + 1)
        for category, count in zip(categories, np.bincount(index, minlength=len(categories)), strict=True):
            self.rows_by_tool[str(category).strip()] += int(count)
        codes = self._codes(list(categories), index)
        unknown = codes < 0
        if unknown.any():
            for category in np.unique(index[unknown]):  # each unknown name once, at its first row
                rows = np.nonzero(index == category)[0]
                name = str(categories[category]).strip()
                if name not in self.unknown_tools:
                    known = ", ".join(self.tool_codes)
                    detail = f"column 'tool': unknown tool configuration '{name}' (known: {known}); its rows are skipped"
                    self._notes.note(int(numbers[rows[0]]), detail, "tool")
                self.unknown_tools[name] += len(rows)
            self.skipped[UNKNOWN_TOOL] += int(unknown.sum())
            keep = ~unknown
            table, codes, numbers = table[keep], codes[keep], numbers[keep]
        full = np.column_stack((table, codes))
        repeated = repeated_rows(full, self._previous_row)
        if len(full):
            self._previous_row = full[-1]
        if repeated.any():
            count = int(repeated.sum())
            self.skipped[DUPLICATE] += count
            self._notes.note(int(numbers[np.argmax(repeated)]), "the same values as the row before it: dropped (counted once)", DUPLICATE)
            self._notes.count(count - 1, DUPLICATE)
            table, codes, numbers = table[~repeated], codes[~repeated], numbers[~repeated]
        self._note_values(table, numbers)
        self._notes.flush()
        if len(table):
            channels = table[:, 1 + n_joints : 1 + n_joints + self.n_channels]
            temperature = table[:, -1] if self.has_temperature else None
            yield SampleBatch(table[:, 0], table[:, 1 : 1 + n_joints], channels, codes, temperature, first_line=int(numbers[0]))

    def _note_values(self, table: np.ndarray, numbers: np.ndarray) -> None:
        """Note the rows the session's checks will skip (see :func:`fts_calib.sources.recording.value_problems`)."""
        names = self._numeric_names
        n_joints, bound = len(self.joint_names), self.max_abs_channel
        found, counts, self._last_time = value_problems(table, names, n_joints, bound, self._last_time, MAX_NOTES)
        for row, kind, detail in found:
            self._notes.note(int(numbers[row]), detail, kind)
        for kind, count in counts.items():
            self._notes.count(count - sum(1 for _, k, _ in found if k == kind), kind)

    def _codes(self, categories: list, index: np.ndarray) -> np.ndarray:
        """Configuration indices of rows given as (distinct names, index of each row's name)."""
        names = [str(c).strip() for c in categories]
        if self._open_tools:
            for name in names:
                self.tool_codes.setdefault(name, len(self.tool_codes))
        lookup = np.array([self.tool_codes.get(name, -1) for name in names], dtype=np.int64)
        return lookup[index] if len(index) else np.zeros(0, dtype=np.int64)

    def _parse_fast(self, block: bytes, count: int):
        """The whole block with pandas' C parser; Nones when any line is not clean.

        Returns the numeric table (rows, 1 + n_joints + n_channels), the distinct tool names (in order
        of appearance) and each row's index into them.
        """
        import pandas as pd  # here: the parser of the command line and the bag reader need none of it

        try:
            frame = pd.read_csv(
                io.BytesIO(block), header=None, names=self.columns, dtype=self._dtypes, na_filter=False, skip_blank_lines=False, engine="c"
            )
        except (ValueError, pd.errors.ParserError):
            return None, None, None
        if len(frame) != count or (frame[self.columns[-1]] == "").any():
            return None, None, None  # a short line leaves its last columns empty
        index, categories = pd.factorize(frame["tool"])
        return frame.iloc[:, self._numeric].to_numpy(dtype=float), list(categories), index

    def _parse_slow(self, lines: list[str], first: int, final: bool):
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
                what = "truncated (no line end)" if final and not line.endswith("\n") else "malformed"
                self._skip(MALFORMED, number, f"{what}: {len(cells)} values but the header has {width} columns")
                continue
            try:
                rows.append([float(cells[i]) for i in self._numeric])
            except ValueError:
                bad = next(i for i in self._numeric if not is_number(cells[i]))
                self._skip(MALFORMED, number, f"column '{self.columns[bad]}': '{cells[bad]}' is not a number")
                tool = cells[self._tool_col].strip()
                self.rows_by_tool[tool] += 1
                self.bad_cells[tool, self.columns[bad]] += 1
                continue
            tools.append(cells[self._tool_col].strip())
            numbers.append(number)
        return np.array(rows, dtype=float).reshape(-1, len(self._numeric)), tools, np.array(numbers, dtype=np.int64)

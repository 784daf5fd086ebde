"""Several CSV recordings read as one: a static-pose dataset of one file per pose, and globs.

A recording argument may name several CSV files (``a.csv b.csv ...``) and patterns
(``'poses/*.csv'``, quoted so that the program expands them: on every shell, and past the
shell's limit on the length of a command line). The rules:

- **Patterns.** An argument that names no file and holds ``*``, ``?`` or ``[`` is a pattern:
  its matches are taken in natural order (``pose_2.csv`` before ``pose_10.csv``); a pattern
  that matches nothing is an error that names it.
- **Order.** The files are read in the order given (each pattern's matches in their place).
- **Times.** Each file's times are its own: a logger that starts at 0 in every file, or a
  clock that runs on. A file whose first time is not at least :data:`FILE_GAP_S` after the
  previous file's last time (times restarting at 0, or overlapping) is shifted, as a
  whole, to start :data:`FILE_GAP_S` after it; a file that starts later keeps its times.
  So time increases through the set, and a file boundary is a gap: the quasi-static
  filter's windows never span two files, and each file starts a new held-out unit of the
  model choice (:mod:`fts_calib.session.held_out`). The drift offset model sees the files
  back to back; the time the arm took between them is unknown and not counted.
- **What each file holds.** Every file has the same channels (``strain_1..n``), the same
  joint columns (or the same orientation form), the same optional ``temperature`` column
  (present in all or in none) and, like a single
  recording, the joints (or an orientation form) and a ``tool`` column that names each
  row's configuration. A file that differs, an empty file (no header, or a header and no
  row) or a file that cannot be read is an error that names it.
- **The same file twice** (by path, or by content: a copy) is an error that names both: its
  samples would count twice and its poses would be held out as two units.

A file none of whose samples the filter keeps is counted and named by the ``calibrate``
job (:func:`fts_calib.session.calibration_run.calibrate_recording`), and the run goes on.
"""

from __future__ import annotations

import dataclasses
import glob
import hashlib
import math
import re
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..core.exceptions import RecordingError
from .batch import SampleBatch
from .recording import MAX_NOTES

if TYPE_CHECKING:
    from .recording import RecordingReader


#: A file of a set starts at least this long after the previous one ends, [s]: longer than
#: the held-out unit gap (0.5 s) and than the filter's windows (0.1 s).
FILE_GAP_S = 1.0

#: Bytes of a file's start compared to find a copy given twice.
COMPARED_BYTES = 1 << 16

_PATTERN = re.compile(r"[*?[]")


def natural_key(path: str) -> list:
    """Sort key of a path in natural order: runs of digits compare as numbers (``pose_2`` < ``pose_10``)."""
    return [int(part) if part.isdigit() else part for part in re.split(r"(\d+)", str(path))]


def describe_files(paths: Sequence[str | Path]) -> str:
    """Recordings in words for a summary: one or a few by name, more as the first ... the last (N files)."""
    names = [str(p) for p in paths]
    return " ".join(names) if len(names) <= 3 else f"{names[0]} ... {names[-1]} ({len(names)} files)"


def expand_patterns(given: Sequence[str | Path]) -> list[str | Path]:
    """The recording arguments with each pattern replaced by its matches, in natural order.

    Args:
        given: Paths (kept as they are), or patterns: an argument that names no file or
            folder and holds ``*``, ``?`` or ``[``.

    Raises:
        RecordingError: A pattern matches no file (the message names it).
    """
    out: list[str | Path] = []
    for item in given:
        text = str(item)
        if Path(text).exists() or not _PATTERN.search(text):
            out.append(item)
            continue
        matches = sorted(glob.glob(text, recursive=True), key=natural_key)
        if not matches:
            folder = Path(text).parent
            where = f"folder {folder} does not exist" if not folder.exists() else f"nothing in {folder} matches"
            message = f"no file matches the pattern '{Path(text).name}' ({where}): expected one recording per pose, e.g. 'poses/*.csv'"
            raise RecordingError(Path(text), None, None, message)
        out.extend(matches)
    return out


def refuse_repeated_files(paths: Sequence[Path]) -> None:
    """Refuse a file given twice, by path or by content (see the module docstring).

    Raises:
        RecordingError: Naming the file and the earlier one it repeats.
    """
    seen: dict[Path, Path] = {}
    heads: dict[tuple[int, str], Path] = {}
    for path in paths:
        if not path.is_file():
            continue  # the reader says why
        resolved = path.resolve()
        if resolved in seen:
            message = f"given twice (also as {seen[resolved]}): each file is read once; its samples would count twice"
            raise RecordingError(path, None, None, message)
        seen[resolved] = path
        with path.open("rb") as handle:
            key = (path.stat().st_size, hashlib.sha256(handle.read(COMPARED_BYTES)).hexdigest())
        if key in heads:
            message = (
                f"the same content as {heads[key]} (a copy?): its samples would count twice and its poses "
                "be held out as two; give each file once"
            )
            raise RecordingError(path, None, None, message)
        heads[key] = path


class RecordingSet:
    """Several CSV recordings read as one stream of :class:`SampleBatch` es (see the module docstring).

    The interface of :class:`fts_calib.sources.recording.RecordingReader` (iterate, then read
    :attr:`skipped`, :meth:`notes`, ...). Every file's header is read and checked when the
    set is made, so that a file that does not fit is refused before any work.

    Args:
        paths: The CSV files, in order (patterns already expanded).
        open_one: Opens one file as a reader (a
            :class:`~fts_calib.sources.recording.RecordingReader`, or one of orientations).

    Raises:
        RecordingError: A file given twice, a file that cannot be read, or one whose
            channels, joint (or orientation) columns or temperature column differ from the
            first file's (naming both).

    Attributes:
        starts: The first time after its shift [s] of each file read so far that has one.
        shifted: How many files were shifted in time to follow the previous one.
    """

    def __init__(self, paths: Sequence[str | Path], open_one: Callable[[Path], RecordingReader]):
        self.paths = [Path(p) for p in paths]
        refuse_repeated_files(self.paths)
        self._open_one = open_one
        self._done: list[RecordingReader] = []
        self.size = 0
        first = None
        self.tool_codes: dict[str, int] = {}
        for path in self.paths:
            with open_one(path) as reader:
                self.size += reader.size
                if not reader.compressed and reader.bytes_read >= reader.size:  # found before any work (a .gz: when read)
                    raise RecordingError(path, 2, None, "no data rows: the file has a header line and nothing after it")
                if first is None:
                    first = reader
                    self.joint_names, self.columns = reader.joint_names, reader.columns
                    self.n_channels, self.has_temperature = reader.n_channels, reader.has_temperature
                    self.tool_codes = dict(reader.tool_codes)  # the tool's names, or none yet (any accepted)
                    continue
                if reader.n_channels != first.n_channels:
                    message = f"{reader.n_channels} channels (strain_1..{reader.n_channels}), but {first.path} has {first.n_channels}"
                    raise RecordingError(path, 1, None, message + ": every file of a recording is of the same sensor")
                if list(reader.joint_names) != list(first.joint_names):
                    message = f"joint (or orientation) columns {list(reader.joint_names)}, but {first.path} has {list(first.joint_names)}"
                    raise RecordingError(path, 1, None, message + ": every file of a recording gives the same")
                if reader.has_temperature != first.has_temperature:
                    has, lacks = (path, first.path) if reader.has_temperature else (first.path, path)
                    message = f"{has} has a temperature column and {lacks} has none: give it in every file or in none"
                    raise RecordingError(path, 1, "temperature", message)
        self._current: RecordingReader | None = None
        self.starts: list[float] = []
        self._started: list[int] = []  # the index in paths of each entry of starts
        self.shifted = 0

    @property
    def path(self) -> Path:
        """The file being read (the first before reading, the last after)."""
        if self._current is not None:
            return self._current.path
        return self._done[-1].path if self._done else self.paths[0]

    @property
    def _readers(self) -> list[RecordingReader]:
        return [*self._done, *([self._current] if self._current is not None else [])]

    @property
    def tool_names(self) -> list[str]:
        """Tool configuration names, by index (shared by every file)."""
        return list(self.tool_codes)

    @property
    def description(self) -> str:
        """The files in words, for messages and provenance (:func:`describe_files`)."""
        return describe_files(self.paths)

    @property
    def bytes_read(self) -> int:
        """Bytes of the files read so far (for progress)."""
        return sum(r.size for r in self._done) + (self._current.bytes_read if self._current is not None else 0)

    @property
    def rows_read(self) -> int:
        """Rows read so far, over the files."""
        return sum(r.rows_read for r in self._readers)

    @property
    def skipped(self) -> Counter[str]:
        """Rows skipped so far by reason, over the files."""
        return sum((r.skipped for r in self._readers), Counter())

    @property
    def extra_columns(self) -> list[str]:
        """Columns ignored in any file."""
        return sorted({c for r in self._readers for c in r.extra_columns})

    def notes(self) -> list[str]:
        """How the files were put together, then the first problems over the files (each with file and line)."""
        shifted = (
            f"; the times of {self.shifted} shifted to follow the previous file {FILE_GAP_S:g} s after its end "
            "(each file starts a new held-out unit)"
            if self.shifted
            else ""
        )
        head = [f"{len(self.paths)} files read in the order given{shifted}"]
        problems = [p for r in self._readers for p in r.problems]
        unlisted = sum(r.unlisted for r in self._readers) + max(len(problems) - MAX_NOTES, 0)
        more = [f"and {unlisted:,} more problem(s) not listed (the counts by reason are complete)"] if unlisted else []
        return [*head, *problems[:MAX_NOTES], *more]

    def unusable_configurations(self) -> list[str]:
        """The configurations none of whose rows could be read in any file, in words (see the reader's)."""
        readers = self._readers
        usable = {
            name
            for r in readers
            for name, rows in r.rows_by_tool.items()
            if rows > sum(n for (tool, _), n in r.bad_cells.items() if tool == name)
        }
        out, said = [], set()
        for r in readers:
            found = r.unusable_configurations()
            names = [n for n, rows in r.rows_by_tool.items() if rows and sum(v for (t, _), v in r.bad_cells.items() if t == n) >= rows]
            for name, line in zip(names, found, strict=False):
                if name not in usable and name not in said:
                    said.add(name)
                    out.append(line)
        return out

    def file_of(self, time: np.ndarray) -> np.ndarray:
        """Index in :attr:`paths` of the file each (shifted) time belongs to (-1 before the first), shape like ``time``."""
        k = np.searchsorted(np.asarray(self.starts), np.asarray(time, dtype=float), side="right") - 1
        return np.where(k >= 0, np.asarray([*self._started, -1])[k], -1)

    def close(self) -> None:
        """Close the file being read."""
        if self._current is not None:
            self._current.close()

    def __enter__(self) -> RecordingSet:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __iter__(self) -> Iterator[SampleBatch]:
        last = -math.inf  # the latest (shifted) time so far [s]
        for index, path in enumerate(self.paths):
            reader = self._open_one(path)
            reader.tool_codes = self.tool_codes  # one numbering of the configurations over the files
            self._current = reader
            shift: float | None = None
            with reader:
                for chunk in reader:
                    finite = chunk.time[np.isfinite(chunk.time)]
                    if shift is None:
                        if not len(finite):
                            yield chunk  # no time yet: the checks skip these rows
                            continue
                        earliest = last + FILE_GAP_S
                        shift = 0.0 if float(finite[0]) >= earliest else earliest - float(finite[0])
                        self.shifted += shift > 0
                        self.starts.append(float(finite[0]) + shift)
                        self._started.append(index)
                    if len(finite):
                        last = max(last, float(finite.max()) + shift)
                    yield dataclasses.replace(chunk, time=chunk.time + shift) if shift else chunk
            self._done.append(reader)
            self._current = None

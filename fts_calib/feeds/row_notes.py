"""The problems a recording's reader reports with their line, and the row values it notes.

:class:`ProblemNotes` keeps the first :data:`MAX_NOTES` problems of a file, in line order,
and counts the rest, so that a report can end with "and N more".

:func:`value_problems` finds the rows the session's checks will skip: a non-finite value;
a channel beyond the plausible range; a time earlier than the latest valid time before it
(the checks' rules). The reader passes such rows on (the checks of
:mod:`fts_calib.pipeline.checks` skip and count them, for every feed); it only names the
first of them, with line and column, so that a user can find them in the file.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from pathlib import Path

import numpy as np

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

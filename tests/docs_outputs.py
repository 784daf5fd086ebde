"""The printed examples of README.md and docs/: run them again and compare, or write them again.

A page marks what it shows with one-line HTML comments (invisible once rendered), run in
page order in a fresh, empty folder, as a user would from anywhere: shipped robots, tools,
configs and plans are named (``--robot ur5``, ``--trajectory ur5``), never reached through
the checkout's folders:

- ``<!-- doc-file: NAME -->`` before a fenced block: the block is written to NAME (a robot
  or tool YAML a later command reads).
- ``<!-- doc-run: fts-calib ARGS -->``: a command run for what it writes; its output is not shown.
- ``<!-- doc-show: NAME -->`` before a fenced block: the block shows the file NAME that an
  earlier command wrote (compared as an output is).
- ``<!-- doc-output: fts-calib ARGS -->`` before a fenced block: the block is what the
  command prints (standard output, then standard error). Options after the kind:
  ``rtol=0.05`` (the numbers' tolerance), ``exit=15`` (the exit status it must end with; 0
  unless given, for every kind).

Every ``fts-calib`` command of a ```sh block that follows a ``<!-- doc-commands -->`` marker
runs too, in order (the README's own-robot steps run as a user types them).

A printed block matches the output when, line by line, the text between the numbers is the
same (runs of spaces count as one) and every number is within ``rtol`` of the printed one
(relative, default 1 %) or within two units of its last printed digit; a line ``...``
stands for any number of lines. ``python -m tests.docs_outputs --write [PAGE ...]`` runs the
pages and writes each block again from the output, keeping its ``...`` lines where the rest
still matches.
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import re
import shlex
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MARKER = re.compile(r"^<!-- doc-(file|run|output|show|commands)((?: \w+=[^\s:]+)*):?\s*(.*?)\s*-->\s*$")
FENCE = re.compile(r"^(```+|~~~+)(\S*)\s*$")
NUMBER = re.compile(r"[-+]?(?:\d{1,3}(?:,\d{3})+|\d+)(?:\.\d+)?(?:[eE][-+]?\d+)?")
ELISION = "..."
DEFAULT_RTOL = 1e-2


@dataclass
class Step:
    """One marked item of a page.

    Attributes:
        kind: ``file``, ``run``, ``output``, ``show`` or ``commands``.
        argument: The file name (file, show) or the command line (run, output).
        rtol: Relative tolerance of the numbers (output).
        status: The exit status the command must end with.
        start: Index of the block's first content line in the page (file, output, commands), else -1.
        end: Index of the block's closing fence (exclusive end of its content), else -1.
        line: The page's line number of the marker (1-based), for messages.
    """

    kind: str
    argument: str
    rtol: float
    status: int
    start: int
    end: int
    line: int


def _block_after(lines: list[str], index: int) -> tuple[int, int]:
    """Content span of the fenced block that starts on the first non-empty line after ``index``."""
    k = index + 1
    while k < len(lines) and not lines[k].strip():
        k += 1
    fence = FENCE.match(lines[k]) if k < len(lines) else None
    if fence is None:
        raise ValueError(f"line {index + 1}: a doc marker must be followed by a fenced block")
    close = k + 1
    while close < len(lines) and lines[close].strip() != fence.group(1):
        close += 1
    return k + 1, close


def parse(text: str) -> list[Step]:
    """The marked steps of a page, in order."""
    lines = text.splitlines()
    steps = []
    for i, line in enumerate(lines):
        match = MARKER.match(line.strip())
        if match is None:
            continue
        kind, argument = match.group(1), match.group(3)
        options = dict(option.split("=", 1) for option in match.group(2).split())
        start, end = _block_after(lines, i) if kind in ("file", "output", "show", "commands") else (-1, -1)
        rtol, status = float(options.get("rtol", DEFAULT_RTOL)), int(options.get("exit", 0))
        steps.append(Step(kind, argument, rtol, status, start, end, i + 1))
    return steps


def commands_of(text: str, step: Step) -> list[str]:
    """The ``fts-calib`` command lines of a ``doc-commands`` block (comments and continuations joined)."""
    block = text.splitlines()[step.start : step.end]
    joined, current = [], ""
    for raw in block:
        current += raw.rstrip().removesuffix("\\") + " "
        if not raw.rstrip().endswith("\\"):
            joined.append(current.strip())
            current = ""
    return [line for line in joined if line.startswith("fts-calib ")]


def run_fts_calib(command: str) -> tuple[int, str]:
    """Run an ``fts-calib`` command line in this process; its exit status and what it printed."""
    from fts_calib.app.cli import main

    argv = shlex.split(command, comments=True)
    if argv[0] != "fts-calib":
        raise ValueError(f"only fts-calib commands run in docs, not {command!r}")
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = main(argv[1:])
        except SystemExit as exc:  # argparse
            status = int(exc.code or 0)
    return status, out.getvalue() + err.getvalue()


def _tokens(line: str) -> tuple[list[str], list[str]]:
    """The text between the numbers (spaces collapsed) and the numbers of a line."""
    numbers = NUMBER.findall(line)
    texts = [" ".join(part.split()) for part in NUMBER.split(line)]
    return texts, numbers


def _value(number: str) -> float:
    return float(number.replace(",", ""))


def _step(number: str) -> float:
    """One unit of the last printed digit of a number (1 for an integer)."""
    mantissa, _, exponent = number.replace(",", "").lower().partition("e")
    decimals = len(mantissa.partition(".")[2])
    return 10.0 ** (-decimals + (int(exponent) if exponent else 0))


def line_matches(expected: str, actual: str, rtol: float) -> bool:
    """Whether a printed line shows the output line, within the numbers' tolerance."""
    texts_e, numbers_e = _tokens(expected)
    texts_a, numbers_a = _tokens(actual)
    if texts_e != texts_a or len(numbers_e) != len(numbers_a):
        return False
    for e, a in zip(numbers_e, numbers_a, strict=True):
        ve, va = _value(e), _value(a)
        if not (math.isclose(ve, va, rel_tol=rtol) or abs(ve - va) <= 2 * _step(e) * (1 + 1e-9)):
            return False
    return True


def align(expected: list[str], actual: list[str], rtol: float) -> list[int] | None:
    """For each expected line, the index of the actual line it shows (-1 for ``...``); None when it does not match.

    A ``...`` line takes any number of actual lines (as few as possible).
    """
    memo: dict[tuple[int, int], list[int] | None] = {}

    def go(i: int, j: int) -> list[int] | None:
        if (i, j) in memo:
            return memo[i, j]
        if i == len(expected):
            result = [] if j == len(actual) else None
        elif expected[i].strip() == ELISION:
            result = None
            for k in range(j, len(actual) + 1):
                rest = go(i + 1, k)
                if rest is not None:
                    result = [-1, *rest]
                    break
        elif j < len(actual) and line_matches(expected[i], actual[j], rtol):
            rest = go(i + 1, j + 1)
            result = None if rest is None else [j, *rest]
        else:
            result = None
        memo[i, j] = result
        return result

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10 * (len(expected) + len(actual)) + 1000))
    return go(0, 0)


def rewritten(expected: list[str], actual: list[str], rtol: float) -> list[str]:
    """The block written again from the output: its ``...`` kept where the text still matches."""
    if not any(line.strip() == ELISION for line in expected):
        return actual
    # numbers may have moved beyond any tolerance: align on the text alone
    alignment = align(expected, actual, math.inf)
    if alignment is None:  # the text changed where the block shows it: the whole output, to shorten again by hand
        print(f"note: a shortened block now shows the whole output ({len(actual)} lines): shorten it again with '{ELISION}' lines")
        return actual
    return [ELISION if j < 0 else actual[j] for j in alignment]


@dataclass
class Mismatch:
    """A printed block that the output does not match."""

    page: str
    line: int
    command: str
    printed: list[str]
    output: list[str]

    def __str__(self) -> str:
        return (
            f"{self.page}:{self.line}: the block printed for `{self.command}` is not its output "
            f"(write it again: python -m tests.docs_outputs --write {self.page})\n"
            "--- printed\n" + "\n".join(self.printed) + "\n--- output\n" + "\n".join(self.output)
        )


@contextlib.contextmanager
def workspace():
    """A fresh, empty working folder; the old one restored after."""
    previous = Path.cwd()
    with tempfile.TemporaryDirectory(prefix="fts-calib-docs-") as folder:
        os.chdir(folder)
        try:
            yield Path(folder)
        finally:
            os.chdir(previous)


def _compare(name, step, what, lines, shown, mismatches, replacements) -> None:
    """Note a mismatch between the block of ``step`` and what it shows, and the block to write instead."""
    printed = lines[step.start : step.end]
    if align(printed, shown, step.rtol) is None:
        mismatches.append(Mismatch(name, step.line, what, printed, shown))
        replacements.append((step.start, step.end, rewritten(printed, shown, step.rtol)))


def run_page(page: Path, write: bool = False) -> list[Mismatch]:
    """Run every marked step of a page in a fresh folder; the printed blocks that do not match.

    With ``write``, each output block is written again from the output (the page is updated).

    Raises:
        AssertionError: A command meant to succeed did not (exit status other than 0).
    """
    text = page.read_text(encoding="utf-8")
    lines = text.splitlines()
    name = page.relative_to(ROOT).as_posix()
    mismatches: list[Mismatch] = []
    replacements: list[tuple[int, int, list[str]]] = []
    with workspace() as folder:
        for step in parse(text):
            if step.kind == "file":
                (folder / step.argument).write_text("\n".join(lines[step.start : step.end]) + "\n", encoding="utf-8")
                continue
            if step.kind == "show":
                shown = (folder / step.argument).read_text(encoding="utf-8").rstrip("\n").splitlines()
                _compare(name, step, step.argument, lines, shown, mismatches, replacements)
                continue
            commands = commands_of(text, step) if step.kind == "commands" else [step.argument]
            for command in commands:
                status, output = run_fts_calib(command)
                assert status == step.status, f"{name}:{step.line}: `{command}` exited {status}, not {step.status}:\n{output}"
                if step.kind == "output":
                    _compare(name, step, command, lines, output.rstrip("\n").splitlines(), mismatches, replacements)
    if write and replacements:
        for start, end, new in sorted(replacements, reverse=True):
            lines[start:end] = new
        page.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return mismatches


def pages() -> list[Path]:
    """README.md and every page of docs/."""
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def main(argv: list[str]) -> int:
    """``--write [PAGE ...]``: write the printed blocks again; without ``--write``: report mismatches."""
    write = "--write" in argv
    chosen = [ROOT / arg for arg in argv if arg != "--write"] or pages()
    os.environ.setdefault("MPLBACKEND", "Agg")
    found = 0
    for page in chosen:
        if not any(step.kind in ("run", "output", "show", "commands") for step in parse(page.read_text(encoding="utf-8"))):
            continue
        for mismatch in run_page(page, write=write):
            found += 1
            print(mismatch if not write else f"wrote {mismatch.page}:{mismatch.line} ({mismatch.command})")
    print(f"{found} printed block(s) {'written' if write else 'differ'}")
    return 0 if write or not found else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

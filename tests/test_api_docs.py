"""docs/api.md: every Python block runs, in order, in one session; each printed block is what it prints.

A ```python block followed by ``<!-- api-output -->`` and a ```text block shows its output.
Numbers are compared within 1 % or two units of their last printed digit (another CPU sums in
another order); the rest of each line exactly (runs of spaces count as one).
``python -m tests.test_api_docs --write`` runs the page and writes the printed blocks again.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import sys
import tempfile
from pathlib import Path

PAGE = Path(__file__).resolve().parents[1] / "docs" / "api.md"
BLOCK = re.compile(r"```python\n(.*?)```(\n\n<!-- api-output -->\n```text\n(.*?)```)?", re.S)
NUMBER = re.compile(r"[-+]?\d+(?:,\d{3})*(?:\.\d+)?(?:[eE][-+]?\d+)?")


def run_blocks(text: str) -> list[tuple[re.Match, str]]:
    """Each block's match and what it printed, run in order in one namespace in an empty folder."""
    namespace: dict = {"__name__": "__api_docs__"}
    out = []
    here = os.getcwd()
    with tempfile.TemporaryDirectory() as folder:
        os.chdir(folder)
        try:
            for match in BLOCK.finditer(text):
                buffer = io.StringIO()
                with contextlib.redirect_stdout(buffer):
                    exec(compile(match.group(1), f"{PAGE.name} block at offset {match.start()}", "exec"), namespace)
                out.append((match, buffer.getvalue()))
        finally:
            os.chdir(here)
    return out


def _close(printed: str, got: str) -> bool:
    a, b = NUMBER.findall(printed), NUMBER.findall(got)
    if NUMBER.sub("#", " ".join(printed.split())) != NUMBER.sub("#", " ".join(got.split())) or len(a) != len(b):
        return False
    for x, y in zip(a, b, strict=True):
        u, v = float(x.replace(",", "")), float(y.replace(",", ""))
        digits = len(x.split(".")[1].split("e")[0].split("E")[0]) if "." in x else 0
        unit = 10.0**-digits * (10.0 ** int(x.lower().split("e")[1]) if "e" in x.lower() else 1.0)
        if abs(u - v) > max(0.01 * abs(u), 2 * unit):
            return False
    return True


def test_every_block_runs_and_prints_what_the_page_shows():
    results = run_blocks(PAGE.read_text(encoding="utf-8"))
    assert len(results) >= 15
    bad = []
    for match, got in results:
        if match.group(2) is None:
            continue
        printed = match.group(3)
        lines_printed, lines_got = printed.rstrip("\n").splitlines(), got.rstrip("\n").splitlines()
        if len(lines_printed) != len(lines_got) or not all(_close(p, g) for p, g in zip(lines_printed, lines_got, strict=True)):
            bad.append(f"block:\n{match.group(1)}\nprinted:\n{printed}\ngot:\n{got}")
    assert not bad, "\n\n".join(bad)


def test_every_public_name_is_on_the_page():
    import fts_calib

    text = PAGE.read_text(encoding="utf-8")
    missing = [name for name in fts_calib.__all__ if name != "__version__" and f"`{name}" not in text]
    assert not missing, f"docs/api.md does not present {missing}"


if __name__ == "__main__" and "--write" in sys.argv:
    text = PAGE.read_text(encoding="utf-8")
    pieces, last = [], 0
    for match, got in run_blocks(text):
        if match.group(2) is not None:
            start = match.start(3)
            pieces += [text[last:start], got]
            last = match.end(3)
    PAGE.write_text("".join(pieces) + text[last:], encoding="utf-8")
    print(f"wrote {PAGE}")

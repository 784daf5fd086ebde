"""Run every randomized test over many seeds, once: a randomized test must pass for any seed.

    python tests/seed_sweep.py               # seeds 0..199, one pytest per core
    python tests/seed_sweep.py -n 500 -j 4   # seeds 0..499 on four processes
    python tests/seed_sweep.py --include-slow -n 20 tests/test_live.py

Each worker is one pytest run over a block of seeds (``--seeds A:B``, see ``conftest.py``),
so the seeded fixtures (the simulated recordings) are built once per seed and the imports
once per worker. Tests marked ``slow`` (more than a second a seed; the reason is at each)
are left out unless ``--include-slow``. The normal suite keeps its one seed; reproduce a
failure with ``pytest --seed S path::test``.
"""

from __future__ import annotations

import argparse
import collections
import os
import re
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SEED_ID = re.compile(r"seed(\d+)")


def _blocks(start: int, count: int, jobs: int) -> list[tuple[int, int]]:
    """``jobs`` contiguous blocks [a, b) covering start..start+count."""
    jobs = max(1, min(jobs, count))
    edges = [start + round(k * count / jobs) for k in range(jobs + 1)]
    return [(a, b) for a, b in zip(edges[:-1], edges[1:], strict=True) if b > a]


def _results(path: Path) -> list[tuple[str, int, str]]:
    """(test id without its seed, seed, outcome) of each case in a JUnit XML report."""
    out = []
    for case in ET.parse(path).getroot().iter("testcase"):
        function, _, params = case.get("name").partition("[")
        parts = params.rstrip("]").split("-") if params else []
        seeds = [int(m.group(1)) for p in parts if (m := SEED_ID.fullmatch(p))]
        rest = [p for p in parts if not SEED_ID.fullmatch(p)]
        test = f"{case.get('classname').replace('.', '/')}.py::{function}" + (f"[{'-'.join(rest)}]" if rest else "")
        seed = seeds[0] if seeds else -1
        outcome = "passed"
        for child in case:
            if child.tag in ("failure", "error"):
                outcome = "failed"
            elif child.tag == "skipped":
                outcome = "skipped"
        out.append((test, seed, outcome))
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("-n", "--count", type=int, default=200, help="number of seeds (default 200)")
    parser.add_argument("--start", type=int, default=0, help="first seed (default 0)")
    parser.add_argument("-j", "--jobs", type=int, default=os.cpu_count() or 1, help="pytest processes (default: one per core)")
    parser.add_argument("--include-slow", action="store_true", help="sweep the tests marked slow too")
    parser.add_argument("pytest_args", nargs="*", help="passed on to pytest (paths, -k ...); default tests/")
    args = parser.parse_args(argv)
    marker = "randomized" if args.include_slow else "randomized and not slow"
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": str(ROOT)}
    begin = time.monotonic()
    with tempfile.TemporaryDirectory() as tmp:
        workers = []
        for a, b in _blocks(args.start, args.count, args.jobs):
            report = Path(tmp) / f"seeds_{a}_{b}.xml"
            command = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-m", marker, f"--seeds={a}:{b}"]
            command += [f"--junitxml={report}", *(args.pytest_args or ["tests"])]
            log = open(Path(tmp) / f"seeds_{a}_{b}.log", "w")  # closed once the worker ends
            workers.append((a, b, report, log, subprocess.Popen(command, cwd=ROOT, env=env, stdout=log, stderr=subprocess.STDOUT)))
        results = []
        for a, b, report, log, proc in workers:
            proc.wait()
            log.close()
            if not report.exists():
                print(Path(log.name).read_text(), file=sys.stderr)
                print(f"seeds {a}:{b}: pytest exited with {proc.returncode} and wrote no report", file=sys.stderr)
                return 2
            results += _results(report)
            if proc.returncode not in (0, 1):
                print(Path(log.name).read_text(), file=sys.stderr)
    wall = time.monotonic() - begin
    tests = sorted({t for t, _, _ in results})
    failed = collections.defaultdict(list)
    for test, seed, outcome in results:
        if outcome == "failed":
            failed[test].append(seed)
    outcomes = collections.Counter(o for _, _, o in results)
    print(
        f"{len(tests)} randomized tests x {args.count} seeds ({args.start}..{args.start + args.count - 1}) = {len(results)} runs: "
        f"{outcomes['passed']} passed, {outcomes['failed']} failed, {outcomes['skipped']} skipped "
        f"in {wall:.0f} s on {len(workers)} processes"
    )
    for test, seeds in sorted(failed.items()):
        shown = ", ".join(map(str, sorted(seeds)[:20])) + (" ..." if len(seeds) > 20 else "")
        print(f"FAILED {test} for {len(seeds)} seed(s): {shown}  (rerun: pytest --seed {min(seeds)} '{test}')")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

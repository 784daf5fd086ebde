"""Benchmark: how far below the first continuous motion's tool-and-mount floor any continuous motion goes.

``trajectory --motion continuous`` refuses a target below
:data:`fts_calib.planning.sizing.MOVING_FLOOR_SHARE` of the least floor screened so far at once
(the terms no plan shrinks: tool mass, tool centre of mass, sensor mount), instead of screening
its 60 candidates first. This screens every candidate of each robot (the shipped paper tool,
three configurations, 25 Hz) with the early refusal off and prints, per robot, the floor of the
first candidate with a finite budget, the least over all of them, their ratio (the share must
stay below it), and the seconds screened. Asserts nothing.
Run: .venv/bin/python bench/bench_moving_floor.py [ROBOT ...]   (default: ur5 panda kinova; about 75 s each)
"""

import contextlib
import io
import sys
import tempfile
import time

from fts_calib.app.cli import main
from fts_calib.planning import sizing


def screen(robot: str) -> tuple[list[float], float]:
    """The floors [% FS] of every candidate with a finite budget, in the order screened, and the seconds it took."""
    floors: list[float] = []
    add = sizing.Screening.add

    def recording(self, plan, budget):
        add(self, plan, budget)
        systematic = sizing._systematic(budget).largest_percent
        if systematic < float("inf"):
            floors.append(systematic)

    sizing.Screening.add = recording
    share, sizing.MOVING_FLOOR_SHARE = sizing.MOVING_FLOOR_SHARE, 0.0  # screen them all
    start = time.perf_counter()
    try:
        with tempfile.TemporaryDirectory() as out, contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            argv = ["trajectory", "--robot", robot, "--tool", "paper_tool", "--motion", "continuous", "--target-error", "1e-9"]
            main([*argv, "-o", out, "--no-plot"])
    finally:
        sizing.Screening.add, sizing.MOVING_FLOOR_SHARE = add, share
    return floors, time.perf_counter() - start


if __name__ == "__main__":
    robots = sys.argv[1:] or ["ur5", "panda", "kinova"]
    print(f"MOVING_FLOOR_SHARE = {sizing.MOVING_FLOOR_SHARE:g}")
    print("robot    candidates  first floor [% FS]  least floor [% FS]  least / first  least after / floor so far  screened [s]")
    for robot in robots:
        floors, seconds = screen(robot)
        if not floors:
            print(f"{robot:<8} no candidate with a finite budget ({seconds:.1f} s)")
            continue
        worst = min(min(floors[k:]) / min(floors[: k + 1]) for k in range(len(floors)))  # the least ahead over the floor so far
        print(
            f"{robot:<8} {len(floors):>10}  {floors[0]:>18.4f}  {min(floors):>18.4f}  {min(floors) / floors[0]:>13.3f}  "
            f"{worst:>26.3f}  {seconds:>12.1f}"
        )

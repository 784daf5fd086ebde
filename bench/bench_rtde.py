"""Benchmark: a UR calibration through the real ``ur_rtde`` client against the RTDE controller on loopback.

The case of :mod:`tests.rtde_case`: configuration A, then B and C with ``--resume`` after the
controller rebooted (its clock near 0 again), each ``calibrate ur://127.0.0.1`` reading the
built-in sensor's wrench; then ``calibrate`` of the rows the client read. Prints the client's
version; per configuration the data packages sent, the samples read, the share not read, the
wall time; then the samples seen, the largest difference of C_bar between the live runs and the
offline calibrate (relative to C_bar's largest coefficient) and of D, and the live C_bar's
largest error against the simulated sensor in standard errors. Needs 127.0.0.1:30004 free.

Run: .venv/bin/python bench/bench_rtde.py [--seed S] [--period-ms 2] [--step 1]
"""

import argparse
import importlib.metadata
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the tests' case module

from tests.rtde_case import factory_runs_of, run_case, short_ur5_plan  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=20261122)
    parser.add_argument("--period-ms", type=float, default=2.0, help="wall time between two data packages (2 ms: an e-Series at 500 Hz)")
    parser.add_argument("--step", type=int, default=1, help="send every STEP-th row of the 100 Hz plan")
    args = parser.parse_args()
    sensor, runs = factory_runs_of(short_ur5_plan(), args.seed)
    print(f"ur_rtde {importlib.metadata.version('ur_rtde')}, a data package every {args.period_ms:g} ms, every {args.step} row(s)")
    with tempfile.TemporaryDirectory() as folder:
        joints = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]
        case = run_case(runs, joints, Path(folder), args.period_ms / 1e3, args.step)
    print(f"{'configuration':>13} {'exit':>4} {'sent':>6} {'read':>6} {'not read':>8} {'wall [s]':>8}")
    for name in case.codes:
        missed = 100 * (1 - case.read[name] / case.sent[name]) if case.sent[name] else float("nan")
        print(f"{name:>13} {case.codes[name]:>4} {case.sent[name]:>6,} {case.read[name]:>6,} {missed:>7.1f}% {case.wall_s[name]:>8.1f}")
    if case.live is None or case.offline is None:
        print("no calibration: " + case.texts[list(case.texts)[-1]].strip().splitlines()[-1])
        return
    live, offline = case.live, case.offline
    scale = np.abs(offline.C_bar).max()
    z = np.abs(live.C_bar - sensor.C_bar) / live.quality.stderr_C_bar
    seen, used = (live.quality.samples_seen, offline.quality.samples_seen), (live.quality.samples_used, offline.quality.samples_used)
    print(f"samples seen: live {seen[0]:,}, offline {seen[1]:,}; used: live {used[0]:,}, offline {used[1]:,}")
    print(f"max |C_bar live - offline| / max |C_bar|: {np.abs(live.C_bar - offline.C_bar).max() / scale:.2e}")
    print(f"max |D live - offline|: {np.abs(live.D - offline.D).max():.2e} (N, N·m)")
    print(f"live C_bar against the simulated sensor: largest error {z.max():.2f} standard errors")


if __name__ == "__main__":
    main()

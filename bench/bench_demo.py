"""Benchmark: the demo's stages (plan, simulate, calibrate, validate) with times and samples/s.

Runs the full demo into a temporary folder and prints the figures. Asserts nothing.
Run: .venv/bin/python bench/bench_demo.py
"""

import io
import tempfile
import time

from fts_calib.app.demo import run_demo
from fts_calib.sources.recording import RecordingReader


def main():
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        result = run_demo(out, stream=io.StringIO())
        total = time.perf_counter() - start
        rows = {}
        for name in ("calibration", "validation"):
            with RecordingReader(f"{out}/recordings/{name}.csv", None, None) as reader:
                rows[name] = sum(len(c.time) for c in reader)
    s = result.seconds
    print(f"demo (full, UR5, 500 Hz): {total:.1f} s in all (target <= 60 s)")
    print(f"  plan      {s['plan']:5.2f} s  (three configurations: plan, limits, clearance, excitation, CSVs, plot)")
    print(f"  simulate  {s['simulate']:5.2f} s  {rows['calibration'] / s['simulate']:>12,.0f} samples/s ({rows['calibration']:,} rows)")
    print(f"  calibrate {s['calibrate']:5.2f} s  {rows['calibration'] / s['calibrate']:>12,.0f} samples/s")
    print(f"  Fig. 7    {s['convergence']:5.2f} s")
    print(f"  validate  {s['validate']:5.2f} s  (plan + simulate + validate {rows['validation']:,} rows, twice with the paper's tables)")
    print(f"  plots     {s['plots']:5.2f} s")


if __name__ == "__main__":
    main()

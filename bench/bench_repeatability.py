"""Benchmark: a sensor that does not repeat from pose to pose, diagnosed, then calibrated with its repeatability declared.

The case of :mod:`tests.repeatability_case` (issue 31, item 2): about 0.02 N of noise within a
still pose, an offset drawn anew at every stop (1.5 N per force axis, 0.1 N m per moment axis),
the paper's tool on a 5 x 6 raster of the UR5 at 100 Hz, every third stop held out. Per seed:
the fit check without the sensor file's ``repeatability`` (ratio, and the two figures its
diagnosis names), then with ``repeatability: {force: 1.5, moment: 0.1}`` (ratio, verdict), and
on the held-out stops the reading's error against the true load (RMS over the stops, largest
force and moment axis) against the budget's total (smallest force and moment axis), and the share
of held-out stops within the total on every axis. The offset model is chosen as by default (``auto``: its BIC counts poses when the
repeatability is declared).

Run: .venv/bin/python bench/bench_repeatability.py [--seeds N]
"""

import argparse
import re
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the tests' case module

from fts_calib.filters.settings import PipelineConfig  # noqa: E402
from fts_calib.session.calibration_run import calibrate_recording  # noqa: E402
from tests import repeatability_case as case  # noqa: E402

FIGURES = r"noise is ([0-9.e-]+) N and ([0-9.e-]+) N·m, between poses its readings scatter by ([0-9.e-]+) N and ([0-9.e-]+) N·m"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    args = parser.parse_args()
    kin, tool, _ = case.setup()
    _, full_scale = case.sensor()
    declared = PipelineConfig().with_repeatability(case.SCATTER)
    start = time.perf_counter()
    print(
        "seed  before: ratio  within N, N·m    between N, N·m   after: ratio verdict     offsets   "
        "unseen RMS N, N·m  budget (smallest) stops within"
    )
    with tempfile.TemporaryDirectory() as folder:
        for seed in range(args.seeds):
            recording, held = case.record(Path(folder), seed)
            before = calibrate_recording(recording, kin, tool, PipelineConfig(), full_scale=full_scale)
            check = before.session.fit_check()
            found = re.search(FIGURES, check.diagnosis)
            figures = "named: no" if found is None else f"{found[1]:>6} {found[2]:>8}   {found[3]:>5} {found[4]:>6}"
            after = calibrate_recording(recording, kin, tool, declared, full_scale=full_scale)
            judged = after.session.fit_check()
            row = f"{seed:>4}  {check.max_ratio:>13.0f}  {figures:<33} {judged.max_ratio:>12.2f} {judged.verdict:<11}"
            if after.calibration is not None:
                row += f" {after.calibration.offset_model['model']:<9}"
                error = case.unseen_error(after.calibration, held)
                rms, total = np.sqrt(np.mean(error**2, axis=0)), after.session.budget.total
                within = np.mean(np.all(np.abs(error) <= total, axis=1))
                row += f" {rms[:3].max():>6.2f} {rms[3:].max():>6.3f}   {total[:3].min():>5.2f} {total[3:].min():>6.3f}"
                row += f"   {within:>6.0%} of {len(error)}"
            print(row)
    print(f"({time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main()

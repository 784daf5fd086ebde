"""Static-pose datasets of the low-cost sensor: how many poses, how long each.

The case of issue 23 is 12 poses of about 13 s, one file per pose. The shipped
``configs/lowcost_sensor.yaml`` (10-bit counts, sub-count noise on three channels, strain_7 at
its rail in some poses, 3 % of full scale of quadratic nonlinearity) is simulated under the
paper's tool (three configurations) at the stops of ``fts-calib trajectory`` plans, one file
per pose (``simulate --pose-files``), and calibrated with the default options from the pattern
``'poses/*.csv'``. Printed per plan: poses, seconds each, samples, the held-out units, the chosen
model, and the largest total of the printed accuracy budget (% of full scale).

Run: ``.venv/bin/python bench/bench_static_poses.py`` (about 40 s on two cores).
"""

from __future__ import annotations

import tempfile
import time
from contextlib import redirect_stdout
from io import StringIO
from pathlib import Path

from fts_calib.app.cli import main
from fts_calib.model.calibration import load_calibration

#: (levels, stops per level, seconds at each stop): 4 or 12 poses per configuration.
PLANS = ((2, 2, 13.0), (3, 4, 3.0), (3, 4, 13.0))


def _run(argv: list[str]) -> str:
    out = StringIO()
    with redirect_stdout(out):
        code = main(argv)
    if code != 0:
        raise SystemExit(f"fts-calib {' '.join(argv)} exited {code}:\n{out.getvalue()}")
    return out.getvalue()


def main_bench() -> None:
    """Print one line per plan (see the module docstring)."""
    start = time.perf_counter()
    setup = ["--robot", "ur5", "--tool", "paper_tool"]
    print("poses (3 configurations)  seconds each  samples kept  units  model               largest budget, % FS")
    with tempfile.TemporaryDirectory() as tmp:
        for levels, stops, dwell in PLANS:
            folder = Path(tmp) / f"{levels}x{stops}x{dwell:g}"
            plan = ["trajectory", *setup, "-o", str(folder / "plan"), "--levels", str(levels), "--stops", str(stops)]
            _run([*plan, "--dwell", str(dwell), "--no-plot"])
            simulate = ["simulate", *setup, "--trajectory", str(folder / "plan"), "--sensor", "lowcost_sensor", "--seed", "1"]
            _run([*simulate, "--pose-files", "-o", str(folder / "poses")])
            out = folder / "cal.yaml"
            _run(["calibrate", *setup, "--sensor", "lowcost_sensor", str(folder / "poses" / "*.csv"), "-o", str(out), "--quiet"])
            cal = load_calibration(out)
            q = cal.quality
            budget = q.budget or {}
            dominant = budget.get("dominant", {})
            poses = 3 * levels * stops
            print(
                f"{poses:>4}                      {dwell:>5g}         {q.samples_used:>9,}     {cal.model_selection['units']:>4}  "
                f"{cal.model_selection['chosen']:<18}  {budget.get('largest_percent_fs')} ({dominant.get('axis')}, {dominant.get('term')})"
            )
    print(f"({time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main_bench()

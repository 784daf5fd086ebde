"""Benchmark: import time of the in-controller path against ``import numpy``, each in a fresh interpreter.

``from fts_calib import Calibration, WrenchReader`` is what a controller imports; it loads
numpy and fts-calib's own small modules, never pandas, ruckig, matplotlib, rosbags,
Pinocchio, coal or PyYAML. Each figure is the median of fresh processes (warm disk cache);
the ratio is the in-controller import over ``import numpy`` alone. The full API (Pinocchio,
the pipeline) is shown for scale. Prints figures; asserts nothing.
Run: .venv/bin/python bench/bench_import.py [--runs N]
"""

import argparse
import json
import statistics
import subprocess
import sys

HEAVY = ("pandas", "ruckig", "matplotlib", "rosbags", "pinocchio", "coal", "yaml")

CASES = {
    "import numpy": "import numpy",
    "from fts_calib import Calibration, WrenchReader": "from fts_calib import Calibration, WrenchReader",
    "the full API (fts_calib.calibrate, Kinematics)": "import fts_calib; fts_calib.calibrate; fts_calib.Kinematics",
}


def timed(statement: str) -> tuple[float, list[str]]:
    """Seconds to run ``statement`` in a fresh interpreter, and the heavy modules it loaded."""
    code = (
        "import json, sys, time\n"
        "t0 = time.perf_counter()\n"
        f"{statement}\n"
        "t = time.perf_counter() - t0\n"
        f"print(json.dumps([t, [m for m in {HEAVY!r} if m in sys.modules]]))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    seconds, heavy = json.loads(out)
    return seconds, heavy


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=9, help="fresh processes per case (default: 9)")
    runs = parser.parse_args().runs
    timed("import numpy")  # warm the disk cache
    medians = {}
    for label, statement in CASES.items():
        results = [timed(statement) for _ in range(runs)]
        medians[label] = statistics.median(t for t, _ in results)
        heavy = results[0][1]
        print(f"{label}: {1e3 * medians[label]:.0f} ms median of {runs}; heavy modules loaded: {', '.join(heavy) or 'none'}")
    ratio = medians["from fts_calib import Calibration, WrenchReader"] / medians["import numpy"]
    print(f"in-controller import / import numpy: {ratio:.2f}")


if __name__ == "__main__":
    main()

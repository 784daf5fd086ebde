"""Benchmark: reading a run as a ROS 2 bag (MCAP, sqlite3) against the CSV of the same run.

Writes the UR5's planned sweep at 1 kHz (simulated sensor with noise) as a CSV recording,
converts it to a bag in each storage (one JointState and one Float64MultiArray message per
row, the configuration on its String topic), then prints rows/s of reading each (every
sample as SampleBatch, through the synchronizer for the bags) and of ``calibrate`` end to
end (in this process). Asserts nothing.
Run: .venv/bin/python bench/bench_bag.py [ROWS]
"""

import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from bench_calibrate import write_recording

from fts_calib.core.resources import resolve
from fts_calib.robot.definition import load_robot
from fts_calib.robot.kinematics import Kinematics
from fts_calib.robot.tool import load_tool
from fts_calib.session.calibration_run import calibrate_recording
from fts_calib.sim.robot_log import recording_to_bag
from fts_calib.sources.source import open_recording


def read_all(path, kin, tool) -> tuple[int, float]:
    start = time.perf_counter()
    with open_recording(path, kin.joint_names, tool.names, continuous=kin.continuous) as reader:
        rows = sum(len(batch) for batch in reader)
    return rows, time.perf_counter() - start


def main():
    rows = int(sys.argv[1]) if len(sys.argv) > 1 else 200_000
    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    tool = load_tool(resolve("paper_tool", "configs"))
    with tempfile.TemporaryDirectory() as folder:
        csv = Path(folder) / "run.csv"
        write_recording(csv, rows)
        sources = {"csv": csv}
        for storage in ("mcap", "sqlite3"):
            start = time.perf_counter()
            sources[storage] = recording_to_bag(csv, Path(folder) / f"run_{storage}", storage)
            size = sum(p.stat().st_size for p in sources[storage].iterdir())
            print(f"wrote the {storage} bag ({size / 1e6:.0f} MB, {2 * rows:,} messages) in {time.perf_counter() - start:.1f} s")
        print(f"{rows:,} rows at 1 kHz (CSV {csv.stat().st_size / 1e6:.0f} MB); rows/s, best of 3 runs:")
        calibrations = {}
        for name, path in sources.items():
            n, read_s = min((read_all(path, kin, tool) for _ in range(3)), key=lambda r: r[1])
            result = min((calibrate_recording(path, kin, tool) for _ in range(3)), key=lambda r: r.seconds)
            calibrations[name] = result.calibration
            print(
                f"  {name:8s} read {n / read_s:>10,.0f} rows/s ({read_s:.2f} s)   calibrate {result.rows / result.seconds:>10,.0f} rows/s"
            )
        worst = max(np.abs(calibrations[name].C - calibrations["csv"].C).max() for name in ("mcap", "sqlite3"))
        print(f"largest difference of C between the bags and the CSV: {worst:.3g} (N or N·m per strain unit)")


if __name__ == "__main__":
    main()

"""Benchmark: planning and checking the calibration sweeps for every shipped robot.

Prints figures; asserts nothing. Run: .venv/bin/python bench/bench_trajectory.py
"""

import tempfile
import time

from fts_calib.app.trajectory import write_run
from fts_calib.core.resources import resolve
from fts_calib.filters.settings import load_pipeline_config
from fts_calib.model.sensor_config import load_sensor_config
from fts_calib.planning.sweeps import SweepPattern
from fts_calib.planning.trajectory_run import plan_trajectories
from fts_calib.robot.tool import load_tool


def main():
    tool = load_tool(resolve("paper_tool", "configs"))
    sensor = load_sensor_config(resolve("sensor", "configs"))
    pipeline = load_pipeline_config(resolve("pipeline", "configs"))
    print("plan + check (limits, clearance, excitation) of all three configurations at 500 Hz (target for UR5: <= 5 s)")
    for robot in ("ur5", "ur10", "panda", "kinova", "xarm7"):
        t0 = time.perf_counter()
        run = plan_trajectories(resolve(robot, "robots"), tool, sensor, pipeline.filter, 1e-5, SweepPattern(), 500.0)
        planned = time.perf_counter() - t0
        with tempfile.TemporaryDirectory() as out:
            t0 = time.perf_counter()
            write_run(run, out, plot=False)
            written = time.perf_counter() - t0
        ex = run.excitation
        print(
            f"  {robot:6s} plan+check {planned:5.2f} s, write 3 CSVs {written:4.2f} s | motion {run.result.plan.duration:5.1f} s "
            f"per configuration, clearance {run.result.clearance.distance:.3f} m, predicted max stderr "
            f"{100 * ex.max_relative_stderr:.5f} % of row max, coverage {ex.coverage_deg:.1f}°"
        )


if __name__ == "__main__":
    main()

"""Benchmark: sensor orientation and static tool wrench per sample, single reading and batched.

Prints figures; asserts nothing. Run: .venv/bin/python bench/bench_kinematics.py
"""

import time

import numpy as np

from fts_calib.core.resources import resolve
from fts_calib.robot.definition import load_robot
from fts_calib.robot.kinematics import Kinematics
from fts_calib.robot.tool import load_tool


def _readings(kin: Kinematics, n: int, rng: np.random.Generator) -> np.ndarray:
    lo = np.where(np.isfinite(kin.limits.lower), kin.limits.lower, -np.pi)
    hi = np.where(np.isfinite(kin.limits.upper), kin.limits.upper, np.pi)
    return rng.uniform(lo, hi, (n, kin.n_joints))


def single(kin: Kinematics, config, gravity: float, readings: np.ndarray, calls: int = 200) -> float:
    """Median over blocks of `calls` readings of the time per reading, in s."""
    per_call = []
    for start in range(0, len(readings) - calls + 1, calls):
        block = readings[start : start + calls]
        t0 = time.perf_counter()
        for reading in block:
            config.static_wrench(kin.g_sensor(reading, gravity))
        per_call.append((time.perf_counter() - t0) / calls)
    return float(np.median(per_call))


def batched(kin: Kinematics, config, gravity: float, readings: np.ndarray, repeats: int = 7) -> float:
    """Median time per sample of one call on the whole batch, in s."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        config.static_wrench(kin.g_sensor(readings, gravity))
        times.append((time.perf_counter() - t0) / len(readings))
    return float(np.median(times))


def main():
    rng = np.random.default_rng(0)
    tool = load_tool(resolve("paper_tool", "configs"))
    config = tool.configurations[0]
    print("sensor orientation + static tool wrench per sample (target <= 5 µs median)")
    for name in ("ur5", "panda"):
        kin = Kinematics(load_robot(resolve(name, "robots")))
        readings = _readings(kin, 20_000, rng)
        one = single(kin, config, tool.gravity, readings)
        many = batched(kin, config, tool.gravity, _readings(kin, 100_000, rng))
        print(f"  {name:6s} single reading (Pinocchio): {one * 1e6:6.2f} µs   batch of 100,000 (vectorised): {many * 1e6:6.3f} µs")


if __name__ == "__main__":
    main()

"""Benchmark: in-service wrench with gravity compensation per sample, and payload identification.

Prints figures; asserts nothing. Run: .venv/bin/python bench/bench_service.py
"""

import time

import numpy as np

from fts_calib import Calibration, identify_payload
from fts_calib.core.resources import resolve
from fts_calib.robot.definition import load_robot
from fts_calib.robot.kinematics import Kinematics
from fts_calib.robot.tool import load_tool
from fts_calib.service.reader import GravityCompensator
from fts_calib.sim.sensor import load_simulated_sensor


def per_call(fn, args, blocks: int = 200, calls: int = 500) -> float:
    """Median over blocks of the time per call, in s."""
    times = []
    for b in range(blocks):
        t0 = time.perf_counter()
        for k in range(calls):
            fn(*args[(b * calls + k) % len(args)])
        times.append((time.perf_counter() - t0) / calls)
    return float(np.median(times))


def main():
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    payload = load_tool(resolve("validation_tool", "configs")).configurations[0]
    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    comp = GravityCompensator(Calibration(sensor.C_bar, sensor.D), payload, kin.g_world(9.81))
    rng = np.random.default_rng(0)
    joints = rng.uniform(-3, 3, (1000, 6))  # [rad]
    channels = rng.standard_normal((1000, 8)) * 0.1  # [mV/V]
    rotations = kin.R_world_sensor(joints)
    given = [(s, R) for s, R in zip(channels, rotations, strict=True)]
    wrench_only = per_call(comp.reader.wrench, [(s,) for s in channels])
    sensor_frame = per_call(comp.external, given)
    world = per_call(lambda s, R: comp.external(s, R, "world"), given)
    with_kin = per_call(lambda s, q: comp.external(s, kin.R_world_sensor(q)), list(zip(channels, joints, strict=True)))
    print(f"WrenchReader.wrench per sample, median: {wrench_only * 1e6:5.2f} µs")
    print("wrench + gravity compensation per sample (the orientation checked as a rotation), median (target <= 10 µs):")
    print(f"  orientation given, sensor frame: {sensor_frame * 1e6:5.2f} µs; world frame: {world * 1e6:5.2f} µs")
    print(f"  orientation from the joint readings (Pinocchio) + compensation: {with_kin * 1e6:5.2f} µs")
    d = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float) / np.sqrt(3)
    g = np.repeat(9.81 * d, 1250, axis=0)
    W = np.hstack([1.4 * g, np.cross(1.4 * payload.p_sensor_com, g)]) + 0.01 * rng.standard_normal((len(g), 6))
    times = []
    for _ in range(20):
        t0 = time.perf_counter()
        identify_payload(W, g)
        times.append(time.perf_counter() - t0)
    times_mount = []
    for _ in range(5):
        t0 = time.perf_counter()
        identify_payload(W, g, mount=True)
        times_mount.append(time.perf_counter() - t0)
    print(
        f"payload identification from {len(g):,} samples: {np.median(times) * 1e3:.1f} ms median (target <= 50 ms); "
        f"with the mount rotation: {np.median(times_mount) * 1e3:.1f} ms"
    )


if __name__ == "__main__":
    main()

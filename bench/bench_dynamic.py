"""Benchmark: `calibrate --filter dynamic` end to end on the long recording of bench_calibrate.py.

Writes the same recording (the UR5's shipped plan repeated up to 3.6 million rows, 1 kHz,
simulated sensor with noise; the positions interpolated by quintic Hermite from the plan's
positions, velocities and accelerations, so that the readings move as the wrench does:
bench_calibrate.py interpolates them linearly, a motion whose accelerations are kinks), then
runs `fts-calib calibrate --filter dynamic` on it in a child process: every sample goes through
the derivative filter, the kinematics, the tool's Newton-Euler wrench and the trust rule; with
the pipeline's `latency_s: auto` the latency is fitted on the way (the recording has none: no
second read; the printed "dynamic filter:" line shows the latency applied, and a recording whose
joints are late would be read twice). Prints rows/s of wall-clock time and of the child's CPU
time (which the machine's load changes much less), the load and the child's peak memory. The
child is the `fts-calib` command, with its one BLAS thread (`OPENBLAS_NUM_THREADS` of the
environment, if set, wins). Asserts nothing.
With LATE_MS the joint readings are that late (the positions of t - LATE_MS at time t): `latency_s:
auto` then fits the latency in a first read and reads the recording again with it applied.
Run: .venv/bin/python bench/bench_dynamic.py [ROWS [LATE_MS]]
"""

import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from bench_calibrate import write_repeated

from fts_calib.core.resources import data_dir, resolve
from fts_calib.planning.trajectory_files import read_trajectory
from fts_calib.robot.definition import load_robot
from fts_calib.robot.kinematics import Kinematics
from fts_calib.robot.tool import load_tool
from fts_calib.sim.runs import tool_wrenches
from fts_calib.sim.sensor import load_simulated_sensor


def hermite(t: np.ndarray, knots: np.ndarray, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> tuple[np.ndarray, ...]:
    """Quintic Hermite through the plan's (knots, q, qd, qdd) at times t: positions, velocities, accelerations (len(t), joints).

    Continuous to the acceleration (the jerk jumps at the knots, as a jerk-limited plan's does).
    """
    k = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, len(knots) - 2)
    h = (knots[k + 1] - knots[k])[:, None]
    s = (t - knots[k])[:, None] / h
    p0, p1, v0, v1, a0, a1 = q[k], q[k + 1], qd[k] * h, qd[k + 1] * h, qdd[k] * h * h, qdd[k + 1] * h * h
    # the quintic's coefficients in s from the end conditions
    c3 = 10 * (p1 - p0) - 6 * v0 - 4 * v1 - 1.5 * a0 + 0.5 * a1
    c4 = -15 * (p1 - p0) + 8 * v0 + 7 * v1 + 1.5 * a0 - a1
    c5 = 6 * (p1 - p0) - 3 * (v0 + v1) - 0.5 * (a0 - a1)
    pos = p0 + s * (v0 + s * (0.5 * a0 + s * (c3 + s * (c4 + s * c5))))
    vel = (v0 + s * (a0 + s * (3 * c3 + s * (4 * c4 + s * 5 * c5)))) / h
    acc = (a0 + s * (6 * c3 + s * (12 * c4 + s * 20 * c5))) / h**2
    return pos, vel, acc


def write_recording(path: Path, rows: int, late_s: float = 0.0) -> None:
    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    tool = load_tool(resolve("paper_tool", "configs"))
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    rng = np.random.default_rng(0)
    parts = []
    for name in tool.names:
        traj = read_trajectory(data_dir("trajectories") / "ur5" / f"{name}.csv.gz")
        t = np.arange(0, traj.time[-1], 0.001)
        q, qd, qdd = hermite(t, traj.time, traj.q, traj.qd, traj.qdd)
        read = q if late_s == 0 else hermite(np.maximum(t - late_s, 0.0), traj.time, traj.q, traj.qd, traj.qdd)[0]
        parts.append((name, t, read, tool_wrenches(kin, tool, name, q, qd, qdd)))
    write_repeated(path, kin.joint_names, parts, rows, sensor, rng)


def main():
    rows = int(sys.argv[1]) if len(sys.argv) > 1 else 3_600_000
    late_s = float(sys.argv[2]) / 1000 if len(sys.argv) > 2 else 0.0
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "long.csv"
        start = time.perf_counter()
        write_recording(path, rows, late_s)
        late = f", joints {late_s * 1000:g} ms late" if late_s else ""
        print(f"wrote {rows:,} rows ({path.stat().st_size / 1e6:.0f} MB{late}) in {time.perf_counter() - start:.1f} s")
        child = (
            "import sys; from fts_calib.app.cli import main; code = main(sys.argv[1:]); "
            "print([l for l in open('/proc/self/status') if l.startswith('VmHWM')][0].strip()); sys.exit(code)"
        )
        for extra, what in (([], "--model auto"), (["--model", "linear"], "--model linear")):
            command = [sys.executable, "-c", child, "calibrate", "--robot", "ur5", "--tool", "paper_tool", "--filter", "dynamic"]
            command += [*extra, str(path), "-o", str(Path(folder) / "cal.yaml"), "--quiet"]
            start, before = time.perf_counter(), resource.getrusage(resource.RUSAGE_CHILDREN)
            result = subprocess.run(command, capture_output=True, text=True)
            seconds, after = time.perf_counter() - start, resource.getrusage(resource.RUSAGE_CHILDREN)
            cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)  # the child's own: what the load does not change
            if result.returncode != 0:
                print(result.stdout, result.stderr)
            peak = float(result.stdout.strip().splitlines()[-1].split()[1]) / 1024  # kB
            lines = result.stdout.splitlines()
            print("\n".join(lines[:2] + [line for line in lines if line.startswith("dynamic filter:")]))
            print(
                f"calibrate --filter dynamic ({what}), end to end (process start included): {rows / seconds:,.0f} rows/s "
                f"(target >= 150,000), {seconds:.1f} s; {rows / cpu:,.0f} rows per CPU-second ({cpu:.1f} s of CPU); "
                f"peak memory {peak:.0f} MB; load average {os.getloadavg()[0]:.1f}"
            )


if __name__ == "__main__":
    main()

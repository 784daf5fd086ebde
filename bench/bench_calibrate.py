"""Benchmark: `calibrate` end to end (read, kinematics, filter, accumulate) on a long recording.

Writes a recording of the UR5's planned sweep repeated up to 3.6 million rows (1 kHz,
simulated sensor with noise), then runs `fts-calib calibrate` on it in a child process and
prints rows/s and the child's peak memory. Asserts nothing.
Run: .venv/bin/python bench/bench_calibrate.py [ROWS]
"""

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from fts_calib.core.resources import data_dir, resolve
from fts_calib.planning.trajectory_files import read_trajectory
from fts_calib.robot.definition import load_robot
from fts_calib.robot.kinematics import Kinematics
from fts_calib.robot.tool import load_tool
from fts_calib.sim.runs import tool_wrenches
from fts_calib.sim.sensor import load_simulated_sensor
from fts_calib.sources.recording import RecordingWriter


def write_recording(path: Path, rows: int) -> None:
    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    tool = load_tool(resolve("paper_tool", "configs"))
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    rng = np.random.default_rng(0)
    # the shipped 100 Hz plan, resampled to 1 kHz by linear interpolation (positions only:
    # the filter estimates velocities from them; the wrench uses the planned ones)
    parts = []
    for name in tool.names:
        traj = read_trajectory(data_dir("trajectories") / "ur5" / f"{name}.csv.gz")
        t = np.arange(0, traj.time[-1], 0.001)
        interp = [np.column_stack([np.interp(t, traj.time, x[:, k]) for k in range(x.shape[1])]) for x in (traj.q, traj.qd, traj.qdd)]
        parts.append((name, t, interp[0], tool_wrenches(kin, tool, name, *interp)))
    write_repeated(path, kin.joint_names, parts, rows, sensor, rng)


def write_repeated(path: Path, joint_names, parts, rows: int, sensor, rng) -> None:
    """Write ``parts`` again and again, 2 s apart, up to ``rows`` rows; channels drawn by ``sensor`` with ``rng``.

    Each part is ``(configuration, time [s] (N,), joints read [rad] (N, n), wrench [N, N m] (N, 6))``.
    """
    written, offset = 0, 0.0
    with RecordingWriter(path, joint_names) as writer:
        while written < rows:
            for name, t, q, W in parts:
                n = min(len(t), rows - written)
                if n <= 0:
                    break
                writer.write(t[:n] + offset, q[:n], sensor.channels(W[:n], rng=rng), name)
                written += n
                offset += t[-1] + 2.0


def main():
    rows = int(sys.argv[1]) if len(sys.argv) > 1 else 3_600_000
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "long.csv"
        start = time.perf_counter()
        write_recording(path, rows)
        print(f"wrote {rows:,} rows ({path.stat().st_size / 1e6:.0f} MB) in {time.perf_counter() - start:.1f} s")
        # the child reports its own high-water mark (VmHWM, reset at exec; ru_maxrss would
        # include the memory of this parent at the time of the fork)
        child = (
            "import sys; from fts_calib.app.cli import main; code = main(sys.argv[1:]); "
            "print([l for l in open('/proc/self/status') if l.startswith('VmHWM')][0].strip()); sys.exit(code)"
        )
        command = [
            sys.executable,
            "-c",
            child,
            "calibrate",
            "--robot",
            "ur5",
            "--tool",
            "paper_tool",
            str(path),
            "-o",
            str(Path(folder) / "cal.yaml"),
            "--quiet",
        ]
        start = time.perf_counter()
        result = subprocess.run(command, capture_output=True, text=True)
        seconds = time.perf_counter() - start
        if result.returncode != 0:
            print(result.stdout, result.stderr)
        peak = float(result.stdout.strip().splitlines()[-1].split()[1]) / 1024  # kB
        print("\n".join(result.stdout.splitlines()[:3]))
        print(
            f"calibrate end to end (process start included): {rows / seconds:,.0f} rows/s (target >= 250,000), "
            f"{seconds:.1f} s; peak memory {peak:.0f} MB (target <= 500 MB)"
        )


if __name__ == "__main__":
    main()

"""One motion at 1 kHz, 100 Hz and 10 Hz: payload mass, calibrate C error and tare D, with the commands' defaults.

Not collected by pytest: ``tests/test_sample_rate.py`` asserts on the same runs (:func:`simulate_rate_runs`),
this prints the table. The runs are simulated at 1 kHz (the shipped sensor; joint readings
8 ms late with 1e-5 rad of noise rounded to a 20-bit encoder) and decimated to 100 Hz and 10 Hz
(every 10th and 100th row): a calibration plan of 2 levels x 3 stops held ``--dwell`` s (1.5 by
default: 1.0 s is the still span at 10 Hz; 0.3 s is the shipped UR5 plan's, too short at 10 Hz),
the validation payload held 1.5 s in six orientations, and the paper's tool A at rest 3 s. Each
command runs as typed (``fts-calib payload``, ``calibrate``, ``tare``); printed per rate: the
payload's mass against the truth (1.4 kg) with its standard error, the calibration's error against
the true sensor (RMS over loads uniform in the full-scale box, % of full scale, the largest axis)
with the filter ``auto`` chose and the samples kept, and the tare's D minus the true D. A command
that refuses prints its message.

Run: ``.venv/bin/python -m tests.rate_table [--dwell 1.5]`` (about 10 s).
"""

from __future__ import annotations

import argparse
import tempfile
from contextlib import redirect_stderr, redirect_stdout
from io import StringIO
from pathlib import Path

import numpy as np

from fts_calib.app.cli import main
from fts_calib.budget.propagation import range_moments
from fts_calib.core.resources import resolve
from fts_calib.model.calibration import Calibration, load_calibration, save_calibration
from fts_calib.model.sensor_config import load_sensor_config
from fts_calib.planning.motion import plan_sweeps
from fts_calib.planning.sweeps import SweepPattern, sweep_ranges, wrist_ranges
from fts_calib.planning.trajectory_files import TrajectoryFile
from fts_calib.robot.collision import CollisionChecker
from fts_calib.robot.definition import load_robot
from fts_calib.robot.kinematics import Kinematics
from fts_calib.robot.tool import load_tool
from fts_calib.sim.payload_run import simulate_payload_motion, still_poses_motion
from fts_calib.sim.runs import decimate_recording, simulate_recording
from fts_calib.sim.sensor import load_simulated_sensor

RATES = {"1 kHz": 1, "100 Hz": 10, "10 Hz": 100}  # decimation factors of the 1 kHz run
LATENCY_S, JOINT_NOISE = 0.008, 1e-5  # [s], [rad]
HOME = np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0])  # [rad] the UR5's pose; wrist 2 and 3 turn from it
POSES = np.array([(0.0, 0.0), (1.2, 0.0), (-1.2, 0.5), (0.6, 2.0), (-0.5, -2.2), (2.2, 1.0)])  # [rad] wrist 2 and 3


def held(poses: np.ndarray, hold_s: float) -> tuple[np.ndarray, ...]:
    """The UR5 at HOME with wrist 2 and 3 at each pose, held ``hold_s`` [s], moves of 1 s, at 1 kHz: ``(time, q, qd, qdd)``."""
    targets = np.tile(HOME, (len(poses), 1))
    targets[:, 4:6] = poses
    return still_poses_motion(targets, hold_s, 1.0)


def _run(argv: list[str]) -> tuple[int, str]:
    out, err = StringIO(), StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue() + err.getvalue()


def _line(text: str, start: str) -> str:
    return next((line for line in text.splitlines() if line.startswith(start)), "")


def simulate_rate_runs(folder: Path, dwell_s: float = 1.5) -> dict[str, dict[str, Path]]:
    """The three runs at 1 kHz and their decimations: ``{rate: {"cal": path, "payload": path, "tare": path}}``.

    Args:
        folder: Where the recordings are written (and ``true.yaml``, the true calibration).
        dwell_s: Seconds at each stop of the calibration plan (2 levels x 3 stops).
    """
    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    tool = load_tool(resolve("paper_tool", "configs"))
    pattern = SweepPattern(levels=2, stops=3, dwell=dwell_s, span=0.5)
    checker = CollisionChecker(kin, tool.shape, kin.sweep_joints[0])
    ranges = wrist_ranges(kin, checker, HOME, sweep_ranges(kin, HOME, pattern.margin), 0.02).ranges
    plan = plan_sweeps(kin, HOME, ranges, pattern, 1000.0)
    trajectories = [TrajectoryFile(plan.joint_names, plan.time, plan.q, plan.qd, plan.qdd, c.name) for c in tool.configurations]
    joints = {"latency_s": LATENCY_S, "joint_noise": JOINT_NOISE}
    simulate_recording(folder / "cal.csv", kin, tool, trajectories, sensor, np.random.default_rng(3), **joints)
    payload = load_tool(resolve("validation_tool", "configs")).configurations[0]
    motion = held(POSES, 1.5)
    simulate_payload_motion(folder / "payload.csv", kin, payload, sensor, motion, np.random.default_rng(1), LATENCY_S, JOINT_NOISE)
    still = held(POSES[1:2], 3.0)  # the arm at rest 3 s with configuration A
    tare = tool.configuration("A")
    simulate_payload_motion(folder / "tare.csv", kin, tare, sensor, still, np.random.default_rng(2), LATENCY_S, JOINT_NOISE)
    save_calibration(Calibration(sensor.C_bar, sensor.D), folder / "true.yaml")
    runs = {}
    for rate, factor in RATES.items():
        runs[rate] = {name: folder / f"{name}.csv" for name in ("cal", "payload", "tare")}
        if factor > 1:
            runs[rate] = {name: decimate_recording(path, folder / f"{name}_{factor}.csv", factor) for name, path in runs[rate].items()}
    return runs


def main_bench(argv: list[str] | None = None) -> None:
    """Print the table (see the module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dwell", type=float, default=1.5, help="seconds at each stop of the calibration plan (default 1.5)")
    dwell_s = parser.parse_args(argv).dwell
    sim = load_simulated_sensor(resolve("sensor", "configs"))
    full_scale = np.asarray(load_sensor_config(resolve("sensor", "configs")).full_scale, dtype=float)
    moments = range_moments(sim.C_bar, sim.D, full_scale)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        runs = simulate_rate_runs(folder, dwell_s)
        print(f"calibration plan: 2 levels x 3 stops, {dwell_s:g} s at each; payload 1.5 s in 6 orientations; tare 3 s at rest")
        print("rate    | payload mass [kg] (truth 1.4) | calibrate: C error [% FS], filter, kept | tare D - truth [N, N, N, N·m, N·m, N·m]")
        for rate, files in runs.items():
            true = folder / "true.yaml"
            code, text = _run(
                ["payload", "--calibration", str(true), "--robot", "ur5", str(files["payload"]), "-o", str(folder / "p.yaml")]
            )
            mass = _line(text, "  mass").strip() if code == 0 else f"exit {code}: {text.strip().splitlines()[-1]}"
            out = folder / f"c_{RATES[rate]}.yaml"
            code, text = _run(["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(files["cal"]), "-o", str(out)])
            if code == 0:
                cal = load_calibration(out)
                error = np.hstack([cal.C_bar - sim.C_bar, (cal.D - sim.D)[:, None]])
                percent = np.max(100 * np.sqrt(np.einsum("jk,kl,jl->j", error, moments, error)) / full_scale)
                calibrated = f"{percent:.4f}, {_line(text, 'filter:').split(' (')[0][8:]}, {_line(text, 'samples:').split(' seen, ')[1]}"
            else:
                calibrated = f"exit {code}: {text.strip().splitlines()[-1]}"
            tared = folder / "t.yaml"
            save_calibration(Calibration(sim.C_bar, np.zeros(6)), folder / "zero.yaml")
            argv = ["tare", "--calibration", str(folder / "zero.yaml"), "--robot", "ur5", "--tool", "paper_tool", "--configuration", "A"]
            code, text = _run([*argv, str(files["tare"]), "-o", str(tared)])
            tare = " ".join(f"{v:+.5f}" for v in load_calibration(tared).D - sim.D) if code == 0 else f"exit {code}: {text.strip()[-200:]}"
            print(f"{rate:7s} | {mass} | {calibrated} | {tare}")


if __name__ == "__main__":
    main_bench()

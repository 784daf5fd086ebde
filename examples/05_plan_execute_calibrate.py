"""Plan the calibration sweeps, execute them (simulated) and calibrate from the recording.

The whole job of the two commands, from Python: ``plan_trajectories`` plans jerk-limited
sweeps of the UR5's last two joints (ruckig), checks limits and collisions, and predicts
the accuracy; each configuration's trajectory is written as the CSV a controller plays
(time, positions, velocities, accelerations at the plan's rate). Here the arm is
simulated: the executed motion goes through the kinematics, the tool's moving wrench and
the simulated sensor into a recording CSV, which ``fts_calib.calibrate`` reads as it would
a real robot's log; the calibration is saved and printed beside the truth. A small raster
(3 levels x 4 stops, 100 Hz) keeps it to a few seconds.
"""

import tempfile
from pathlib import Path

import numpy as np

import fts_calib
from fts_calib.filters.settings import PipelineConfig
from fts_calib.planning.sweeps import SweepPattern
from fts_calib.planning.trajectory_files import write_trajectory
from fts_calib.sim.runs import simulate_recording


def main():
    """Plan, write the trajectories, simulate their execution, calibrate and print the result."""
    tool = fts_calib.load_tool("paper_tool")
    spec = fts_calib.load_sensor_config("sensor")  # the paper's sensor: its nominal C predicts the accuracy
    pattern = SweepPattern(levels=3, stops=4, dwell=0.4)  # dwell [s] at each stop
    run = fts_calib.plan_trajectories("ur5", tool, spec, PipelineConfig().filter, 1e-5, pattern, rate=100.0)  # noise [mV/V], [Hz]
    plan = run.result.plan
    print(f"planned {plan.duration:.1f} s of motion per configuration, {len(plan.time):,} samples at 100 Hz")
    print(f"checks of limits and collisions: problems: {run.problems or 'none'}")
    print(f"predicted accuracy: largest error {run.budget.largest_percent:.3f} % of full scale" if run.budget else "")
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder)
        trajectories = []
        for name in tool.names:  # one file per configuration: mount it, then play the file on the arm
            t = plan.trajectory(name)
            write_trajectory(out / f"{name}.csv", t.joint_names, t.time, t.q, t.qd, t.qdd, name)
            trajectories.append(t)
        print(f"wrote {', '.join(f'{n}.csv' for n in tool.names)} (a temporary folder): time, per joint position [rad], _vel, _acc, tool")
        # the "robot": the executed motion through the simulated sensor, logged as a robot would
        kin = fts_calib.Kinematics(fts_calib.load_robot("ur5"))
        sensor = fts_calib.load_simulated_sensor("sensor")
        recording = simulate_recording(out / "recording.csv", kin, tool, trajectories, sensor, np.random.default_rng(0))
        calibration = fts_calib.calibrate(recording, robot="ur5", tool="paper_tool", sensor="sensor")
        saved = calibration.save(out / "calibration.yaml")
        lines = len(saved.read_text().splitlines())
        print(f"calibrated from {recording.name}, saved {saved.name} ({lines} lines; the folder goes at the end)")
    q = calibration.quality
    error = np.abs(calibration.C - sensor.C) / q.stderr_C
    print(f"rank {q.rank} of {q.full_rank}, fit {q.fit['verdict']}, {q.samples_used:,} samples kept of {q.samples_seen:,}")
    print(f"C against Table 1: largest error {error.max():.2f} standard errors (expected below 5)")
    print("D       =", " ".join(f"{v:+.4f}" for v in calibration.D), "[N, N·m]")
    print("true D  =", " ".join(f"{v:+.4f}" for v in sensor.D))
    print(f"measured accuracy: largest error {q.budget['largest_percent_fs']} % of full scale")


if __name__ == "__main__":
    main()

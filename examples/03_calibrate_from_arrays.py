"""Calibrate from numpy arrays in memory, with `fts_calib.calibrate`.

No file: the arrays a controller or a notebook already holds go straight in. Here they
come from a simulation: the shipped UR5 sweeps (``trajectories/ur5``, 100 Hz) played once
per tool configuration through the arm's kinematics, the paper's 2 kg tool (moving: its
Newton-Euler wrench) and the simulated sensor (true C = Table 1 of the paper, noise
1e-5 mV/V per bridge, 24-bit ADC). ``fts_calib.calibrate`` keeps the quasi-static samples,
solves, checks the fit and measures the accuracy budget, as the ``calibrate`` command does.
"""

import numpy as np

import fts_calib
from fts_calib.core.resources import data_dir
from fts_calib.planning.trajectory_files import read_trajectory


def main():
    """Simulate the arrays, calibrate, and print C, D and the budget beside the truth."""
    kin = fts_calib.Kinematics(fts_calib.load_robot("ur5"))
    tool = fts_calib.load_tool("paper_tool")  # configurations A, B, C: 2 kg, three centres of mass
    sensor = fts_calib.load_simulated_sensor("sensor")
    trajectories = [read_trajectory(data_dir("trajectories") / "ur5" / f"{name}.csv.gz") for name in tool.names]
    batches = list(fts_calib.simulate_batches(kin, tool, trajectories, sensor, np.random.default_rng(0)))
    arrays = {
        "time": np.concatenate([b.time for b in batches]),  # [s], (N,)
        "joints": np.concatenate([b.joints for b in batches]),  # [rad], (N, 6) in kin.joint_names order
        "channels": np.concatenate([b.channels for b in batches]),  # [mV/V], (N, 8) raw
        "configuration": [tool.names[c] for b in batches for c in b.configuration],  # the tool configuration mounted
    }
    print(f"{len(arrays['time']):,} samples in memory, {len(tool.names)} tool configurations, {arrays['time'][-1]:.1f} s")
    calibration = fts_calib.calibrate(arrays, robot=kin, tool=tool, sensor="sensor")
    q = calibration.quality
    print(f"kept {q.samples_used:,} quasi-static samples; rank {q.rank} of {q.full_rank}; fit: {q.fit['verdict']}")
    print("C[Fx]   =", " ".join(f"{v:9.4f}" for v in calibration.C[0]), "N per mV/V")
    print("Table 1 =", " ".join(f"{v:9.4f}" for v in sensor.C[0]))
    print("stderr  =", " ".join(f"{v:9.4f}" for v in q.stderr_C[0]))
    print("D       =", " ".join(f"{v:+.4f}" for v in calibration.D), "[N, N·m]")
    print("true D  =", " ".join(f"{v:+.4f}" for v in sensor.D))
    print("stderr  =", " ".join(f"{v:.1e}" for v in q.stderr_D))
    print(f"measured accuracy budget: largest error {q.budget['largest_percent_fs']} % of full scale")


if __name__ == "__main__":
    main()

"""A sensor that does not repeat: quiet within a still pose, its reading of one load scattered from pose to pose.

Issue 31, item 2: a low-cost sensor shows 0.02 N of noise within a still pose but 1-2 N of
scatter between poses (hysteresis, creep). Simulated here as the paper's sensor (8 bridges,
24-bit ADC) with channel noise of about 0.02 N on the forces and an offset of the wrench drawn
anew at every stop of the arm (standard deviation 1.5 N per force axis, 0.1 N m per moment
axis), which it keeps while the arm moves to the next stop. The UR5 sweeps a 5 x 6 raster of
wrist stops per configuration at 100 Hz with the paper's tool; every third stop is held out of
the calibration, and the calibration is judged there, against the true load. Units: N, N m, s.
"""

from __future__ import annotations

import dataclasses
from functools import cache
from pathlib import Path

import numpy as np

from fts_calib.core.resources import resolve
from fts_calib.model.sensor_config import load_sensor_config
from fts_calib.planning.motion import plan_sweeps
from fts_calib.planning.sweeps import SweepPattern, sweep_ranges, wrist_ranges
from fts_calib.robot.collision import CollisionChecker
from fts_calib.robot.definition import load_robot
from fts_calib.robot.kinematics import Kinematics
from fts_calib.robot.tool import load_tool
from fts_calib.sim.runs import tool_wrenches
from fts_calib.sim.sensor import SimulatedSensor, simulated_sensor
from fts_calib.sources.writer import RecordingWriter

SCATTER = np.array([1.5, 1.5, 1.5, 0.1, 0.1, 0.1])  # [N, N m] standard deviation of the offset drawn at every stop
CHANNEL_NOISE = 1.0e-4  # [mV/V] per bridge: about 0.02 N on the forces within a pose
RATE_HZ = 100.0
RASTER = SweepPattern(levels=5, stops=6, dwell=0.5)
HELD_OUT = 3  # every third stop is held out of the calibration


@cache
def setup():
    """``(kinematics, tool, plan)``: the UR5, the paper's tool and the raster (computed once per process)."""
    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    tool = load_tool(resolve("paper_tool", "configs"))
    checker = CollisionChecker(kin, tool.shape, kin.sweep_joints[0])
    home = np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0])
    ranges = wrist_ranges(kin, checker, home, sweep_ranges(kin, home, RASTER.margin), 0.02).ranges
    return kin, tool, plan_sweeps(kin, home, ranges, RASTER, RATE_HZ)


def sensor() -> tuple[SimulatedSensor, np.ndarray]:
    """The simulated sensor (the paper's, noisier) and its full scale [N, N m] (6,)."""
    path = resolve("sensor", "configs")
    spec = load_sensor_config(path)
    return dataclasses.replace(simulated_sensor(spec, path), noise_std=np.full(8, CHANNEL_NOISE)), spec.full_scale


def record(folder: Path, seed: int) -> tuple[Path, dict]:
    """Write the calibration recording (held-out stops left out) and return the held-out stops' samples.

    Returns:
        ``(recording, held_out)``: held_out holds ``channels`` (M, 8), the true load ``W`` (M, 6) [N, N m]
        and the stop ``pose`` (M,) of the still samples of the held-out stops.
    """
    rng = np.random.default_rng(seed)
    kin, tool, plan = setup()
    sim, _ = sensor()
    still = np.all(plan.qd == 0.0, axis=1) & np.all(plan.qdd == 0.0, axis=1)
    pose = np.cumsum(np.concatenate([[still[0]], still[1:] & ~still[:-1]]))  # the stop a sample is at or has left
    held = {"channels": [], "W": [], "pose": []}
    path = folder / f"repeatability-{seed}.csv"
    with RecordingWriter(path, kin.joint_names, 8) as writer:
        start = 0.0
        for k, c in enumerate(tool.configurations):
            W = tool_wrenches(kin, tool, c.name, plan.q, plan.qd, plan.qdd)
            offsets = rng.standard_normal((int(pose.max()) + 1, 6)) * SCATTER
            channels = sim.channels(W + offsets[pose], rng=rng)
            out = still & (pose % HELD_OUT == 0)
            keep = ~out
            writer.write(plan.time[keep] - plan.time[0] + start, plan.q[keep], channels[keep], c.name)
            held["channels"].append(channels[out])
            held["W"].append(W[out])
            held["pose"].append(pose[out] + 1000 * k)
            start += plan.time[-1] - plan.time[0] + 2.0
    return path, {key: np.concatenate(v) for key, v in held.items()}


def unseen_error(calibration, held: dict) -> np.ndarray:
    """The calibration's reading minus the true load, averaged over each held-out stop, [N, N m]. Shape (stops, 6)."""
    error = calibration.wrench(held["channels"], region_check=False) - held["W"]
    poses, where = np.unique(held["pose"], return_inverse=True)
    sums = np.zeros((len(poses), 6))
    np.add.at(sums, where, error)
    return sums / np.bincount(where)[:, None]

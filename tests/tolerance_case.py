"""A tool and a sensor mount known only to a tolerance: the hidden physics differs from the files within it.

The files declare the tool's centres of mass to +-0.5 mm per coordinate and its mass to +-1 g
(``tolerance`` of the tool file: one error common to every configuration, as the paper's tool
moves one weight) and the sensor mount to +-0.1 deg about each axis (``accuracy.mount_rotation``
of the robot file). The recording is simulated with the true tool (its centre of mass off by one
error drawn uniformly within the tolerance, or on its corners, and its mass by one within +-1 g;
optionally one configuration's centre of mass off by more: a wrong tool file) and the true mount
(S rotated by a draw within its tolerance), through the paper's simulated sensor (noise, 24-bit
ADC) and the moving tool's wrench, and calibrated with the files as declared (constant offsets,
as the issue asks). The truth for the error is the simulated sensor.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pinocchio as pin

from fts_calib.budget.propagation import range_moments
from fts_calib.core.resources import resolve
from fts_calib.filters.settings import OffsetConfig, PipelineConfig
from fts_calib.model.sensor_config import load_sensor_config
from fts_calib.planning.trajectory_files import TrajectoryFile
from fts_calib.robot.definition import load_robot
from fts_calib.robot.kinematics import Kinematics
from fts_calib.robot.tool import Tool, ToolTolerance, load_tool
from fts_calib.session.calibration_run import CalibrateResult, calibrate_recording
from fts_calib.sim.runs import simulate_recording
from fts_calib.sim.sensor import simulated_sensor

COM_TOLERANCE = 5e-4  # [m] per coordinate, declared in the tool file
MASS_TOLERANCE = 1e-3  # [kg], declared in the tool file
MOUNT_TOLERANCE = math.radians(0.1)  # [rad] about each axis, declared in the robot file
CONSTANT = PipelineConfig(offsets=OffsetConfig(model="constant"))


def declared(robot: str = "ur5") -> tuple[Kinematics, Tool]:
    """The robot and tool files as the user writes them: nominal values, with their tolerances declared."""
    definition = load_robot(resolve(robot, "robots"))
    accuracy = dataclasses.replace(definition.accuracy, mount_rotation=MOUNT_TOLERANCE)
    tool = load_tool(resolve("paper_tool", "configs"))
    return Kinematics(dataclasses.replace(definition, accuracy=accuracy)), dataclasses.replace(
        tool, tolerance=ToolTolerance(mass=MASS_TOLERANCE, com=COM_TOLERANCE, own_mass=0.0, own_com=0.0)
    )


def hidden(kin: Kinematics, tool: Tool, rng: np.random.Generator, corners: bool = False, b_off: float = 0.0):
    """The true robot and tool: the centre of mass, mass and mount off within their tolerances.

    Args:
        kin: The declared robot.
        tool: The declared tool.
        rng: The draws.
        corners: Draw the centre-of-mass and mount errors on the corners of their boxes (the largest).
        b_off: Configuration B's centre of mass is off by this many tolerances more along Z (its own error).

    Returns:
        ``(kinematics, tool, drawn)``: drawn holds the errors, ``com`` (k, 3) [m], ``mount`` (3,) [rad].
    """
    k = len(tool.configurations)
    draw = rng.choice([-1.0, 1.0], 3) if corners else rng.uniform(-1.0, 1.0, 3)
    com = np.tile(COM_TOLERANCE * draw, (k, 1))
    com[tool.names.index("B"), 2] += b_off * COM_TOLERANCE
    mass = MASS_TOLERANCE * rng.uniform(-1.0, 1.0)  # one weight moved between configurations: one mass
    moved = [
        dataclasses.replace(c, mass=c.mass + mass, p_sensor_com=c.p_sensor_com + e) for c, e in zip(tool.configurations, com, strict=True)
    ]
    true_tool = dataclasses.replace(tool, configurations=tuple(moved))
    mount = MOUNT_TOLERANCE * (rng.choice([-1.0, 1.0], 3) if corners else rng.uniform(-1.0, 1.0, 3))
    sensor = kin.robot.sensor
    rpy = pin.rpy.matrixToRpy(pin.rpy.rpyToMatrix(*sensor.rpy) @ pin.exp3(mount))  # S turned about its own axes
    robot = dataclasses.replace(kin.robot, sensor=dataclasses.replace(sensor, rpy=np.asarray(rpy)))
    return Kinematics(robot), true_tool, {"com": com, "mount": mount}


def own_error(calibration, sim, full_scale) -> np.ndarray:
    """The calibration's error against the true sensor, RMS over loads uniform in the full-scale box, % FS per axis."""
    error = np.hstack([calibration.C_bar - sim.C_bar, (calibration.D - sim.D)[:, None]])
    M = range_moments(sim.C_bar, sim.D, full_scale)
    return 100 * np.sqrt(np.einsum("jk,kl,jl->j", error, M, error)) / full_scale


def run(plan, folder: Path, seed: int, corners: bool = False, b_off: float = 0.0, robot: str = "ur5"):
    """Simulate the hidden physics on ``plan`` and calibrate with the declared files (constant offsets).

    Returns:
        ``(result, error % FS (6,) or None, budget total % FS (6,) or None, drawn errors)``.
    """
    rng = np.random.default_rng(seed)
    kin, tool = declared(robot)
    true_kin, true_tool, drawn = hidden(kin, tool, rng, corners, b_off)
    path = resolve("sensor", "configs")
    spec = load_sensor_config(path)
    sensor = simulated_sensor(spec, path)
    trajectories = [TrajectoryFile(plan.joint_names, plan.time, plan.q, plan.qd, plan.qdd, c.name) for c in tool.configurations]
    recording = simulate_recording(folder / f"tolerance-{seed}.csv", true_kin, true_tool, trajectories, sensor, rng)
    result: CalibrateResult = calibrate_recording(recording, kin, tool, CONSTANT, full_scale=spec.full_scale)
    if result.calibration is None:
        return result, None, None, drawn
    error = own_error(result.calibration, sensor, spec.full_scale)
    return result, error, result.session.budget.total_percent, drawn

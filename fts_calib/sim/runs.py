"""Simulated recordings: planned trajectories played through the kinematics and a simulated sensor.

For each tool configuration's trajectory, the moving tool's full wrench on the sensor
(Newton-Euler with its mass, centre of mass and inertia, from the trajectory's positions,
velocities and accelerations: :meth:`fts_calib.robot.tool.ToolConfiguration.dynamic_wrench`) goes
through the simulated sensor (:class:`fts_calib.sim.sensor.SimulatedSensor`: eq 22, null
content, noise, drift, 24-bit ADC). The recording has exactly the format a real robot
produces (:mod:`fts_calib.sources.recording`); configurations follow each other with a pause for the
tool change, during which nothing is recorded. With ``poses_only`` only the samples where
the planned motion holds still are recorded: a static-pose dataset (the arm still at each
stop for the trajectory's dwell, poses separated by gaps), as a user records by hand.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from ..core import arrays as validation
from ..core.exceptions import FtsCalibError
from ..planning.trajectory_files import TrajectoryFile
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool, tool_load
from ..sources.batch import SampleBatch
from ..sources.recording import RecordingWriter
from .drift import OffsetDrift
from .sensor import SimulatedSensor

_BLOCK = 1 << 15  # samples simulated at a time (bounded memory)


def tool_wrenches(kin: Kinematics, tool: Tool, configuration: str, q, qd, qdd, dynamic: bool = True) -> np.ndarray:
    """The wrench a tool configuration exerts on the sensor along a motion.

    Args:
        kin: Kinematics.
        tool: The tool.
        configuration: Configuration name.
        q: Joint positions [rad], shape (N, n_joints).
        qd: Joint velocities [rad/s], shape (N, n_joints).
        qdd: Joint accelerations [rad/s^2], shape (N, n_joints).
        dynamic: Newton-Euler wrench of the moving tool; False for the static one (eqs 17-18).

    Returns:
        ``[Fx, Fy, Fz, Mx, My, Mz]`` in [N, N m], shape (N, 6).
    """
    if not dynamic:
        return tool_load(kin, tool, q, configuration).static
    return tool_load(kin, tool, q, configuration, qd, qdd).w_sensor


def simulate_batches(
    kin: Kinematics,
    tool: Tool,
    trajectories: Sequence[TrajectoryFile],
    sensor: SimulatedSensor,
    rng: np.random.Generator | None,
    tool_change_s: float = 2.0,
    start_time: float = 0.0,
    dynamic: bool = True,
    drift: OffsetDrift | None = None,
    poses_only: bool = False,
) -> Iterator[SampleBatch]:
    """The samples of the given trajectories, as a feed would deliver them (see the module docstring).

    Args:
        kin: Kinematics of the robot the trajectories are for.
        tool: The tool; each trajectory's ``tool`` names its configuration.
        trajectories: One trajectory per configuration, in the order they are run.
        sensor: The simulated sensor.
        rng: Random generator for the sensor noise (noiseless when None).
        tool_change_s: Pause between configurations [s].
        start_time: Time of the first sample [s].
        dynamic: Use the moving tool's wrench (True) or the static one.
        drift: Offsets that move (:class:`fts_calib.sim.drift.OffsetDrift`: time from
            ``start_time``, one jump per tool change) and the temperature channel; constant
            offsets and no temperature when None.
        poses_only: Only the samples where the planned joints hold still (zero velocity and
            acceleration): a static-pose recording.

    Yields:
        Batches of at most 32,768 samples, each of one configuration (its index in the tool).

    Raises:
        FtsCalibError: A trajectory's joints differ from the robot's.
        ConfigError: A negative pause between configurations (time would go backwards).
    """
    validation.non_negative("tool_change_s", tool_change_s, "s")
    offset = start_time
    for changes, traj in enumerate(trajectories):
        if tuple(traj.joint_names) != tuple(kin.joint_names):
            raise FtsCalibError(f"trajectory joints {list(traj.joint_names)} differ from the robot's {list(kin.joint_names)}")
        code = tool.names.index(tool.configuration(traj.tool).name)  # a clear error for an unknown configuration
        for start in range(0, len(traj.time), _BLOCK):
            part: slice | np.ndarray = slice(start, start + _BLOCK)
            if poses_only:
                rows = np.arange(start, min(start + _BLOCK, len(traj.time)))
                still = rows[np.all(traj.qd[rows] == 0.0, axis=1) & np.all(traj.qdd[rows] == 0.0, axis=1)]
                if not len(still):
                    continue
                part = still
            W = tool_wrenches(kin, tool, traj.tool, traj.q[part], traj.qd[part], traj.qdd[part], dynamic)
            t = traj.time[part] - traj.time[0] + offset
            temperature = None
            if drift is not None:
                W = W - drift.offsets(t - start_time, changes)  # the sensor reads W - delta D: its offsets moved
                temperature = drift.temperature(t - start_time)
            codes = np.full(len(t), code, dtype=np.int64)
            yield SampleBatch(t, traj.q[part], sensor.channels(W, time=t, rng=rng), codes, temperature)
        offset += traj.time[-1] - traj.time[0] + tool_change_s


def simulate_recording(
    path: str | Path,
    kin: Kinematics,
    tool: Tool,
    trajectories: Sequence[TrajectoryFile],
    sensor: SimulatedSensor,
    rng: np.random.Generator | None,
    tool_change_s: float = 2.0,
    start_time: float = 0.0,
    dynamic: bool = True,
    drift: OffsetDrift | None = None,
    poses_only: bool = False,
) -> Path:
    """Write a recording of the given trajectories (see the module docstring).

    Args:
        path: Recording to write (``.csv`` or ``.csv.gz``), atomically.
        kin: Kinematics of the robot the trajectories are for.
        tool: The tool; each trajectory's ``tool`` names its configuration.
        trajectories: One trajectory per configuration, in the order they are run.
        sensor: The simulated sensor.
        rng: Random generator for the sensor noise (noiseless when None).
        tool_change_s: Pause between configurations [s].
        start_time: Time of the first sample [s].
        dynamic: Use the moving tool's wrench (True) or the static one.
        drift: Offsets that move, and a ``temperature`` column (:class:`fts_calib.sim.drift.OffsetDrift`);
            constant offsets and no temperature column when None.
        poses_only: Record only the samples where the planned joints hold still.

    Raises:
        FtsCalibError: A trajectory's joints differ from the robot's.
        ConfigError: A negative pause between configurations (time would go backwards).
    """
    with RecordingWriter(path, kin.joint_names, sensor.layout.n_channels, temperature=drift is not None) as writer:
        for batch in simulate_batches(kin, tool, trajectories, sensor, rng, tool_change_s, start_time, dynamic, drift, poses_only):
            writer.write(batch.time, batch.joints, batch.channels, tool.names[int(batch.configuration[0])], batch.temperature)
    return Path(path)

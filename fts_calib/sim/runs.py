"""Simulated recordings: planned trajectories played through the kinematics and a simulated sensor.

For each tool configuration's trajectory, the moving tool's full wrench on the sensor
(Newton-Euler with its mass, centre of mass and inertia, from the trajectory's positions,
velocities and accelerations: :meth:`fts_calib.robot.tool.ToolConfiguration.dynamic_wrench`) goes
through the simulated sensor (:class:`fts_calib.sim.sensor.SimulatedSensor`: eq 22, null
content, noise, drift, 24-bit ADC). The recording has exactly the format a real robot
produces (:mod:`fts_calib.sources.recording`); configurations follow each other with a pause for the
tool change, during which nothing is recorded. With ``poses_only`` only the samples where
the planned motion holds still are recorded: a static-pose dataset (the arm still at each
stop for the trajectory's dwell, poses separated by gaps), as a user records by hand. The
joint readings may be late and noisy (:func:`joint_readings`: ``latency_s``, ``joint_noise``,
a 20-bit encoder's rounding).

:func:`decimate_recording` writes the same run at a lower sample rate (every k-th row), as a
logger at 100 Hz or 10 Hz would have recorded the motion a 1 kHz controller recorded.
"""

from __future__ import annotations

import gzip
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from ..core import arrays as validation
from ..core.exceptions import ConfigError, FtsCalibError
from ..core.files import AtomicFile
from ..planning.trajectory_files import TrajectoryFile
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool, tool_load
from ..sources.batch import SampleBatch
from ..sources.recording import RecordingWriter
from .drift import OffsetDrift
from .sensor import SimulatedSensor

_BLOCK = 1 << 15  # samples simulated at a time (bounded memory)
#: A 20-bit encoder's step [rad]: the rounding of simulated joint readings.
ENCODER_STEP = 2 * np.pi / 2**20


def joint_readings(time, q, latency_s: float, joint_noise: float, rng: np.random.Generator | None) -> np.ndarray:
    """The joint readings of a motion: ``latency_s`` late, with white noise and a 20-bit encoder's rounding.

    Args:
        time: Sample times [s], shape (N,).
        q: The joints' true positions at ``time`` [rad], shape (N, n_joints).
        latency_s: How late the readings are [s]: the row of time t holds the joints of t - latency_s
            (interpolated; before the first sample, the first).
        joint_noise: Standard deviation of the white reading noise [rad].
        rng: Random generator of the noise; None: exact readings, not rounded.

    Returns:
        Shape (N, n_joints), [rad].
    """
    time, q = np.asarray(time, dtype=float), np.asarray(q, dtype=float)
    readings = q if latency_s == 0.0 else np.stack([np.interp(time - latency_s, time, q[:, k]) for k in range(q.shape[1])], axis=1)
    if rng is None:
        return readings
    return np.round((readings + joint_noise * rng.standard_normal(readings.shape)) / ENCODER_STEP) * ENCODER_STEP


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
    latency_s: float = 0.0,
    joint_noise: float = 0.0,
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
        latency_s: How late the joint readings are [s] (:func:`joint_readings`, within each block).
        joint_noise: White noise of the joint readings [rad]; with ``rng``, the readings are
            also rounded to a 20-bit encoder's step (:func:`joint_readings`).

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
            readings = joint_readings(t, traj.q[part], latency_s, joint_noise, rng) if latency_s or joint_noise else traj.q[part]
            yield SampleBatch(t, readings, sensor.channels(W, time=t, rng=rng), codes, temperature)
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
    latency_s: float = 0.0,
    joint_noise: float = 0.0,
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
        latency_s: How late the joint readings are [s] (:func:`joint_readings`).
        joint_noise: White noise of the joint readings [rad] (with ``rng``, rounded to a 20-bit encoder's step).

    Raises:
        FtsCalibError: A trajectory's joints differ from the robot's.
        ConfigError: A negative pause between configurations (time would go backwards).
    """
    with RecordingWriter(path, kin.joint_names, sensor.layout.n_channels, temperature=drift is not None) as writer:
        batches = simulate_batches(
            kin, tool, trajectories, sensor, rng, tool_change_s, start_time, dynamic, drift, poses_only, latency_s, joint_noise
        )
        for batch in batches:
            writer.write(batch.time, batch.joints, batch.channels, tool.names[int(batch.configuration[0])], batch.temperature)
    return Path(path)


def decimate_recording(path: str | Path, output: str | Path, factor: int) -> Path:
    """Write every ``factor``-th row of a recording (the first kept): the same run at 1 / ``factor`` of its rate.

    The rows are copied as written (header, numbers, tool names), so the lower-rate recording
    holds exactly those samples of the original; a logger that records at a lower rate without
    averaging gives the same (per-sample noise unchanged).

    Args:
        path: The recording (``.csv`` or ``.csv.gz``).
        output: The recording to write (``.csv`` or ``.csv.gz``), atomically.
        factor: Keep one row in ``factor`` (>= 1).

    Returns:
        The path written.

    Raises:
        ConfigError: ``factor`` is not an integer >= 1.
    """
    if not (float(factor).is_integer() and factor >= 1):
        raise ConfigError("factor", factor, "an integer >= 1 (one row kept in factor)")
    opener = gzip.open if str(path).endswith(".gz") else open
    with opener(path, "rt", encoding="utf-8", newline="") as source, AtomicFile(Path(output)) as target:
        packed = gzip.GzipFile(fileobj=target.handle, mode="wb") if str(output).endswith(".gz") else None
        sink = packed or target.handle
        sink.write(source.readline().encode("utf-8"))  # the header
        for k, line in enumerate(source):
            if k % int(factor) == 0:
                sink.write(line.encode("utf-8"))
        if packed is not None:
            packed.close()
    return Path(output)

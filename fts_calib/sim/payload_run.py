"""A simulated recording of a payload moved continuously, with late and noisy joint readings.

The payload's Newton-Euler wrench (:meth:`fts_calib.robot.tool.ToolConfiguration.dynamic_wrench`,
from the planned positions, velocities and accelerations) goes through the simulated sensor
(noise, 24-bit ADC); the joint readings are those of ``latency_s`` earlier (the row of time t
holds the joints of t - latency_s, as a joint stream that lags the channels), with white noise
of ``joint_noise`` [rad] and the rounding of a 20-bit encoder; the offsets may drift. Times in [s], angles in [rad].
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..robot.kinematics import Kinematics
from ..robot.tool import ToolConfiguration
from ..sources.recording import RecordingWriter
from .drift import OffsetDrift
from .runs import joint_readings
from .sensor import SimulatedSensor


def still_poses_motion(targets, hold_s: float, move_s: float, rate_hz: float = 1000.0):
    """A motion that holds each target still ``hold_s``, then moves to the next in ``move_s`` (a quintic, rest to rest).

    For :func:`simulate_payload_motion`: still poses joined by moves, as a user records a payload
    or a tare window (the arm at rest, then the next orientation).

    Args:
        targets: The joint positions held [rad], shape (P, n_joints).
        hold_s: Time at each target [s].
        move_s: Time of each move [s].
        rate_hz: Sample rate [Hz].

    Returns:
        ``(time (N,), q, qd, qdd (N, n_joints))`` in [s, rad, rad/s, rad/s^2], time from 0.
    """
    targets = np.atleast_2d(np.asarray(targets, dtype=float))
    n_hold, n_move = int(round(hold_s * rate_hz)), int(round(move_s * rate_hz))
    s = np.arange(n_move) / max(n_move, 1)
    position = 10 * s**3 - 15 * s**4 + 6 * s**5
    velocity = (30 * s**2 - 60 * s**3 + 30 * s**4) / move_s
    acceleration = (60 * s - 180 * s**2 + 120 * s**3) / move_s**2
    parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    zeros = np.zeros((n_hold, targets.shape[1]))
    for k, target in enumerate(targets):
        parts.append((np.tile(target, (n_hold, 1)), zeros, zeros))
        if k + 1 < len(targets):
            step = targets[k + 1] - target
            parts.append((target + np.outer(position, step), np.outer(velocity, step), np.outer(acceleration, step)))
    q, qd, qdd = (np.concatenate([part[i] for part in parts]) for i in range(3))
    return np.arange(len(q)) / rate_hz, q, qd, qdd


def simulate_payload_motion(
    path: str | Path,
    kin: Kinematics,
    payload: ToolConfiguration,
    sensor: SimulatedSensor,
    motion: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    rng: np.random.Generator | None,
    latency_s: float = 0.0,
    joint_noise: float = 0.0,
    gravity: float | None = None,
    drift: OffsetDrift | None = None,
) -> Path:
    """Write the recording of ``payload`` moved along ``motion`` (see the module docstring).

    Args:
        path: Recording to write (``.csv`` or ``.csv.gz``).
        kin: Kinematics.
        payload: The payload (its inertia: a point mass when None).
        sensor: The simulated sensor.
        motion: ``(time (N,), q, qd, qdd (N, n_joints))`` in [s, rad, rad/s, rad/s^2]
            (e.g. :func:`fts_calib.payload.inertia_motion.payload_excitation`).
        rng: Random generator of the sensor and joint noise (noiseless and unrounded when None).
        latency_s: How late the joint readings are [s].
        joint_noise: Standard deviation of the joint reading noise [rad].
        gravity: Magnitude of gravity [m/s^2]; the robot model's when None.
        drift: Offsets that move from the start of the motion (:class:`fts_calib.sim.drift.OffsetDrift`);
            constant when None.

    Returns:
        The path written.
    """
    time, q, qd, qdd = (np.asarray(v, dtype=float) for v in motion)
    state = kin.sensor_motion(q, qd, qdd)
    g = np.einsum("nji,j->ni", state.R_world_sensor, kin.g_world(gravity))
    wrench = payload.dynamic_wrench(g, state.omega, state.alpha, state.a)
    if drift is not None:
        wrench = wrench - drift.offsets(time - time[0], 0)  # the sensor reads W - delta D: its offsets moved
    readings = joint_readings(time, q, latency_s, joint_noise, rng)
    with RecordingWriter(path, kin.joint_names, sensor.layout.n_channels) as writer:
        writer.write(time, readings, sensor.channels(wrench, time=time, rng=rng), payload.name)
    return Path(path)

"""Payload from a recorded continuous motion: the sensor's motion from the joint readings, the latency estimated.

The recording's rows (:func:`fts_calib.service.payload_recording.read_payload_samples`: one
payload, bad rows and railed channels refused) give the calibrated wrench; the joint readings,
aligned by the stream latency, give the sensor frame's motion (joint rates by
:func:`fts_calib.pipeline.qsfilter.joint_rates`, then :meth:`Kinematics.sensor_motion`), and
:func:`fts_calib.service.payload_motion.fit_payload_motion` the payload. The latency starts at
the pipeline's ``live.latency_s`` and is then estimated with the payload just identified
(:func:`fts_calib.pipeline.latency.estimate_latency`, axes weighted by the fit's residual
spread), the joints re-aligned and the payload fitted again, until the latency moves by less
than 10 us. Samples within half a derivative window of the recording's ends are left out
(their rates come from a cut window). Times in [s].
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.exceptions import PayloadError
from ..model.calibration import Calibration
from ..model.channel_limits import ChannelLimits
from ..pipeline.latency import estimate_latency
from ..pipeline.qsfilter import PERIOD_SAMPLES, joint_rates, sample_period
from ..robot.kinematics import Kinematics
from .payload_motion import MotionPayloadEstimate, fit_payload_motion
from .payload_recording import read_payload_samples

_LATENCY_TOLERANCE_S = 1e-5  # [s] a latency step below this ends the alternation
_ROUNDS = 5  # fits at most


@dataclass(frozen=True)
class RecordedMotionPayload:
    """A payload identified from a recorded motion.

    Attributes:
        estimate: The payload, offsets and latency with their standard errors.
        rows: Rows read from the recording.
        duration_s: Time spanned by the samples used [s].
        rails: One line per channel whose samples were refused at its rail.
    """

    estimate: MotionPayloadEstimate
    rows: int
    duration_s: float
    rails: tuple[str, ...] = ()


def aligned_joints(time: np.ndarray, joints: np.ndarray, latency_s: float, continuous: np.ndarray) -> np.ndarray:
    """The joints at each sample's time when the readings are ``latency_s`` late: read at ``t + latency_s``.

    Args:
        time: Sample times [s], non-decreasing. Shape (N,).
        joints: Joint readings [rad]. Shape (N, n_joints).
        latency_s: How late the readings are [s] (the row of time t holds the joints of t - latency_s).
        continuous: Which joints are continuous (unwrapped before interpolating). Shape (n_joints,).

    Returns:
        Shape (N, n_joints); rows whose ``t + latency_s`` is outside the recording take its end value.
    """
    joints = np.array(joints, dtype=float)
    if np.any(continuous) and len(joints) > 1:
        joints[:, continuous] = np.unwrap(joints[:, continuous], axis=0)
    if latency_s == 0.0:
        return joints
    return np.stack([np.interp(time + latency_s, time, joints[:, k]) for k in range(joints.shape[1])], axis=1)


def identify_payload_from_motion(
    path: str | Path,
    kin: Kinematics,
    calibration: Calibration,
    window_s: float = 0.05,
    latency_s: float = 0.0,
    fit_latency: bool = True,
    limits: ChannelLimits | None = None,
) -> RecordedMotionPayload:
    """Identify mass, centre of mass, inertia and offsets from a recording of a continuous motion (module docstring).

    Args:
        path: Recording (CSV, CSV.gz or a ROS 2 bag) of one payload moving.
        kin: Kinematics of the robot (its model's gravity is used).
        calibration: The sensor's calibration.
        window_s: Window of the joint-rate estimates [s] (the filter's ``derivative_window_s``).
        latency_s: How late the joint readings are [s] (the pipeline's ``live.latency_s``): the start.
        fit_latency: Estimate the remaining latency from the recording (else ``latency_s`` is used as is).
        limits: The channels' declared resolution and rails; what is not declared is detected.

    Raises:
        RecordingError: The recording cannot be read.
        PayloadError: No usable row, more than one configuration, or a motion that does not
            determine the payload (the message names what is missing).
    """
    read = read_payload_samples(path, kin, calibration, limits)
    samples = read.samples
    if len(samples) < 3:
        raise PayloadError(f"{path}: {len(samples)} usable rows, too few for a motion")
    time = samples.time
    dt = sample_period(time) if len(time) > PERIOD_SAMPLES else float(np.median(np.diff(time)))
    wrench = calibration.wrench(samples.channels)
    g_world = kin.g_world()
    gravity = float(np.linalg.norm(g_world))
    middle = len(time) // 2
    lag, stderr_lag = float(latency_s), math.inf
    final = not fit_latency
    for round_ in range(_ROUNDS):
        joints = aligned_joints(time, samples.joints, lag, kin.continuous)
        velocity, acceleration = joint_rates(time, joints, window_s, dt, kin.continuous)
        motion = kin.sensor_motion(joints, velocity, acceleration)
        R = motion.R_world_sensor
        g = np.einsum("nji,j->ni", R, g_world)
        keep = (time - time[0] >= window_s / 2) & (time[-1] - time >= window_s / 2)
        keep &= (time + lag >= time[0]) & (time + lag <= time[-1])
        axes = {name: R[middle].T @ kin.joint_axis_world(joints[middle], name) for name in kin.joint_names}
        estimate = fit_payload_motion(wrench[keep], g[keep], motion.omega[keep], motion.alpha[keep], motion.a[keep], axes, str(path), final)
        if final:
            break
        found = estimate_latency(
            kin,
            estimate.tool(gravity=gravity),
            dataclasses.replace(calibration, D=calibration.D - estimate.offsets),
            time[keep],
            joints[keep],
            samples.channels[keep],
            np.zeros(int(keep.sum()), dtype=np.int64),
            estimate.residual_rms,
            window_s,
        )
        if found is not None:
            stderr_lag = found.stderr_s
            lag += found.latency_s
        # the last fit is the one checked: with the joints aligned (what is left is below the tolerance)
        final = found is None or abs(found.latency_s) < _LATENCY_TOLERANCE_S or round_ == _ROUNDS - 2
    estimate = dataclasses.replace(estimate, latency_s=lag, stderr_latency_s=stderr_lag)
    used = time[keep]
    return RecordedMotionPayload(estimate, read.rows, float(used[-1] - used[0]) if len(used) else 0.0, read.rails)

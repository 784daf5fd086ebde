"""Payload from a recorded continuous motion: the sensor's motion from the joint readings, the latency estimated.

The recording's rows (:func:`fts_calib.service.payload_recording.read_payload_samples`: one
payload, bad rows and railed channels refused) give the calibrated wrench; the joint readings,
aligned by the stream latency, give the sensor frame's motion (joint rates by
:func:`fts_calib.pipeline.qsfilter.joint_rates`, then :meth:`Kinematics.sensor_motion`), and
:func:`fts_calib.service.payload_motion.fit_payload_motion` the payload. The latency starts at
the pipeline's ``live.latency_s`` and is then estimated from the residuals of the payload just
identified (:func:`latency_step`: the regression of :mod:`fts_calib.pipeline.latency` with the
offsets' drift left out), the joints re-aligned and the payload fitted again, until the
latency moves by less than 20 us. Samples within half a derivative window of the recording's ends, or of a
sample missing (a row refused, a datagram lost), are left out (their rates come from a cut or uneven window).
Times in [s].
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
from ..pipeline.qsfilter import PERIOD_SAMPLES, joint_rates, sample_period
from ..robot import inertial
from ..robot.kinematics import Kinematics
from .payload_motion import MotionPayloadEstimate, fit_payload_regressor
from .payload_recording import PayloadSamples, read_payload_samples

_LATENCY_TOLERANCE_S = 2e-5  # [s] a latency step below this ends the alternation (the estimate's own error: tests/test_latency.py)
_ROUNDS = 5  # fits at most
_MISSING = 1.5  # an interval above this many sample periods has a sample missing


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


def smoothed_like_rates(time: np.ndarray, values: np.ndarray, window_s: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """``values`` smoothed as the joint accelerations are: by the biweight kernel of the joint-rate window.

    A least-squares quadratic over a window of half-width h (:func:`joint_rates`) gives the
    second derivative of the readings smoothed by the biweight kernel ``(1 - t^2/h^2)^2``
    (its weights integrated twice): about ``alpha + h^2/14 alpha''``, 1 % of the inertia on a
    jerk-limited motion at h = 25 ms if the wrench were not smoothed alike.

    Args:
        time: Sample times [s]. Shape (N,).
        values: Samples, shape (N, k).
        window_s: The joint-rate window [s].
        dt: The sample period [s].

    Returns:
        ``(smoothed (N, k), whether each sample's window is whole and evenly sampled, no
        interval in it above 1.5 periods (N,))``; the others keep their value.
    """
    half = int(round(window_s / 2 / dt)) if dt > 0 else 0
    n = len(values)
    if half < 1 or n < 2 * half + 1:
        return values, np.zeros(n, dtype=bool)
    offsets = np.arange(-half, half + 1) / (half + 1)
    kernel = (1.0 - offsets**2) ** 2
    kernel /= kernel.sum()
    out = values.copy()
    inner = slice(half, n - half)
    windows = np.lib.stride_tricks.sliding_window_view(values, 2 * half + 1, axis=0)  # (n - 2 half, k, 2 half + 1)
    out[inner] = windows @ kernel
    whole = np.zeros(n, dtype=bool)
    span = time[2 * half :] - time[: n - 2 * half]
    # no sample missing in the window either (a datagram lost, a row refused): the kernels take the samples as evenly
    # spaced, and one missing shifts half the window by a period: up to 2.2 rad/s^2 of acceleration at 1 rad/s, 1 kHz, 50 ms
    missing = np.concatenate([[0], np.cumsum(np.diff(time) > _MISSING * dt)])
    whole[inner] = (np.abs(span - 2 * half * dt) <= 0.25 * 2 * half * dt) & (missing[2 * half :] == missing[: n - 2 * half])
    return out, whole


def _regressor(time, g, omega, alpha, a, window_s: float, dt: float) -> np.ndarray:
    """The regressor seen through the joint-rate window: its terms in gravity and speed smoothed, (N, 6, 10).

    The regressor is linear in the accelerations: ``Y(g, omega, alpha, a) = Y(g, omega, 0, 0) +
    Y(0, 0, alpha, a)``. The accelerations from the joint-rate estimates are already smoothed
    by the window's kernel, and the measured wrench is smoothed by it
    (:func:`smoothed_like_rates`); the terms in gravity and speed are smoothed here, so that
    every term of the model sees the same smoothing (in the simulation this takes the inertia's
    bias from about 1 % to 0.2 %).
    """
    zero = np.zeros_like(g)
    rest = inertial.body_regressor(g, omega, zero, zero)
    smoothed, _ = smoothed_like_rates(time, rest.reshape(len(time), -1), window_s, dt)
    return smoothed.reshape(rest.shape) + inertial.body_regressor(zero, zero, alpha, a)


def latency_step(
    time: np.ndarray, measured: np.ndarray, regressor: np.ndarray, estimate: MotionPayloadEstimate, block_samples: int
) -> tuple[float, float]:
    """How much later the joints still are than the fit assumed, from its residuals.

    The regression of :mod:`fts_calib.pipeline.latency` (``W_meas - W_pred ~ tau dW_pred/dt``,
    each axis weighted by its residual spread) on the fit's own residuals, which leave out the
    offsets' drift (``estimate_latency`` takes constant offsets: a sensor warming up moved its
    estimate by 0.15 ms); its standard error from the spread of the estimates of blocks of
    ``block_samples``.

    Args:
        time: Sample times [s]. Shape (N,).
        measured: Measured wrenches [N, N m]. Shape (N, 6).
        regressor: The fit's regressor. Shape (N, 6, 10).
        estimate: The fit.
        block_samples: Samples per block.

    Returns:
        ``(latency step [s], its standard error [s])`` (0 and inf when the motion shows none).
    """
    predicted = regressor @ estimate.parameters
    middle = (time[0] + time[-1]) / 2
    residual = measured - predicted - estimate.offsets - np.outer(time - middle, estimate.offset_rate)
    with np.errstate(divide="ignore", invalid="ignore"):  # repeated time stamps: no slope there
        rate = np.gradient(predicted, time, axis=0)
    ok = np.all(np.isfinite(rate), axis=1)
    weight = 1.0 / np.maximum(estimate.residual_rms, 1e-15) ** 2
    num = np.sum(residual[ok] * rate[ok] * weight, axis=1)
    den = np.sum(rate[ok] ** 2 * weight, axis=1)
    if not len(den) or np.sum(den) <= 0:
        return 0.0, math.inf
    step = float(np.sum(num) / np.sum(den))
    blocks = max(len(den) // max(block_samples, 1), 1)
    edges = np.linspace(0, len(den), blocks + 1).astype(int)[:-1]
    block_num, block_den = np.add.reduceat(num, edges), np.add.reduceat(den, edges)
    good = block_den > 0
    if good.sum() < 2:
        return step, math.inf
    each, w = block_num[good] / block_den[good], block_den[good]
    return step, math.sqrt(float(np.sum(w * (each - step) ** 2) / np.sum(w)) / (good.sum() - 1))


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
    return identify_payload_from_samples(
        read_payload_samples(path, kin, calibration, limits), str(path), kin, calibration, window_s, latency_s, fit_latency
    )


def identify_payload_from_samples(
    read: PayloadSamples,
    where: str,
    kin: Kinematics,
    calibration: Calibration,
    window_s: float = 0.05,
    latency_s: float = 0.0,
    fit_latency: bool = True,
) -> RecordedMotionPayload:
    """Identify mass, centre of mass, inertia and offsets from the samples of a continuous motion (module docstring).

    The arrays' form of :func:`identify_payload_from_motion`: the samples of a recording, or
    of a live feed (:mod:`fts_calib.service.payload_live`), checked by
    :func:`fts_calib.service.payload_recording.check_payload_samples`.

    Args:
        read: The accepted samples (time [s], joints [rad], channels), in time order.
        where: Where they come from, for the messages (a path, ``udp://HOST:PORT``).
        kin: Kinematics of the robot (its model's gravity is used).
        calibration: The sensor's calibration.
        window_s: Window of the joint-rate estimates [s].
        latency_s: How late the joint readings still are [s]: the start.
        fit_latency: Estimate the remaining latency (else ``latency_s`` is used as is).

    Raises:
        PayloadError: Too few samples, or a motion that does not determine the payload.
    """
    samples = read.samples
    if len(samples) < 3:
        raise PayloadError(f"{where}: {len(samples)} usable rows, too few for a motion")
    time = samples.time
    dt = sample_period(time) if len(time) > PERIOD_SAMPLES else float(np.median(np.diff(time)))
    wrench, smooth = smoothed_like_rates(time, calibration.wrench(samples.channels), window_s, dt)
    g_world = kin.g_world()
    middle = len(time) // 2
    block = max(int(round(8 * window_s / dt)), 40)  # samples per block of the standard errors: eight joint-rate windows
    lag, stderr_lag = float(latency_s), math.inf
    final = not fit_latency
    for round_ in range(_ROUNDS):
        joints = aligned_joints(time, samples.joints, lag, kin.continuous)
        velocity, acceleration = joint_rates(time, joints, window_s, dt, kin.continuous)
        motion = kin.sensor_motion(joints, velocity, acceleration)
        R = motion.R_world_sensor
        g = np.einsum("nji,j->ni", R, g_world)
        keep = smooth.copy()
        keep &= (time + lag >= time[0]) & (time + lag <= time[-1])
        axes = {name: R[middle].T @ kin.joint_axis_world(joints[middle], name) for name in kin.joint_names}
        regressor = _regressor(time, g, motion.omega, motion.alpha, motion.a, window_s, dt)
        estimate = fit_payload_regressor(wrench[keep], regressor[keep], axes, where, final, block, time[keep])
        if final:
            break
        step, stderr_lag = latency_step(time[keep], wrench[keep], regressor[keep], estimate, block)
        lag += step
        # the last fit is the one checked: with the joints aligned (what is left is below the tolerance)
        final = abs(step) < _LATENCY_TOLERANCE_S or round_ == _ROUNDS - 2
    estimate = dataclasses.replace(estimate, latency_s=lag, stderr_latency_s=stderr_lag)
    used = time[keep]
    return RecordedMotionPayload(estimate, read.rows, float(used[-1] - used[0]) if len(used) else 0.0, read.rails)

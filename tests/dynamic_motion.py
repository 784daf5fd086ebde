"""Continuous motion of the UR5 for the dynamic filter's tests: no still sample, wrenches by Pinocchio's RNEA.

Every joint moves on a sinusoid of its own frequency (0.11-0.23 Hz, within the UR5's
acceleration limit of 2 rad/s^2), so no sample is still; the tool's wrench comes from
:func:`fts_calib.sim.rnea.rnea_tool_wrench` (Pinocchio's spatial RNEA on an attached body),
not from the calibration's Newton-Euler. The joints can be read late and noisy.
"""

import dataclasses

import numpy as np

from fts_calib.sim.rnea import rnea_tool_wrench
from fts_calib.sources.batch import SampleBatch

HOME = np.array([0.0, -1.2, 1.4, -1.8, -1.57, 0.0])  # [rad]
AMPLITUDE = np.array([0.2, 0.2, 0.3, 0.8, 1.2, 1.2])  # [rad]
FREQUENCY = np.array([0.11, 0.13, 0.17, 0.19, 0.2, 0.23])  # [Hz]
RATE_HZ = 1000.0


def motion(t: np.ndarray, configuration: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions [rad], velocities [rad/s] and accelerations [rad/s^2] at times t [s], each (N, 6)."""
    w = 2 * np.pi * FREQUENCY
    phase = np.array([0.3, 1.1, 2.0, 0.7, 1.9 + configuration, 0.4 * configuration])
    arg = w * t[:, None] + phase
    return HOME + AMPLITUDE * np.sin(arg), AMPLITUDE * w * np.cos(arg), -AMPLITUDE * w * w * np.sin(arg)


def noiseless(sensor):
    """The simulated sensor without noise or quantization (its null-space content kept)."""
    return dataclasses.replace(sensor, adc_bits=0, noise_std=np.zeros_like(sensor.noise_std))


def recording(kin, tool, sensor, seconds=5.0, lag_s=0.0, joint_noise=0.0, rng=None):
    """One batch per tool configuration, with the exact joint rates of the channels' times.

    Returns:
        ``[(batch, (velocity, acceleration)), ...]``, configurations 100 s apart.
    """
    out = []
    for c, name in enumerate(tool.names):
        t = np.arange(0.0, seconds, 1.0 / RATE_HZ)
        q, qd, qdd = motion(t, c)
        channels = sensor.channels(rnea_tool_wrench(kin, tool, name, q, qd, qdd), rng=rng)
        read = motion(t - lag_s, c)[0]
        if joint_noise:
            read = read + joint_noise * rng.standard_normal(read.shape)
        out.append((SampleBatch(t + 100.0 * c, read, channels, np.full(len(t), c)), (qd, qdd)))
    return out


def error_percent_fs(calibration, simulated, full_scale, n=4000):
    """RMS error per axis in % of full scale over loads spread uniformly across the full-scale box, shape (6,)."""
    W = np.random.default_rng(12345).uniform(-1.0, 1.0, (n, 6)) * full_scale
    bar = np.linalg.solve(simulated.C_bar, (W - simulated.D).T).T  # what the true sensor reads (eq 22)
    error = bar @ calibration.C_bar.T + calibration.D - W
    return 100.0 * np.sqrt(np.mean(error**2, axis=0)) / full_scale

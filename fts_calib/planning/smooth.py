"""A smooth continuous excitation: every joint on a sinusoid of its own, ramped in and out at home.

The jerk-limited rasters of :mod:`fts_calib.planning.motion` change their jerk often and
abruptly; the dynamic filter's rate estimate is biased there (its polynomial misses the snap)
and its trust rule drops most of a short raster's samples. This motion has a small, smooth
snap throughout: joint ``j`` follows

    q_j(t) = home_j + A_j sin(k_j pi tau(t) / tau(T)),

a whole number ``k_j`` of half cycles in the warped time ``tau``, whose rate ``tau'(t) = w(t)``
rises from 0 to 1 over the ramp (a 7th-degree smoothstep: its first three derivatives vanish
at both ends), holds 1, and falls back to 0 at the end. The motion therefore starts and ends at
rest (velocity, acceleration and jerk 0) at home, and each joint stays within ``home +- A_j``.
The two sweep joints swing widely (their range about home, at most :data:`SWEEP_AMPLITUDE`),
with half-cycle counts one apart, the first joint's the larger when the limits allow only one
(it then swings to both sides of home; a Lissajous figure: gravity crosses the sensor frame's
sphere); the other joints swing by :data:`ARM_AMPLITUDE` (the arm's accelerations add
inertial excitation). Frequencies and the ramp are set within :data:`LIMIT_FRACTION` of the
velocity, acceleration and jerk limits, then checked on the samples.
Angles in [rad], times in [s], rates in [Hz].
"""

from __future__ import annotations

import math

import numpy as np

from ..core.exceptions import TrajectoryError
from ..robot.kinematics import Kinematics
from .motion import Plan
from .sweeps import SweepPattern

SWEEP_AMPLITUDE = 1.3  # [rad] largest swing of a sweep joint about home
ARM_AMPLITUDE = 0.2  # [rad] swing of the other joints about home
SWEEP_FREQUENCY = 0.22  # [Hz] the sweep joints' nominal frequency (lowered to fit the limits)
ARM_FREQUENCY = 0.12  # [Hz] the other joints' nominal frequency
LIMIT_FRACTION = 0.8  # of each velocity, acceleration and jerk limit
_SMOOTH_PEAKS = (35 / 16, 7.5, 52.5)  # peaks of the smoothstep's 1st, 2nd, 3rd derivatives on [0, 1] (upper bounds)


def _smoothstep(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The 7th-degree smoothstep on [0, 1] and its first three derivatives (clipped outside)."""
    x = np.clip(x, 0.0, 1.0)
    s = x**4 * (35 - 84 * x + 70 * x**2 - 20 * x**3)
    d1 = 140 * x**3 * (1 - x) ** 3
    d2 = 420 * x**2 * (1 - x) ** 2 * (1 - 2 * x)
    d3 = 840 * x * (1 - x) * (1 - 5 * x + 5 * x**2)
    return s, d1, d2, d3


def _warp(time: np.ndarray, duration: float, ramp: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The warped time tau [s], its rate w [1] and w' [1/s] at ``time``; tau(T) = T - ramp."""
    up, dup, _, _ = _smoothstep(time / ramp)
    down, ddown, _, _ = _smoothstep((duration - time) / ramp)
    w = np.minimum(up, down)
    dw = np.where(time < duration / 2, dup / ramp, -ddown / ramp)
    # tau: the integral of w (the smoothstep's integral in closed form on each ramp)
    x_in, x_out = np.clip(time / ramp, 0, 1), np.clip((duration - time) / ramp, 0, 1)
    integral = lambda x: x**5 * (7 - 14 * x + 10 * x**2 - 2.5 * x**3)  # noqa: E731  (the smoothstep's integral: 1/2 at x = 1)
    tau = np.where(
        time < ramp, ramp * integral(x_in), np.where(time > duration - ramp, duration - ramp - ramp * integral(x_out), time - ramp / 2)
    )
    return tau, w, dw


def amplitudes(kin: Kinematics, home: np.ndarray, ranges: np.ndarray, margin: float) -> np.ndarray:
    """Swing of each joint about home [rad], shape (n_joints,): the sweep joints within their ranges (W x 2) and the limits."""
    lim = kin.limits
    amp = np.full(kin.n_joints, ARM_AMPLITUDE)
    for row, name in enumerate(kin.sweep_joints):
        k = kin.joint_names.index(name)
        low, high = ranges[row]
        amp[k] = min(SWEEP_AMPLITUDE, home[k] - low - margin, high - home[k] - margin)
    room = np.minimum(home - lim.lower, lim.upper - home) - margin
    return np.clip(np.minimum(amp, room), 0.0, None)


def smooth_motion(kin: Kinematics, home: np.ndarray, amp: np.ndarray, duration: float, rate: float):
    """Sample the smooth excitation: ``(time (N,), q, qd, qdd (N, n_joints))`` [s, rad, rad/s, rad/s^2].

    Args:
        kin: Kinematics (limits, sweep joints).
        home: Start and end pose [rad], shape (n_joints,).
        amp: Swing of each joint about home [rad], shape (n_joints,) (0: the joint holds).
        duration: Length of the motion [s].
        rate: Sample rate [Hz].

    Raises:
        TrajectoryError: A duration too short for the ramps within the limits, or a bad rate.
    """
    if not (math.isfinite(rate) and rate > 0):
        raise TrajectoryError(f"rate={rate} Hz but expected a finite rate > 0", "invalid rate")
    lim = kin.limits
    sweep = np.isin(np.arange(kin.n_joints), [kin.joint_names.index(n) for n in kin.sweep_joints])
    moving = amp > 0
    a = np.where(moving, amp, 1.0)
    # the highest angular frequency each joint may reach within the limits on the steady part
    cap = LIMIT_FRACTION * np.minimum.reduce([lim.velocity / a, np.sqrt(lim.acceleration / a), np.cbrt(lim.jerk / a)])
    nominal = 2 * np.pi * np.where(sweep, SWEEP_FREQUENCY, ARM_FREQUENCY)
    omega = np.minimum(cap, nominal)
    # the ramp: the speed A omega reached within the acceleration and jerk limits
    speed = a * omega
    ramp = float(
        np.max(
            np.maximum(
                _SMOOTH_PEAKS[0] * speed / (LIMIT_FRACTION * lim.acceleration),
                np.sqrt(_SMOOTH_PEAKS[1] * speed / (LIMIT_FRACTION * lim.jerk)),
            )
        )
    )
    ramp = max(ramp, 0.5)
    steady = duration - ramp
    if not (math.isfinite(duration) and steady > ramp):
        raise TrajectoryError(f"duration {duration:g} s but the ramps in and out take {2 * ramp:.2f} s: expected more", "too short")
    # whole half cycles: the sweep joints one apart (one fewer for the second, or one more for the first), the others as fit
    half = np.maximum(1, np.floor(omega * steady / np.pi)).astype(int)
    order = [k for k in range(kin.n_joints) if sweep[k] and moving[k]]
    if len(order) == 2 and half[order[0]] == half[order[1]]:
        if half[order[1]] > 1:
            half[order[1]] -= 1
        else:
            half[order[0]] += 1
    omega = half * np.pi / steady
    n = int(math.ceil(duration * rate - 1e-9)) + 1  # the last sample at or after the end, where the motion is at rest
    time = np.arange(n) / rate
    tau, w, dw = _warp(time, duration, ramp)
    phase = omega[None, :] * tau[:, None]
    unit_qd = omega * np.cos(phase) * w[:, None]
    unit_qdd = -(omega**2) * np.sin(phase) * (w**2)[:, None] + omega * np.cos(phase) * dw[:, None]
    # each joint's swing shrunk until its peaks are within LIMIT_FRACTION of its limits (they scale with it)
    fine = np.arange(0.0, duration, min(1.0 / rate, 0.005))
    f_tau, f_w, f_dw = _warp(fine, duration, ramp)
    f_phase = omega[None, :] * f_tau[:, None]
    f_qdd = -(omega**2) * np.sin(f_phase) * (f_w**2)[:, None] + omega * np.cos(f_phase) * f_dw[:, None]
    peaks = np.vstack(
        [
            np.max(np.abs(omega * np.cos(f_phase) * f_w[:, None]), axis=0) / lim.velocity,
            np.max(np.abs(f_qdd), axis=0) / lim.acceleration,
            np.max(np.abs(np.diff(f_qdd, axis=0)), axis=0) / np.diff(fine[:2]) / lim.jerk,
        ]
    )
    amp_m = np.where(moving, np.minimum(amp, LIMIT_FRACTION / np.max(peaks, axis=0)), 0.0)[None, :]
    return time, home[None, :] + amp_m * np.sin(phase), amp_m * unit_qd, amp_m * unit_qdd


def smooth_plan(kin: Kinematics, home: np.ndarray, ranges: np.ndarray, duration: float, rate: float, margin: float = 0.02) -> Plan:
    """The smooth excitation as a :class:`Plan` from home back to home (see the module docstring).

    Args:
        kin: Kinematics.
        home: Base pose [rad], shape (n_joints,).
        ranges: Range of each sweep joint [rad], shape (2, 2).
        duration: Length of the motion [s].
        rate: Sample rate [Hz].
        margin: Distance kept from the position limits and the range ends [rad].
    """
    home = np.asarray(home, dtype=float)
    amp = amplitudes(kin, home, np.asarray(ranges, dtype=float), margin)
    time, q, qd, qdd = smooth_motion(kin, home, amp, duration, rate)
    pattern = SweepPattern(2, 1, 0.0, margin, 1.0, continuous=True, smooth=True)
    first, second = kin.sweep_joints
    return Plan(
        kin.robot.name, kin.joint_names, (first, second), home, ranges, np.empty((0, 2)), pattern, kin.limits, rate, time, q, qd, qdd
    )

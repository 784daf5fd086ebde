r"""Joint motion from joint readings without phase lag: a centred local cubic, evaluated where the joints really were.

The dynamic filter (:mod:`fts_calib.filters.dynamic`) needs, at every sample, the joint
positions, velocities and accelerations at the time the *channels* were read. The readings
are late by a latency ``tau`` (the row of time t holds the joints of t - tau), so the motion
at the sample is the motion of the readings ``tau`` later. A least-squares cubic through the
``2h + 1`` readings of a window of ``window_s`` centred on the sample (Savitzky-Golay: a
linear filter, symmetric, so without phase lag) is evaluated at the offset ``+tau``:

.. math::

    q(\tau) = c_0 + c_1\tau + c_2\tau^2 + c_3\tau^3, \quad \dot q = c_1 + 2c_2\tau + 3c_3\tau^2,
    \quad \ddot q = 2c_2 + 6c_3\tau.

Each is one kernel of ``2h + 1`` weights applied by a convolution (O(N w) per joint). A
cubic is exact on the cubic pieces of a jerk-limited motion; where the jerk changes within
the window (a snap ``s``) the acceleration is off by about ``gain_s s`` (a kernel property,
:func:`kernel_gains`), and by more where the window spans several changes of the jerk (a
jerk-limited ramp shorter than the window): the same polynomial over a window a third as wide
(:attr:`JointMotion.check`) follows it closer, and their difference shows the bias. Joint noise ``sigma_q``
(white) reaches the velocity as ``sigma_q |k_v|`` and the acceleration as ``sigma_q |k_a|``:
for the quintic over 300 ms at 1 kHz ``|k_v| = 2.9 s^-1`` and ``|k_a| = 60 s^-2``, so 1e-5 rad
of noise gives 3e-5 rad/s and 6e-4 rad/s^2 (over 100 ms: 917 s^-2).

Where the window is cut (a stream's edges, a gap, irregular sampling) the rates come from
the local quadratic of :func:`fts_calib.filters.quasi_static.joint_rates` (its cut-window fit), moved to ``+tau``
by its own Taylor terms. Times [s], angles [rad].
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .quasi_static import _local_rates


@dataclass(frozen=True)
class JointMotion:
    """Joint motion at the channels' times (one row per sample).

    Attributes:
        joints: Positions [rad], shape (N, n_joints).
        velocity: Velocities [rad/s], shape (N, n_joints).
        acceleration: Accelerations [rad/s^2], shape (N, n_joints).
        full: Which samples had a whole regular window (the others: the cut-window fit), shape (N,) bool.
        check: The acceleration from a window a third as wide [rad/s^2], shape (N, n_joints) (zero
            outside whole windows), or None: the wide window's bias shows in the difference.
    """

    joints: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    full: np.ndarray
    check: np.ndarray | None = None


@lru_cache(maxsize=32)
def _kernels(half: int, dt: float, shift: float, order: int = 3) -> np.ndarray:
    """The (3, 2 half + 1) kernels of position, velocity and acceleration at offset ``shift`` [s] of a local polynomial."""
    scale = half * dt  # conditioning: offsets within [-1, 1]
    x = np.arange(-half, half + 1) * dt / scale
    fit = np.linalg.pinv(np.column_stack([x**k for k in range(order + 1)]))  # (order + 1, w): coefficients in x
    s = shift / scale
    powers = np.arange(order + 1)
    position = (s**powers) @ fit
    velocity = (powers[1:] * s ** (powers[1:] - 1)) @ fit[1:] / scale
    acceleration = (powers[2:] * (powers[2:] - 1) * s ** (powers[2:] - 2)) @ fit[2:] / scale**2
    return np.stack([position, velocity, acceleration])


@lru_cache(maxsize=32)
def kernel_gains(window_s: float, dt: float, order: int = 3) -> tuple[float, float, float, float]:
    """How the centred local polynomial of a window passes joint noise and jerk changes on.

    Args:
        window_s: Width of the window [s].
        dt: Sample period [s].
        order: Degree of the polynomial (3 or 5).

    Returns:
        ``(velocity gain [1/s], acceleration gain [1/s^2], snap gain [s^2], check gain [1/s^2])``:
        white joint noise sigma_q [rad] gives velocity noise ``gain_v sigma_q`` and acceleration
        noise ``gain_a sigma_q`` (``gain_c sigma_q`` for the window a third as wide of
        :attr:`JointMotion.check`); where the jerk changes, the acceleration is off by at most
        ``gain_s`` times the snap estimate of :func:`fts_calib.filters.dynamic.snap_estimate` (twice the
        ratio of the largest error to the largest estimate along a jump of the jerk, computed here).
    """
    half = max(2, int(round(window_s / 2 / dt)))
    k = _kernels(half, dt, 0.0, order)
    t = np.arange(-3 * half, 3 * half + 1) * dt
    jump = np.maximum(t, 0.0)  # a jerk of 1 from t = 0: positions t^3 / 6, acceleration t
    estimate = np.convolve(jump**3 / 6.0, k[2][::-1], mode="same")
    error = np.abs(estimate - jump)[half:-half]
    snap = np.abs(estimate[2 * half :] - 2 * estimate[half:-half] + estimate[: -2 * half]) / (half * dt) ** 2
    narrow = _kernels(max(2, half // 3), dt, 0.0, order)[2]
    return float(np.linalg.norm(k[1])), float(np.linalg.norm(k[2])), float(2.0 * error.max() / snap.max()), float(np.linalg.norm(narrow))


def joint_motion(
    time: np.ndarray,
    joints: np.ndarray,
    window_s: float,
    dt: float,
    continuous: np.ndarray | None = None,
    shift_s: float = 0.0,
    order: int = 3,
    cut: bool = True,
) -> JointMotion:
    """Joint positions, velocities and accelerations at ``time + shift_s`` of the readings (see the module docstring).

    Args:
        time: Sample times [s], non-decreasing. Shape (N,).
        joints: Joint readings [rad]. Shape (N, n_joints).
        window_s: Width of the window [s].
        dt: The stream's sample period [s] (0: the cut-window fit everywhere).
        continuous: Which joints are continuous (unwrapped first). Shape (n_joints,) bool.
        shift_s: The latency of the readings [s]: the motion is that of the readings this much later.
        order: Degree of the local polynomial (3 or 5).
        cut: Fit the cut windows too; False: a sample without a whole window keeps its reading
            as position and zero rates (for a caller that drops those samples anyway: the
            dynamic filter).

    Returns:
        :class:`JointMotion` with N rows.
    """
    q = np.array(joints, dtype=float)
    if continuous is not None and np.any(continuous) and len(q) > 1:
        q[:, continuous] = np.unwrap(q[:, continuous], axis=0)
    n = len(time)
    position, velocity, acceleration, check = q.copy(), np.zeros_like(q), np.zeros_like(q), np.zeros_like(q)
    full = np.zeros(n, dtype=bool)
    half = int(round(window_s / 2 / dt)) if dt > 0 else 0
    if half >= 2 and n >= 2 * half + 1:
        kernels = _kernels(half, float(dt), float(shift_s), order)
        inner = slice(half, n - half)
        origin = q[half]  # the FFT's rounding is relative to the values: take the first window's out
        narrow = np.zeros_like(kernels[2])
        third = max(2, half // 3)
        narrow[half - third : half + third + 1] = _kernels(third, float(dt), float(shift_s), order)[2]
        fitted = _correlate(q - origin, np.vstack([kernels, narrow[None]]))
        for out, values in zip((position, velocity, acceleration, check), fitted, strict=True):
            out[inner] = values
        position[inner] += origin
        span = time[2 * half :] - time[: n - 2 * half]
        full[inner] = np.abs(span - 2 * half * dt) <= 0.25 * 2 * half * dt
    rest = np.nonzero(~full)[0] if cut else np.zeros(0, dtype=np.int64)
    if len(rest):  # cut windows: the local quadratic at the sample, moved by its Taylor terms
        v, a = _rates_at(time, q, window_s, rest)
        position[rest] = q[rest] + v * shift_s + 0.5 * a * shift_s**2
        velocity[rest] = v + a * shift_s
        acceleration[rest] = a
    return JointMotion(position, velocity, acceleration, full, check)


def _fast_size(n: int) -> int:
    """The smallest ``2^a 3^b 5^c`` at least n: a length pocketfft transforms fast (a power of two wastes up to half)."""
    best = 1 << int(np.ceil(np.log2(max(n, 1))))
    fives = 1
    while fives < best:
        threes = fives
        while threes < best:
            size = threes << max(0, int(np.ceil(np.log2(n / threes))))
            best = min(best, size)
            threes *= 3
        fives *= 5
    return best


def _correlate(values: np.ndarray, kernels: np.ndarray) -> list[np.ndarray]:
    """Each kernel (w,) slid over every column of ``values`` (N, c): the "valid" part, (N - w + 1, c) each.

    By FFT (O(N log N), not O(N w)): one transform per column, one product and inverse per
    kernel; the rounding error is ~1e-16 of the values' magnitude.
    """
    n, w = len(values), kernels.shape[1]
    size = _fast_size(n + w - 1)
    spectrum = np.fft.rfft(values, size, axis=0)
    out = []
    for kernel in kernels:
        product = spectrum * np.fft.rfft(kernel[::-1], size)[:, None]
        out.append(np.fft.irfft(product, size, axis=0)[w - 1 : n])
    return out


def _rates_at(time: np.ndarray, q: np.ndarray, window_s: float, index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The cut-window rates at ``index`` only (the fit over the samples within the window there)."""
    velocity, acceleration = np.zeros((len(index), q.shape[1])), np.zeros((len(index), q.shape[1]))
    for block in range(0, len(index), 4096):
        part = index[block : block + 4096]
        velocity[block : block + len(part)], acceleration[block : block + len(part)] = _local_rates(time, q, part, window_s / 2)
    return velocity, acceleration

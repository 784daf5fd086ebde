r"""Joint velocities and accelerations from joint readings: one local-polynomial estimator, without phase lag.

The feeds carry joint positions only. :func:`joint_rates` fits a least-squares polynomial of
degree ``order`` through the ``2h + 1`` readings of a window of ``window_s`` centred on each
sample (Savitzky-Golay: a linear filter, symmetric, so without phase lag) and evaluates it at
the offset ``+shift_s``, where the joints were when the channels were read (the readings are
late by a latency ``tau``: the row of time t holds the joints of t - tau):

.. math::

    q(\tau) = \sum_k c_k \tau^k, \quad \dot q(\tau) = \sum_k k\,c_k \tau^{k-1},
    \quad \ddot q(\tau) = \sum_k k (k - 1)\,c_k \tau^{k-2}.

Each is one kernel of ``2h + 1`` weights, applied by FFT (O(N log N) per joint). Every user
calls it with its own window and degree:

- the quasi-static filter's speed and acceleration rules, ``validate``'s expected wrench, the
  stream-latency estimate (:func:`fts_calib.filters.latency.estimate_latency`) and payload from
  motion: the quadratic (``order`` 2) over ``filter.derivative_window_s`` (50 ms), at the
  sample (``shift_s`` 0), cut windows fitted;
- the dynamic filter: ``filter.dynamic_order`` (5, or 3) over ``filter.dynamic_window_s``
  (0.3 s), at the latency (``shift_s``), samples whose window is cut dropped (``cut`` False),
  with the narrower window's ``check``.

The quadratic over 50 ms at 1 kHz passes 1e-6 rad of reading noise as about 1.4e-3 rad/s^2 of
acceleration noise, twenty times less than a second difference. A cubic or quintic is exact on
the pieces of a jerk-limited motion; where the jerk changes within the window (a snap ``s``)
the acceleration is off by about ``gain_s s`` (:func:`kernel_gains`), and by more where the
window spans several changes of the jerk (a jerk-limited ramp shorter than the window): the same
polynomial over a window a third as wide (``check``) follows it closer, and their difference
shows the bias. Joint noise ``sigma_q`` (white) reaches the velocity as ``sigma_q |k_v|`` and the
acceleration as ``sigma_q |k_a|``: for the quintic over 300 ms at 1 kHz ``|k_v| = 2.9 s^-1`` and
``|k_a| = 60 s^-2``, so 1e-5 rad of noise gives 3e-5 rad/s and 6e-4 rad/s^2 (over 100 ms: 917 s^-2).

Where the window is cut (a stream's edges, a gap, irregular sampling) the rates come from a
least-squares quadratic through the samples there are, evaluated at the sample (not at the
middle of the cut window), and moved to ``+shift_s`` by its own Taylor terms. The quadratic's
acceleration is about the second derivative smoothed by the biweight kernel of its window
(:func:`smoothed_like_acceleration` smooths other signals alike). Times [s], angles [rad].
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

#: An interval above this many sample periods has a sample missing.
MISSING_PERIODS = 1.5


@dataclass(frozen=True)
class JointMotion:
    """Joint motion at the channels' times (one row per sample).

    Attributes:
        joints: Positions [rad], shape (N, n_joints): the polynomial's in whole windows; elsewhere
            the readings, moved by ``shift_s`` with the cut-window fit's rates (as read without it).
        velocity: Velocities [rad/s], shape (N, n_joints).
        acceleration: Accelerations [rad/s^2], shape (N, n_joints).
        full: Which samples had a whole regular window (the others: the cut-window fit), shape (N,) bool.
        check: The acceleration from a window a third as wide [rad/s^2], shape (N, n_joints) (zero
            outside whole windows), or None when not asked for: the wide window's bias shows in the difference.
    """

    joints: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    full: np.ndarray
    check: np.ndarray | None = None


def half_window(window_s: float, dt: float) -> int:
    """Samples each side of the centre in a window of ``window_s`` [s] at the sample period ``dt`` [s] (0 without a period)."""
    return int(round(window_s / 2 / dt)) if dt > 0 else 0


def window_bounds(time: np.ndarray, index: np.ndarray, half: float) -> tuple[np.ndarray, np.ndarray]:
    """First and last sample indices within ``half`` [s] of each sample ``index``."""
    left = np.searchsorted(time, time[index] - half, side="left")
    right = np.searchsorted(time, time[index] + half, side="right") - 1
    return left, right


def whole_windows(time: np.ndarray, half: int, dt: float, complete: bool = False) -> np.ndarray:
    """Which samples have a whole, regular window of ``half`` samples each side, shape (N,) bool.

    Whole: the window's span within a quarter of ``2 half dt``; ``complete``: no interval in it
    above 1.5 periods either (a datagram lost, a row refused: the kernels take the samples as
    evenly spaced, and one missing shifts half the window by a period: up to 2.2 rad/s^2 of
    acceleration at 1 rad/s, 1 kHz, 50 ms).
    """
    n = len(time)
    whole = np.zeros(n, dtype=bool)
    if half < 1 or n < 2 * half + 1:
        return whole
    span = time[2 * half :] - time[: n - 2 * half]
    inner = np.abs(span - 2 * half * dt) <= 0.25 * 2 * half * dt
    if complete:
        missing = np.concatenate([[0], np.cumsum(np.diff(time) > MISSING_PERIODS * dt)])
        inner &= missing[2 * half :] == missing[: n - 2 * half]
    whole[half : n - half] = inner
    return whole


@lru_cache(maxsize=32)
def rate_kernels(half: int, dt: float, shift_s: float, order: int) -> np.ndarray:
    """The kernels of the local polynomial: position, velocity and acceleration at ``shift_s`` after the window's middle.

    ``estimate_i = sum_k K[:, k + half] q_{i+k}``, k = -half .. half.

    Args:
        half: Samples each side of the middle.
        dt: Sample period [s].
        shift_s: Where the polynomial is evaluated, after the middle [s].
        order: Degree of the polynomial.

    Returns:
        Shape (3, 2 half + 1), in [1, 1/s, 1/s^2], read-only.
    """
    scale = half * dt  # conditioning: offsets within [-1, 1]
    x = np.arange(-half, half + 1) * dt / scale
    fit = np.linalg.pinv(np.column_stack([x**k for k in range(order + 1)]))  # (order + 1, w): coefficients in x
    s = shift_s / scale
    powers = np.arange(order + 1)
    position = (s**powers) @ fit
    velocity = (powers[1:] * s ** (powers[1:] - 1)) @ fit[1:] / scale
    acceleration = (powers[2:] * (powers[2:] - 1) * s ** (powers[2:] - 2)) @ fit[2:] / scale**2
    kernels = np.stack([position, velocity, acceleration])
    kernels.setflags(write=False)  # cached: one array for every caller
    return kernels


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
    k = rate_kernels(half, dt, 0.0, order)
    t = np.arange(-3 * half, 3 * half + 1) * dt
    jump = np.maximum(t, 0.0)  # a jerk of 1 from t = 0: positions t^3 / 6, acceleration t
    estimate = np.convolve(jump**3 / 6.0, k[2][::-1], mode="same")
    error = np.abs(estimate - jump)[half:-half]
    snap = np.abs(estimate[2 * half :] - 2 * estimate[half:-half] + estimate[: -2 * half]) / (half * dt) ** 2
    narrow = rate_kernels(max(2, half // 3), dt, 0.0, order)[2]
    return float(np.linalg.norm(k[1])), float(np.linalg.norm(k[2])), float(2.0 * error.max() / snap.max()), float(np.linalg.norm(narrow))


def joint_rates(
    time: np.ndarray,
    joints: np.ndarray,
    window_s: float,
    dt: float,
    continuous: np.ndarray | None = None,
    order: int = 2,
    shift_s: float = 0.0,
    cut: bool = True,
    check: bool = False,
) -> JointMotion:
    """Joint positions, velocities and accelerations at ``time + shift_s`` of the readings (see the module docstring).

    Args:
        time: Sample times [s], non-decreasing. Shape (N,).
        joints: Joint readings [rad]. Shape (N, n_joints).
        window_s: Width of the window [s].
        dt: The stream's sample period [s] (0: the cut-window fit everywhere).
        continuous: Which joints are continuous (unwrapped first). Shape (n_joints,) bool.
        order: Degree of the local polynomial (2: the quasi-static filter's; 3 or 5: the
            dynamic filter's). A window needs ``order + 1`` samples at least.
        shift_s: The latency of the readings [s]: the motion is that of the readings this much later.
        cut: Fit the cut windows too; False: a sample without a whole window keeps its reading
            as position and zero rates (for a caller that drops those samples anyway: the
            dynamic filter).
        check: Also the acceleration of the window a third as wide (:attr:`JointMotion.check`).

    Returns:
        :class:`JointMotion` with N rows.
    """
    q = np.array(joints, dtype=float)
    if continuous is not None and np.any(continuous) and len(q) > 1:
        q[:, continuous] = np.unwrap(q[:, continuous], axis=0)
    n = len(time)
    position, velocity, acceleration = q.copy(), np.zeros_like(q), np.zeros_like(q)
    narrow = np.zeros_like(q) if check else None
    half = half_window(window_s, dt)
    full = np.zeros(n, dtype=bool)
    if half >= 1 and 2 * half >= order and n >= 2 * half + 1:
        kernels = rate_kernels(half, float(dt), float(shift_s), order)
        if check:
            third = max(2, half // 3)
            wide = np.zeros_like(kernels[2])
            wide[half - third : half + third + 1] = rate_kernels(third, float(dt), float(shift_s), order)[2]
            kernels = np.vstack([kernels, wide[None]])
        inner = slice(half, n - half)
        origin = q[half]  # the FFT's rounding is relative to the values: take the first window's out
        outputs = [position, velocity, acceleration] if narrow is None else [position, velocity, acceleration, narrow]
        for out, values in zip(outputs, _correlate(q - origin, kernels), strict=True):
            out[inner] = values
        position[inner] += origin
        full = whole_windows(time, half, dt)
    rest = np.nonzero(~full)[0] if cut else np.zeros(0, dtype=np.int64)
    for block in range(0, len(rest), 4096):  # cut windows, bounded memory: (block, window, joints) at a time
        index = rest[block : block + 4096]
        v, a = _cut_window_rates(time, q, index, window_s / 2)
        position[index] = q[index] + v * shift_s + 0.5 * a * shift_s**2
        velocity[index] = v + a * shift_s
        acceleration[index] = a
    return JointMotion(position, velocity, acceleration, full, narrow)


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


_LOCAL_POINTS = 32  # samples of a cut window the local quadratic is fitted through, at most


def _cut_window_rates(time: np.ndarray, joints: np.ndarray, index: np.ndarray, half: float) -> tuple[np.ndarray, np.ndarray]:
    """Joint rates at samples ``index`` from a least-squares quadratic over the samples within ``half`` [s], evaluated at the sample.

    At the sample, not at the middle of the window: where the window is cut (a stream's end, a
    gap), a difference over it is the velocity half a cut window earlier or later, short of the
    sample's by that time the acceleration (at a stream ending while it speeds up, a joint just
    over the speed limit passed). Two sample times give their slope and no acceleration, one gives zeros.
    """
    left, right = window_bounds(time, index, half)
    width = int(np.max(right - left)) + 1
    # every stride-th sample of the window: at 5 kHz a 50 ms window holds 250, and a quadratic
    # through 32 of them is as good a fit at an eighth of the work (live feeds cut windows often)
    cols = left[:, None] + np.arange(0, width, max(1, -(-width // _LOCAL_POINTS)))
    valid = cols <= right[:, None]
    cols = np.minimum(cols, len(time) - 1)
    x = np.where(valid, (time[cols] - time[index, None]) / half, 0.0)  # (m, w), within [-1, 1]
    y = np.where(valid[:, :, None], joints[cols] - joints[index, None, :], 0.0)  # (m, w, joints)
    distinct = 1 + np.sum((np.diff(time[cols], axis=1) > 0) & valid[:, 1:], axis=1)
    powers = np.stack([valid, x, x * x], axis=-1).astype(float)  # (m, w, 3); masked rows are zero
    normal = np.swapaxes(powers, 1, 2) @ powers
    moments = np.swapaxes(powers, 1, 2) @ y  # (m, 3, joints)
    velocity, acceleration = np.zeros((len(index), joints.shape[1])), np.zeros((len(index), joints.shape[1]))
    two = distinct == 2
    if np.any(two):
        n, sx, sxx = normal[two, 0, 0], normal[two, 0, 1], normal[two, 1, 1]
        velocity[two] = (n[:, None] * moments[two, 1] - sx[:, None] * moments[two, 0]) / (n * sxx - sx * sx)[:, None] / half
    three = distinct >= 3
    if np.any(three):
        coefficients = np.linalg.solve(normal[three], moments[three])
        velocity[three] = coefficients[:, 1] / half
        acceleration[three] = 2.0 * coefficients[:, 2] / half**2
    return velocity, acceleration


def smoothed_like_acceleration(time: np.ndarray, values: np.ndarray, window_s: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """``values`` smoothed as the quadratic's accelerations are: by the biweight kernel of its window.

    The quadratic (``order`` 2) of :func:`joint_rates` over a window of half-width h gives the
    second derivative of the readings smoothed by the biweight kernel ``(1 - t^2/h^2)^2`` (its
    weights integrated twice): about ``alpha + h^2/14 alpha''``, 1 % of the inertia on a
    jerk-limited motion at h = 25 ms if the wrench were not smoothed alike (payload from motion).

    Args:
        time: Sample times [s]. Shape (N,).
        values: Samples, shape (N, k).
        window_s: The joint-rate window [s].
        dt: The sample period [s].

    Returns:
        ``(smoothed (N, k), whether each sample's window is whole and complete (N,))``
        (:func:`whole_windows`); the others keep their value.
    """
    half = half_window(window_s, dt)
    n = len(values)
    if half < 1 or n < 2 * half + 1:
        return values, np.zeros(n, dtype=bool)
    offsets = np.arange(-half, half + 1) / (half + 1)
    kernel = (1.0 - offsets**2) ** 2
    kernel /= kernel.sum()
    out = values.copy()
    windows = np.lib.stride_tricks.sliding_window_view(values, 2 * half + 1, axis=0)  # (n - 2 half, k, 2 half + 1)
    out[half : n - half] = windows @ kernel
    return out, whole_windows(time, half, dt, complete=True)

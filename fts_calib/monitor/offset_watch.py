r"""Offsets that stay right in service: the wrench offset tracked where nothing touches the payload.

With a known payload (its tool file, or an identified payload) and the joints, the wrench the
payload exerts on the sensor is known at every sample; the residual ``rho = W_measured -
W_payload`` is then the offset error ``delta`` (how far the sensor's offsets have moved since
the calibration or the last tare) plus any contact. Per block of ``block`` samples, with the
block mean ``m`` and the tracked offset error predicted to the block ``delta^``:

.. math::

    |m_i - \hat\delta_i| \le k\,\sigma_i / \sqrt{B} + a_i \quad\text{for every axis } i

and a scatter of its samples within twice the noise (and, when the joints are given, no joint
faster than the quasi-static filter's rule 1 allows over the window,
:func:`fts_calib.filters.quasi_static.window_moves`: a constant speed's steady dynamics), is a window without contact (``sigma``:
the wrench noise per sample; ``a``: the payload's allowance, what the payload known to a
tolerance adds, plus the fastest drift believed times the time since the last update, at most
10 s of it). Only
such windows update the tracker, an alpha-beta filter of the offset error and its rate (a drift of 1 N/min is followed without
lag); a contact window (a 15 N push) never moves it, and the tracker predicts through the
contact with the rate it learnt. When ``|delta^|`` exceeds the re-tare threshold, ``retare``
returns the calibration with the corrected offsets (``D - delta^``), the old ones kept in its
tare history. :meth:`OffsetWatch.forecast_s` says when the offset error will exceed a threshold.

Units: time [s]; wrenches [N, N, N, N m, N m, N m].
"""

from __future__ import annotations

import math

import numpy as np

from ..core.exceptions import ConfigError, ShapeError
from ..filters.quasi_static import window_moves
from ..filters.settings import FilterConfig
from ..model.calibration import Calibration

#: Longest time since the last update over which the fastest believed drift widens the window test [s].
MAX_GAP_S = 10.0
#: Largest share of a window's error the tracker takes (however long since the last update).
MAX_ALPHA = 0.5
#: Standard deviations of its rate's noise a rate must exceed before a forecast extrapolates it
#: (six axes at 4σ: a drift-free run forecasts nothing but about once in 2,500 looks).
RATE_SIGMAS = 4.0


class OffsetWatch:
    """Tracks the offset error of the wrench in windows without contact (see the module docstring).

    Args:
        noise: Wrench noise per sample, [N, N, N, N m, N m, N m], shape (6,).
        allowance: What the payload's model may be off by, same units, shape (6,) (0: exact).
        block: Samples per window (B >= 10).
        k: Noise sigmas of a window's mean that a window without contact stays within.
        time_constant_s: Time constant of the tracker [s] (alpha-beta gains for it).
        max_rate: Fastest offset drift believed, per second, shape (6,); 5 N/min and 0.5 N m/min
            when None (a drift faster than this is taken for a contact).
        still: The filter settings whose joint-speed rule judges a window's motion (the pipeline's
            ``filter``); the defaults when None.

    Attributes:
        offset: The tracked offset error, shape (6,).
        rate: Its rate, per second, shape (6,).
        updates: Windows that updated the tracker.
        contacts: Windows refused as contact.
        in_contact: Whether the last window was a contact.
        steady: Windows refused as contact whose samples were still (a spread within twice the
            noise, no joint moving) but whose mean disagreed with the tracked offset: the load
            assumed does not fit there (another payload than the one named), or something rests
            on it. A payload that fits, drifting or not, gives none.
        steady_worst: The largest disagreement of those windows, per axis, shape (6,).
        tilt_rad: The largest angle between the payload's force, in the sensor frame, at the
            windows that updated the tracker since the last re-tare and at the first of them
            [rad]: a wrong payload shows only once the orientation changes.
    """

    def __init__(
        self,
        noise,
        allowance=None,
        block: int = 100,
        k: float = 6.0,
        time_constant_s: float = 1.0,
        max_rate=None,
        still: FilterConfig | None = None,
    ):
        self.noise = np.asarray(noise, dtype=float).reshape(-1)
        if self.noise.shape != (6,) or np.any(~np.isfinite(self.noise) | (self.noise <= 0)):
            raise ConfigError("noise", self.noise.tolist(), "six positive wrench noises per sample [N, N m]")
        self.allowance = np.zeros(6) if allowance is None else np.asarray(allowance, dtype=float).reshape(6)
        if block < 10 or not (k > 0 and time_constant_s > 0):
            raise ConfigError("offset watch", [block, k, time_constant_s], "block >= 2, k > 0, time constant > 0")
        self.block, self.k, self.time_constant_s = block, k, time_constant_s
        self.max_rate = np.array([5 / 60] * 3 + [0.5 / 60] * 3) if max_rate is None else np.asarray(max_rate, dtype=float).reshape(6)
        self.still = still or FilterConfig()
        self.offset, self.rate = np.zeros(6), np.zeros(6)
        self._time: float | None = None
        self._period = math.nan  # [s] the interval of the last windows that updated the rate
        self._left_time, self._left_rho = np.zeros(0), np.zeros((0, 6))  # samples waiting for a full block
        self._left_q = np.zeros((0, 0))  # their joints (no column: none given)
        self._started = False
        self.updates = self.contacts = self.steady = 0
        self.steady_worst = np.zeros(6)
        self.in_contact = False
        self.tilt_rad = 0.0
        self._direction: np.ndarray | None = None  # the payload's force direction at the first update since the last re-tare
        self._left_load = np.zeros((0, 6))

    def update_batch(self, time, w_measured, w_payload, joints=None) -> None:
        """Add samples, judged per block of ``block`` samples.

        Samples that do not fill a block wait for the next call (a live feed's batches are small):
        the windows are the same however the samples are batched.

        Args:
            time: Sample times [s], shape (N,).
            w_measured: The measured wrench, [N, N, N, N m, N m, N m], shape (N, 6).
            w_payload: The payload's own wrench on the sensor, same units, shape (N, 6).
            joints: The joints [rad], shape (N, n_joints), or None: a window in which a joint moves
                faster than the quasi-static joint-speed rule allows (:func:`fts_calib.filters.quasi_static.window_moves`)
                is motion (the payload's static wrench leaves out its dynamics, steady at a constant
                speed), refused. None: no joints, only the spread tells.
        """
        time = np.asarray(time, dtype=float).reshape(-1)
        rho = np.asarray(w_measured, dtype=float) - np.asarray(w_payload, dtype=float)
        if rho.shape != (len(time), 6):
            raise ShapeError(f"wrenches of shape {rho.shape} but expected ({len(time)}, 6)")
        q = np.zeros((len(time), 0)) if joints is None else np.asarray(joints, dtype=float).reshape(len(time), -1)
        load = np.asarray(w_payload, dtype=float).reshape(len(time), 6)
        if len(self._left_time):
            time, rho = np.concatenate([self._left_time, time]), np.vstack([self._left_rho, rho])
            q = np.vstack([self._left_q, q]) if self._left_q.shape[1] == q.shape[1] else np.zeros((len(time), 0))
            load = np.vstack([self._left_load, load])
        full = len(time) - len(time) % self.block
        for start in range(0, full, self.block):
            at, window = time[start : start + self.block], rho[start : start + self.block]
            moving = window_moves(at, q[start : start + self.block], self.still)
            updates = self.updates
            self._window(float(at.mean()), window.mean(axis=0), window.std(axis=0), moving)
            if self.updates > updates:
                self._turned(load[start : start + self.block, :3].mean(axis=0))
        self._left_time, self._left_rho, self._left_q = time[full:].copy(), rho[full:].copy(), q[full:].copy()
        self._left_load = load[full:].copy()

    def _turned(self, force: np.ndarray) -> None:
        """Widen :attr:`tilt_rad` with the payload's force [N] (3,) of a window that updated the tracker."""
        size = float(np.linalg.norm(force))
        if size == 0.0:  # no payload force: no direction to turn
            return
        direction = force / size
        if self._direction is None:
            self._direction = direction
            return
        self.tilt_rad = max(self.tilt_rad, math.acos(min(1.0, max(-1.0, float(direction @ self._direction)))))

    def _window(self, t: float, mean: np.ndarray, spread: np.ndarray, moving: bool = False) -> None:
        varying = moving or np.any(spread > 2.0 * self.noise + self.allowance)
        if not self._started:  # the first still window sets the offset error (nothing to compare it with)
            if varying:
                self.contacts += 1
                return
            self.offset[:], self._time, self._started = mean, t, True
            self.updates += 1
            return
        dt = t - (self._time or t)
        predicted = self.offset + self.rate * dt
        # a drift not learnt yet, over at most MAX_GAP_S: a push held longer is never taken for drift
        limit = self.k * self.noise / math.sqrt(self.block) + self.allowance + self.max_rate * min(dt, MAX_GAP_S)
        # a contact that starts, ends or varies within the window spreads its samples (as motion does: the
        # payload's static wrench leaves out its dynamics): twice the noise is beyond any window of B >= 10
        # healthy samples (P(chi2_9 > 36) = 4e-5)
        self.in_contact = bool(varying or np.any(np.abs(mean - predicted) > limit))
        if self.in_contact:
            self.contacts += 1
            if not varying:  # still, yet off the tracked offset: a steady load other than the one assumed
                self.steady += 1
                self.steady_worst = np.maximum(self.steady_worst, np.abs(mean - predicted))
            return  # a contact never moves the offset; the prediction carries on from the last update
        # gains of the time constant for windows dt apart; after a long gap (motion, a contact) the offset
        # is corrected but its rate is not: one window's noise over a short dt must not set a rate
        alpha = min(MAX_ALPHA, 2.0 * dt / self.time_constant_s)
        beta = alpha * alpha / (2.0 - alpha)
        error = mean - predicted
        self.offset = predicted + alpha * error
        if dt <= 2.0 * self.time_constant_s:
            self.rate = self.rate + beta * error / max(dt, 1e-9)
            self._period = dt
        self._time = t
        self.updates += 1

    @property
    def pending(self) -> int:
        """Samples waiting for a full block (the next window is judged when ``block - pending`` more arrive)."""
        return len(self._left_time)

    @property
    def last_time(self) -> float:
        """Time of the last update [s] (nan before the first window)."""
        return math.nan if self._time is None else self._time

    def predicted(self, time: float) -> np.ndarray:
        """The offset error predicted at ``time`` [s] from the last update and the rate, shape (6,)."""
        return self.offset + self.rate * (time - (self._time if self._time is not None else time))

    @property
    def rate_std(self) -> np.ndarray:
        """The standard deviation of :attr:`rate` that the noise alone gives, per second, shape (6,) (inf before a rate).

        The steady state of an alpha-beta tracker fed window means of standard deviation
        ``σ = noise / sqrt(block)`` every ``T`` seconds: ``σ_rate = σ sqrt(2β² / (α (4 - 2α - β))) / T``
        (Kalata 1984), with the gains the tracker uses for that ``T``.
        """
        period = self._period
        if not (math.isfinite(period) and period > 0):
            return np.full(6, math.inf)
        alpha = min(MAX_ALPHA, 2.0 * period / self.time_constant_s)
        beta = alpha * alpha / (2.0 - alpha)
        gain = math.sqrt(2.0 * beta * beta / (alpha * (4.0 - 2.0 * alpha - beta)))
        return self.noise / math.sqrt(self.block) * gain / period

    def drifting(self) -> np.ndarray:
        """Axes whose rate differs from zero beyond its noise (:data:`RATE_SIGMAS` × :attr:`rate_std`), shape (6,) bool."""
        return np.abs(self.rate) > RATE_SIGMAS * self.rate_std

    def forecast_s(self, threshold) -> float:
        """Seconds from the last update until the offset error exceeds ``threshold`` on some axis (inf: never at this rate).

        Only a rate that differs from zero (:meth:`drifting`) is extrapolated: a drift-free run's
        rate at the noise level forecasts nothing.

        Args:
            threshold: Largest offset error tolerated per axis, [N, N, N, N m, N m, N m], shape (6,).
        """
        threshold = np.asarray(threshold, dtype=float).reshape(6)
        times = []
        drifting = self.drifting()
        for i in range(6):
            if abs(self.offset[i]) >= threshold[i]:
                return 0.0
            if drifting[i]:
                bound = math.copysign(threshold[i], self.rate[i])
                times.append((bound - self.offset[i]) / self.rate[i])
        return min(times) if times else math.inf

    def retare(self, calibration: Calibration, reason: str = "re-tared in service: offset drift tracked without contact") -> Calibration:
        """The calibration with its offsets corrected by the tracked error (the old ones in its history); the error restarts at 0."""
        corrected = calibration.with_offsets(calibration.D - self.offset, reason)
        self.offset = np.zeros(6)
        self.tilt_rad, self._direction = 0.0, None  # the next re-tare needs its own orientations
        return corrected

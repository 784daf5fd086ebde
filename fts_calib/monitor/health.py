"""Sensor health in service: the parity residual of each sample, faults detected and named.

:class:`HealthMonitor` takes raw channel samples (one at a time, or in batches) into
preallocated ring buffers and judges them every block of ``block`` samples (0.1 s at
1 kHz) with the calibration's parity model (:mod:`fts_calib.model.parity`). With the
whitened parity residual ``e = L (N Delta - c)`` (unit covariance per sample, m
components) it reports:

- ``rail``: a channel at or beyond its rail (:func:`fts_calib.model.channel_limits.railed`,
  the one rail rule): an open or shorted half-bridge drives its amplifier to a rail;
- ``open-or-shorted``: a channel beyond any reading a load within the full scale gives it;
- ``frozen``: a channel that repeats one value longer than its noise allows (the run length
  whose probability under the calibration's noise and resolution, or for a quiet quantized
  channel under its stays in one code learnt at calibration, is below the test's share of the
  false-alarm budget: :func:`freeze_thresholds`);
- ``jump``: the block mean of ``e`` steps away from the mean of the ``jump_blocks`` before
  it: ``|d|^2 / (1/B + 1/(J B)) ~ chi^2(m)``; the channel is the one whose own step,
  through its signature, matches d best;
- ``gain``: over the last ``window_blocks`` (the samples since the last jump), ``e``
  follows one channel's own reading: with ``x~`` the reading and ``e~`` the residual,
  both detrended in time (the parity offset drifts like the wrench offsets and is no
  fault), ``z_k^2 = (u_k^T e~^T x~)^2 / (|u_k|^2 |x~|^2) ~ chi^2(1)``, u_k the channel's
  whitened signature. The channel with the largest ``z_k^2`` is named: a gain change g of
  bridge k makes ``e = u_k g Delta_k``, proportional to its own reading, which tells apart
  the bridges whose signatures lie on one line.

A jump opens a decision of ``window_blocks``: if the gain test fires on the samples after
it, the event is a gain change (at the jump's time); else a jump. A channel reported
faulty leaves the parity tests (its signature's direction is projected out of ``e``).

False alarms: the thresholds split ``false_alarms_per_hour`` over the tests made per hour
(Bonferroni: the chi-square tail of each test times the number of tests, an upper bound).

Units: time [s]; channels raw.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.exceptions import ConfigError, ShapeError
from ..model.channel_limits import ChannelLimits, railed
from ..model.parity import GROUP_COSINE, CodeDwell, ParityModel, chi2_isf

#: The kinds of fault the monitor reports.
KINDS = ("gain", "jump", "frozen", "rail", "open-or-shorted")


@dataclass(frozen=True)
class HealthEvent:
    """A fault the monitor found.

    Attributes:
        time_s: When the fault began (its best estimate), sensor clock [s].
        kind: One of :data:`KINDS`.
        channel: The channel it points to, 1-based (``strain_<channel>``).
        detail: What was seen, in words with units.
        detected_s: When the monitor reported it [s].
    """

    time_s: float
    kind: str
    channel: int
    detail: str
    detected_s: float

    def as_dict(self) -> dict:
        """The event as ``monitor --json`` writes it."""
        return {"time_s": self.time_s, "kind": self.kind, "channel": self.channel, "detail": self.detail, "detected_s": self.detected_s}


class HealthMonitor:
    """Watches a stream of raw channels against a calibration's parity model (see the module docstring).

    Args:
        parity: The calibration's parity model.
        rate_hz: Sample rate [Hz] (the number of tests per hour, for the thresholds).
        block: Samples per judgement (B).
        window_blocks: Blocks in the gain test's window.
        jump_blocks: Blocks the jump test compares a block with (J).
        false_alarms_per_hour: False-alarm budget of all tests together, per hour of service.
        naming_margin: How much the named channel's z^2 must exceed that of every other channel
            whose signature lies on the same line before it is named (25: five standard deviations).
        decide_blocks: Blocks a jump waits for the gain test before it is reported as a jump.
        min_gain: Smallest relative gain change reported (0.2 %): the parity's dependence on the
            wrench is known from a finite calibration, to about 0.002 % of a bridge's gain on the
            paper's sensor, which a long window of large loads shows as significant.
        min_jump: Smallest jump reported, in noise standard deviations of one sample of the parity
            residual (the same finite calibration moves its block means by up to ~0.6 of them).

    Attributes:
        freeze_samples: Samples each channel may hold one value before it is ``frozen``, shape (n,) (:func:`freeze_thresholds`).
        freeze_words: Those thresholds and their grounds, one line per kind.
        events: The faults found so far, in order.
        samples: Samples seen.
        faulty: Channels reported faulty (0-based).
    """

    def __init__(
        self,
        parity: ParityModel,
        rate_hz: float = 1000.0,
        block: int = 100,
        window_blocks: int = 15,
        jump_blocks: int = 5,
        false_alarms_per_hour: float = 1e-3,
        naming_margin: float = 25.0,
        decide_blocks: int = 18,
        min_gain: float = 0.002,
        min_jump: float = 1.0,
    ):
        if not (rate_hz > 0 and block >= 10 and window_blocks >= 3 and jump_blocks >= 1 and false_alarms_per_hour > 0):
            raise ConfigError("monitor", [rate_hz, block, window_blocks, jump_blocks], "rate > 0, block >= 10, window >= 3, jump >= 1")
        self.parity = parity
        n, m = parity.n_channels, parity.n_parity
        self.block, self.window_blocks, self.jump_blocks = block, window_blocks, jump_blocks
        self.naming_margin, self.decide_blocks = naming_margin, decide_blocks
        self.min_gain, self.min_jump = min_gain, min_jump
        unit = self._unit_signatures = parity.signatures / np.linalg.norm(parity.signatures, axis=1, keepdims=True)
        self._same_line = np.abs(unit @ unit.T) >= GROUP_COSINE  # (n, n): channels parity alone cannot tell apart
        self.limits = ChannelLimits(parity.resolution, parity.low, parity.high)
        self._L = parity.whitening
        self._Nw = self._L @ parity.N  # whitened parity rows (m, n)
        self._cw = self._L @ parity.c
        self._u = self._Nw.T.copy()  # whitened signatures (n, m)
        self._Q = np.eye(m)  # projection removing the directions of channels already reported
        tests_per_hour = 3600.0 * rate_hz / block
        budget = false_alarms_per_hour / 3.0  # shared by the gain, jump and freeze tests
        self.gain_threshold = chi2_isf(budget / (tests_per_hour * n), 1)
        self.jump_threshold = chi2_isf(budget / tests_per_hour, m)
        self.freeze_samples, self.freeze_words = freeze_thresholds(parity, budget / (3600.0 * rate_hz * n), rate_hz)
        self._both = np.zeros((2 * block, n))  # the previous block, then the block being filled
        self._both_time = np.zeros(2 * block)
        self._channels = self._both[block:]  # views: writing a sample allocates nothing
        self._time = self._both_time[block:]
        rings = max(window_blocks, jump_blocks + 1)
        self._e_means = np.zeros((rings, m))  # block means of the whitened residual (before Q), the newest last
        self._x_means = np.zeros((rings, n))  # block means of the channels
        self._t_means = np.zeros(rings)
        self._in_block = 0  # samples in the block being filled
        self._since_reset = 0  # blocks since the start or the last jump
        self._run = np.zeros(n, dtype=np.int64)  # samples each channel has repeated its value
        self._last = np.full(n, np.nan)
        self._pending: tuple[float, int, float] | None = None  # a jump being decided: time, channel, its step
        self._waited = 0
        self.events: list[HealthEvent] = []
        self.samples = 0
        self.faulty: set[int] = set()
        self.last_statistics = (0.0, 0.0)  # largest gain and jump statistics of the last block

    # -- input ----------------------------------------------------------------------------

    def update(self, time: float, channels) -> None:
        """Add one sample: its time [s] and raw channels, shape (n,) (copied into the block, nothing allocated)."""
        i = self._in_block
        self._channels[i] = channels
        self._time[i] = time
        self.samples += 1
        self._in_block = i + 1
        if self._in_block == self.block:
            self._in_block = 0
            self._judge()

    def update_batch(self, time, channels) -> None:
        """Add samples in time order: times [s] shape (N,), raw channels shape (N, n)."""
        time = np.asarray(time, dtype=float).reshape(-1)
        channels = np.asarray(channels, dtype=float)
        if channels.shape != (len(time), self.parity.n_channels):
            raise ShapeError(f"channels.shape={channels.shape} but expected ({len(time)}, {self.parity.n_channels})")
        start = 0
        while start < len(time):
            take = min(self.block - self._in_block, len(time) - start)
            self._channels[self._in_block : self._in_block + take] = channels[start : start + take]
            self._time[self._in_block : self._in_block + take] = time[start : start + take]
            self._in_block += take
            self.samples += take
            start += take
            if self._in_block == self.block:
                self._in_block = 0
                self._judge()

    # -- judgement --------------------------------------------------------------------------

    def _judge(self) -> None:
        """Judge the block just completed, then keep it as the previous one."""
        self._decide()
        self._both[: self.block] = self._channels
        self._both_time[: self.block] = self._time

    def _decide(self) -> None:
        """The tests of the block just completed (see the module docstring)."""
        t, x = self._time, self._channels
        now = float(t[-1])
        self._channel_checks(t, x)
        for ring in (self._e_means, self._x_means, self._t_means):
            ring[:-1] = ring[1:]
        self._x_means[-1] = x.mean(axis=0)
        self._e_means[-1] = self._Nw @ self._x_means[-1] - self._cw
        self._t_means[-1] = t.mean()
        self._since_reset += 1
        jump, d = 0.0, None
        if self._since_reset > self.jump_blocks:
            J = self.jump_blocks
            d = self._Q @ (self._e_means[-1] - self._e_means[-1 - J : -1].mean(axis=0))
            jump = float(d @ d) / (1.0 / self.block + 1.0 / (J * self.block)) if float(d @ d) >= self.min_jump**2 else 0.0
        blocks = min(self.window_blocks, self._since_reset)
        gain, k_gain, margin = self._gain_test(blocks) if blocks >= 3 else (0.0, -1, 0.0)
        if gain > self.gain_threshold and abs(self._gain_change(k_gain, blocks)) < self.min_gain:
            gain = 0.0  # significant, but below what the calibration's own uncertainty can produce
        self.last_statistics = (gain, jump)
        named = gain > self.gain_threshold and margin > self.naming_margin
        if self._pending is not None:
            self._waited += 1
            onset, k_jump, size = self._pending
            late = self._waited >= self.decide_blocks
            if named or (late and gain > self.gain_threshold):
                if not named and self._same_line[k_gain, k_jump]:
                    k_gain, named = k_jump, True  # a gain change steps its own reading at the onset: the jump's channel
                self._report(onset, "gain", k_gain, self._gain_words(k_gain, blocks, named), now)
            elif late:
                self._report(onset, "jump", k_jump, f"its reading stepped by {size:+.4g} (raw units) with no load to explain it", now)
            return
        if jump > self.jump_threshold and d is not None:
            onset, k_jump, size = self._jump_channel(d)
            self._pending = (onset, k_jump, size)
            self._waited = 0
            self._since_reset = 0  # the gain test looks at the blocks after the jump only
            return
        if named:
            self._report(float(self._t_means[-blocks]), "gain", k_gain, self._gain_words(k_gain, blocks, named), now)

    def _jump_channel(self, d: np.ndarray) -> tuple[float, int, float]:
        """Where and on which channel a jump happened: ``(time [s], channel (0-based), step (raw units))``.

        The sample of the step is where the residual (along its step d, over this block and
        the previous one) splits into two means furthest apart. The channels whose signature
        lies along d are the candidates (parity cannot tell them apart); the load moves a
        reading smoothly at 1 kHz, so the candidate whose own reading steps at that sample
        (a line plus a step fitted over 20 samples either side) is the one.
        """
        u = self._u @ self._Q.T
        cosine = np.abs(u @ d) / np.maximum(np.linalg.norm(u, axis=1) * math.sqrt(float(d @ d)), 1e-300)
        along = cosine >= cosine.max() * GROUP_COSINE
        for k in self.faulty:
            along[k] = False
        y = (self._both @ self._Nw.T - self._cw) @ (self._Q.T @ d)
        n = len(y)
        total, before = float(y.sum()), np.cumsum(y)[:-1]
        count = np.arange(1, n)
        split = np.abs(before / count - (total - before) / (n - count)) * np.sqrt(count * (n - count) / n)
        i0 = int(np.argmax(split)) + 1  # first sample after the step
        half = min(20, i0, n - i0)
        if half < 3:
            k = int(np.argmax(np.where(along, cosine, -1.0)))
            return float(self._both_time[i0]), k, 0.0
        window = self._both[i0 - half : i0 + half]
        design = np.column_stack([np.ones(2 * half), np.arange(2 * half) - half, np.arange(2 * half) >= half])
        coefficients, *_ = np.linalg.lstsq(design, window, rcond=None)
        steps = coefficients[2]
        score = np.where(along, np.abs(steps) / np.maximum(self.parity.channel_noise, 1e-300), -1.0)
        k = int(np.argmax(score))
        return float(self._both_time[i0]), k, float(steps[k])

    def _gain_words(self, k: int, blocks: int, named: bool) -> str:
        """The detail of a gain event: the change, and whether the load moved enough to single the channel out."""
        words = f"its gain changed by {self._gain_change(k, blocks):+.2%} (parity follows its reading)"
        if not named:
            line = ", ".join(str(j + 1) for j in np.flatnonzero(self._same_line[k]))
            words += f"; the load moved too little to tell it from the other channels of its parity line ({line})"
        return words

    def _detrended(self, blocks: int) -> tuple[np.ndarray, np.ndarray]:
        """Block means of the channels and of the projected residual over the last ``blocks``, detrended in time."""
        t, x, e = self._t_means[-blocks:], self._x_means[-blocks:], self._e_means[-blocks:] @ self._Q.T
        tc = t - t.mean()
        xc, ec = x - x.mean(axis=0), e - e.mean(axis=0)
        tt = float(tc @ tc)
        if tt > 0:
            xc -= np.outer(tc, (tc @ xc) / tt)
            ec -= np.outer(tc, (tc @ ec) / tt)
        return xc, ec

    def _gain_test(self, blocks: int) -> tuple[float, int, float]:
        """The largest z_k^2 over the channels not reported yet, its channel, and its margin over the others on its line.

        On block means (variance 1/B each): a channel's own noise, which is in the residual
        too, then biases z_k^2 by at most ``|u_k|^2 sigma_k^2`` per block instead of per sample.
        """
        xc, ec = self._detrended(blocks)
        sxx = np.einsum("ij,ij->j", xc, xc)
        sxe = xc.T @ ec  # (n, m)
        u = self._u @ self._Q.T
        uu = np.einsum("ij,ij->i", u, u)
        usable = (sxx > 0) & (uu > 0.04 * np.einsum("ij,ij->i", self._u, self._u))
        z2 = np.zeros(len(sxx))
        z2[usable] = self.block * np.einsum("ij,ij->i", u, sxe)[usable] ** 2 / (uu[usable] * sxx[usable])
        for j in self.faulty:
            z2[j] = 0.0
        k = int(np.argmax(z2))
        rivals = z2[self._same_line[k] & (np.arange(len(z2)) != k)]
        return float(z2[k]), k, float(z2[k] - (rivals.max() if len(rivals) else 0.0))

    def _gain_change(self, k: int, blocks: int) -> float:
        """The relative gain change of channel k the window shows, g = u^T e~^T x~ / (|u|^2 |x~|^2)."""
        xc, ec = self._detrended(blocks)
        u = self._Q @ self._u[k]
        return float((ec.T @ xc[:, k]) @ u / max(float(u @ u) * float(xc[:, k] @ xc[:, k]), 1e-300))

    def _channel_checks(self, t: np.ndarray, x: np.ndarray) -> None:
        """Rails, readings out of any load's span, frozen channels, in the block."""
        at = railed(x, self.limits)
        for k in np.flatnonzero(at.any(axis=0)):
            i = int(np.argmax(at[:, k]))
            self._report(
                float(t[i]),
                "rail",
                int(k),
                f"reads {x[i, k]:.6g} at its rail: an open or shorted half-bridge, or an overload",
                float(t[-1]),
            )
        out = ((x < self.parity.span_low) | (x > self.parity.span_high)) & ~at
        for k in np.flatnonzero(out.any(axis=0)):
            i = int(np.argmax(out[:, k]))
            span = f"[{self.parity.span_low[k]:.4g}, {self.parity.span_high[k]:.4g}]"
            self._report(
                float(t[i]),
                "open-or-shorted",
                int(k),
                f"reads {x[i, k]:.6g}, beyond {span} that any load within the full scale gives",
                float(t[-1]),
            )
        changed = np.empty_like(x, dtype=bool)
        changed[0] = x[0] != self._last
        np.not_equal(x[1:], x[:-1], out=changed[1:])
        self._last[:] = x[-1]
        moved = changed.any(axis=0)
        last_change = len(x) - 1 - np.argmax(changed[::-1], axis=0)
        self._run[:] = np.where(moved, len(x) - 1 - last_change, self._run + len(x))
        for k in np.flatnonzero(self._run >= self.freeze_samples):
            start = float(t[-1]) - int(self._run[k]) * (float(t[-1] - t[0]) / max(len(t) - 1, 1))  # its last change
            self._report(
                start,
                "frozen",
                int(k),
                f"has read {x[-1, k]:.6g} for {int(self._run[k])} samples, beyond the {int(self.freeze_samples[k]):,} "
                "its noise or its stays in one code at calibration allow",
                float(t[-1]),
            )

    def _report(self, time_s: float, kind: str, k: int, detail: str, now: float) -> None:
        """Record an event (once per channel) and take the channel out of the parity tests."""
        self._pending = None
        if k in self.faulty:
            return
        self.faulty.add(k)
        self.events.append(HealthEvent(time_s, kind, k + 1, detail, now))
        direction = self._Q @ self._u[k]
        if float(direction @ direction) > 0:
            direction = direction / math.sqrt(float(direction @ direction))
            self._Q = self._Q - np.outer(direction, direction) @ self._Q
        self._since_reset = 0

    @property
    def state(self) -> str:
        """One word for a status line: 'ok' or 'FAULT'."""
        return "FAULT" if self.events else "ok"


#: A quiet quantized channel whose stay in one code the calibration cannot bound is frozen after this long in one code [s].
QUIET_FROZEN_S = 600.0
#: A learnt threshold is at least this many times the longest stay in one code the calibration saw.
LONGEST_MARGIN = 2.0


def freeze_thresholds(parity: ParityModel, probability: float, rate_hz: float) -> tuple[np.ndarray, list[str]]:
    """Samples each channel may hold one value before it is frozen, and why, in words.

    - Off a grid (resolution 0) a repeat is itself improbable: 20 samples.
    - A channel whose noise spans a code (``channel_noise >= step``): a reading with Gaussian
      noise sigma stays in its code with probability at most ``erf(step / (2 sqrt(2) sigma))``
      per sample; n repeats are frozen when that to the power n is below ``probability``.
    - A quiet quantized channel (noise below one step: its measured noise is mostly the step's
      own step / sqrt(12), and it may hold a code for seconds when its mean sits mid-code):
      from its stays in one code learnt at calibration (:class:`fts_calib.model.parity.CodeDwell`):
      n = max(mean ln(1 / probability), 2 longest, the Gaussian n) with ``mean`` the longest
      mean stay of any still stop (a geometric stay of that mean exceeds n with probability
      ``probability``) and ``longest`` the longest stay seen, both scaled by
      ``max(1, rate_hz / the calibration's rate)``. Where the calibration cannot bound it (the
      channel held one code through a whole still stop, or a file without the dwell):
      :data:`QUIET_FROZEN_S` seconds, said so.

    Args:
        parity: The calibration's parity model (noise, resolution, dwell).
        probability: False-alarm probability allowed per sample and channel.
        rate_hz: The monitor's sample rate [Hz].

    Returns:
        The thresholds [samples], shape (n,), and one line per kind of threshold.
    """
    noise, resolution, dwell = parity.channel_noise, parity.resolution, parity.dwell
    n = len(noise)
    out = np.full(n, np.iinfo(np.int64).max // 4, dtype=np.int64)
    basis: dict[str, list[int]] = {}
    scale = 1.0 if dwell is None else max(1.0, rate_hz / dwell.rate_hz)
    for k, (sigma, step) in enumerate(zip(noise, resolution, strict=True)):
        if step <= 0:
            out[k] = 20
            basis.setdefault("off-grid", []).append(k)
            continue
        stay = math.erf(step / (2.0 * math.sqrt(2.0) * max(sigma, 1e-300)))
        gaussian = max(20, math.ceil(math.log(probability) / math.log(stay))) if stay < 0.999 else int(out[k])
        if sigma >= step:
            out[k] = gaussian
            basis.setdefault("noise", []).append(k)
        elif dwell is not None and not math.isnan(dwell.mean[k]):
            learnt = max(dwell.mean[k] * math.log(1.0 / probability), LONGEST_MARGIN * dwell.longest[k]) * scale
            out[k] = max(gaussian, math.ceil(learnt))
            basis.setdefault("learnt", []).append(k)
        else:
            out[k] = max(math.ceil(QUIET_FROZEN_S * rate_hz), math.ceil(LONGEST_MARGIN * (0 if dwell is None else dwell.held[k]) * scale))
            basis.setdefault("quiet" if dwell is not None else "unknown", []).append(k)
    return out, [_freeze_words(kind, ks, out, rate_hz, dwell) for kind, ks in basis.items()]


def _freeze_words(kind: str, channels: list[int], threshold: np.ndarray, rate_hz: float, dwell: CodeDwell | None) -> str:
    """One line on the frozen threshold of some channels and why."""
    names = ", ".join(f"strain_{k + 1}" for k in channels)
    low, high = int(threshold[channels].min()), int(threshold[channels].max())
    after = (
        f"{low:,} samples ({low / rate_hz:.3g} s)"
        if low == high
        else f"{low:,} to {high:,} samples ({low / rate_hz:.3g} to {high / rate_hz:.3g} s)"
    )
    if kind == "off-grid":
        return f"{names}: frozen after 20 repeats of one value (not quantized: a repeat is itself improbable)"
    if kind == "noise":
        return f"{names}: frozen after {after} in one code (their noise spans a code)"
    if kind == "learnt" and dwell is not None:
        stays = ", ".join(f"{dwell.mean[k]:.3g}" for k in channels)
        return (
            f"{names}: frozen after {after} in one code, from their stays in one code at calibration "
            f"(longest mean stay of a still stop {stays} samples at {dwell.rate_hz:.4g} Hz)"
        )
    why = (
        "they held one code through a whole still stop of the calibration, so how long they may stay is not known"
        if kind == "quiet"
        else "the calibration does not record their stays in one code (an older file, or a calibration in motion)"
    )
    return (
        f"{names}: quiet (noise below one ADC step): frozen only after {after} in one code: {why}; "
        "a stuck channel shows sooner as a jump or gain fault when the load changes"
    )

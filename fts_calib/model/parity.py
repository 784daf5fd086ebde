r"""The parity model of a sensor with more channels than wrench axes: load-free checks of its bridges.

A layout of n channels for 6 axes (the paper's 8 half-bridges) leaves ``m = n - 6``
combinations of the channels that carry no load: the left null space of the fitted linear
model ``C`` (every model family shares it). The calibration learns them from its kept
samples:

.. math::

    N_0 = \mathrm{null}(P)\ (m \times n),\quad
    N_0 \Delta = A\, \hat W + b + \varepsilon,\quad \hat W = C \Delta + D

    r = N \Delta - c,\quad N = N_0 - A C,\quad c = b + A D

so the parity residual ``r`` (m,) is near zero under any load: ``A`` (m x 6) is the small
dependence of the null content on the wrench that a real sensor has, ``Sigma`` (m x m) the
covariance of ``r`` over the kept samples (never below what the channels' quantization
gives). A change ``delta`` of channel k moves ``r`` by ``N[:, k] delta``: column k of N is
channel k's *signature*. For the paper's P the signatures of bridges 1, 3, 5, 7 lie on one
line and those of 2, 4, 6, 8 on another: parity alone says "an odd bridge"; which one
follows from how ``r`` moves with each bridge's own reading (a gain change g of bridge k
gives ``r = N[:, k] g Delta_k``), see :mod:`fts_calib.monitor.health`.

The offset of ``r`` moves like the wrench offsets (temperature, tool changes): only changes
that follow the load, jumps and freezes are faults.

Units: channels raw; wrenches [N, N, N, N m, N m, N m]; r in raw channel units.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.arrays import frozen
from ..core.exceptions import ConfigError, ShapeError
from .channel_limits import quantization_noise
from .channels import ChannelLayout, channel_layout

#: How far beyond the readings a full-scale load gives a channel may go before it is out of range
#: (an open or shorted bridge drives its half-bridge to a supply: far beyond any load).
SPAN_MARGIN = 2.0
#: Probability that one healthy sample is flagged by :meth:`ParityModel.check`.
SAMPLE_FALSE_FLAG = 1e-9
#: Parallel signatures (|cos| of the whitened columns) above this share a group: parity alone cannot separate them.
GROUP_COSINE = 0.98


#: A still segment shorter than this many samples says nothing of a channel's dwell in one code.
MIN_SEGMENT = 20


@dataclass(frozen=True)
class CodeDwell:
    """How long each quantized channel stays in one ADC code while the sensor is still, learnt at calibration.

    A channel whose analog noise is below one step (0.14 counts of a 10-bit ADC) holds one
    code for seconds when its mean sits mid-code: the Gaussian model of its measured noise
    (never below step / sqrt(12)) cannot tell that stay from a stuck channel. Each still
    segment of the calibration (consecutive kept samples of one stop) gives each channel's
    stays in one code; the monitor's ``frozen`` test takes its threshold from them
    (:mod:`fts_calib.monitor.health`).

    Attributes:
        mean: Per channel, the longest mean stay in its most frequent code of any still
            segment (samples in that code / its runs there) [samples]: ``1 / (1 - q)`` for a
            stay probability q per sample; NaN where the channel held one code through a whole
            segment of at least :data:`MIN_SEGMENT` samples (its stay there is longer than the
            segment: the calibration cannot bound it). Shape (n,).
        longest: Per channel, the longest run in one code seen in any still segment (a run
            cut by the segment's end included) [samples]. Shape (n,).
        held: Per channel, the longest still segment it held one code through [samples]
            (0: it changed code in every segment). Shape (n,).
        rate_hz: Sample rate of the still samples [Hz].
        segments: Still segments of at least :data:`MIN_SEGMENT` samples examined.
    """

    mean: np.ndarray
    longest: np.ndarray
    held: np.ndarray
    rate_hz: float
    segments: int

    def __post_init__(self):
        n = len(np.atleast_1d(self.mean))
        for name in ("mean", "longest", "held"):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (n,):
                raise ShapeError(f"health.dwell.{name}.shape={value.shape} but expected ({n},)")
            if np.any(value[~np.isnan(value)] < 0) or (name != "mean" and not np.all(np.isfinite(value))):
                raise ConfigError(f"health.dwell.{name}", value.tolist(), "numbers of samples >= 0")
            object.__setattr__(self, name, frozen(value))
        if not (math.isfinite(self.rate_hz) and self.rate_hz > 0):
            raise ConfigError("health.dwell.rate_hz", self.rate_hz, "a sample rate > 0", "Hz")
        object.__setattr__(self, "rate_hz", float(self.rate_hz))
        object.__setattr__(self, "segments", int(self.segments))

    def to_dict(self) -> dict[str, Any]:
        """The ``health.dwell`` section (a mean that cannot be bounded is null)."""
        return {
            "mean": [None if math.isnan(v) else float(v) for v in self.mean],
            "longest": [int(v) for v in self.longest],
            "held": [int(v) for v in self.held],
            "rate_hz": self.rate_hz,
            "segments": self.segments,
            "units": "samples at rate_hz; mean null: the channel held one code through a whole still segment",
        }

    @classmethod
    def from_dict(cls, data: Any) -> CodeDwell:
        """The dwell of a ``health.dwell`` section (as :meth:`to_dict` writes it).

        Raises:
            ConfigError: A missing or malformed field (named ``health.dwell.<field>``).
        """
        if not isinstance(data, Mapping):
            raise ConfigError("health.dwell", data, "a mapping: mean, longest, held, rate_hz, segments")
        try:
            mean = np.array([math.nan if v is None else float(v) for v in data["mean"]])
            return cls(
                mean,
                np.asarray(data["longest"], dtype=float),
                np.asarray(data["held"], dtype=float),
                float(data["rate_hz"]),
                int(data["segments"]),
            )
        except KeyError as exc:
            raise ConfigError(f"health.dwell.{exc.args[0]}", None, "a value: the dwell written by the calibration") from None
        except (TypeError, ValueError) as exc:
            raise ConfigError("health.dwell", "…", f"the dwell as the calibration writes it ({exc})") from None


def code_dwell(channels, segment, rate_hz: float) -> CodeDwell | None:
    """Each channel's stays in one code over the still segments of a calibration (:class:`CodeDwell`).

    Args:
        channels: Raw readings of the still samples, in time order, shape (K, n).
        segment: Index of each sample's still segment (consecutive samples of one stop), shape (K,).
        rate_hz: Their sample rate [Hz].

    Returns:
        The dwell, or None when no segment has :data:`MIN_SEGMENT` samples or the rate is not > 0.
    """
    channels, segment = np.asarray(channels, dtype=float), np.asarray(segment)
    if channels.ndim != 2 or len(segment) != len(channels) or not (math.isfinite(rate_hz) and rate_hz > 0):
        return None
    n = channels.shape[1]
    mean, longest, held = np.zeros(n), np.zeros(n), np.zeros(n)
    count = 0
    bounds = np.flatnonzero(np.diff(segment) != 0) + 1
    for part in np.split(channels, bounds):
        if len(part) < MIN_SEGMENT:
            continue
        count += 1
        for k in range(n):
            x = part[:, k]
            starts = np.concatenate([[0], np.flatnonzero(x[1:] != x[:-1]) + 1])
            runs = np.diff(np.concatenate([starts, [len(x)]]))
            longest[k] = max(longest[k], float(runs.max()))
            if len(runs) == 1:
                held[k] = max(held[k], len(x))
                continue
            values, counts = np.unique(x, return_counts=True)
            modal = values[np.argmax(counts)]  # its stays there are the long ones: the others are excursions
            in_modal = x[starts] == modal
            mean[k] = max(mean[k], float(runs[in_modal].sum()) / int(in_modal.sum()))
    if not count:
        return None
    return CodeDwell(np.where(held > 0, np.nan, mean), longest, held, rate_hz, count)


@dataclass(frozen=True)
class ParityModel:
    """The load-free combinations of the channels and what a fault of each channel does to them.

    Attributes:
        N: Parity rows, shape (m, n): ``r = N @ channels - c``.
        c: Parity offset at the calibration, raw units, shape (m,).
        A: Dependence of the null content on the wrench that N removes, raw units per N or N m, shape (m, 6).
        covariance: Covariance of r per sample over the calibration's kept samples, shape (m, m).
        channel_noise: Noise of each channel per sample, raw units (never below step / sqrt(12)), shape (n,).
        zero: Reading of each channel at zero load, raw units, shape (n,).
        gain: Reading of each channel per unit wrench, raw units per N or N m, shape (n, 6).
        span_low: Lowest reading a load within the full scale can give each channel (with margin), shape (n,).
        span_high: Highest such reading, shape (n,).
        resolution: Step of each channel, raw units (0: not quantized), shape (n,).
        low: Lower rail of each channel, raw units (-inf: none), shape (n,).
        high: Upper rail of each channel, raw units (+inf: none), shape (n,).
        samples: Samples the model was learnt from.
        dwell: Each quantized channel's stays in one code while still (:class:`CodeDwell`), or
            None (not learnt: no still segment, a moving calibration, or an older file).
    """

    N: np.ndarray
    c: np.ndarray
    A: np.ndarray
    covariance: np.ndarray
    channel_noise: np.ndarray
    zero: np.ndarray
    gain: np.ndarray
    span_low: np.ndarray
    span_high: np.ndarray
    resolution: np.ndarray
    low: np.ndarray
    high: np.ndarray
    samples: int = 0
    dwell: CodeDwell | None = None

    def __post_init__(self):
        N = np.asarray(self.N, dtype=float)
        if N.ndim != 2 or N.shape[0] < 1 or N.shape[1] <= N.shape[0]:
            raise ShapeError(f"N.shape={N.shape} but expected (m, n) with 1 <= m < n: the parity rows")
        m, n = N.shape
        shapes = {
            "N": (m, n),
            "c": (m,),
            "A": (m, 6),
            "covariance": (m, m),
            "channel_noise": (n,),
            "zero": (n,),
            "gain": (n, 6),
            "span_low": (n,),
            "span_high": (n,),
            "resolution": (n,),
            "low": (n,),
            "high": (n,),
        }
        for name, shape in shapes.items():
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != shape:
                raise ShapeError(f"health.{name}.shape={value.shape} but expected {shape}")
            finite = value if name not in ("low", "high") else value[~np.isinf(value)]
            if not np.all(np.isfinite(finite)):
                raise ConfigError(f"health.{name}", value.tolist(), "finite numbers")
            object.__setattr__(self, name, frozen(value))
        eigenvalues = np.linalg.eigvalsh(self.covariance)
        if eigenvalues.min() <= 0.0:
            raise ConfigError("health.covariance", self.covariance.tolist(), "a positive definite matrix")
        object.__setattr__(self, "samples", int(self.samples))
        if self.dwell is not None and len(self.dwell.mean) != n:
            raise ShapeError(f"health.dwell.mean.shape={self.dwell.mean.shape} but expected ({n},)")

    @property
    def n_channels(self) -> int:
        """Number of channels n."""
        return self.N.shape[1]

    @property
    def n_parity(self) -> int:
        """Number of parity combinations m = n - 6."""
        return self.N.shape[0]

    @property
    def whitening(self) -> np.ndarray:
        """L (m, m) with ``L Sigma L^T = I``: ``L r`` has unit covariance."""
        return np.linalg.inv(np.linalg.cholesky(self.covariance))

    @property
    def signatures(self) -> np.ndarray:
        """Each channel's signature in whitened parity space, per raw unit of the channel, shape (n, m)."""
        return (self.whitening @ self.N).T

    def groups(self) -> list[list[int]]:
        """Channels whose signatures lie on one line (0-based): parity alone cannot tell them apart."""
        unit = self.signatures / np.maximum(np.linalg.norm(self.signatures, axis=1, keepdims=True), 1e-300)
        groups: list[list[int]] = []
        for k in range(self.n_channels):
            for group in groups:
                if abs(float(unit[group[0]] @ unit[k])) >= GROUP_COSINE:
                    group.append(k)
                    break
            else:
                groups.append([k])
        return groups

    def residual(self, channels) -> np.ndarray:
        """The parity residual ``N channels - c``, raw units.

        Args:
            channels: Raw readings, shape (n,) or (N, n).

        Returns:
            Shape (m,) or (N, m).
        """
        return np.asarray(channels, dtype=float) @ self.N.T - self.c

    def check(self, channels, baseline=None, threshold: float | None = None) -> tuple[np.ndarray, bool]:
        """The per-sample parity check the C header exports: whitened residual and fault flag.

        Args:
            channels: Raw readings of one sample, shape (n,).
            baseline: The whitened residual's offset the caller tracks (it moves like the
                wrench offsets), shape (m,); zeros when None.
            threshold: Flag when ``|e|^2`` exceeds it; :attr:`sample_threshold` when None.

        Returns:
            ``(e (m,), fault)``: ``e = L (N channels - c) - baseline`` (unit covariance per
            sample when healthy), and whether ``e @ e > threshold``.
        """
        e = self.whitening @ self.residual(channels)
        if baseline is not None:
            e = e - np.asarray(baseline, dtype=float)
        limit = self.sample_threshold if threshold is None else float(threshold)
        return e, bool(e @ e > limit)

    @property
    def sample_threshold(self) -> float:
        """The per-sample threshold of :meth:`check`: the chi-square(m) point of probability 1e-9 (3.6e-3 false flags per hour at 1 kHz)."""
        return chi2_isf(SAMPLE_FALSE_FLAG, self.n_parity)

    def to_dict(self) -> dict[str, Any]:
        """The ``health`` section of a calibration file (plain data; rails at infinity are null)."""

        def rails(values: np.ndarray) -> list[float | None]:
            return [None if math.isinf(v) else float(v) for v in values]

        return {
            "kind": "parity",
            "parity": self.N.tolist(),
            "offset": self.c.tolist(),
            "wrench_dependence": self.A.tolist(),
            "covariance": self.covariance.tolist(),
            "noise": np.sqrt(np.diag(self.covariance)).tolist(),
            "signatures": self.signatures.tolist(),
            "groups": [[k + 1 for k in group] for group in self.groups()],
            "channel_noise": self.channel_noise.tolist(),
            "zero": self.zero.tolist(),
            "gain": self.gain.tolist(),
            "span": [[float(a), float(b)] for a, b in zip(self.span_low, self.span_high, strict=True)],
            "resolution": self.resolution.tolist(),
            "range": [[lo, hi] for lo, hi in zip(rails(self.low), rails(self.high), strict=True)],
            "samples": self.samples,
            **({} if self.dwell is None else {"dwell": self.dwell.to_dict()}),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> ParityModel:
        """The model of a calibration file's ``health`` section (as :meth:`to_dict` writes it).

        Raises:
            ConfigError: A field is missing or malformed (named ``health.<field>``).
            ShapeError: A field has the wrong shape.
        """
        if not isinstance(data, Mapping):
            raise ConfigError("health", data, "a mapping (the parity model)")
        missing = [
            key
            for key in ("parity", "offset", "wrench_dependence", "covariance", "channel_noise", "zero", "gain", "span")
            if key not in data
        ]
        if missing:
            raise ConfigError(f"health.{missing[0]}", None, "a value: the parity model written by the calibration")
        try:
            span = np.asarray(data["span"], dtype=float).reshape(-1, 2)
            n = len(span)
            bounds = data.get("range") or [[None, None]] * n
            low = [-math.inf if pair[0] is None else float(pair[0]) for pair in bounds]
            high = [math.inf if pair[1] is None else float(pair[1]) for pair in bounds]
            return cls(
                N=np.asarray(data["parity"], dtype=float),
                c=np.asarray(data["offset"], dtype=float),
                A=np.asarray(data["wrench_dependence"], dtype=float),
                covariance=np.asarray(data["covariance"], dtype=float),
                channel_noise=np.asarray(data["channel_noise"], dtype=float),
                zero=np.asarray(data["zero"], dtype=float),
                gain=np.asarray(data["gain"], dtype=float),
                span_low=span[:, 0],
                span_high=span[:, 1],
                resolution=np.asarray(data.get("resolution") or np.zeros(n), dtype=float),
                low=np.asarray(low),
                high=np.asarray(high),
                samples=int(data.get("samples", 0)),
                dwell=None if data.get("dwell") is None else CodeDwell.from_dict(data["dwell"]),
            )
        except (TypeError, ValueError, IndexError) as exc:
            raise ConfigError("health", "…", f"the parity model as the calibration writes it ({exc})") from None


def fit_parity(
    layout: ChannelLayout | str,
    C,
    D,
    channels,
    full_scale,
    channel_noise=None,
    resolution=None,
    low=None,
    high=None,
    dwell: CodeDwell | None = None,
) -> ParityModel | None:
    """The parity model from a calibration's kept samples (see the module docstring).

    Args:
        layout: The channel layout (n channels).
        C: The fitted linear model, shape (6, n).
        D: Its offsets [N, N, N, N m, N m, N m], shape (6,).
        channels: Kept raw readings under varied loads, shape (K, n), K > n + 7.
        full_scale: Full scale per axis [N, N, N, N m, N m, N m], shape (6,): the readings a
            load within it gives bound each channel's plausible span.
        channel_noise: Noise of each channel per sample, raw units, shape (n,); None: from the fit.
        resolution: Step of each channel, raw units (0: none), shape (n,); None: none.
        low: Lower rail of each channel (-inf: none), shape (n,); None: none.
        high: Upper rail of each channel (+inf: none), shape (n,); None: none.
        dwell: The channels' stays in one code while still (:func:`code_dwell`); None: not learnt.

    Returns:
        The model, or None when the layout has no more channels than axes (nothing is load-free)
        or too few samples.
    """
    layout = channel_layout(layout)
    n = layout.n_channels
    channels = np.asarray(channels, dtype=float)
    channels = channels[np.all(np.isfinite(channels), axis=1)] if channels.ndim == 2 else channels
    if n <= 6 or channels.ndim != 2 or channels.shape[1] != n or len(channels) <= n + 7:
        return None
    C, D = np.asarray(C, dtype=float), np.asarray(D, dtype=float)
    resolution = np.zeros(n) if resolution is None else np.asarray(resolution, dtype=float)
    quantization = quantization_noise(resolution)
    N0 = layout.null_basis
    # the regressors: the wrench the service sees (from the channels), and 1
    X = np.hstack([channels @ C.T + D, np.ones((len(channels), 1))])
    B, *_ = np.linalg.lstsq(X, channels @ N0.T, rcond=None)
    A, b = B[:6].T, B[6]
    N, c = N0 - A @ C, b + A @ D
    r = channels @ N.T - c
    covariance = r.T @ r / max(len(r) - 7, 1)
    G, *_ = np.linalg.lstsq(X, channels, rcond=None)  # readings per unit wrench and at zero load
    gain, zero = G[:6].T, G[6]
    fitted = channels - X @ G
    measured = np.sqrt(np.mean(fitted**2, axis=0))  # the channels' scatter the load does not explain
    noise = measured if channel_noise is None else np.asarray(channel_noise, dtype=float)
    noise = np.maximum(noise, quantization)
    covariance = covariance_floored(covariance, N @ np.diag(noise**2) @ N.T)
    if covariance is None:
        return None
    reach = np.abs(gain) @ np.abs(np.asarray(full_scale, dtype=float))
    return ParityModel(
        N=N,
        c=c,
        A=A,
        covariance=covariance,
        channel_noise=noise,
        zero=zero,
        gain=gain,
        span_low=zero - SPAN_MARGIN * reach - 10 * noise,
        span_high=zero + SPAN_MARGIN * reach + 10 * noise,
        resolution=resolution,
        low=np.full(n, -np.inf) if low is None else np.asarray(low, dtype=float),
        high=np.full(n, np.inf) if high is None else np.asarray(high, dtype=float),
        samples=len(channels),
        dwell=dwell,
    )


#: Smallest eigenvalue of the parity covariance, relative to its mean variance: r of a channel
#: noise that neither the samples nor the resolution show (a noiseless simulation) still whitens.
COVARIANCE_CONDITION = 1e-6


def covariance_floored(sample, floor) -> np.ndarray | None:
    """The smallest covariance at least both ``sample`` and ``floor`` (in the matrix order), positive definite.

    The sample covariance of r from few or quantized samples can be near singular (a channel
    that held one code); the floor (what the channels' noise, never below step / sqrt(12),
    gives r) is the physical least. In the floor's whitened frame the sample's eigenvalues are
    raised to 1: ``F^(1/2) U max(mu, 1) U^T F^(1/2)``. A floor that is itself near singular
    (channels of unknown resolution and no measured noise) is first raised to
    :data:`COVARIANCE_CONDITION` of the mean variance of both.

    Args:
        sample: Sample covariance of r, raw units squared, shape (m, m).
        floor: ``N diag(noise^2) N^T``, raw units squared, shape (m, m).

    Returns:
        Shape (m, m), symmetric positive definite; None when both are zero or not finite
        (nothing to learn the health model from).
    """
    sample = 0.5 * (np.asarray(sample, dtype=float) + np.asarray(sample, dtype=float).T)
    floor = 0.5 * (np.asarray(floor, dtype=float) + np.asarray(floor, dtype=float).T)
    m = len(sample)
    level = max(float(np.trace(sample)), float(np.trace(floor))) / m
    if not np.isfinite(level) or level <= 0.0 or not np.all(np.isfinite(sample)):
        return None
    floor = floor + COVARIANCE_CONDITION * level * np.eye(m)
    root = np.linalg.cholesky(floor)
    inverse = np.linalg.inv(root)
    mu, U = np.linalg.eigh(inverse @ sample @ inverse.T)
    raised = root @ (U * np.maximum(mu, 1.0)) @ U.T @ root.T
    return 0.5 * (raised + raised.T)


def chi2_sf(x: float, dof: int) -> float:
    """Survival function of the chi-square distribution with an integer number of degrees of freedom."""
    if x <= 0.0:
        return 1.0
    half = x / 2.0
    if dof % 2 == 0:
        term, total = 1.0, 1.0
        for i in range(1, dof // 2):
            term *= half / i
            total += term
        return math.exp(-half) * total
    total, term = 0.0, math.sqrt(x) * math.sqrt(2.0 / math.pi) * math.exp(-half)
    for i in range(1, (dof - 1) // 2 + 1):
        total += term
        term *= x / (2 * i + 1)
    return math.erfc(math.sqrt(half)) + total


def chi2_isf(p: float, dof: int) -> float:
    """The x with ``chi2_sf(x, dof) = p`` (bisection; p in (0, 1))."""
    if not 0.0 < p < 1.0:
        raise ConfigError("probability", p, "a number in (0, 1)")
    low, high = 0.0, 1.0
    while chi2_sf(high, dof) > p:
        high *= 2.0
    for _ in range(200):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if chi2_sf(mid, dof) > p else (low, mid)
    return 0.5 * (low + high)

"""What a channel can read: its resolution (the ADC step) and its valid range (its rails).

A low-cost sensor's channels are integer ADC counts: a reading moves in steps, and a
channel driven past its input range stays at the last code (its *rail*), whatever the load
does. Both matter to a calibration:

- *resolution*: the step between the values a channel can take. Rounding to it adds an
  error uniform over one step, of standard deviation ``step / sqrt(12)`` (the quantization
  noise); a noise floor is never below it (a channel whose noise is a fraction of a count
  reads the same code for seconds: its measured scatter is 0, yet its error is not);
- *range* ``[low, high]``: the lowest and highest reading the channel gives. A sample with
  a channel at or beyond either end is *railed*: its reading no longer follows the load,
  and it is refused (:func:`railed`, the one rule every stage applies).

Both are declared in the sensor file (:mod:`fts_calib.model.sensor_config`) or detected
from the data: the resolution by :func:`detect_resolution` (the common step of the
differences of a channel's distinct values, :class:`GridWatch` for a stream), a rail by
:class:`RailWatch` (a channel held at the run's extreme with no spread for a window, at an
end of an ADC's code range).

Units: raw channel units throughout (counts, mV/V, ...).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..core.arrays import frozen
from ..core.exceptions import ConfigError, ShapeError

#: Largest relative rounding error tolerated when values are compared with a grid (float noise of
#: values such as 0.1 k written in decimal, or counts scaled by a float factor).
GRID_TOLERANCE = 1e-6
#: Relative rounding error of a reading read from a text file of 10 significant digits (the
#: recording writer's ``%.9e``); a float's own 1e-16 is within it.
TEXT_ROUNDING = 5e-10
#: Largest error of a gap between two readings, as a fraction of the step, for which a grid is
#: still asserted: beyond it the file's digits do not resolve the codes (a 24-bit grid written
#: with 10 digits) and a channel off any grid could pass the test.
GRID_RESOLVED = 1e-4
#: Samples a channel must hold its extreme, with no spread, for the stretch to count as a rail.
RAIL_MIN_SAMPLES = 20
#: Separate stretches at the same extreme that make it a detected rail, off a grid.
RAIL_MIN_STRETCHES = 2


def quantization_noise(resolution) -> np.ndarray:
    """Standard deviation of the rounding error of a channel of step ``resolution``: step / sqrt(12).

    Args:
        resolution: Step of each channel, raw units (0: not quantized). Shape (n,).

    Returns:
        Shape (n,), raw units (0 where the resolution is 0).
    """
    return np.asarray(resolution, dtype=float) / math.sqrt(12.0)


def detect_resolution(values) -> np.ndarray:
    """The step of each channel's grid, from its values; 0 for a channel not on a grid.

    The distinct values of a channel, sorted (values closer than float noise are one), have
    differences that are all whole multiples of the step; the smallest difference is the step
    when it divides every other within :data:`GRID_TOLERANCE`. A channel with fewer than two
    distinct values shows no step (0); so does one whose differences have no common step (a
    channel not quantized, or one with too many distinct values for its grid to be seen).

    Args:
        values: Channel readings, raw units. Shape (N, n) (or (N,) for one channel).

    Returns:
        Step per channel, raw units. Shape (n,) (or () for one channel).
    """
    values = np.asarray(values, dtype=float)
    single = values.ndim == 1
    columns = values.reshape(len(values), -1)
    steps = np.zeros(columns.shape[1])
    for k in range(columns.shape[1]):
        steps[k] = _step(columns[:, k])
    return steps[0] if single else steps


def _step(column: np.ndarray) -> float:
    """The grid step of one channel's values (see :func:`detect_resolution`).

    A gap between two readings read from a text file is off its whole number of steps by up
    to twice the readings' rounding (:data:`TEXT_ROUNDING` of the largest value): the step is
    refined over all gaps (least squares on their multiples), and each gap must lie within
    that rounding plus :data:`GRID_TOLERANCE` of a step of a whole multiple. A grid whose
    codes the digits do not resolve (:data:`GRID_RESOLVED`) shows no step.
    """
    unique = np.unique(column[np.isfinite(column)])
    if len(unique) < 2:
        return 0.0
    scale = float(np.max(np.abs(unique)))
    gaps = np.diff(unique)
    gaps = gaps[gaps > 1e-12 * scale]  # float noise of one value written twice
    if not len(gaps):
        return 0.0
    step = float(gaps.min())
    rounding = 2 * TEXT_ROUNDING * scale  # the largest error of one gap, raw units
    if rounding > GRID_RESOLVED * step:
        return 0.0
    for _ in range(2):  # the smallest gap carries the rounding: refine the step over all gaps
        multiples = np.round(gaps / step)
        step = float(gaps @ multiples / (multiples @ multiples))
    multiples = np.round(gaps / step)
    if np.max(np.abs(gaps - multiples * step)) > GRID_TOLERANCE * step + rounding:
        return 0.0
    return step


@dataclass(frozen=True)
class ChannelLimits:
    """The resolution and valid range of each channel (see the module docstring).

    Attributes:
        resolution: Step of each channel, raw units; 0 where unknown or not quantized. Shape (n,).
        low: Lowest reading of each channel (its lower rail), raw units; -inf for none. Shape (n,).
        high: Highest reading of each channel (its upper rail), raw units; +inf for none. Shape (n,).
        detected: Names of what was detected from the data rather than declared, for the
            printout (e.g. ``('resolution of strain_3', 'rail of strain_7')``).
    """

    resolution: np.ndarray
    low: np.ndarray
    high: np.ndarray
    detected: tuple[str, ...] = field(default=())

    def __post_init__(self):
        resolution = np.asarray(self.resolution, dtype=float).reshape(-1)
        n = len(resolution)
        for name in ("resolution", "low", "high"):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape not in ((), (n,)):
                raise ShapeError(f"{name}.shape={value.shape} but expected () or ({n},), one per channel")
            object.__setattr__(self, name, frozen(np.broadcast_to(value, (n,)).copy()))
        if np.any(~np.isfinite(self.resolution) | (self.resolution < 0)):
            raise ConfigError("resolution", self.resolution.tolist(), "finite values >= 0 (0: not quantized)")
        if np.any(np.isnan(self.low) | np.isnan(self.high)) or np.any(self.low >= self.high):
            pairs = [[float(a), float(b)] for a, b in zip(self.low, self.high, strict=True)]
            raise ConfigError("range", pairs, "[low, high] with low < high for every channel")
        object.__setattr__(self, "detected", tuple(self.detected))

    @classmethod
    def none(cls, n: int) -> ChannelLimits:
        """Limits of n channels with nothing known: no resolution, no rails."""
        return cls(np.zeros(n), np.full(n, -np.inf), np.full(n, np.inf))

    @property
    def n_channels(self) -> int:
        """Number of channels."""
        return len(self.resolution)

    @property
    def has_rails(self) -> bool:
        """Whether any channel has a finite rail."""
        return bool(np.any(np.isfinite(self.low)) or np.any(np.isfinite(self.high)))

    @property
    def noise(self) -> np.ndarray:
        """The quantization noise of each channel, step / sqrt(12), raw units. Shape (n,)."""
        return quantization_noise(self.resolution)

    def with_detected(self, resolution=None, low=None, high=None, names=()) -> ChannelLimits:
        """These limits, completed where they are unknown by detected ones (a declared value always wins).

        Args:
            resolution: Detected step per channel (0: none), shape (n,), or None.
            low: Detected lower rail per channel (-inf: none), shape (n,), or None.
            high: Detected upper rail per channel (+inf: none), shape (n,), or None.
            names: What was detected, in words, added to :attr:`detected`.
        """
        n = self.n_channels
        new_resolution = np.where(self.resolution > 0, self.resolution, np.zeros(n) if resolution is None else resolution)
        new_low = np.where(np.isfinite(self.low), self.low, np.full(n, -np.inf) if low is None else low)
        new_high = np.where(np.isfinite(self.high), self.high, np.full(n, np.inf) if high is None else high)
        return ChannelLimits(new_resolution, new_low, new_high, (*self.detected, *names))


def railed(channels, limits: ChannelLimits) -> np.ndarray:
    """Which channels of which samples are at or beyond their rail: the one rule of every stage.

    Args:
        channels: Raw channel readings. Shape (N, n).
        limits: The channels' limits (n channels).

    Returns:
        Shape (N, n) bool. A NaN is never railed (it is a non-finite value, counted as such).
    """
    channels = np.asarray(channels, dtype=float)
    if channels.ndim != 2 or channels.shape[1] != limits.n_channels:
        raise ShapeError(f"channels.shape={channels.shape} but expected (N, {limits.n_channels})")
    with np.errstate(invalid="ignore"):
        return (channels <= limits.low) | (channels >= limits.high)


class GridWatch:
    """The resolution of each channel, learnt from a stream (:func:`detect_resolution` on its distinct values).

    Keeps each channel's distinct values (at most :data:`GRID_VALUES`: a grid is plain long
    before that) and completes the declared resolution where it is 0.

    Args:
        declared: Declared step of each channel (0: unknown), raw units, shape (n,); None:
            nothing declared (n is that of the first readings).
    """

    def __init__(self, declared=None) -> None:
        self.declared = None if declared is None else np.asarray(declared, dtype=float).reshape(-1)
        self._values: list[np.ndarray] = []
        self._resolution = None if self.declared is None else self.declared.copy()
        self._dirty = False

    def update(self, channels) -> None:
        """Add readings. Shape (N, n)."""
        channels = np.asarray(channels, dtype=float)
        if not len(channels):
            return
        if self.declared is None or len(self.declared) != channels.shape[1]:  # nothing declared for n channels
            self.declared = np.zeros(channels.shape[1])
            self._resolution = self.declared.copy()
        if len(self._values) != len(self.declared):
            self._values = [np.zeros(0) for _ in self.declared]
        for k in np.nonzero(self.declared == 0)[0]:
            if len(self._values[k]) < GRID_VALUES:
                column = channels[:, k]
                self._values[k] = np.union1d(self._values[k], column[np.isfinite(column)])
                self._dirty = True

    @property
    def resolution(self) -> np.ndarray | None:
        """Step of each channel, raw units (declared, else detected; 0: none seen), shape (n,); None before anything."""
        if self._resolution is None or self.declared is None:
            return None
        if self._dirty:
            for k in np.nonzero(self.declared == 0)[0]:
                self._resolution[k] = _step(self._values[k])
            self._dirty = False
        return self._resolution.copy()

    def floor(self, measured: np.ndarray | None) -> np.ndarray | None:
        """A measured noise floor (raw units, shape (n,)) never below the quantization noise step / sqrt(12); None stays None."""
        resolution = self.resolution
        return measured if measured is None or resolution is None else np.maximum(measured, quantization_noise(resolution))

    def state(self) -> list[float] | None:
        """What a checkpoint keeps: the resolution so far (None before any reading)."""
        resolution = self.resolution
        return None if resolution is None else resolution.tolist()

    def restore(self, state) -> None:
        """Restore a resolution a checkpoint kept (a detected one stands until new values refine it)."""
        values = np.asarray(state, dtype=float).reshape(-1)
        declared = self.declared if self.declared is not None and len(self.declared) == len(values) else np.zeros(len(values))
        self.declared, self._resolution = declared, np.where(declared > 0, declared, values)


#: Distinct values of a channel :class:`GridWatch` keeps, at most.
GRID_VALUES = 4096


def on_adc_boundary(value: float, step: float, high: bool = True) -> bool:
    """Whether ``value`` is the upper (or lower) end of an ADC's code range on a grid of ``step``.

    The ends of a b-bit converter (8 to 32 bits) in counts of ``step``: lower 0 (unsigned)
    or -2^(b-1) (signed); upper 2^b - 1 (unsigned) or 2^(b-1) - 1 (signed).

    Args:
        value: A reading, raw units.
        step: The grid's step, raw units.
        high: The upper end (True) or the lower one.
    """
    if step <= 0 or not math.isfinite(value):
        return False
    code = value / step
    if abs(code - round(code)) > GRID_TOLERANCE + 1e-12 * abs(code):  # off the grid: not a code at all
        return False
    code = round(code)
    if high:
        return any(code in (2**bits - 1, 2 ** (bits - 1) - 1) for bits in range(8, 33))
    return code == 0 or any(code == -(2 ** (bits - 1)) for bits in range(8, 33))


class RailWatch:
    """Detects rails in a stream: a channel held at its extreme, with no spread, for a window.

    For each channel and each side, the watch keeps the extreme seen so far and counts the
    stretches of at least :data:`RAIL_MIN_SAMPLES` consecutive samples exactly at it (a new
    extreme starts afresh). :meth:`rails` judges them with the channels' resolution: on a
    grid, such an extreme is a rail when it is an end of an ADC's code range
    (:func:`on_adc_boundary`; the lower end 0, a common reading, in two stretches; a
    channel stuck at one value all along takes the step the other channels share; a quantized channel with sub-count noise holds its largest
    reading over a whole pose, and the same pose in another tool configuration repeats it,
    so holding alone proves nothing); off a grid, when it is held in at least
    :data:`RAIL_MIN_STRETCHES` separate stretches (a noisy linear channel never reads exactly
    the same value twice for a window). A rail elsewhere (an amplifier that saturates before
    the converter) is caught only by a declared ``range``.

    Args:
        n_channels: Number of channels.
    """

    def __init__(self, n_channels: int):
        self.n_channels = n_channels
        # per side (0: low, 1: high) and channel: extreme, completed stretches long enough, length of the open stretch
        self.extreme = np.array([np.full(n_channels, np.inf), np.full(n_channels, -np.inf)])
        self.stretches = np.zeros((2, n_channels), dtype=np.int64)
        self.open = np.zeros((2, n_channels), dtype=np.int64)

    def update(self, channels) -> None:
        """Add samples, in time order. Shape (N, n), finite readings (the checks skip the others first)."""
        channels = np.asarray(channels, dtype=float).reshape(-1, self.n_channels)
        if not len(channels):
            return
        for side, best in ((0, channels.min(axis=0)), (1, channels.max(axis=0))):
            newer = best < self.extreme[0] if side == 0 else best > self.extreme[1]
            self.extreme[side, newer] = best[newer]
            self.stretches[side, newer] = 0
            self.open[side, newer] = 0
            touched = best == self.extreme[side]  # only a batch that reaches the extreme can hold it
            for k in np.nonzero(touched)[0]:
                self._stretches(side, int(k), channels[:, k] == self.extreme[side, k])
            idle = ~touched
            self.stretches[side, idle & (self.open[side] >= RAIL_MIN_SAMPLES)] += 1
            self.open[side, idle] = 0

    def _stretches(self, side: int, k: int, at: np.ndarray) -> None:
        """Count the stretches of ``at`` (one channel, one side), continuing the open one."""
        edges = np.diff(np.concatenate([[0], at.astype(np.int8), [0]]))
        starts, ends = np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]
        lengths = ends - starts
        if starts[0] == 0:  # continues the stretch open at the end of the previous batch
            lengths[0] += self.open[side, k]
        elif self.open[side, k] >= RAIL_MIN_SAMPLES:
            self.stretches[side, k] += 1
        open_now = ends[-1] == len(at)
        done = lengths[:-1] if open_now else lengths
        self.stretches[side, k] += int(np.sum(done >= RAIL_MIN_SAMPLES))
        self.open[side, k] = lengths[-1] if open_now else 0

    def rails(self, resolution) -> tuple[np.ndarray, np.ndarray]:
        """The detected rails: ``(low (n,), high (n,))``, -inf and +inf where none.

        Args:
            resolution: Step of each channel (0: not on a grid), raw units. Shape (n,).
        """
        resolution = np.broadcast_to(np.asarray(resolution, dtype=float), (self.n_channels,)).copy()
        steps = resolution[resolution > 0]
        if len(steps) and np.allclose(steps, steps[0], rtol=GRID_TOLERANCE, atol=0.0):
            # a channel stuck all along shows no step of its own: it shares the converter of the others
            resolution[resolution == 0] = steps[0]
        count = self.stretches + (self.open >= RAIL_MIN_SAMPLES)
        found = np.zeros((2, self.n_channels), dtype=bool)
        for side in (0, 1):
            for k in range(self.n_channels):
                if resolution[k] > 0:
                    extreme, step = float(self.extreme[side, k]), float(resolution[k])
                    # 0 is a common reading too (a decimal column rounded near zero): held twice, like a value off a grid
                    held = RAIL_MIN_STRETCHES if extreme == 0.0 else 1
                    found[side, k] = count[side, k] >= held and on_adc_boundary(extreme, step, high=side == 1)
                else:
                    found[side, k] = count[side, k] >= RAIL_MIN_STRETCHES
        return np.where(found[0], self.extreme[0], -np.inf), np.where(found[1], self.extreme[1], np.inf)


def detect_limits(channels, declared: ChannelLimits | None = None, names=None) -> ChannelLimits:
    """Limits of the channels of a whole recording held in memory: declared ones, completed by detection.

    Args:
        channels: Raw readings, in time order. Shape (N, n).
        declared: What the sensor file declares, or None (nothing).
        names: Channel names for :attr:`ChannelLimits.detected` (``strain_1`` ... by default).

    Returns:
        The limits; what was detected is named in their ``detected``.
    """
    channels = np.asarray(channels, dtype=float)
    n = channels.shape[1]
    declared = declared if declared is not None else ChannelLimits.none(n)
    names = list(names) if names is not None else [f"strain_{k + 1}" for k in range(n)]
    resolution = detect_resolution(channels[np.all(np.isfinite(channels), axis=1)]) if len(channels) else np.zeros(n)
    watch = RailWatch(n)
    watch.update(channels[np.all(np.isfinite(channels), axis=1)])
    low, high = watch.rails(np.where(declared.resolution > 0, declared.resolution, resolution))
    return declared.with_detected(resolution, low, high, detected_names(declared, resolution, low, high, names))


def detected_names(declared: ChannelLimits, resolution, low, high, names) -> list[str]:
    """Words for what detection adds to ``declared``: 'resolution of strain_3 (1)', 'rail of strain_7 at 1023'."""
    out = []
    for k, name in enumerate(names):
        if declared.resolution[k] == 0 and resolution is not None and resolution[k] > 0:
            out.append(f"resolution of {name} ({resolution[k]:.6g})")
        for side, value, mine in (("low", low, declared.low), ("high", high, declared.high)):
            if value is not None and math.isfinite(float(value[k])) and not math.isfinite(float(mine[k])):
                out.append(f"{side} rail of {name} at {float(value[k]):.6g}")
    return out

"""Sample checks before the filter: valid values, rails, time order, known configuration, joint limits.

A sample that fails a check is skipped and counted by reason; the run goes on. A value is
valid when it is finite and, for a channel, within the plausible range
(``checks.max_abs_channel`` of the pipeline settings): one corrupt cell (1e160) is one bad
sample, never fed to the filter's stationarity windows, where it would make every sample
near it look moving. The time order is the stream's: a sample earlier than one already
accepted is dropped (the one time-order check of the pipeline). Joint readings far beyond
2π on a revolute joint are taken for degrees and warned about once (only finite ones: an
``inf`` is a non-finite value, not a degree).

A sample with a channel at or beyond its rail (:func:`fts_calib.model.channel_limits.railed`,
the declared or detected range of the channel) is skipped as railed: its reading no longer
follows the load. :class:`RailTally` counts them per channel and configuration, with the
poses (railed samples of a channel less than :data:`POSE_GAP_S` apart are one pose) and
the readings, for the summary
("strain_7 at its rail 1023 in 8 poses (A 3, B 2, C 3): 11,234 samples"); validate, tare
and payload count theirs with the same class.
"""

from __future__ import annotations

import math
import warnings
from collections import Counter
from collections.abc import Sequence

import numpy as np

from ..core.exceptions import FtsCalibWarning
from ..model.channel_limits import ChannelLimits, RailWatch, detected_names, railed
from ..robot.kinematics import Kinematics
from ..sources.batch import UNKNOWN_TOOL, SampleBatch
from .settings import DEFAULT_MAX_ABS_CHANNEL

#: Skip reasons counted by the checks.
BEFORE_CHECKPOINT = "before the checkpoint (already counted)"
BACKWARDS = "time going backwards"
NON_FINITE = "non-finite value"
OUT_OF_RANGE = "channel out of range"
RAILED = "channel at its rail"
#: Railed samples of a channel closer in time than this are one pose, in [s] (a noisy channel
#: flickers off its rail and back within a pose; moving to the next pose takes longer).
POSE_GAP_S = 0.5
OUTSIDE_LIMITS = "outside joint limits"

#: Sensor temperatures a strain-gauge sensor and its electronics can have, in [°C] (the
#: industrial range). Beyond it the column is in another unit (kelvin: 298 for 25 °C) and is
#: warned about; the samples are kept: the drift model's temperature term is linear, so its fit
#: and C do not depend on the unit, only the file's temperature_C fields do. Within it a unit
#: error (°F: 77 for 25 °C) cannot be told from a warm sensor.
PLAUSIBLE_TEMPERATURE_C = (-40.0, 125.0)


def valid_values(time: np.ndarray, joints: np.ndarray, channels: np.ndarray, max_abs_channel: float) -> tuple[np.ndarray, np.ndarray]:
    """Which samples have finite values, and which of those have every channel in range.

    Args:
        time: Sample times in [s]. Shape (N,).
        joints: Joint readings in [rad]. Shape (N, n_joints).
        channels: Raw channel readings. Shape (N, n_channels).
        max_abs_channel: Largest plausible magnitude of a channel, in raw units.

    Returns:
        ``(finite (N,) bool, in_range (N,) bool)``; ``in_range`` is False where ``finite`` is.
    """
    finite = np.isfinite(time) & np.all(np.isfinite(joints), axis=1) & np.all(np.isfinite(channels), axis=1)
    with np.errstate(invalid="ignore"):
        in_range = finite & np.all(np.abs(channels) <= max_abs_channel, axis=1)
    return finite, in_range


def forward_in_time(time: np.ndarray, ok: np.ndarray, last_time: float) -> np.ndarray:
    """Which samples are not earlier than every accepted sample before them.

    Args:
        time: Sample times in [s]. Shape (N,).
        ok: Samples accepted so far by other checks (the others do not count). Shape (N,) bool.
        last_time: Time of the last sample accepted before this batch, in [s] (-inf: none).

    Returns:
        Shape (N,) bool.
    """
    previous = np.maximum.accumulate(np.concatenate([[last_time], np.where(ok, time, -np.inf)]))[:-1]
    return time >= previous


class RailTally:
    """Railed samples of a stream, per channel and configuration (see the module docstring).

    Args:
        n_channels: Number of channels.

    Attributes:
        samples: Railed samples per ``(channel index, configuration index)``.
        poses: Poses (railed samples less than :data:`POSE_GAP_S` apart) per ``(channel, configuration)``.
        readings: Lowest and highest railed reading per channel index, raw units.
    """

    def __init__(self, n_channels: int):
        self.n_channels = n_channels
        self.samples: Counter[tuple[int, int]] = Counter()
        self.poses: Counter[tuple[int, int]] = Counter()
        self.readings: dict[int, tuple[float, float]] = {}
        self._last = np.full(n_channels, -np.inf)  # time of the last railed sample, per channel [s]

    def add(self, at: np.ndarray, channels: np.ndarray, configuration: np.ndarray, time: np.ndarray) -> None:
        """Count samples, in stream order.

        Args:
            at: Which channel of which sample is railed (:func:`railed`). Shape (N, n) bool.
            channels: The readings, raw units. Shape (N, n).
            configuration: Configuration index of each sample (-1: unknown). Shape (N,).
            time: Sample times in [s]. Shape (N,).
        """
        for k in np.nonzero(at.any(axis=0))[0]:
            rows = at[:, k]
            for c, count in zip(*np.unique(configuration[rows], return_counts=True), strict=True):
                self.samples[(int(k), int(c))] += int(count)
            t = time[rows]
            starts = np.diff(np.concatenate([[self._last[k]], t])) > POSE_GAP_S  # NaN times never start a pose
            self._last[k] = t[-1]
            for c, count in zip(*np.unique(configuration[rows][starts], return_counts=True), strict=True):
                self.poses[(int(k), int(c))] += int(count)
            values = channels[rows, k]
            low, high = self.readings.get(int(k), (np.inf, -np.inf))
            self.readings[int(k)] = (min(low, float(values.min())), max(high, float(values.max())))

    def lines(self, configurations, channels=None) -> list[str]:
        """One line per railed channel, e.g. 'strain_7 at its rail 1023 in 8 poses (A 3, B 5): 11,234 samples'.

        Args:
            configurations: Configuration names, in index order.
            channels: Channel names, in order (``strain_1`` ... by default).
        """
        names = list(channels) if channels is not None else [f"strain_{k + 1}" for k in range(self.n_channels)]
        out = []
        for k in sorted(self.readings):
            low, high = self.readings[k]
            reading = f"{low:g}" if low == high else f"{low:g}-{high:g}"
            mine = sorted((c, n) for (j, c), n in self.poses.items() if j == k)
            per = ", ".join(f"{configurations[c] if 0 <= c < len(configurations) else 'unknown'} {n}" for c, n in mine)
            poses = sum(n for _, n in mine)
            samples = sum(n for (j, _), n in self.samples.items() if j == k)
            plural = ("s" if poses != 1 else "", "s" if samples != 1 else "")
            out.append(f"{names[k]} at its rail {reading} in {poses} pose{plural[0]} ({per}): {samples:,} sample{plural[1]}")
        return out

    def state(self) -> dict:
        """Plain data for a checkpoint."""
        return {
            "samples": [[k, c, n] for (k, c), n in self.samples.items()],
            "poses": [[k, c, n] for (k, c), n in self.poses.items()],
            "readings": [[k, low, high] for k, (low, high) in self.readings.items()],
            "last": self._last.tolist(),
        }

    def restore(self, state: dict) -> None:
        """Restore :meth:`state`."""
        self.samples = Counter({(int(k), int(c)): int(n) for k, c, n in state.get("samples", [])})
        self.poses = Counter({(int(k), int(c)): int(n) for k, c, n in state.get("poses", [])})
        self.readings = {int(k): (float(low), float(high)) for k, low, high in state.get("readings", [])}
        last = np.asarray(state.get("last", []), dtype=float)
        if last.shape == self._last.shape:
            self._last = last


def refuse_railed(
    channels: np.ndarray, configuration: np.ndarray, time: np.ndarray, limits: ChannelLimits | None, tally: RailTally | None
) -> np.ndarray:
    """Which samples have no channel at or beyond its rail; the others are counted in ``tally``.

    The one place every stage (the session's checks, validate, tare, payload) applies
    :func:`railed`.

    Args:
        channels: Raw readings. Shape (N, n).
        configuration: Configuration index of each sample (-1: unknown). Shape (N,).
        time: Sample times in [s] (the poses of the tally). Shape (N,).
        limits: The channels' limits; None or no rails: every sample passes.
        tally: Where to count the railed samples, or None.

    Returns:
        Shape (N,) bool: True for a sample with every channel within its range.
    """
    if limits is None or not limits.has_rails or not len(channels):
        return np.ones(len(channels), dtype=bool)
    at = railed(channels, limits)
    if tally is not None:
        tally.add(at, channels, np.asarray(configuration), np.asarray(time, dtype=float))
    return np.asarray(~at.any(axis=1))


class SampleChecks:
    """The checks of one stream, with what they skipped (see the module docstring).

    Args:
        kin: Kinematics of the robot (joint limits); None for a stream without joints (no joint check).
        max_abs_channel: Largest plausible magnitude of a channel reading, in raw units
            (``checks.max_abs_channel`` of the pipeline settings).
        limits: The channels' declared (or already detected) resolution and rails; None for none.

    Attributes:
        skipped: Samples skipped, by reason.
        last_time: Time of the last accepted sample in [s] (-inf before the first).
        resume_time: Samples up to this time are already in a checkpoint [s] (-inf: none).
        rails: The railed samples, per channel and configuration (created with the first batch).
        watch: Detects rails not declared in the samples accepted (created with the first batch).
    """

    def __init__(self, kin: Kinematics | None, max_abs_channel: float = DEFAULT_MAX_ABS_CHANNEL, limits: ChannelLimits | None = None):
        self.kin = kin
        self.max_abs_channel = float(max_abs_channel)
        self.limits = limits
        self.rails: RailTally | None = None
        self.watch: RailWatch | None = None
        self.skipped: Counter[str] = Counter()
        self.last_time = -math.inf
        self.resume_time = -math.inf
        self._warned_degrees = False
        self._warned_temperature = False

    def accept(self, batch: SampleBatch) -> np.ndarray:
        """The samples of ``batch`` that pass every check, shape (N,) bool; the others are counted."""
        time = batch.time
        ok = time > self.resume_time
        self._count(BEFORE_CHECKPOINT, ~ok)
        finite, in_range = valid_values(time, batch.joints, batch.channels, self.max_abs_channel)
        if batch.temperature is not None:  # a NaN temperature would poison the offset model's sums
            finite &= np.isfinite(batch.temperature)
            in_range &= finite
            self._check_temperature(batch.temperature[ok & finite])
        self._count(NON_FINITE, ok & ~finite)
        self._count(OUT_OF_RANGE, ok & finite & ~in_range)
        ok &= in_range
        n = batch.channels.shape[1]
        self.rails = self.rails or RailTally(n)
        self.watch = self.watch or RailWatch(n)
        within = np.ones(len(time), dtype=bool)
        within[ok] = refuse_railed(batch.channels[ok], batch.configuration[ok], time[ok], self.limits, self.rails)
        self._count(RAILED, ok & ~within)
        ok &= within
        forward = forward_in_time(time, ok, self.last_time)
        self._count(BACKWARDS, ok & ~forward)
        ok &= forward
        known = batch.configuration >= 0
        self._count(UNKNOWN_TOOL, ok & ~known)
        ok &= known
        # only the samples still in: an inf or a corrupt row must not look like degrees
        outside = np.zeros(len(time), dtype=bool)
        degrees: Sequence[str] = ()  # no kinematics: no joint to check
        if self.kin is not None:
            _, outside[ok], degrees = self.kin.reading_problems(batch.joints[ok])
        self._count(OUTSIDE_LIMITS, outside)
        ok &= ~outside
        if degrees and not self._warned_degrees:
            self._warned_degrees = True
            warnings.warn(
                f"joint readings look like degrees ({', '.join(degrees)} far beyond 2π): readings must be in rad; "
                "these samples are skipped as outside the joint limits",
                FtsCalibWarning,
                stacklevel=4,
            )
        if ok.any():
            self.last_time = float(time[ok][-1])
            if self.watch is not None:
                self.watch.update(batch.channels[ok])
        return ok

    def state(self) -> dict:
        """What a checkpoint keeps: the samples skipped, by reason, and the railed ones."""
        return {"skipped": dict(self.skipped), "rails": None if self.rails is None else self.rails.state()}

    def restore(self, state: dict) -> None:
        """Restore :meth:`state` (of a checkpoint)."""
        self.skipped = Counter({str(k): int(v) for k, v in state["skipped"].items()})
        if state.get("rails") is not None:
            self.rails = RailTally(len(state["rails"]["last"]))
            self.rails.restore(state["rails"])

    def detected_limits(self, resolution) -> ChannelLimits | None:
        """The limits with the rails :attr:`watch` found and :attr:`limits` do not declare; None when there are none.

        A rail found here was not refused (it was not known while the samples came): a
        recording is then calibrated again with these limits
        (:func:`fts_calib.session.calibration_run.calibrate_recording`).

        Args:
            resolution: Step of each channel (the filter's: declared or learnt), raw units,
                shape (n,); None: the declared.
        """
        if self.watch is None:
            return None
        n = self.watch.n_channels
        declared = self.limits if self.limits is not None else ChannelLimits.none(n)
        low, high = self.watch.rails(declared.resolution if resolution is None else resolution)
        if not np.any((np.isfinite(low) & ~np.isfinite(declared.low)) | (np.isfinite(high) & ~np.isfinite(declared.high))):
            return None
        return declared.with_detected(None, low, high, detected_names(declared, None, low, high, [f"strain_{k + 1}" for k in range(n)]))

    def _check_temperature(self, temperature_C: np.ndarray) -> None:
        """Warn once about temperatures beyond :data:`PLAUSIBLE_TEMPERATURE_C` (another unit)."""
        low, high = PLAUSIBLE_TEMPERATURE_C
        beyond = temperature_C[(temperature_C < low) | (temperature_C > high)]
        if len(beyond) and not self._warned_temperature:
            self._warned_temperature = True
            warnings.warn(
                f"temperature {beyond[0]:g} °C is beyond what a sensor can have ({low:g} to {high:g} °C): the temperature "
                "must be in °C (kelvin? subtract 273.15); the samples are kept (the drift model's fit does not depend on the "
                "unit, the calibration file's temperature_C fields do)",
                FtsCalibWarning,
                stacklevel=4,
            )

    def _count(self, reason: str, mask: np.ndarray) -> None:
        count = int(mask.sum())
        if count:
            self.skipped[reason] += count

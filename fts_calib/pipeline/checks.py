"""Sample checks before the filter: valid values, time order, known configuration, joint limits.

A sample that fails a check is skipped and counted by reason; the run goes on. A value is
valid when it is finite and, for a channel, within the plausible range
(``checks.max_abs_channel`` of the pipeline settings): one corrupt cell (1e160) is one bad
sample, never fed to the filter's stationarity windows, where it would make every sample
near it look moving. The time order is the stream's: a sample earlier than one already
accepted is dropped (the one time-order check of the pipeline). Joint readings far beyond
2π on a revolute joint are taken for degrees and warned about once (only finite ones: an
``inf`` is a non-finite value, not a degree).
"""

from __future__ import annotations

import math
import warnings
from collections import Counter

import numpy as np

from ..core.exceptions import FtsCalibWarning
from ..feeds.batch import UNKNOWN_TOOL, SampleBatch
from ..robot.kinematics import Kinematics
from .settings import DEFAULT_MAX_ABS_CHANNEL

#: Skip reasons counted by the checks.
BEFORE_CHECKPOINT = "before the checkpoint (already counted)"
BACKWARDS = "time going backwards"
NON_FINITE = "non-finite value"
OUT_OF_RANGE = "channel out of range"
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


class SampleChecks:
    """The checks of one stream, with what they skipped (see the module docstring).

    Args:
        kin: Kinematics of the robot (joint limits).
        max_abs_channel: Largest plausible magnitude of a channel reading, in raw units
            (``checks.max_abs_channel`` of the pipeline settings).

    Attributes:
        skipped: Samples skipped, by reason.
        last_time: Time of the last accepted sample in [s] (-inf before the first).
        resume_time: Samples up to this time are already in a checkpoint [s] (-inf: none).
    """

    def __init__(self, kin: Kinematics, max_abs_channel: float = DEFAULT_MAX_ABS_CHANNEL):
        self.kin = kin
        self.max_abs_channel = float(max_abs_channel)
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
        forward = forward_in_time(time, ok, self.last_time)
        self._count(BACKWARDS, ok & ~forward)
        ok &= forward
        known = batch.configuration >= 0
        self._count(UNKNOWN_TOOL, ok & ~known)
        ok &= known
        # only the samples still in: an inf or a corrupt row must not look like degrees
        outside = np.zeros(len(time), dtype=bool)
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
        return ok

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

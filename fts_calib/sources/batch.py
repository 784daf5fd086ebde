"""SampleBatch: the one record that carries samples from the feeds to the pipeline.

Every feed (recordings, the live synchronizer, replay, robot logs) yields these; every
later stage takes them. The sample axis is first; joint readings are in the robot
definition's joint order, in [rad]; channels are raw readings in the sensor's unit; a
configuration is an index into the tool's configurations (-1: unknown, counted and
skipped by the session's checks).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..core.exceptions import ShapeError, UnknownToolConfiguration

#: Configuration index of a sample whose tool configuration is not in the tool file.
UNKNOWN_CONFIGURATION = -1
#: The skip reason of such a sample (the recording reader and the session's checks count it).
UNKNOWN_TOOL = "unknown tool configuration"
#: The skip reason of a sample identical to the one before it in every value (a row or a message
#: recorded twice): dropped and counted by the readers, so that no sample weighs twice.
DUPLICATE = "duplicate sample"


def repeated_rows(table: np.ndarray, previous: np.ndarray | None) -> np.ndarray:
    """Which rows of a table equal the row before them in every column (the first row: ``previous``).

    A log that holds every sample twice (a CSV written twice over, a bag given with its own
    storage file) must not count each sample twice: the standard errors would be too small by
    sqrt 2, and the repeated stamps stall every rate estimate. Rows that merely share a time
    stamp (a coarse clock) differ in their values and are kept.

    Args:
        table: Samples, one row each (time, joints, channels, ...; any columns). Shape (N, k).
        previous: The last row of the table before this one (a reader reads in chunks), or None.
            Shape (k,).

    Returns:
        True where a row repeats the one before it. Shape (N,) bool.
    """
    table = np.asarray(table)
    same = np.zeros(len(table), dtype=bool)
    if len(table) > 1:
        same[1:] = np.all(table[1:] == table[:-1], axis=1)
    if len(table) and previous is not None:
        same[0] = bool(np.all(table[0] == previous))
    return same


@dataclass(frozen=True)
class SampleBatch:
    """Consecutive samples of one feed, in time order.

    Attributes:
        time: Sample times in [s]. Shape (N,).
        joints: Joint readings in [rad], the robot definition's order. Shape (N, n_joints).
        channels: Raw channel readings (strains). Shape (N, n_channels).
        configuration: Index of each sample's tool configuration in the tool's order, -1
            when unknown. Shape (N,), int.
        temperature: Sensor temperature in [°C], or None when the feed has none. Shape (N,).
        first_line: For a recording, the file line (1-based, header = line 1) of the first
            sample; None for other feeds.
    """

    time: np.ndarray
    joints: np.ndarray
    channels: np.ndarray
    configuration: np.ndarray
    temperature: np.ndarray | None = None
    first_line: int | None = None

    def __post_init__(self):
        time = np.asarray(self.time, dtype=float).reshape(-1)
        n = len(time)
        joints = np.asarray(self.joints, dtype=float)
        channels = np.asarray(self.channels, dtype=float)
        configuration = np.asarray(self.configuration, dtype=np.int64).reshape(-1)
        if joints.ndim != 2 or channels.ndim != 2 or len(joints) != n or len(channels) != n or len(configuration) != n:
            raise ShapeError(
                f"a sample batch needs one row per time: time {time.shape}, joints {joints.shape}, channels {channels.shape}, "
                f"configuration {configuration.shape}; expected (N,), (N, n_joints), (N, n_channels), (N,)"
            )
        object.__setattr__(self, "time", time)
        object.__setattr__(self, "joints", joints)
        object.__setattr__(self, "channels", channels)
        object.__setattr__(self, "configuration", configuration)
        if self.temperature is not None:
            temperature = np.asarray(self.temperature, dtype=float).reshape(-1)
            if len(temperature) != n:
                raise ShapeError(f"temperature.shape={temperature.shape} but expected ({n},)")
            object.__setattr__(self, "temperature", temperature)

    def __len__(self) -> int:
        return len(self.time)

    @classmethod
    def empty(cls, n_joints: int, n_channels: int) -> SampleBatch:
        """A batch of no sample, with the widths of a feed."""
        return cls(np.zeros(0), np.zeros((0, n_joints)), np.zeros((0, n_channels)), np.zeros(0, dtype=np.int64))

    def rows(self, start: int, stop: int) -> SampleBatch:
        """Samples ``start`` to ``stop - 1`` (views, no copy)."""
        return SampleBatch(
            self.time[start:stop],
            self.joints[start:stop],
            self.channels[start:stop],
            self.configuration[start:stop],
            None if self.temperature is None else self.temperature[start:stop],
        )

    def select(self, mask: np.ndarray) -> SampleBatch:
        """The samples where ``mask`` (bool, shape (N,)) holds, in order (``first_line`` is dropped)."""
        return SampleBatch(
            self.time[mask],
            self.joints[mask],
            self.channels[mask],
            self.configuration[mask],
            None if self.temperature is None else self.temperature[mask],
        )

    @classmethod
    def concatenate(cls, batches: Sequence[SampleBatch]) -> SampleBatch:
        """One batch of several, in the given order (temperature kept only when all have it)."""
        if not batches:
            raise ValueError("concatenate needs at least one batch (a programming error, not a user's)")
        temperature = None
        if all(b.temperature is not None for b in batches):
            temperature = np.concatenate([b.temperature for b in batches if b.temperature is not None])
        return cls(
            np.concatenate([b.time for b in batches]),
            np.concatenate([b.joints for b in batches]),
            np.concatenate([b.channels for b in batches]),
            np.concatenate([b.configuration for b in batches]),
            temperature,
            batches[0].first_line,
        )


def configuration_indices(names: Sequence[str | None], known: Sequence[str]) -> np.ndarray:
    """Index of each configuration name in ``known`` (the tool's order), -1 when unknown.

    Args:
        names: A configuration name per sample (None: none announced). Length N.
        known: The tool's configuration names, in order.

    Returns:
        Shape (N,), int64.
    """
    lookup = {name: k for k, name in enumerate(known)}
    return np.array(
        [lookup.get(name, UNKNOWN_CONFIGURATION) if name is not None else UNKNOWN_CONFIGURATION for name in names], dtype=np.int64
    )


def configuration_codes(configuration, n: int, known: Sequence[str]) -> np.ndarray:
    """The configuration index of each of ``n`` samples a caller gives: one name, a name per sample, or indices.

    Unlike a feed's unknown names (counted and skipped: :func:`configuration_indices`), a
    caller's are a mistake in the code that calls and are refused.

    Args:
        configuration: One configuration name, a name per sample (length n), or indices in
            the tool's order (-1: unknown, skipped and counted).
        n: Number of samples.
        known: The tool's configuration names, in order.

    Returns:
        Shape (n,), int64 (indices given per sample keep their own length, for the caller's
        length check).

    Raises:
        UnknownToolConfiguration: A name that is not in ``known``, or an index outside
            -1 .. len(known) - 1.
    """
    given = np.asarray(configuration)
    if given.dtype.kind in "iu":
        codes = np.full(n, int(given), dtype=np.int64) if given.ndim == 0 else given.astype(np.int64).reshape(-1)
        wrong = codes[(codes < UNKNOWN_CONFIGURATION) | (codes >= len(known))]
        if len(wrong):
            raise UnknownToolConfiguration(str(int(wrong[0])), known)
        return codes
    names = [str(configuration)] * n if given.ndim == 0 else [str(name) for name in given.reshape(-1)]
    codes = configuration_indices(names, known)
    if (codes == UNKNOWN_CONFIGURATION).any():
        raise UnknownToolConfiguration(names[int(np.argmax(codes == UNKNOWN_CONFIGURATION))], known)
    return codes

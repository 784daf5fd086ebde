"""Sample checks before the filter: time order, finite values, known configuration, joint limits.

A sample that fails a check is skipped and counted by reason; the run goes on. The time
order is the stream's: a sample earlier than one already accepted is dropped (the one
time-order check of the pipeline). Joint readings far beyond 2π on a revolute joint are
taken for degrees and warned about once.
"""

from __future__ import annotations

import math
import warnings
from collections import Counter

import numpy as np

from ..core.exceptions import FtsCalibWarning
from ..feeds.batch import SampleBatch
from ..robot.kinematics import Kinematics

#: Skip reasons counted by the checks.
BEFORE_CHECKPOINT = "before the checkpoint (already counted)"
BACKWARDS = "time going backwards"
NON_FINITE = "non-finite value"
UNKNOWN_TOOL = "unknown tool configuration"
OUTSIDE_LIMITS = "outside joint limits"


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

    Attributes:
        skipped: Samples skipped, by reason.
        last_time: Time of the last accepted sample in [s] (-inf before the first).
        resume_time: Samples up to this time are already in a checkpoint [s] (-inf: none).
    """

    def __init__(self, kin: Kinematics):
        self.kin = kin
        self.skipped: Counter[str] = Counter()
        self.last_time = -math.inf
        self.resume_time = -math.inf
        self._warned_degrees = False

    def accept(self, batch: SampleBatch) -> np.ndarray:
        """The samples of ``batch`` that pass every check, shape (N,) bool; the others are counted."""
        time = batch.time
        ok = time > self.resume_time
        self._count(BEFORE_CHECKPOINT, ~ok)
        finite = np.isfinite(time) & np.all(np.isfinite(batch.joints), axis=1) & np.all(np.isfinite(batch.channels), axis=1)
        self._count(NON_FINITE, ok & ~finite)
        ok &= finite
        forward = forward_in_time(time, ok, self.last_time)
        self._count(BACKWARDS, ok & ~forward)
        ok &= forward
        known = batch.configuration >= 0
        self._count(UNKNOWN_TOOL, ok & ~known)
        ok &= known
        _, outside, degrees = self.kin.reading_problems(batch.joints)
        self._count(OUTSIDE_LIMITS, ok & outside)
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

    def _count(self, reason: str, mask: np.ndarray) -> None:
        count = int(mask.sum())
        if count:
            self.skipped[reason] += count

"""The synchronizer: joint readings interpolated at strain times, across two live streams.

Joint and strain messages arrive at different rates and out of order. Joint samples are
kept sorted by time (their stamps less the configured latency: a joint stream whose stamps
are late by ``latency_s`` is shifted back). A strain sample is placed once the joint
stream has passed its time by ``hold_s`` (so that late joint messages can still arrive):
the joints are interpolated linearly between the two joint samples around it (continuous
joints along the shorter arc), and its tool configuration is the last one announced at or
before its time. A strain sample is dropped, and counted, when it cannot be placed: before
the first joint sample or after the last one, inside a joint gap longer than
``max_gap_s`` (the synchronizer refuses to interpolate across it), before any tool
message, or arriving after later strain samples were already placed.

With no joints expected (``joint_names`` empty: a sensor alone, for a re-tare with nothing
mounted or the health monitor) the strain stream is its own frontier: a strain sample is
placed once a strain sample ``hold_s`` later has arrived (with ``hold_s`` 0, on arrival; with
an infinite ``hold_s``, only at the final :meth:`Synchronizer.pop`), in time order. One that
arrives at or behind that frontier is late, and dropped and counted, so what is placed does
not depend on how often :meth:`Synchronizer.pop` is called. Its joints have no column, and its
tool configuration is the last one announced, or -1 before any (a sensor alone needs none).
"""

from __future__ import annotations

import bisect
import math
from collections import Counter
from collections.abc import Sequence

import numpy as np

from .batch import SampleBatch, configuration_indices

BEFORE_JOINTS = "strain before the first joint sample"
JOINT_GAP = "joint gap longer than max_gap_s"
AFTER_JOINTS = "strain after the last joint sample"
NO_TOOL = "no tool configuration announced yet"
LATE = "strain sample arrived too late (reordered beyond the hold)"
#: Reason of a strain message of another length than the sensor's; ends with the expected length.
WRONG_LENGTH = "strain message of another length than the sensor's channels: expected"


class Synchronizer:
    """Pairs the two streams (see the module docstring).

    Args:
        joint_names: Joint names, in the robot's order; empty for the strain stream alone (see
            the module docstring).
        continuous: Which joints are continuous (interpolated along the shorter arc). Shape (n,).
        max_gap_s: Longest joint gap interpolated across [s].
        latency_s: How late the joint stamps are relative to the strain stamps [s].
        hold_s: How far the joint stream (the strain stream, with no joints) must pass a
            strain time before it is placed [s]; ``max_gap_s`` when None.
        configurations: The tool's configuration names, in order: a placed sample's
            configuration is its index there (-1 for a name not in it). None: indices in
            order of first announcement (names in :attr:`configurations`).
        n_channels: Values a strain message must have (the sensor layout's channels); None
            takes the first message's length. A message of another length is dropped and
            counted (:data:`WRONG_LENGTH`, followed by the expected number).

    Attributes:
        dropped: Strain samples dropped, by reason.
    """

    def __init__(
        self,
        joint_names: Sequence[str],
        continuous: Sequence[bool] | np.ndarray | None = None,
        max_gap_s: float = 0.05,
        latency_s: float = 0.0,
        hold_s: float | None = None,
        configurations: Sequence[str] | None = None,
        n_channels: int | None = None,
    ):
        self.n_channels = n_channels
        self.joint_names = list(joint_names)
        self._open_configurations = configurations is None
        self.configurations: list[str] = list(configurations or [])
        self._index = {name: k for k, name in enumerate(self.joint_names)}
        self.continuous = np.zeros(len(self.joint_names), dtype=bool) if continuous is None else np.asarray(continuous, dtype=bool)
        self.max_gap_s = float(max_gap_s)
        self.latency_s = float(latency_s)
        self.hold_s = self.max_gap_s if hold_s is None else float(hold_s)
        self._joint_t = np.zeros(0)
        self._joint_q = np.zeros((0, len(self.joint_names)))
        self._new_joints: list[tuple[float, np.ndarray]] = []
        self._strain: list[tuple[float, tuple[float, ...], float | None]] = []
        self._tools: list[tuple[float, str]] = []
        self._placed_until = -math.inf
        self._empty_batch: SampleBatch | None = None
        self._newest_strain = -math.inf  # the latest strain time accepted so far [s] (the frontier with no joints)
        self.dropped: Counter[str] = Counter()
        self.joint_messages = 0
        self.strain_messages = 0

    @property
    def strain_only(self) -> bool:
        """No joints are expected: the strain stream alone is placed (see the module docstring)."""
        return not self.joint_names

    def add_joints(self, t: float, joints: dict[str, float]) -> bool:
        """Add a joint message; False (nothing added) when its joints are not exactly the robot's.

        Args:
            t: The sender's time stamp, in [s] (the latency is taken off).
            joints: Joint name -> reading in [rad], one per joint of the robot.
        """
        if len(joints) != len(self._index) or any(name not in self._index for name in joints):
            return False
        self.joint_messages += 1
        self._new_joints.append((t - self.latency_s, np.array([joints[n] for n in self.joint_names])))
        return True

    def add_strain(self, t: float, strain: Sequence[float], temperature: float | None = None) -> None:
        """Add a strain message.

        Args:
            t: The sender's time stamp, in [s].
            strain: Raw channel readings. Length n_channels.
            temperature: The sensor's temperature [°C], or None. When some samples of a batch
                have one and others not, the others get NaN (the session's checks skip them).
        """
        self.strain_messages += 1
        if self.n_channels is None:
            self.n_channels = len(strain)
        if len(strain) != self.n_channels:
            self._drop(f"{WRONG_LENGTH} {self.n_channels}", 1)
            return
        if t <= self._placed_until or (self.strain_only and t <= self._newest_strain - self.hold_s):
            self._drop(LATE, 1)
            return
        self._newest_strain = max(self._newest_strain, t)
        self._strain.append((t, tuple(strain), temperature))

    def add_tool(self, t: float, name: str) -> None:
        """Announce the tool configuration mounted from ``t`` on (repeats change nothing)."""
        if self._open_configurations and name not in self.configurations:
            self.configurations.append(name)
        k = bisect.bisect_right(self._tools, (t, name))
        if k and self._tools[k - 1][1] == name:
            return  # the same configuration is already mounted at t
        self._tools.insert(k, (t, name))

    def _drop(self, reason: str, count: int) -> None:
        if count:
            self.dropped[reason] += count

    def _merge_joints(self) -> None:
        if not self._new_joints:
            return
        t = np.array([j[0] for j in self._new_joints])
        q = np.array([j[1] for j in self._new_joints])
        self._new_joints = []
        all_t = np.concatenate([self._joint_t, t])
        all_q = np.concatenate([self._joint_q, q])
        order = np.argsort(all_t, kind="stable")
        all_t, all_q = all_t[order], all_q[order]
        unique = np.concatenate([[True], np.diff(all_t) > 0])  # a repeated stamp keeps its first reading
        self._joint_t, self._joint_q = all_t[unique], all_q[unique]

    def pop(self, final: bool = False) -> SampleBatch:
        """Place every strain sample the joint stream has passed (all of them when ``final``)."""
        self._merge_joints()
        if not self._strain:
            return self._empty()
        self._strain.sort(key=lambda s: s[0])
        if final:
            frontier = math.inf
        elif self.strain_only:
            frontier = self._newest_strain - self.hold_s
        else:
            frontier = self._joint_t[-1] - self.hold_s if len(self._joint_t) else -math.inf
        count = bisect.bisect_right([s[0] for s in self._strain], frontier)
        ready, self._strain = self._strain[:count], self._strain[count:]
        if not ready:
            return self._empty()
        t = np.array([s[0] for s in ready])
        strain = np.array([s[1] for s in ready], dtype=float)
        heat = None if all(s[2] is None for s in ready) else np.array([math.nan if s[2] is None else s[2] for s in ready])
        self._placed_until = max(self._placed_until, float(t[-1]))
        if self.strain_only:
            codes = configuration_indices(self._tool_at(t), self.configurations)
            return SampleBatch(t, np.zeros((len(t), 0)), strain, codes, heat)
        jt, jq = self._joint_t, self._joint_q
        if len(jt) == 0:
            self._drop(BEFORE_JOINTS, len(t))
            return self._empty()
        right = np.searchsorted(jt, t, side="left")
        exact = (right < len(jt)) & (jt[np.minimum(right, len(jt) - 1)] == t)
        left = np.where(exact, right, right - 1)  # an exact stamp interpolates with itself
        inside = (left >= 0) & (right < len(jt))
        self._drop(BEFORE_JOINTS, int(np.sum(left < 0)))
        after = (left >= 0) & (right >= len(jt))  # only when final: beyond the last joint sample
        self._drop(AFTER_JOINTS, int(np.sum(after)))
        lo, hi = np.clip(left, 0, len(jt) - 1), np.clip(right, 0, len(jt) - 1)
        gap = jt[hi] - jt[lo]
        ok = inside & (gap <= self.max_gap_s)
        self._drop(JOINT_GAP, int(np.sum(inside & ~ok)))
        with np.errstate(invalid="ignore", divide="ignore"):
            w = np.where(gap > 0, (t - jt[lo]) / np.where(gap > 0, gap, 1.0), 0.0)[:, None]
        delta = jq[hi] - jq[lo]
        delta[:, self.continuous] = (delta[:, self.continuous] + math.pi) % (2 * math.pi) - math.pi
        readings = jq[lo] + w * delta
        tools = self._tool_at(t)
        has_tool = np.array([name is not None for name in tools], dtype=bool)
        self._drop(NO_TOOL, int(np.sum(ok & ~has_tool)))
        ok &= has_tool
        # joints older than what the pending strain samples can still need are dropped
        oldest = self._strain[0][0] if self._strain else self._placed_until
        keep_from = max(0, int(np.searchsorted(jt, oldest - self.max_gap_s, side="left")) - 1)
        self._joint_t, self._joint_q = jt[keep_from:], jq[keep_from:]
        codes = configuration_indices(tools, self.configurations)
        return SampleBatch(t[ok], readings[ok], strain[ok], codes[ok], None if heat is None else heat[ok])

    def _empty(self) -> SampleBatch:
        """No sample, in this stream's shape (one batch per shape, shared: a live loop asks 50 times a second)."""
        width = 8 if self.n_channels is None else self.n_channels  # no message yet: the paper's sensor
        if self._empty_batch is None or self._empty_batch.channels.shape[1] != width:
            self._empty_batch = SampleBatch.empty(len(self.joint_names), width)
        return self._empty_batch

    def _tool_at(self, t: np.ndarray) -> list[str | None]:
        if not self._tools:
            return [None] * len(t)
        times = np.array([x[0] for x in self._tools])
        k = np.searchsorted(times, t, side="right") - 1
        return [self._tools[i][1] if i >= 0 else None for i in k]

"""The offset trajectory's sample points: time, configuration and temperature of a few samples of a run.

The estimator keeps only sums; to report the offset D over time (the calibration file's
``offset_model.trajectory``) it also keeps, in bounded memory, the time [s], configuration
index and temperature [°C] of at most :data:`TRACE_POINTS` samples: one at least every
``spacing_s`` seconds and one at each change of configuration, the spacing doubling (and
every other point dropped) whenever the list is full; and always the last sample, the one
the calibration's D belongs to.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

#: Points kept at most.
TRACE_POINTS = 64

Point = tuple[float, int, float]


class OffsetTrace:
    """Bounded list of ``(time [s], configuration, temperature [°C])`` points (see the module docstring)."""

    def __init__(self, spacing_s: float = 1.0):
        self.points: list[Point] = []
        self.spacing_s = float(spacing_s)
        self.end: Point | None = None

    def note(self, time: np.ndarray | None, codes: np.ndarray | None, temperature: np.ndarray | None, default_temperature: float) -> None:
        """Record samples, in time order.

        Args:
            time: Sample times [s], shape (N,); nothing is recorded when None.
            codes: Configuration index per sample, shape (N,); all 0 when None.
            temperature: Temperatures [°C], shape (N,); ``default_temperature`` when None.
            default_temperature: The temperature of samples without one [°C].
        """
        if time is None or not len(time):
            return
        c = np.zeros(len(time), dtype=np.int64) if codes is None else codes
        T = np.full(len(time), default_temperature) if temperature is None else temperature
        i = 0
        while i < len(time):
            if self.points and self.points[-1][1] == c[i]:
                later = np.flatnonzero((time[i:] >= self.points[-1][0] + self.spacing_s) | (c[i:] != c[i]))
                if not len(later):
                    break
                i += int(later[0])
            self.points.append((float(time[i]), int(c[i]), float(T[i])))
            self._bound()
            i += 1
        self.end = (float(time[-1]), int(c[-1]), float(T[-1]))

    def _bound(self) -> None:
        while len(self.points) > TRACE_POINTS:
            self.points = self.points[::2]
            self.spacing_s *= 2.0

    def with_end(self) -> list[Point]:
        """The points, ending with the last sample."""
        if self.end is None or (self.points and self.points[-1] == self.end):
            return list(self.points)
        return [*self.points, self.end]

    def merged(self, other: OffsetTrace) -> OffsetTrace:
        """The points of both, in time order, bounded again."""
        out = OffsetTrace(max(self.spacing_s, other.spacing_s))
        out.points = sorted(self.points + other.points)
        out._bound()
        ends = [e for e in (self.end, other.end) if e is not None]
        out.end = max(ends) if ends else None
        return out

    def state(self) -> dict:
        """Plain data for checkpoints."""
        return {"points": [list(p) for p in self.points], "spacing_s": self.spacing_s, "end": None if self.end is None else list(self.end)}

    @classmethod
    def from_state(cls, state: Mapping | None) -> OffsetTrace:
        """Inverse of :meth:`state` (an empty trace for None: a checkpoint of an older version)."""
        out = cls(float((state or {}).get("spacing_s", 1.0)))
        if state:
            out.points = [(float(t), int(c), float(T)) for t, c, T in state.get("points", [])]
            end = state.get("end")
            out.end = None if not end else (float(end[0]), int(end[1]), float(end[2]))
        return out

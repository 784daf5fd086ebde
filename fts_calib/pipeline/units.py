"""Held-out units of the kept samples: what the model choice leaves out as a whole.

The choice of the sensor model by held-out error (:mod:`fts_calib.model.model_choice`) leaves
one *unit* out at a time. Samples of one unit share their errors (one orientation, one
stretch of time), so a unit must be a whole static pose, or a block of still windows:

- a new unit starts when the tool configuration changes;
- or after a gap of more than :data:`UNIT_GAP_S` between kept samples (the arm moved: the
  next pose of a static-pose dataset, or the next still stretch of a sweep);
- or when a unit has lasted :data:`UNIT_SPAN_S` (a long slow sweep, or the moving samples of the
  dynamic mode, are cut into blocks in time: one unit per configuration would leave the others
  rank 6 when one is left out),
  once the joints have moved more than :data:`UNIT_STILL_RAD` from the stretch's first
  sample: a static pose held for longer (13 s, say) stays one unit, since its blocks
  would share one orientation and leaving one out would test nothing. (Without joints,
  every stretch is cut by time.)

A new file of a recording made of several files starts after a gap
(:mod:`fts_calib.feeds.recording_set`), so it starts a new unit. Times in [s], joints in [rad].
"""

from __future__ import annotations

import numpy as np

#: A gap between kept samples longer than this starts a new unit, [s].
UNIT_GAP_S = 0.5
#: A unit lasts at most this long, [s]: a sweep's still stretches and a continuous motion are cut into blocks.
UNIT_SPAN_S = 2.0
#: Joints within this of a stretch's first sample hold one pose, [rad]: its stretch is not cut in time.
UNIT_STILL_RAD = 1e-3


class HeldOutUnits:
    """Assigns each kept sample its unit, online, in time order (see the module docstring)."""

    def __init__(self) -> None:
        self.count = 0  # units started so far
        self._open: tuple[float, int, float, int] | None = None  # the open stretch: start [s], its first unit, last time [s], configuration
        self._pose: tuple[np.ndarray, bool] | None = None  # the open stretch's first joints [rad], and whether they moved since

    def assign(self, time: np.ndarray, configuration: np.ndarray, joints: np.ndarray | None = None) -> np.ndarray:
        """Unit indices of kept samples (in time order), continuing the open stretch.

        Args:
            time: Times [s], shape (N,).
            configuration: Tool configuration index per sample, shape (N,).
            joints: Joint readings [rad], shape (N, n_joints); None: every stretch is cut in time.

        Returns:
            Shape (N,), integers >= 0.
        """
        time = np.asarray(time, dtype=float)
        codes = np.asarray(configuration, dtype=np.int64)
        n = len(time)
        out = np.empty(n, dtype=np.int64)
        if not n:
            return out
        last_time, last_code = (self._open[2], self._open[3]) if self._open else (-np.inf, -1)
        new = (codes != np.r_[last_code, codes[:-1]]) | (time - np.r_[last_time, time[:-1]] > UNIT_GAP_S)
        firsts = np.flatnonzero(new).tolist()
        ends = [*firsts, n]
        stretches = [] if firsts and firsts[0] == 0 else [(0, ends[0], self._open)]
        stretches += [(a, ends[j + 1], None) for j, a in enumerate(firsts)]
        for a, e, opened in stretches:
            start, first = (opened[0], opened[1]) if opened else (float(time[a]), self.count)
            blocks = np.floor((time[a:e] - start) / UNIT_SPAN_S).astype(np.int64)
            if joints is not None:
                pose = self._pose if opened and self._pose is not None else (np.array(joints[a], dtype=float), False)
                moved = pose[1] | (np.cumsum(np.any(np.abs(joints[a:e] - pose[0]) > UNIT_STILL_RAD, axis=1)) > 0)
                blocks = np.where(moved, blocks, 0)  # one pose held: one unit, however long
                self._pose = (pose[0], bool(moved[-1]))
            out[a:e] = first + blocks
            self.count = max(self.count, int(out[e - 1]) + 1)
            self._open = (start, first, float(time[e - 1]), int(codes[e - 1]))
        return out

    def state(self) -> dict:
        """Plain data for checkpoints."""
        pose = None if self._pose is None else [self._pose[0].tolist(), self._pose[1]]
        return {"count": self.count, "open": None if self._open is None else list(self._open), "pose": pose}

    def restore(self, state: dict | None) -> None:
        """Load :meth:`state` (None: nothing saved)."""
        if state:
            self.count = int(state["count"])
            o = state.get("open")
            self._open = None if o is None else (float(o[0]), int(o[1]), float(o[2]), int(o[3]))
            pose = state.get("pose")  # absent from an older checkpoint: the stretch is cut in time
            self._pose = None if pose is None else (np.asarray(pose[0], dtype=float), bool(pose[1]))

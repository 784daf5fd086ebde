"""The offsets part of ``fts-calib monitor``: a known payload's wrench against the measured one (:mod:`fts_calib.service.offset_watch`)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..core.exceptions import ConfigError
from ..model.calibration import Calibration, save_calibration
from ..model.health import ParityModel
from ..model.sensor import WRENCH_AXES, WRENCH_UNITS
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool
from ..robot.tool_wrench import tool_load
from ..service.offset_watch import OffsetWatch
from .exit_codes import writing

#: Windows without contact before an automatic re-tare is trusted.
MIN_UPDATES = 10
#: Samples whose median time step sizes the windows (0.1 s), whatever batches they arrive in.
SIZING_SAMPLES = 20


class OffsetFeed:
    """Feeds an :class:`OffsetWatch` from a recording's batches and re-tares when asked.

    Args:
        calibration: The calibration in use (its C and D turn channels into wrenches).
        path: Its file (re-tares are written there, atomically, with the old offsets in its history).
        parity: Its parity model (the channels' noise, for the wrench noise).
        kin: Kinematics of the robot.
        tool: The payload's tool file.
        configuration: The payload's configuration, or None for each sample's (the recording's tool column).
        full_scale: Full scale per axis [N, N, N, N m, N m, N m], shape (6,).
        auto_tare: Re-tare when the offset error exceeds ``threshold_percent``.
        threshold_percent: Offset error tolerated, in % of full scale.
    """

    def __init__(
        self,
        calibration: Calibration,
        path,
        parity: ParityModel,
        kin: Kinematics,
        tool: Tool,
        configuration,
        full_scale,
        auto_tare,
        threshold_percent,
    ):
        if configuration is not None and configuration not in tool.names:
            raise ConfigError("configuration", configuration, f"one of the tool's: {', '.join(tool.names)}")
        self.calibration, self.path, self.kin, self.tool = calibration, Path(path), kin, tool
        self.index = None if configuration is None else tool.names.index(configuration)
        self.full_scale = np.asarray(full_scale, dtype=float)
        self.threshold = self.full_scale * threshold_percent / 100.0
        self.auto_tare = auto_tare
        noise = np.sqrt(np.diag(calibration.C @ np.diag(parity.channel_noise**2) @ calibration.C.T))
        allowance = np.zeros(6)
        if tool.tolerance is not None:  # what a payload known to a tolerance adds to the residual
            heaviest = max(c.mass for c in tool.configurations)
            farthest = max(float(np.linalg.norm(c.p_sensor_com)) for c in tool.configurations)
            allowance[:3] = tool.gravity * tool.tolerance.mass
            allowance[3:] = tool.gravity * (heaviest * tool.tolerance.com + tool.tolerance.mass * farthest)
        self._noise, self._allowance = noise, allowance
        self.watch = OffsetWatch(noise, allowance)  # replaced by one with 0.1 s windows once the rate is known
        self._sized = False
        self._waiting: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
        self.tares: list[float] = []
        self.last_time = math.nan

    def add(self, time: np.ndarray, joints: np.ndarray, channels: np.ndarray, configuration: np.ndarray) -> None:
        """Add a batch: times [s] (N,), joints [rad] (N, n_joints), raw channels (N, n), configuration indices (N,) (-1: unknown).

        The windows, the updates and the re-tares do not depend on how a feed is cut into
        batches: the window length comes from the first :data:`SIZING_SAMPLES` samples (held
        until they have all arrived), and a re-tare is judged after each window.
        """
        codes = np.full(len(time), self.index) if self.index is not None else np.asarray(configuration)
        if not self._sized:
            self._waiting.append((np.asarray(time, dtype=float), np.asarray(joints), np.asarray(channels), codes))
            if sum(len(w[0]) for w in self._waiting) < SIZING_SAMPLES:
                return
            self._size_and_judge()
            return
        self._judge(time, joints, channels, codes)

    def finish(self) -> None:
        """End of the feed: a feed shorter than :data:`SIZING_SAMPLES` samples is sized from what arrived and judged."""
        if not self._sized and self._waiting:
            self._size_and_judge()

    def _size_and_judge(self) -> None:
        time, joints, channels, codes = (np.concatenate([w[k] for w in self._waiting]) for k in range(4))
        self._waiting = []
        steps = np.diff(time[:SIZING_SAMPLES])
        steps = steps[steps > 0]
        block = max(10, int(round(0.1 / float(np.median(steps))))) if len(steps) else 100  # windows of 0.1 s
        self.watch, self._sized = OffsetWatch(self._noise, self._allowance, block=block), True
        self._judge(time, joints, channels, codes)

    def _judge(self, time: np.ndarray, joints: np.ndarray, channels: np.ndarray, codes: np.ndarray) -> None:
        known = codes >= 0
        if not known.any():
            return
        time, joints, channels = time[known], joints[known], channels[known]
        payload = tool_load(self.kin, self.tool, joints, codes[known]).static
        wrench = self.calibration.wrench(channels, region_check=False)  # monitor counts the region itself
        start = 0
        while start < len(time):
            # with --auto-tare, up to the end of the next window: a re-tare is judged after each one
            stop = min(len(time), start + self.watch.block - self.watch.pending) if self.auto_tare else len(time)
            self.watch.update_batch(time[start:stop], wrench[start:stop], payload[start:stop], joints[start:stop])
            self.last_time, start = float(time[stop - 1]), stop
            learnt = self.watch.updates >= MIN_UPDATES  # never re-tare on the first windows' estimate
            if self.auto_tare and learnt and self.watch.pending == 0 and np.any(np.abs(self.watch.offset) > self.threshold):
                self._retare()
                wrench[start:] = self.calibration.wrench(channels[start:], region_check=False)

    def _retare(self) -> None:
        self.calibration = self.watch.retare(
            self.calibration, f"re-tared by monitor at {self.last_time:.3f} s: offset drift without contact"
        )
        with writing(self.path):
            save_calibration(self.calibration, self.path)
        self.tares.append(self.last_time)

    def lines(self) -> list[str]:
        """The offset state in words: error, rate, windows, forecast, re-tares."""
        w = self.watch
        error = ", ".join(f"{a} {v:+.4g} {u}" for a, v, u in zip(WRENCH_AXES, w.offset, WRENCH_UNITS, strict=True))
        rate = ", ".join(f"{a} {60 * v:+.3g} {u}/min" for a, v, u in zip(WRENCH_AXES, w.rate, WRENCH_UNITS, strict=True))
        forecast = w.forecast_s(self.threshold)
        when = "never at this rate" if math.isinf(forecast) else f"in {forecast:.1f} s"
        out = [
            f"offset error (measured - payload, windows without contact): {error}",
            f"offset drift: {rate}; {w.updates:,} windows without contact, {w.contacts:,} refused (contact or motion)",
            f"the offset error exceeds {100 * self.threshold[0] / self.full_scale[0]:g} % of full scale {when}",
        ]
        if self.tares:
            out.append(f"re-tared {len(self.tares)} time(s) (at {', '.join(f'{t:.1f}' for t in self.tares)} s); wrote {self.path}")
        return out

    def status(self) -> str:
        """The offset state for a status line: the largest error in % FS, contact or not, the re-tares."""
        worst = float(np.max(np.abs(self.watch.offset) / self.full_scale)) * 100
        state = "contact" if self.watch.in_contact else "free"
        return f"offset error {worst:.4f} % FS ({state}, {self.watch.updates:,} windows), {len(self.tares)} re-tare(s)"

    def as_dict(self) -> dict:
        """The offset state for ``--json``."""
        return {
            "error": self.watch.offset.tolist(),
            "rate_per_s": self.watch.rate.tolist(),
            "windows_without_contact": self.watch.updates,
            "windows_refused": self.watch.contacts,
            "exceeds_threshold_in_s": self.watch.forecast_s(self.threshold),
            "tares_s": self.tares,
        }

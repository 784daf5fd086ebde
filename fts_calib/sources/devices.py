"""Channel devices on the host's clock: what a serial line or an ATI Net F/T box gives the live loop.

A :class:`ChannelDevice` reads its hardware in a background thread and stamps every sample on
arrival with the host's monotonic clock (``time.monotonic()``, [s]); the live loop
(:class:`fts_calib.sources.live_feed.LiveFeed`) drains the samples into the synchronizer as
strain messages and puts the other streams (joint datagrams, RTDE) on the same clock.

:class:`StreamClock` keeps, per stream, what a recording needs to be trusted: the samples, the
rate, the jitter of the arrival intervals and, for a stream that carries its own time stamps
(joint datagrams, RTDE), the offset that maps them onto the host's clock (the smallest
``arrival - stamp`` seen: network and scheduling delays only ever add to it) and the mean delay
above it (the latency).

The devices: :class:`fts_calib.sources.serial_line.SerialChannels` (``serial://``) and
:class:`fts_calib.sources.netft.NetFtChannels` (``netft://``).
"""

from __future__ import annotations

import collections
import math
import threading
from collections import Counter
from typing import Any

from ..core.exceptions import DeviceLost, FeedTimeout


class StreamClock:
    """Arrival statistics of one stream on the host's monotonic clock (see the module docstring).

    Args:
        name: The stream in words (``channels``, ``joints``).
        source: Where it comes from (``serial:///dev/ttyUSB0``), for the summary.
    """

    def __init__(self, name: str, source: str = ""):
        self.name, self.source = name, source
        self.samples = 0
        self.first_s = self.last_s = math.nan
        self._n_intervals = 0
        self._mean_interval = 0.0
        self._m2 = 0.0  # Welford's sum of squared deviations of the intervals [s²]
        self.offset_s = math.inf  # host time - sender time, the smallest seen [s]
        self._stamped = 0
        self._delay_sum = 0.0  # sum of arrival - stamp over the stamped samples [s]

    def arrive(self, arrival_s: float, stamp_s: float | None = None) -> float:
        """Count one sample that arrived at ``arrival_s`` (host monotonic [s]); its time on the host's clock [s].

        Args:
            arrival_s: When it arrived, ``time.monotonic()`` [s].
            stamp_s: Its own time stamp on the sender's clock [s], or None (then the arrival is its time).

        Returns:
            ``arrival_s`` for an unstamped sample; ``stamp_s + offset_s`` for a stamped one (the
            offset so far: the first samples of a stream may be placed a little late).
        """
        if self.samples:
            interval = arrival_s - self.last_s
            self._n_intervals += 1
            delta = interval - self._mean_interval
            self._mean_interval += delta / self._n_intervals
            self._m2 += delta * (interval - self._mean_interval)
        else:
            self.first_s = arrival_s
        self.samples += 1
        self.last_s = arrival_s
        if stamp_s is None:
            return arrival_s
        self.offset_s = min(self.offset_s, arrival_s - stamp_s)
        self._stamped += 1
        self._delay_sum += arrival_s - stamp_s
        return stamp_s + self.offset_s

    @property
    def rate_hz(self) -> float | None:
        """Samples per second of arrival [Hz], or None before two."""
        span = self.last_s - self.first_s
        return (self.samples - 1) / span if self.samples > 1 and span > 0 else None

    @property
    def jitter_s(self) -> float | None:
        """Standard deviation of the arrival intervals [s], or None before three samples."""
        return math.sqrt(self._m2 / (self._n_intervals - 1)) if self._n_intervals > 1 else None

    @property
    def latency_s(self) -> float | None:
        """Mean delay of the stamped samples above the fastest one [s] (arrival - stamp - offset); None unstamped."""
        if not self._stamped:
            return None
        return self._delay_sum / self._stamped - self.offset_s

    def summary(self) -> dict[str, Any]:
        """The figures, for the YAML beside a recording: samples, rate [Hz], jitter [s], latency [s], offset [s]."""

        def rounded(value: float | None, digits: int = 9) -> float | None:
            return None if value is None or not math.isfinite(value) else round(float(value), digits)

        return {
            "source": self.source,
            "samples": self.samples,
            "rate_hz": rounded(self.rate_hz, 4),
            "interval_jitter_s": rounded(self.jitter_s),
            "latency_s": rounded(self.latency_s),
            "clock_offset_s": rounded(self.offset_s) if self._stamped else None,
            "first_arrival_s": rounded(self.first_s, 6),
            "last_arrival_s": rounded(self.last_s, 6),
        }


class ChannelDevice:
    """A source of raw channel samples read by a background thread and stamped on arrival (see the module docstring).

    Subclasses implement :meth:`_open` (connect, in the reading thread's caller) and
    :meth:`_read` (one blocking read of at most a fraction of a second, which calls
    :meth:`_add` with the samples it read and :meth:`_skip` for what it drops); an exception out of
    :meth:`_read` ends the reading and becomes :attr:`error`.

    Args:
        description: The device in words (its URL), for messages.
        n_channels: The values a sample must have; None takes the first sample's.

    Attributes:
        clock: The arrival statistics (:class:`StreamClock`).
        skipped: What was dropped, by reason.
        error: Why the reading stopped (a :class:`DeviceLost` or a
            :class:`~fts_calib.core.exceptions.FeedTimeout`), None while it runs.
    """

    def __init__(self, description: str, n_channels: int | None = None):
        self.description = description
        self.n_channels = n_channels
        self.clock = StreamClock("channels", description)
        self.skipped: Counter[str] = Counter()
        self._notes: list[str] = []
        self.error: BaseException | None = None
        self._last_s = -math.inf  # the time of the last sample [s]
        self._pending: collections.deque[tuple[float, list[float]]] = collections.deque()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    @property
    def samples(self) -> int:
        """Samples read so far."""
        return self.clock.samples

    def notes(self) -> list[str]:
        """The first problems, in words (each kind once), and why the reading stopped."""
        return self._notes + ([] if self.error is None else [str(self.error)])

    def _note(self, text: str) -> None:
        if len(self._notes) < 10:
            self._notes.append(text)

    def _skip(self, reason: str, detail: str = "") -> None:
        """Count one dropped sample or line; the first of each reason is noted with its ``detail``."""
        if not self.skipped[reason] and detail:
            self._note(f"{self.description}: the first {reason}: {detail}")
        self.skipped[reason] += 1

    def _add(self, arrival_s: float, samples: list[list[float]]) -> None:
        """Samples that arrived together at ``arrival_s`` (host monotonic [s]); those of another length than the first are skipped.

        Samples that arrive together (lines in one read) are spread evenly between the previous
        sample's time and ``arrival_s``, the last at ``arrival_s``: times strictly increase, and
        a steady stream read in bursts keeps its rate.
        """
        kept = []
        for values in samples:
            if self.n_channels is None:
                self.n_channels = len(values)
            if len(values) != self.n_channels:
                self._skip(f"sample of another channel count (expected {self.n_channels})", f"{len(values)} values")
            else:
                kept.append(values)
        if not kept:
            return
        previous = self._last_s if math.isfinite(self._last_s) else arrival_s
        step = max(arrival_s - previous, 0.0) / len(kept)
        with self._lock:
            for k, values in enumerate(kept):
                t = max(arrival_s - (len(kept) - 1 - k) * step, self._last_s + 1e-9)
                self._last_s = t
                self._pending.append((self.clock.arrive(t), values))

    def drain(self) -> list[tuple[float, list[float]]]:
        """The (host time [s], values) read since the last call, in arrival order."""
        with self._lock:
            out, self._pending = list(self._pending), collections.deque()
        return out

    def start(self) -> None:
        """Open the device and read it in a background thread until :meth:`stop` or an error.

        Raises:
            The device's errors of opening (not installed, not found, no answer), naming it.
        """
        self._open()
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name=f"fts-calib-{type(self).__name__}", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            while not self._stop.is_set():
                self._read()
        except BaseException as exc:  # noqa: BLE001 (handed to the live loop, which ends the run with what came)
            kept = isinstance(exc, (DeviceLost, FeedTimeout))
            self.error = exc if kept else DeviceLost(f"{self.description}: the device stopped ({exc}): the run ends with what it has")
        finally:
            self._close()

    def stop(self) -> None:
        """End the reading (waits for the thread) and release the device."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        else:
            self._close()

    # -- what a device implements ---------------------------------------------------------

    def _open(self) -> None:
        raise NotImplementedError

    def _read(self) -> None:
        raise NotImplementedError

    def _close(self) -> None:
        raise NotImplementedError

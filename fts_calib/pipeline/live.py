"""The ``live`` job: calibrate from live UDP feeds (joints and strains) until the run ends.

A background thread only reads datagrams (a 4 MiB socket buffer absorbs bursts); the main
thread decodes them (:mod:`fts_calib.feeds.protocol`), pairs the two streams
(:mod:`fts_calib.feeds.sync`) and feeds the session (:mod:`fts_calib.pipeline.session`) every 20 ms, and
prints a status line. The run ends on an ``end`` message, Ctrl-C, SIGTERM, SIGHUP (the
terminal closed) or an optional idle timeout; then the calibration is written. Datagrams
lost on the way are counted from the protocol's optional ``seq`` numbers, per sender, and
shown in the status line and the summary. The session checkpoints every few seconds,
so ``--resume`` after a crash loses at most that interval. The socket binds to 127.0.0.1
unless told otherwise.
"""

from __future__ import annotations

import collections
import signal
import threading
import time
from typing import TextIO

from ..core.exceptions import FeedTimeout, FtsCalibError
from ..feeds.rtde import RtdePoller
from ..feeds.sync import Synchronizer
from ..feeds.udp import LiveStats, UdpReceiver, feed_datagram
from .remaining import PlanProgress
from .session import CalibrationSession

_BATCH_S = 0.02  # how often paired samples go to the session [s]
#: Signals that end a run like Ctrl-C: checkpoint and calibration written (SIGHUP: the terminal closed).
_STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name))


class LiveRunner:
    """Runs a session on live feeds (see the module docstring).

    Args:
        session: The calibration session (fresh or resumed).
        receiver: The UDP receiver.
        sync: The synchronizer of the two streams, made with the session tool's
            ``configurations`` (so that its indices are the tool's).
        status: Where to print the status line (None: no status).
        status_interval_s: Time between status lines [s].
        rtde: A UR controller's RTDE poller (:mod:`fts_calib.feeds.rtde`) that gives the joints
            (and the built-in sensor's wrench); the datagrams then add what it does not give.
        plan: What the sized plan expects (:mod:`fts_calib.pipeline.remaining`): the status
            line then shows the motion left and the configuration to mount next.
    """

    def __init__(
        self,
        session: CalibrationSession,
        receiver: UdpReceiver,
        sync: Synchronizer,
        status: TextIO | None = None,
        status_interval_s: float = 0.5,
        rtde: RtdePoller | None = None,
        plan: PlanProgress | None = None,
    ):
        if sync.configurations != session.tool.names:
            raise FtsCalibError(
                f"the synchronizer indexes configurations {sync.configurations}, the session's tool has {session.tool.names}: "
                "make it with Synchronizer(..., configurations=tool.names)"
            )
        self.session = session
        self.receiver = receiver
        self.sync = sync
        self.status = status
        self.status_interval_s = status_interval_s
        self.rtde = rtde
        self.plan = plan
        self.stats = LiveStats()
        self._stopping = False
        self._rates: collections.deque[tuple[float, int, int]] = collections.deque(maxlen=20)  # (wall time, joints, strain) for the rates
        self._shown = 0
        self._stream: tuple[float, float, int] | None = None  # (first time [s], last time [s], samples) the session was given

    def stop(self, *_args) -> None:
        """Ask the run to end (signal handler)."""
        self._stopping = True

    def _handle(self, data: bytes, sender: object = None) -> None:
        message = feed_datagram(data, None if self.rtde is not None else self.sync, self.stats, sender)
        if self.rtde is not None and message is not None:
            self.rtde.route(message, self.sync)

    def _drain_rtde(self) -> int:
        """The RTDE samples read since the last call, into the synchronizer (counted as joint and strain messages)."""
        if self.rtde is None:
            return 0
        count = self.rtde.drain(self.sync)
        self.stats.joints += count
        self.stats.strain += count if self.rtde.wrench else 0
        return count

    def _feed(self, final: bool = False) -> None:
        self._drain_rtde()
        batch = self.sync.pop(final)
        if len(batch.time):
            first, _, count = self._stream or (float(batch.time[0]), 0.0, 0)
            self._stream = (first, float(batch.time[-1]), count + len(batch.time))
            self.session.add_samples(batch)

    def stream_rate_hz(self) -> float | None:
        """The channel rate the stream shows on its own clock [Hz] (samples over time), or None before 1 s of it."""
        if self._stream is None or self._stream[1] - self._stream[0] < 1.0:
            return None
        first, last, count = self._stream
        return (count - 1) / (last - first)

    def status_line(self) -> str:
        """Rates, kept %, counts per configuration, rank and what is missing."""
        now = time.monotonic()
        self._rates.append((now, self.stats.joints, self.stats.strain))
        t0, j0, s0 = self._rates[0]
        span = max(now - t0, 1e-9)
        p = self.session.progress()
        per = " ".join(f"{k} {v}" for k, v in p.kept_by_configuration.items())
        bad = self.stats.malformed + self.stats.oversized
        text = (
            f"t {p.last_time if p.last_time is not None else 0.0:8.2f} s | joints {(self.stats.joints - j0) / span:6.0f} Hz "
            f"strain {(self.stats.strain - s0) / span:6.0f} Hz | kept {100 * p.kept_fraction:5.1f} % | {per} "
            f"| rank {p.rank} of {p.full_rank}"
        )
        if bad:
            text += f" | bad datagrams {bad}"
        if self.stats.gaps:
            text += f" | lost datagrams {self.stats.gaps}"
        if self.plan is not None:
            text += f" | {self.plan.at_rate(self.stream_rate_hz()).status(p)}"
        if p.missing:
            text += f" | missing: {p.missing}"
        return text

    def _show(self, line: str, end: str = "") -> None:
        if self.status is None:  # the callers only show a line when there is a status stream
            return
        line = line[:240]
        self.status.write("\r" + line.ljust(self._shown) + end)  # spaces clear a longer previous line
        self.status.flush()
        self._shown = 0 if end else len(line)

    def run(self, idle_timeout_s: float | None = None, duration_s: float | None = None) -> LiveStats:
        """Process messages until the run ends; return the counts.

        Args:
            idle_timeout_s: End after this long without any datagram [s]; None waits forever.
            duration_s: End after this long in any case [s]; None for no limit.
        """
        start, cpu0 = time.monotonic(), time.process_time()
        last_data = last_feed = last_status = start
        previous = {}
        if threading.current_thread() is threading.main_thread():
            previous = {sig: signal.signal(sig, self.stop) for sig in _STOP_SIGNALS}
        if self.rtde is not None:
            self.rtde.start()
        try:
            while not self._stopping and not self.stats.ended:
                datagrams = self.receiver.drain_from()
                now = time.monotonic()
                if self._drain_rtde():
                    last_data = now
                if self.rtde is not None and self.rtde.samples == 0 and now - start >= self.rtde.timeout_s:
                    self.rtde.error = FeedTimeout("the first sample of the UR controller (RTDE)", self.rtde.timeout_s)
                if self.rtde is not None and self.rtde.error is not None:
                    break  # the controller's connection is lost: what was read is kept
                if datagrams:
                    last_data = now
                    for data, sender in datagrams:
                        self._handle(data, sender)
                        if self.stats.ended:
                            break
                else:
                    time.sleep(0.002)
                if now - last_feed >= _BATCH_S:
                    self._feed()
                    last_feed = now
                if self.status is not None and now - last_status >= self.status_interval_s:
                    self._show(self.status_line())
                    last_status = now
                if idle_timeout_s is not None and now - last_data >= idle_timeout_s:
                    break
                if duration_s is not None and now - start >= duration_s:
                    break
        except KeyboardInterrupt:
            pass
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)
            if self.rtde is not None:
                self.rtde.stop()
        for data, sender in self.receiver.drain_from():  # whatever arrived with the end
            self._handle(data, sender)
        self._feed(final=True)
        self.session.flush()
        self.session.checkpoint()
        if self.status is not None:
            self._show(self.status_line(), end="\n")
        self.stats.wall_s = time.monotonic() - start
        self.stats.cpu_s = time.process_time() - cpu0
        return self.stats


def format_stats(stats: LiveStats, sync: Synchronizer) -> str:
    """Message counts and CPU use of a live run, one line each."""
    lines = [
        f"messages: {stats.received:,} datagrams ({stats.joints:,} joints, {stats.strain:,} strain, {stats.tool} tool), "
        f"{stats.malformed} malformed and {stats.oversized} oversized skipped, {_lost(stats)}"
        f"{f', {stats.duplicates:,} duplicates dropped (a seq number received twice)' if stats.duplicates else ''}; "
        f"{'ended by the sender' if stats.ended else 'stopped'} after {stats.wall_s:.1f} s, CPU {stats.cpu_s:.1f} s "
        f"({100 * stats.cpu_s / max(stats.wall_s, 1e-9):.0f} % of one core)"
    ]
    if stats.first_malformed is not None:
        lines.append(f"  the first skipped: {stats.first_malformed}")
    if sync.dropped:
        lines.append("strain samples not paired: " + ", ".join(f"{r}: {n:,}" for r, n in sync.dropped.items()))
    return "\n".join(lines)


def _lost(stats: LiveStats) -> str:
    """The datagrams lost on the way, in words: counted from ``seq``, or not measurable without it."""
    if not stats.seq.sequenced:
        return "losses not counted (no datagram with a seq number)"
    return f"{stats.gaps:,} lost on the way (gaps in seq)"

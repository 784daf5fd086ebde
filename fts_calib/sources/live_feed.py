"""The one live loop: UDP datagrams, and a UR controller's RTDE samples, as a source of synchronized batches.

:class:`LiveFeed` reads the live protocol (:mod:`fts_calib.sources.udp`: a background thread
receives, the loop decodes and counts) and, when given, a UR controller through RTDE
(:mod:`fts_calib.sources.ur`), hands both to the synchronizer
(:mod:`fts_calib.sources.synchronizer`) and yields what it can place, every
:data:`PLACE_S` [s], as :class:`~fts_calib.sources.batch.SampleBatch` es in time order: the
joints interpolated at the strain times, or the strains alone when no joints are expected
(``Synchronizer([])``: a re-tare with nothing mounted, the health monitor).

Every user of a live stream (``live``, ``tare``, ``payload --motion``, ``monitor``) iterates
it, and the stream ends here, once, for all of them (:class:`StreamEnd`):

- ``END``: the sender's ``end`` datagram;
- ``IDLE``: no datagram (and no RTDE sample) for ``idle_timeout_s``;
- ``DURATION``: ``duration_s`` of wall time since the stream started;
- ``STREAM``: the placed samples span ``stream_s`` on the sender's clock;
- ``INTERRUPTED``: Ctrl-C or a stop signal (SIGINT and SIGTERM by default): handlers are
  installed while the stream runs, in the main thread only, and the previous ones restored;
- ``RTDE_LOST``: the connection to the UR controller is lost, or its first sample does not
  come within the poller's ``timeout_s`` (its ``error`` then says which);
- ``DEVICE_LOST``: the channel device (a serial line, a Net F/T box:
  :mod:`fts_calib.sources.devices`) stopped: the cable pulled, the box silent (its ``error``
  says which; before any sample that error is raised).

With a channel device, or ``host_clock``, every stream is on the host's monotonic clock: the
device stamps its samples on arrival, and the datagrams' own stamps are mapped onto it
(:class:`~fts_calib.sources.devices.StreamClock`, per kind: joints and tool changes on the
joint sender's offset, strains on theirs); a strain datagram beside a device is counted and
ignored. :attr:`LiveFeed.clocks` holds each stream's rate, jitter and latency.

However it ends, what came is kept: the datagrams that arrived with the end are read, and the
samples still held are placed. Only a stream that heard nothing at all within
``first_timeout_s`` raises :class:`~fts_calib.core.exceptions.FeedTimeout`, naming the address
and what to check. Times in [s].
"""

from __future__ import annotations

import collections
import dataclasses
import math
import signal
import threading
import time
from collections import Counter
from collections.abc import Callable, Generator, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

from ..core import arrays as validation
from ..core.exceptions import FeedTimeout, FtsCalibError
from .batch import SampleBatch
from .devices import ChannelDevice, StreamClock
from .synchronizer import Synchronizer
from .udp import Joints, LiveStats, Message, Orientation, Strain, ToolChange, UdpReceiver, feed_datagram
from .ur import RtdePoller

#: How often the synchronizer places what it can [s].
PLACE_S = 0.02
#: Pause of the loop when nothing arrived [s] (the receiver's thread queues what arrives meanwhile).
_WAIT_S = 0.002
#: Signals that end a stream like Ctrl-C, by default.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
#: What to check when a feed sends nothing at all (the :class:`FeedTimeout` hint).
SILENT_HINT = (
    "check that the sender runs and sends to this host and port (its address, not 127.0.0.1, when it runs "
    "on another machine: then --listen this host's address), and that no firewall drops UDP"
)

#: Why a stream ended (:attr:`LiveFeed.ended_by`).
END = "the sender's end"
IDLE = "idle timeout"
DURATION = "duration"
STREAM = "stream time"
INTERRUPTED = "interrupted"
RTDE_LOST = "RTDE connection lost"
DEVICE_LOST = "channel device stopped"

#: Reasons of :attr:`LiveFeed.skipped` for datagrams, beside the synchronizer's for samples.
MALFORMED = "malformed datagram"
OVERSIZED = "oversized datagram"
DUPLICATE = "duplicate datagram (a seq number received twice)"


@dataclass(frozen=True)
class StreamEnd:
    """What ends a live stream besides the sender's ``end`` (see the module docstring); None: no limit.

    Attributes:
        idle_timeout_s: End after this long without a datagram or an RTDE sample [s].
        first_timeout_s: Raise FeedTimeout when nothing at all came within this long [s].
        duration_s: End after this much wall time [s].
        stream_s: End once the placed samples span this much of the sender's clock [s].
        signals: Signals that end the stream as Ctrl-C does (the main thread's handlers).
    """

    idle_timeout_s: float | None = None
    first_timeout_s: float | None = None
    duration_s: float | None = None
    stream_s: float | None = None
    signals: tuple[int, ...] = STOP_SIGNALS

    def __post_init__(self):
        for name in ("idle_timeout_s", "first_timeout_s", "duration_s", "stream_s"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, validation.non_negative(name, value, "s"))


@dataclass(frozen=True)
class FeedStatus:
    """A live stream's counts so far, for a status line.

    Attributes:
        received: Datagrams received.
        joints: Joint messages used (RTDE samples included).
        strain: Strain messages (the built-in sensor's RTDE wrenches included).
        tool: Tool messages.
        malformed: Malformed datagrams, counted and skipped.
        oversized: Oversized datagrams, counted and skipped.
        duplicates: Datagrams whose ``seq`` was already received, dropped.
        lost: Datagrams lost on the way (gaps in the senders' ``seq`` numbers).
        joints_hz: Joint messages per second of wall time, over the last 20 statuses [Hz].
        strain_hz: Strain messages per second of wall time, likewise [Hz].
        samples: Samples placed (joints paired with strains).
        stream_s: Time the placed samples span on the sender's clock [s].
        elapsed_s: Wall time since the stream started [s].
    """

    received: int
    joints: int
    strain: int
    tool: int
    malformed: int
    oversized: int
    duplicates: int
    lost: int
    joints_hz: float
    strain_hz: float
    samples: int
    stream_s: float
    elapsed_s: float = 0.0


class LiveFeed:
    """A live source of sample batches (see the module docstring); iterate it once.

    It owns the receiver and the poller: both are closed when the stream ends (or on
    :meth:`close`).

    Args:
        receiver: The UDP receiver, bound; None with ``rtde`` alone (the built-in sensor).
        sync: The synchronizer (its ``joint_names`` empty for the strain stream alone).
        rtde: A UR controller's RTDE poller that gives the joints (and the built-in sensor's
            wrench); the datagrams then add what it does not give.
        end: What ends the stream besides the sender's ``end``; none of the limits when None.
        on_status: Called with the counts (:class:`FeedStatus`) every ``status_interval_s``
            while the stream runs.
        status_interval_s: Time between two calls of ``on_status`` [s].
        on_listening: Called with the bound (host, port) when the stream starts.
        description: The source in words; ``udp://HOST:PORT`` of the receiver when None.
        device: The channel device (a serial line, a Net F/T box) that gives the strains;
            the datagrams then add the joints and tool changes, on the host's clock.
        host_clock: Put the datagrams on the host's monotonic clock even without a device
            (``record``: every stream stamped on arrival).

    Attributes:
        stats: The datagram counts (:class:`~fts_calib.sources.udp.LiveStats`).
        ended_by: Why the stream ended (:data:`END`, :data:`IDLE`, ...), None before.
        samples: Samples placed so far.
        clocks: Each stream's arrival statistics on the host's clock, by name (with a device
            or ``host_clock``; empty otherwise).
    """

    def __init__(
        self,
        receiver: UdpReceiver | None,
        sync: Synchronizer,
        rtde: RtdePoller | None = None,
        *,
        end: StreamEnd | None = None,
        on_status: Callable[[FeedStatus], None] | None = None,
        status_interval_s: float = 0.5,
        on_listening: Callable[[tuple[str, int]], None] | None = None,
        description: str | None = None,
        device: ChannelDevice | None = None,
        host_clock: bool = False,
    ):
        if receiver is None and rtde is None and device is None:
            raise FtsCalibError("a live feed reads a UDP receiver, a UR controller (RTDE) or a channel device: neither was given")
        self.receiver, self.sync, self.rtde, self.device = receiver, sync, rtde, device
        self.host_clock = host_clock or device is not None
        self.clocks: dict[str, StreamClock] = {}
        if self.host_clock:
            where = "" if receiver is None else f"udp://{receiver.address[0]}:{receiver.address[1]}"
            self.clocks = {"joints": StreamClock("joints", where), "channels": StreamClock("channels", where)}
            if device is not None:
                self.clocks["channels"] = device.clock
            if rtde is not None:
                self.clocks["joints"] = rtde.clock
        self.end = end or StreamEnd()
        self.on_status, self.status_interval_s, self.on_listening = on_status, float(status_interval_s), on_listening
        self.address: tuple[str, int] | None = None if receiver is None else (receiver.address[0], receiver.address[1])
        self._description = description
        self.stats = LiveStats()
        self.ended_by: str | None = None
        self.samples = 0
        self._first_s = self._last_s = math.nan  # the first and last placed times [s]
        self._signalled: int | None = None
        self._rates: collections.deque[tuple[float, int, int]] = collections.deque(maxlen=20)  # (wall time, joints, strain)
        self._running: Generator[SampleBatch, None, None] | None = None
        self._started: float | None = None  # time.monotonic() when the stream started

    # -- the source -----------------------------------------------------------------------

    @property
    def description(self) -> str:
        """The source in words: ``udp://HOST:PORT`` (the bound port), or as given."""
        if self._description is not None:
            return self._description
        return "RTDE" if self.address is None else f"udp://{self.address[0]}:{self.address[1]}"

    @property
    def tool_names(self) -> list[str]:
        """The tool configuration names, by index."""
        return list(self.sync.configurations)

    @property
    def skipped(self) -> Counter[str]:
        """Samples the synchronizer could not place and datagrams not used, by reason."""
        out = Counter(self.sync.dropped)
        for reason, count in ((MALFORMED, self.stats.malformed), (OVERSIZED, self.stats.oversized), (DUPLICATE, self.stats.duplicates)):
            if count:
                out[reason] += count
        if self.device is not None:
            out.update(self.device.skipped)
        return out

    def notes(self) -> list[str]:
        """Why the first malformed datagram was skipped, and the datagrams lost on the way, in words."""
        lines = [] if self.stats.first_malformed is None else [f"the first skipped: {self.stats.first_malformed}"]
        if self.stats.gaps:
            lines.append(f"{self.stats.gaps:,} datagrams lost on the way (gaps in seq)")
        return lines + ([] if self.device is None else self.device.notes())

    @property
    def stream_s(self) -> float:
        """Time the placed samples span on the sender's clock [s] (0 before two)."""
        return self._last_s - self._first_s if self.samples else 0.0

    def stream_rate_hz(self) -> float | None:
        """The channel rate the stream shows on its own clock [Hz] (samples over time), or None before 1 s of it."""
        if not self.samples or self.stream_s < 1.0:
            return None
        return (self.samples - 1) / self.stream_s

    def status(self) -> FeedStatus:
        """The counts so far; the rates over the last 20 calls (each call is one step of the rates' window)."""
        now, stats = time.monotonic(), self.stats
        self._rates.append((now, stats.joints, stats.strain))
        t0, j0, s0 = self._rates[0]
        span = max(now - t0, 1e-9)
        return FeedStatus(
            stats.received,
            stats.joints,
            stats.strain,
            stats.tool,
            stats.malformed,
            stats.oversized,
            stats.duplicates,
            stats.gaps,
            (stats.joints - j0) / span,
            (stats.strain - s0) / span,
            self.samples,
            self.stream_s,
            now - self._started if self._started is not None else 0.0,
        )

    def place(self, final: bool = False) -> SampleBatch:
        """The samples the synchronizer can place now (all it holds when ``final``), counted in :attr:`samples`."""
        self._drain_rtde()
        batch = self.sync.pop(final)
        if len(batch):
            if not self.samples:
                self._first_s = float(batch.time[0])
            self._last_s = float(batch.time[-1])
            self.samples += len(batch)
        return batch

    def __iter__(self) -> Iterator[SampleBatch]:
        if self._running is not None:
            raise FtsCalibError(f"the live stream of {self.description} was read already: a live stream is read once")
        self._running = self._stream()
        return self._running

    def close(self) -> None:
        """End the stream where it is (signal handlers restored), stop the poller, close the socket."""
        if self._running is not None:
            self._running.close()
        self._release()

    def _release(self) -> None:
        """Stop the RTDE poller and the channel device, close the socket (what it held stays readable)."""
        if self.rtde is not None:
            self.rtde.stop()
        if self.device is not None:
            self.device.stop()
        if self.receiver is not None:
            self.receiver.close()

    def __enter__(self) -> LiveFeed:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- the loop -------------------------------------------------------------------------

    def _stream(self) -> Generator[SampleBatch, None, None]:
        start, cpu0 = time.monotonic(), time.process_time()
        self._started = start
        last_data = last_place = last_status = start
        if self.device is not None:
            self.device.start()  # before the handlers: a device that cannot be opened is an error, nothing to keep
        previous = self._install_handlers()
        if self.rtde is not None:
            self.rtde.start()
        try:
            if self.on_listening is not None and self.address is not None:
                self.on_listening(self.address)
            while True:
                datagrams = self.receiver.drain_from() if self.receiver is not None else []
                now = time.monotonic()
                if self._drain_rtde() + self._drain_device():
                    last_data = now
                if datagrams:
                    last_data = now
                    for data, sender in datagrams:
                        self._handle(data, sender, now)
                        if self.stats.ended:
                            break
                else:
                    time.sleep(_WAIT_S)
                if now - last_place >= PLACE_S:
                    last_place = now
                    batch = self.place()
                    if len(batch):
                        yield batch
                if self.on_status is not None and now - last_status >= self.status_interval_s:
                    last_status = now
                    self.on_status(self.status())
                self.ended_by = self._why_end(now - start, now - last_data)
                if self.ended_by is not None:
                    break
        except KeyboardInterrupt:  # raised in a callback (or before the handlers were in place): what came is kept
            self.ended_by = INTERRUPTED
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)
            self._release()
        arrival = time.monotonic()
        for data, sender in self.receiver.drain_from() if self.receiver is not None else ():  # whatever arrived with the end
            self._handle(data, sender, arrival)
        self._drain_device()
        batch = self.place(final=True)
        self.stats.wall_s, self.stats.cpu_s = time.monotonic() - start, time.process_time() - cpu0
        if len(batch):
            yield batch

    def _why_end(self, elapsed_s: float, idle_s: float) -> str | None:
        """Why the stream ends now, or None (see the module docstring).

        Raises:
            FeedTimeout: Nothing at all came within ``first_timeout_s``.
        """
        if self.stats.ended:
            return END
        if self._signalled is not None:
            return INTERRUPTED
        rtde, end = self.rtde, self.end
        if rtde is not None:
            if rtde.samples == 0 and rtde.error is None and elapsed_s >= rtde.timeout_s:
                at = f" at {rtde.where}" if rtde.where else ""
                rtde.error = FeedTimeout(f"the first sample of the UR controller{at} (RTDE)", rtde.timeout_s)
            if rtde.error is not None:
                return RTDE_LOST  # what was read is kept
        device = self.device
        if device is not None and device.error is not None:
            if not device.samples:
                raise device.error  # nothing to keep: the device's own error (a FeedTimeout naming the box, ...)
            return DEVICE_LOST  # what was read is kept
        silent = not self.stats.received and (rtde is None or not rtde.samples)
        if end.first_timeout_s is not None and silent and elapsed_s >= end.first_timeout_s:
            raise FeedTimeout(f"the first datagram on {self.description}", end.first_timeout_s, SILENT_HINT)
        if end.idle_timeout_s is not None and idle_s >= end.idle_timeout_s:
            return IDLE
        if end.duration_s is not None and elapsed_s >= end.duration_s:
            return DURATION
        if end.stream_s is not None and self.samples and self.stream_s >= end.stream_s:
            return STREAM
        return None

    def _install_handlers(self) -> dict[int, Any]:
        """Our handler for each stop signal (the main thread only: Python runs handlers there); the previous ones."""
        if threading.current_thread() is not threading.main_thread():
            return {}
        return {sig: signal.signal(sig, self._stop) for sig in self.end.signals}

    def _stop(self, signum: int, _frame) -> None:
        """Signal handler: end the stream at the next step of the loop."""
        self._signalled = signum

    def _handle(self, data: bytes, sender: object = None, arrival_s: float = math.nan) -> None:
        if self.host_clock:  # every stream on the host's clock (see the module docstring)
            feed_datagram(data, self.sync, self.stats, sender, lambda message: self._on_host_clock(message, arrival_s))
            return
        message = feed_datagram(data, None if self.rtde is not None else self.sync, self.stats, sender)
        if self.rtde is not None and message is not None:
            self.rtde.route(message, self.sync)

    def _on_host_clock(self, message: Message, arrival_s: float) -> Message | None:
        """A datagram's message with its time on the host's clock, or None for a stream another source gives."""
        if isinstance(message, Strain):
            if self.device is not None or (self.rtde is not None and self.rtde.wrench):
                return None  # the device's, or RTDE's
            return dataclasses.replace(message, t=self.clocks["channels"].arrive(arrival_s, message.t))
        if isinstance(message, Joints | Orientation):
            if self.rtde is not None:
                return None  # RTDE's
            return dataclasses.replace(message, t=self.clocks["joints"].arrive(arrival_s, message.t))
        if isinstance(message, ToolChange):  # on the joint sender's clock (the one that knows the tool), or now
            offset = self.clocks["joints"].offset_s
            known = math.isfinite(offset) and self.rtde is None
            return dataclasses.replace(message, t=message.t + offset if known else arrival_s)
        return message

    def _drain_device(self) -> int:
        """The channel device's samples read since the last call, into the synchronizer (counted as strain messages)."""
        if self.device is None:
            return 0
        samples = self.device.drain()
        for t, values in samples:
            self.sync.add_strain(t, values)
        self.stats.strain += len(samples)
        return len(samples)

    def _drain_rtde(self) -> int:
        """The RTDE samples read since the last call, into the synchronizer (counted as joint and strain messages)."""
        if self.rtde is None:
            return 0
        count = self.rtde.drain(self.sync)
        self.stats.joints += count
        self.stats.strain += count if self.rtde.wrench else 0
        return count


def stop_signals(names: Sequence[str]) -> tuple[int, ...]:
    """The signals of these names that this system has (``SIGHUP`` is not on Windows)."""
    return tuple(getattr(signal, name) for name in names if hasattr(signal, name))

"""UR arms through RTDE (``ur_rtde``): joint readings and the built-in sensor's wrench, into the synchronizer.

:class:`RtdePoller` reads an ``rtde_receive.RTDEReceiveInterface`` (or any object with the
same three methods) in a background thread, faster than the controller publishes (500 Hz
on e-Series, 125 Hz on CB3), and keeps each controller sample once (by its timestamp):

- ``getTimestamp()``: controller time, in [s] since the controller started;
- ``getActualQ()``: the six joint readings, in [rad], in the robot's joint order;
- ``getFtRawWrench()``: the built-in sensor's raw wrench ``[Fx, Fy, Fz, Tx, Ty, Tz]`` in
  [N, N·m] (e-Series), the channels of the ``wrench-6`` layout, when ``wrench`` is set.

:meth:`RtdePoller.drain` hands the samples to the live path's synchronizer
(:mod:`fts_calib.sources.synchronizer`) as joint and strain messages. With the built-in sensor both
streams carry the controller's clock. With an external sensor whose strains keep coming
over UDP, the joints are put on the receiving host's clock (``time.time()``, s), the one the
strain sender must stamp with: ``t_host = t_controller + offset``, the offset being the
smallest ``time.time() - t_controller`` seen so far (network and scheduling delays only
ever add to it); a constant delay left over is the joint stream's ``latency_s``.

``ur_rtde`` is an optional extra (``pip install 'fts-calib[ur]'``), imported only by
:func:`connect_ur`.

Every wait on the controller has a watchdog (``timeout_s``, ``--ur-timeout``, 5 s by
default): :func:`connect_ur` first asks the controller for RTDE's protocol version over a
plain socket (:func:`probe_rtde`), so that a host that accepts the connection and then says
nothing is named in one line instead of hanging ``ur_rtde``'s constructor, which does not
return to Python (Ctrl-C included) until it is answered; the constructor then runs in a
daemon thread that the caller waits for in short, interruptible steps.

A connection the controller drops raises nothing in ``ur_rtde``: it prints "End of file" on
standard error, keeps answering ``getTimestamp()`` with the last sample's time and turns
``isConnected()`` false. So :class:`RtdePoller` asks ``isConnected()`` after :data:`CHECK_S`
without a new sample, and stops with a ``ConnectionError`` naming the controller's address: the
live loop then ends like Ctrl-C, with what was read.
"""

from __future__ import annotations

import collections
import math
import socket
import struct
import threading
import time
from collections.abc import Callable, Sequence
from typing import Protocol

from ..core.exceptions import ConfigError, FeedTimeout
from .devices import StreamClock
from .synchronizer import Synchronizer
from .udp import Joints, Message, Strain, ToolChange

#: Pause between two reads of the receiver [s]: four reads per 500 Hz controller cycle.
POLL_S = 0.0005
#: Samples kept between two drains, at most (20 s at 500 Hz): older ones are dropped and counted.
MAX_PENDING = 10_000
#: The TCP port of a UR controller's RTDE interface.
RTDE_PORT = 30004
#: How long each wait on the controller lasts at most, by default [s] (``--ur-timeout``).
TIMEOUT_S = 5.0
#: How long without a new sample before the receiver's connection is checked (``isConnected()``) [s].
CHECK_S = 0.1
#: RTDE's request for the protocol version (package type 'V'), and the version asked for.
_RTDE_VERSION_REQUEST, _RTDE_PROTOCOL = 86, 2


class RtdeReceive(Protocol):
    """What :class:`RtdePoller` reads: the methods of ``rtde_receive.RTDEReceiveInterface`` it uses."""

    def getTimestamp(self) -> float:  # noqa: D102, N802 (ur_rtde's names)
        ...

    def getActualQ(self) -> Sequence[float]:  # noqa: D102, N802
        ...

    def getFtRawWrench(self) -> Sequence[float]:  # noqa: D102, N802
        ...


def connection_lost(receiver: object) -> bool:
    """True when ``receiver`` says its connection is down (``ur_rtde``'s ``isConnected()`` false); False without that method.

    When the controller drops the connection, ``ur_rtde`` prints "End of file" on standard error
    and keeps answering ``getTimestamp()`` with the last sample's time: only ``isConnected()`` tells.
    """
    is_connected = getattr(receiver, "isConnected", None)
    return callable(is_connected) and not is_connected()


def probe_rtde(host: str, port: int = RTDE_PORT, timeout_s: float = TIMEOUT_S) -> None:
    """Check that an RTDE server answers at ``host:port``: connect, ask its protocol version, read the answer.

    A plain socket with a deadline on every step, so that a host that accepts the connection
    and sends nothing is a clear error, not a hang; Ctrl-C works throughout.

    Args:
        host: The controller's address.
        port: RTDE's port (30004 on every UR controller).
        timeout_s: The longest wait of each step (connect, answer) [s].

    Raises:
        FeedTimeout: No connection, or no answer, within ``timeout_s``.
        ConnectionError: The connection is refused or closed, or the answer is not RTDE's.
    """
    where = f"the UR controller at {host}:{port} (RTDE)"
    answer = b""
    try:
        with socket.create_connection((host, port), timeout=timeout_s) as sock:
            sock.sendall(struct.pack(">HBH", 5, _RTDE_VERSION_REQUEST, _RTDE_PROTOCOL))
            while len(answer) < 4 and (part := sock.recv(4 - len(answer))):
                answer += part
    except TimeoutError:
        hint = "is HOST the robot's controller, with RTDE enabled? (--ur-timeout sets the wait)"
        raise FeedTimeout(f"{where} to answer RTDE's protocol request", timeout_s, hint) from None
    except OSError as exc:  # refused, reset, no route: the OS's words, with the host, the port and RTDE
        reason = exc.strerror or str(exc) or type(exc).__name__
        raise ConnectionError(f"cannot connect to {where}: {reason}; is {host} the robot's controller, with RTDE enabled?") from None
    if len(answer) < 4:
        raise ConnectionError(f"{where} closed the connection without answering RTDE's protocol request")
    if answer[2] != _RTDE_VERSION_REQUEST:
        raise ConnectionError(f"{where} answered, but not as an RTDE server (package type {answer[2]}): is HOST a UR controller?")


def connect_ur(host: str, timeout_s: float = TIMEOUT_S) -> RtdeReceive:
    """An ``rtde_receive.RTDEReceiveInterface`` connected to the UR controller at ``host``, within ``timeout_s``.

    Args:
        host: The controller's address.
        timeout_s: The longest wait of each step (the handshake, then the connection of
            ``ur_rtde``) [s].

    Raises:
        ConfigError: ``ur_rtde`` is not installed (the message says how to install it).
        FeedTimeout: The controller does not answer within ``timeout_s``.
        ConnectionError: The controller refuses the connection at ``host``.
    """
    try:
        import rtde_receive  # type: ignore[import-not-found]
    except ImportError:
        message = "--ur reads the arm through ur_rtde, which is not installed: pip install 'fts-calib[ur]'"
        raise ConfigError("ur", host, "", message=message) from None
    if not (math.isfinite(timeout_s) and timeout_s > 0):
        raise ConfigError("ur_timeout_s", timeout_s, "a finite number of seconds > 0", "s")
    probe_rtde(host, RTDE_PORT, timeout_s)
    result: dict[str, object] = {}

    def build() -> None:
        try:
            result["receiver"] = rtde_receive.RTDEReceiveInterface(host)
        except Exception as exc:  # noqa: BLE001 (handed to the waiting thread, which names it)
            result["error"] = exc

    thread = threading.Thread(target=build, name="ur-rtde-connect", daemon=True)  # a daemon: never keeps the process alive
    thread.start()
    deadline = time.monotonic() + timeout_s
    while thread.is_alive() and time.monotonic() < deadline:
        thread.join(0.05)  # short steps: Ctrl-C is seen between them
    if thread.is_alive():
        raise FeedTimeout(f"ur_rtde to connect to the UR controller at {host} (it answered RTDE's protocol request)", timeout_s)
    error = result.get("error")
    if isinstance(error, RuntimeError):
        raise ConnectionError(f"cannot connect to the UR controller at {host} (RTDE, port {RTDE_PORT}): {error}") from None
    if isinstance(error, BaseException):
        raise error
    return result["receiver"]  # type: ignore[return-value]


class RtdePoller:
    """Poll a UR controller's RTDE data into the synchronizer (see the module docstring).

    Args:
        receiver: The RTDE receive interface (or an object with the same methods).
        joint_names: The robot's joints, in the order of ``getActualQ()`` (UR's: base to wrist 3).
        wrench: Also read ``getFtRawWrench()`` as the channels (the built-in sensor).
        host_clock: Put the joint stamps on this clock instead of the controller's (an
            external sensor's strains, stamped with it, come over UDP); None keeps the
            controller's clock.
        poll_s: Pause between two reads [s].
        timeout_s: The longest wait for the first sample after :meth:`start` [s] (the live
            runner's watchdog: a controller that connects and never publishes).
        where: The controller's ``HOST:PORT``, named when the connection is lost ("": not named).

    Attributes:
        samples: Controller samples read (each once).
        dropped: Samples dropped because nobody drained them in time.
        offset_s: ``host_clock() - controller time`` in use [s] (0 on the controller's clock).
        latest_s: Time of the latest sample drained, on the synchronizer's clock [s].
        ignored: Datagrams that RTDE makes redundant (joints; strains with the built-in sensor), ignored.
        error: Why polling stopped (the receiver raised, or its connection is down: a
            ``ConnectionError`` naming ``where``), or None.
    """

    def __init__(
        self,
        receiver: RtdeReceive,
        joint_names: Sequence[str],
        wrench: bool,
        host_clock: Callable[[], float] | None = None,
        poll_s: float = POLL_S,
        timeout_s: float = TIMEOUT_S,
        where: str = "",
    ):
        if len(joint_names) != 6:
            raise ConfigError(
                "robot", len(joint_names), "6 joints (a UR arm)", message=f"--ur reads six joints, the robot has {list(joint_names)}"
            )
        self.receiver = receiver
        self.joint_names = list(joint_names)
        self.wrench = wrench
        self.host_clock = host_clock
        self.poll_s = float(poll_s)
        self.timeout_s = float(timeout_s)
        self.where = where
        self.samples = 0
        self.dropped = 0
        self.offset_s = math.inf if host_clock is not None else 0.0
        self.clock = StreamClock("joints", "RTDE")  # arrivals on host_clock (the controller's time when None)
        self._last = -math.inf
        self.latest_s = -math.inf
        self.ignored = 0
        self.malformed = 0  # samples whose joints are not one per robot joint: counted, never paired
        self.error: Exception | None = None
        self._pending: collections.deque[tuple[float, list[float], list[float] | None]] = collections.deque()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def poll(self) -> bool:
        """Read the receiver once; True when it holds a sample not read before."""
        t = float(self.receiver.getTimestamp())
        if t <= self._last:
            return False
        q = [float(v) for v in self.receiver.getActualQ()]
        w = [float(v) for v in self.receiver.getFtRawWrench()] if self.wrench else None
        if self.host_clock is not None:
            self.clock.arrive(self.host_clock(), t)
            self.offset_s = self.clock.offset_s
        else:
            self.clock.arrive(t)
        self._last = t
        with self._lock:
            self.samples += 1
            if len(self._pending) >= MAX_PENDING:
                self._pending.popleft()
                self.dropped += 1
            self._pending.append((t, q, w))
        return True

    def drain(self, sync: Synchronizer) -> int:
        """Give the samples read since the last drain to ``sync`` (joints, and the wrench as strains); returns how many."""
        with self._lock:
            pending, self._pending = self._pending, collections.deque()
            offset = self.offset_s
        for t, q, w in pending:
            if len(q) != len(self.joint_names):  # a controller that is not a six-joint arm sends nothing usable
                self.malformed += 1
                continue
            self.latest_s = t + offset
            sync.add_joints(t + offset, dict(zip(self.joint_names, q, strict=True)))
            if w is not None:
                sync.add_strain(t + offset, w)
        return len(pending)

    def route(self, message: Message, sync: Synchronizer) -> None:
        """A live-protocol message received beside RTDE: what of it still counts.

        Joint messages are ignored (RTDE gives the joints), and so are strain messages with the
        built-in sensor (RTDE gives the wrench); a tool message takes effect at its own time, or,
        with the built-in sensor (whose samples carry the controller's clock, which no sender
        has), at the latest RTDE sample.
        """
        if isinstance(message, Joints) or (isinstance(message, Strain) and self.wrench):
            self.ignored += 1
        elif isinstance(message, Strain):
            sync.add_strain(message.t, message.strain, message.temperature)
        elif isinstance(message, ToolChange):
            sync.add_tool(self.latest_s if self.wrench else message.t, message.name)

    def start(self) -> None:
        """Poll in a background thread until :meth:`stop`."""
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="rtde-poller", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        checked = time.monotonic()
        while not self._stop.is_set():
            try:
                fresh = self.poll()
            except (RuntimeError, OSError) as exc:  # the connection to the controller is lost
                self.error = exc
                return
            now = time.monotonic()
            if fresh:
                checked = now
            elif now - checked >= CHECK_S:  # no new sample for a while: is the connection still up?
                checked = now
                if connection_lost(self.receiver):
                    last = f"; the last sample at controller time {self._last:.3f} s" if self.samples else ""
                    at = f" at {self.where}" if self.where else ""
                    self.error = ConnectionError(f"the UR controller{at} closed the RTDE connection{last}")
                    return
            if not fresh:
                time.sleep(self.poll_s)

    def stop(self) -> None:
        """End the background thread (waits for it)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=1.0)
            self._thread = None

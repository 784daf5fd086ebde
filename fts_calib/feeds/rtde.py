"""UR arms through RTDE (``ur_rtde``): joint readings and the built-in sensor's wrench, into the synchronizer.

:class:`RtdePoller` reads an ``rtde_receive.RTDEReceiveInterface`` (or any object with the
same three methods) in a background thread, faster than the controller publishes (500 Hz
on e-Series, 125 Hz on CB3), and keeps each controller sample once (by its timestamp):

- ``getTimestamp()``: controller time, in [s] since the controller started;
- ``getActualQ()``: the six joint readings, in [rad], in the robot's joint order;
- ``getFtRawWrench()``: the built-in sensor's raw wrench ``[Fx, Fy, Fz, Tx, Ty, Tz]`` in
  [N, N·m] (e-Series), the channels of the ``wrench-6`` layout, when ``wrench`` is set.

:meth:`RtdePoller.drain` hands the samples to the live path's synchronizer
(:mod:`fts_calib.feeds.sync`) as joint and strain messages. With the built-in sensor both
streams carry the controller's clock. With an external sensor whose strains keep coming
over UDP, the joints are put on the receiving host's clock (``time.time()``, s), the one the
strain sender must stamp with: ``t_host = t_controller + offset``, the offset being the
smallest ``time.time() - t_controller`` seen so far (network and scheduling delays only
ever add to it); a constant delay left over is the joint stream's ``latency_s``.

``ur_rtde`` is an optional extra (``pip install 'fts-calib[ur]'``), imported only by
:func:`connect_ur`.
"""

from __future__ import annotations

import collections
import math
import threading
import time
from collections.abc import Callable, Sequence
from typing import Protocol

from ..core.exceptions import ConfigError
from .protocol import Joints, Message, Strain, ToolChange
from .sync import Synchronizer

#: Pause between two reads of the receiver [s]: four reads per 500 Hz controller cycle.
POLL_S = 0.0005
#: Samples kept between two drains, at most (20 s at 500 Hz): older ones are dropped and counted.
MAX_PENDING = 10_000


class RtdeReceive(Protocol):
    """What :class:`RtdePoller` reads: the methods of ``rtde_receive.RTDEReceiveInterface`` it uses."""

    def getTimestamp(self) -> float:  # noqa: D102, N802 (ur_rtde's names)
        ...

    def getActualQ(self) -> Sequence[float]:  # noqa: D102, N802
        ...

    def getFtRawWrench(self) -> Sequence[float]:  # noqa: D102, N802
        ...


def connect_ur(host: str) -> RtdeReceive:
    """An ``rtde_receive.RTDEReceiveInterface`` connected to the UR controller at ``host``.

    Raises:
        ConfigError: ``ur_rtde`` is not installed (the message says how to install it).
        ConnectionError: The controller does not answer at ``host``.
    """
    try:
        import rtde_receive  # type: ignore[import-not-found]
    except ImportError:
        message = "--ur reads the arm through ur_rtde, which is not installed: pip install 'fts-calib[ur]'"
        raise ConfigError("ur", host, "", message=message) from None
    try:
        return rtde_receive.RTDEReceiveInterface(host)
    except RuntimeError as exc:
        raise ConnectionError(f"cannot connect to the UR controller at {host} (RTDE, port 30004): {exc}") from None


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

    Attributes:
        samples: Controller samples read (each once).
        dropped: Samples dropped because nobody drained them in time.
        offset_s: ``host_clock() - controller time`` in use [s] (0 on the controller's clock).
        latest_s: Time of the latest sample drained, on the synchronizer's clock [s].
        ignored: Datagrams that RTDE makes redundant (joints; strains with the built-in sensor), ignored.
        error: Why polling stopped (the receiver raised), or None.
    """

    def __init__(
        self,
        receiver: RtdeReceive,
        joint_names: Sequence[str],
        wrench: bool,
        host_clock: Callable[[], float] | None = None,
        poll_s: float = POLL_S,
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
        self.samples = 0
        self.dropped = 0
        self.offset_s = math.inf if host_clock is not None else 0.0
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
            self.offset_s = min(self.offset_s, self.host_clock() - t)
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
        while not self._stop.is_set():
            try:
                fresh = self.poll()
            except (RuntimeError, OSError) as exc:  # the connection to the controller is lost
                self.error = exc
                return
            if not fresh:
                time.sleep(self.poll_s)

    def stop(self) -> None:
        """End the background thread (waits for it)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=1.0)
            self._thread = None

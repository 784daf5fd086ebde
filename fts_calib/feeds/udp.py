"""The live protocol over UDP: a receiver thread, message counts, and one decode-and-dispatch.

Datagrams are JSON messages of the live protocol (:mod:`fts_calib.feeds.protocol`): joint
readings, strains, tool changes and the end of a run. :class:`UdpReceiver` reads them on a
background thread (a 4 MiB socket buffer absorbs bursts), with the address of their sender;
:func:`feed_datagram` decodes one, counts it in :class:`LiveStats` (the datagrams lost on
the way too, from the optional ``seq`` numbers of each sender: :class:`SeqGaps`) and hands
it to the synchronizer. The socket binds to 127.0.0.1 unless told otherwise; port 0 picks
a free port (see ``UdpReceiver.address``). Binding beyond loopback lets any host that
reaches this one feed the calibration, so it must be asked for (:func:`listen_host`): a
wildcard address (``0.0.0.0``, ``0``, ``::``) only with ``listen_any`` (``--listen-any``), and
any address other than loopback is warned about (:data:`EXPOSED`).
"""

from __future__ import annotations

import collections
import ipaddress
import socket
import threading
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..core.exceptions import ConfigError, FtsCalibWarning, ProtocolError
from .protocol import End, Joints, Message, Orientation, Strain, ToolChange, decode
from .sync import Synchronizer

_RECV_BUFFER = 1 << 22  # socket receive buffer [bytes]

#: Host texts that mean every interface.
WILDCARDS = ("0", "0.0.0.0", "*", "::", "[::]")
#: The warning of a socket bound beyond loopback ({address}: where it listens).
EXPOSED = (
    "listening on {address}, beyond loopback: any host that reaches this one can send datagrams into the calibration; "
    "bind 127.0.0.1 unless the sender runs on another machine"
)


def _is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:  # a host name: beyond loopback unless it is localhost
        return False


def listen_host(host: str, listen_any: bool = False, port: int | None = None) -> str:
    """The address to bind for ``host``: a wildcard only when asked for with ``listen_any``.

    Args:
        host: The host part of ``--listen`` (an address, a name, or a wildcard such as ``0``).
        listen_any: Bind every interface (``--listen-any``): a wildcard host, or a loopback
            one (the default), becomes 0.0.0.0; a network address stays as it is.
        port: The port, for the message.

    Returns:
        The address to bind.

    Raises:
        ConfigError: ``host`` is a wildcard and ``listen_any`` is not set (the message says
            how to listen on the network knowingly).
    """
    host = host.strip()
    shown = f"{host or '0'}:{port if port is not None else 'PORT'}"
    if host in WILDCARDS and not listen_any:
        number = port if port is not None else "PORT"
        message = (
            f"--listen {shown} would bind every network interface: any host that reaches this one could send datagrams "
            f"into the calibration. Listen on loopback (--listen 127.0.0.1:{number}, the default) when the sender runs here; "
            f"otherwise say so: this host's address on the sender's network (--listen 192.168.1.20:{number}), or every "
            "interface with --listen-any (live)"
        )
        raise ConfigError("listen", shown, "a loopback or network address, or --listen-any", message=message)
    if listen_any and (host in WILDCARDS or _is_loopback(host)):
        return "0.0.0.0"
    return host


class UdpReceiver:
    """Reads datagrams on a background thread into a queue.

    Args:
        host: Address to bind (127.0.0.1 by default: loopback only); a wildcard only with
            ``listen_any`` (see :func:`listen_host`). An address beyond loopback is warned
            about (:class:`FtsCalibWarning`).
        port: UDP port; 0 picks a free one (see :attr:`address`).
        listen_any: Bind every interface.

    Raises:
        ConfigError: A wildcard ``host`` without ``listen_any``.
    """

    def __init__(self, host: str = "127.0.0.1", port: int = 5005, listen_any: bool = False):
        host = listen_host(host, listen_any, port)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, _RECV_BUFFER)
        self.sock.bind((host, port))
        self.sock.settimeout(0.05)
        self.address = self.sock.getsockname()
        if not _is_loopback(host):
            warnings.warn(EXPOSED.format(address=f"udp://{self.address[0]}:{self.address[1]}"), FtsCalibWarning, stacklevel=2)
        self.queue: collections.deque[tuple[bytes, object]] = collections.deque()  # (datagram, sender address)
        self.received = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="fts-calib-udp", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                data, sender = self.sock.recvfrom(65536)
            except TimeoutError:
                continue
            except OSError:
                return
            self.queue.append((data, sender))
            self.received += 1

    def drain(self) -> list[bytes]:
        """Every datagram received since the last call, in arrival order."""
        return [data for data, _ in self.drain_from()]

    def drain_from(self) -> list[tuple[bytes, object]]:
        """Every (datagram, sender address) received since the last call, in arrival order."""
        out = []
        while self.queue:
            out.append(self.queue.popleft())
        return out

    def close(self) -> None:
        """Stop the thread and close the socket."""
        self._stop.set()
        self._thread.join(timeout=1.0)
        self.sock.close()


class SeqGaps:
    """Datagrams lost on the way, from the ``seq`` numbers of each sender.

    A number above the next one expected opens a gap of the numbers skipped; one of those
    arriving late (reordered) closes its place in the gap again. A number already received
    (below the next one expected and not in a gap) is a duplicate: :meth:`observe` says so,
    and the receiver drops it (a network or a sender that sends every datagram twice must not
    count each sample twice: the standard errors would be too small by sqrt 2). :attr:`missing` is the
    count of numbers not received so far, over every sender. A number far below the
    expected one (more than :attr:`window` back) is a sender that started again from 0: a
    new sequence, not a loss. Gaps older than ``window`` numbers stay counted as lost.

    Args:
        window: How many numbers back a late datagram may fill its gap, and how far back
            a number means a restarted sender.
    """

    def __init__(self, window: int = 4096):
        self.window = window
        self.missing = 0
        self.sequenced = 0
        self._next: dict[object, int] = {}
        self._open: dict[object, set[int]] = {}

    def observe(self, sender: object, seq: int) -> bool:
        """Count datagram number ``seq`` from ``sender`` (any hashable key, e.g. its address).

        Returns:
            False when the number was already received from that sender (a duplicate, not
            counted again), True otherwise.
        """
        expected = self._next.get(sender)
        if expected is None or seq < expected - self.window:  # a new sender, or one that started again
            self.sequenced += 1
            self._next[sender], self._open[sender] = seq + 1, set()
            return True
        holes = self._open[sender]
        if seq < expected and seq not in holes:
            return False
        self.sequenced += 1
        if seq >= expected:
            skipped = seq - expected
            self.missing += skipped
            if skipped:
                holes.update(range(max(expected, seq - self.window), seq))
            self._next[sender] = seq + 1
            if len(holes) > 2 * self.window:  # forget gaps too old to be filled: lost for good
                holes.difference_update([h for h in holes if h < seq - self.window])
        else:
            holes.discard(seq)
            self.missing -= 1
        return True


@dataclass
class LiveStats:
    """Message counts of a live run.

    Attributes:
        received: Datagrams received.
        joints: Joint messages used.
        strain: Strain messages.
        tool: Tool messages.
        malformed: Malformed datagrams (counted, skipped).
        first_malformed: Why the first malformed datagram was skipped (None before one), for
            the run's summary: a sender's mistake (``"temperature": "hot"``) is named once.
        oversized: Oversized datagrams (counted, skipped).
        duplicates: Datagrams whose ``seq`` number was already received from their sender
            (dropped: each sample counts once).
        ended: The run ended on an 'end' message.
        wall_s: Wall-clock time [s].
        cpu_s: CPU time of the process [s].
        seq: The ``seq`` numbers seen, per sender: ``seq.missing`` datagrams lost on the way
            (gaps), of the ``seq.sequenced`` that carried a number.
    """

    received: int = 0
    joints: int = 0
    strain: int = 0
    tool: int = 0
    malformed: int = 0
    first_malformed: str | None = None
    oversized: int = 0
    duplicates: int = 0
    ended: bool = False
    wall_s: float = 0.0
    cpu_s: float = 0.0
    seq: SeqGaps = field(default_factory=SeqGaps, repr=False)

    @property
    def gaps(self) -> int:
        """Datagrams lost on the way: the ``seq`` numbers missing so far, over every sender."""
        return self.seq.missing


def feed_datagram(data: bytes, sync: Synchronizer | None, stats: LiveStats, sender: object = None) -> Message | None:
    """Decode one datagram, count it and hand it to the synchronizer.

    Args:
        data: The datagram's bytes.
        sync: Where joint, strain and tool messages go; None to only decode and count.
        stats: Counts to update (received, per kind, malformed, oversized, ended, seq gaps).
        sender: Who sent it (its address), whose ``seq`` numbers it continues.

    Returns:
        The message, or None for a malformed, oversized or duplicated datagram (counted,
        skipped: never fatal).
    """
    stats.received += 1
    try:
        message = decode(data)
    except ProtocolError as exc:
        if exc.reason == "oversized":
            stats.oversized += 1
        else:
            stats.malformed += 1
            stats.first_malformed = stats.first_malformed or str(exc)
        return None
    if message.seq is not None and not stats.seq.observe(sender, message.seq):
        stats.duplicates += 1
        return None
    if isinstance(message, Strain):
        stats.strain += 1
        if sync is not None:
            sync.add_strain(message.t, message.strain, message.temperature)
    elif isinstance(message, Joints):
        if sync is None or sync.add_joints(message.t, message.q):
            stats.joints += 1
        else:
            stats.malformed += 1  # not exactly the robot's joints
            if stats.first_malformed is None:
                unknown = sorted(set(message.q) - set(sync.joint_names))
                missing = [name for name in sync.joint_names if name not in message.q]
                stats.first_malformed = (
                    f"malformed datagram: a joints message with unknown joints {unknown} and missing {missing} "
                    "(expected exactly the robot's)"
                )
    elif isinstance(message, Orientation):
        _feed_orientation(message, sync, stats)
    elif isinstance(message, ToolChange):
        stats.tool += 1
        if sync is not None:
            sync.add_tool(message.t, message.name)
    elif isinstance(message, End):
        stats.ended = True
    return message


def _feed_orientation(message: Orientation, sync: Synchronizer | None, stats: LiveStats) -> None:
    """An orientation datagram as the gimbal's joints (a run without a robot); malformed when a robot's joints are expected."""
    from ..robot.orientation import GIMBAL_JOINTS, gimbal_angles  # lazily: pinocchio is not for the parser of the command line

    if sync is None:
        stats.joints += 1
    elif tuple(sync.joint_names) == GIMBAL_JOINTS:
        angles = gimbal_angles(np.array(message.R).reshape(3, 3))[0]
        sync.add_joints(message.t, dict(zip(GIMBAL_JOINTS, angles.tolist(), strict=True)))
        stats.joints += 1
    else:
        stats.malformed += 1
        stats.first_malformed = stats.first_malformed or (
            f"malformed datagram: a joints message with the orientation '{message.field}' but the robot's joints "
            f"{list(sync.joint_names)} are expected (without --robot the feed may give the orientation)"
        )

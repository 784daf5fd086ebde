"""The live protocol over UDP: a receiver thread, message counts, and one decode-and-dispatch.

Datagrams are JSON messages of the live protocol (:mod:`fts_calib.feeds.protocol`): joint
readings, strains, tool changes and the end of a run. :class:`UdpReceiver` reads them on a
background thread (a 4 MiB socket buffer absorbs bursts); :func:`feed_datagram` decodes
one, counts it in :class:`LiveStats` and hands it to the synchronizer. The socket binds to
127.0.0.1 unless told otherwise; port 0 picks a free port (see ``UdpReceiver.address``).
"""

from __future__ import annotations

import collections
import socket
import threading
from dataclasses import dataclass

from ..core.exceptions import ProtocolError
from .protocol import End, Joints, Message, Strain, ToolChange, decode
from .sync import Synchronizer

_RECV_BUFFER = 1 << 22  # socket receive buffer [bytes]


class UdpReceiver:
    """Reads datagrams on a background thread into a queue.

    Args:
        host: Address to bind (127.0.0.1 by default: loopback only).
        port: UDP port; 0 picks a free one (see :attr:`address`).
    """

    def __init__(self, host: str = "127.0.0.1", port: int = 5005):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, _RECV_BUFFER)
        self.sock.bind((host, port))
        self.sock.settimeout(0.05)
        self.address = self.sock.getsockname()
        self.queue: collections.deque[bytes] = collections.deque()
        self.received = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="fts-calib-udp", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                data = self.sock.recv(65536)
            except TimeoutError:
                continue
            except OSError:
                return
            self.queue.append(data)
            self.received += 1

    def drain(self) -> list[bytes]:
        """Every datagram received since the last call, in arrival order."""
        out = []
        while self.queue:
            out.append(self.queue.popleft())
        return out

    def close(self) -> None:
        """Stop the thread and close the socket."""
        self._stop.set()
        self._thread.join(timeout=1.0)
        self.sock.close()


@dataclass
class LiveStats:
    """Message counts of a live run.

    Attributes:
        received: Datagrams received.
        joints: Joint messages used.
        strain: Strain messages.
        tool: Tool messages.
        malformed: Malformed datagrams (counted, skipped).
        oversized: Oversized datagrams (counted, skipped).
        ended: The run ended on an 'end' message.
        wall_s: Wall-clock time [s].
        cpu_s: CPU time of the process [s].
    """

    received: int = 0
    joints: int = 0
    strain: int = 0
    tool: int = 0
    malformed: int = 0
    oversized: int = 0
    ended: bool = False
    wall_s: float = 0.0
    cpu_s: float = 0.0


def feed_datagram(data: bytes, sync: Synchronizer | None, stats: LiveStats) -> Message | None:
    """Decode one datagram, count it and hand it to the synchronizer.

    Args:
        data: The datagram's bytes.
        sync: Where joint, strain and tool messages go; None to only decode and count.
        stats: Counts to update (received, per kind, malformed, oversized, ended).

    Returns:
        The message, or None for a malformed or oversized datagram (counted, skipped: never fatal).
    """
    stats.received += 1
    try:
        message = decode(data)
    except ProtocolError as exc:
        if exc.reason == "oversized":
            stats.oversized += 1
        else:
            stats.malformed += 1
        return None
    if isinstance(message, Strain):
        stats.strain += 1
        if sync is not None:
            sync.add_strain(message.t, message.strain)
    elif isinstance(message, Joints):
        if sync is None or sync.add_joints(message.t, message.q):
            stats.joints += 1
        else:
            stats.malformed += 1  # not exactly the robot's joints
    elif isinstance(message, ToolChange):
        stats.tool += 1
        if sync is not None:
            sync.add_tool(message.t, message.name)
    elif isinstance(message, End):
        stats.ended = True
    return message

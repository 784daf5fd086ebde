"""The live protocol: JSON datagrams over UDP (loopback by default).

::

    {"type": "joints", "t": 12.345, "q": {"shoulder_pan_joint": 0.1, ...}, "seq": 41}
    {"type": "joints", "t": 12.345, "R": [r11, r12, r13, r21, ..., r33]}   (or "R": [[r11, r12, r13], ...])
    {"type": "joints", "t": 12.345, "quat": [w, x, y, z]}
    {"type": "strain", "t": 12.346, "strain": [s1, ..., sn], "temperature": 31.2, "seq": 42}
    {"type": "tool",   "t": 12.0,   "name": "B", "seq": 43}
    {"type": "end", "seq": 44}

``t`` is the sender's clock in [s], one clock for both streams; joint readings in [rad];
instead of joint readings, a joints message may give the sensor's orientation (for a run
without a robot, :mod:`fts_calib.robot.orientation`): ``"R"``, the rotation matrix
``R_world_sensor`` row-major (9 numbers or 3 rows), or ``"quat"``, its unit quaternion
``[w, x, y, z]`` (with a mount rotation, the orientation of the frame the sensor is mounted on).
One farther than :data:`~fts_calib.robot.orientation.UNIT_TOLERANCE` from a rotation (a
quaternion of another norm, an R not orthonormal or a reflection), of the wrong length or
not finite, is malformed;
strains raw, one value per channel of the sensor (8 for the paper's, 6 for a factory
wrench; the synchronizer counts and skips a message of another length); ``temperature``
is optional, the sensor's temperature in [°C] (for the drift offset model). ``seq`` is
optional, in every message: an integer >= 0 that each sender increases by one per
datagram it sends (all types in one sequence), so that a receiver counts the datagrams
lost on the way (:class:`fts_calib.sources.udp.SeqGaps`); a datagram without it is valid.
A datagram larger than :data:`MAX_DATAGRAM` bytes, nested deeper than :data:`MAX_NESTING`,
with an integer of more than 20 digits, a number that is not finite (``NaN``, ``Infinity``,
``1e400``), or that is not such an object, raises :class:`ProtocolError`, which a receiver
counts and skips (:mod:`fts_calib.core.bounded` parses it).

The live protocol over UDP: a receiver thread, message counts, and one decode-and-dispatch.

Datagrams are JSON messages of the live protocol (:mod:`fts_calib.sources.udp`): joint
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
import json
import math
import socket
import threading
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..core.bounded import LimitError, loads_json
from ..core.exceptions import ConfigError, FtsCalibWarning, ProtocolError
from .recording import unlogged_joints_hint
from .synchronizer import Synchronizer

#: Largest datagram accepted, in bytes (a joints message of a 7-joint arm is ~250 bytes).
MAX_DATAGRAM = 8192
#: Deepest nesting of a datagram's JSON (the messages nest two levels: an object holding a list or an object).
MAX_NESTING = 4


@dataclass(frozen=True)
class Joints:
    """Joint readings at time ``t`` [s]: joint name -> [rad]; ``seq``: the sender's datagram number, or None."""

    t: float
    q: dict[str, float]
    seq: int | None = None


@dataclass(frozen=True)
class Orientation:
    """The sensor's orientation at time ``t`` [s]: ``R`` row-major (9 numbers), from the datagram's ``field`` ('R' or 'quat').

    ``seq``: the sender's datagram number, or None.
    """

    t: float
    R: tuple[float, ...]
    field: str = "R"
    seq: int | None = None


@dataclass(frozen=True)
class Strain:
    """Raw channels (n values) at time ``t`` [s]; ``seq``: the sender's datagram number, or None; ``temperature`` [°C] or None."""

    t: float
    strain: tuple[float, ...]
    seq: int | None = None
    temperature: float | None = None


@dataclass(frozen=True)
class ToolChange:
    """The tool configuration mounted from time ``t`` [s] on; ``seq``: the sender's datagram number, or None."""

    t: float
    name: str
    seq: int | None = None


@dataclass(frozen=True)
class End:
    """The end of the run; ``seq``: the sender's datagram number, or None."""

    seq: int | None = None


Message = Joints | Orientation | Strain | ToolChange | End

#: The fields of a joints message that give an orientation instead of joint readings.
ORIENTATION_FIELDS = ("R", "quat")


def _time(obj: dict) -> float:
    t = obj.get("t")
    if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t):
        raise ProtocolError("malformed", f"'t' must be a finite number of seconds, got {t!r}")
    return float(t)


def _seq(obj: dict) -> int | None:
    seq = obj.get("seq")
    if seq is None:
        return None
    if isinstance(seq, bool) or not isinstance(seq, int) or seq < 0:
        raise ProtocolError("malformed", f"'seq' must be an integer >= 0 (the sender's datagram number), got {seq!r}")
    return seq


def _orientation(obj: dict, seq: int | None) -> Orientation:
    given = [name for name in ORIENTATION_FIELDS if name in obj]
    if len(given) > 1:
        raise ProtocolError("malformed", "a joints message gives both 'R' and 'quat': give one orientation")
    field = given[0]
    value = obj[field]
    items = value if isinstance(value, list) else []
    if items and all(isinstance(row, list) for row in items):  # rows of a matrix
        items = [v for row in items for v in row]
    if not items or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in items):
        shape = "[w, x, y, z]" if field == "quat" else "9 numbers row-major, or 3 rows of 3"
        raise ProtocolError("malformed", f"'{field}' must be a list of numbers: {shape}")
    from ..robot.orientation import checked_rotation

    try:
        R = checked_rotation(value, field)
    except ValueError as exc:
        raise ProtocolError("malformed", str(exc)) from None
    return Orientation(_time(obj), tuple(R.ravel().tolist()), field, seq)


def _named(data: bytes, problem: str) -> str:
    """``problem`` with the field that holds a NaN or an infinity named (the datagram, at most MAX_DATAGRAM bytes, read again)."""
    found: list[str] = []

    def constant(name: str) -> float:
        found.append(name)
        return math.nan

    try:
        obj = json.loads(data, parse_constant=constant)
    except (UnicodeDecodeError, ValueError, RecursionError):
        return problem
    if not found or not isinstance(obj, dict):
        return problem
    fields = [key for key, value in obj.items() if not math.isfinite(sum(_numbers(value)))]
    named = ", ".join(repr(k) for k in fields)
    return f"{named} holds {found[0]}, not a number fts-calib accepts (expected finite numbers)" if fields else problem


def _numbers(value) -> list[float]:
    if isinstance(value, (list, dict)):
        return [v for item in (value.values() if isinstance(value, dict) else value) for v in _numbers(item)]
    return [value] if isinstance(value, float) else []


def decode(data: bytes) -> Message:
    """Parse one datagram.

    Raises:
        ProtocolError: Oversized, not JSON, or not one of the four messages.
    """
    if len(data) > MAX_DATAGRAM:
        raise ProtocolError("oversized", f"{len(data)} bytes, at most {MAX_DATAGRAM}")
    try:
        obj = loads_json(data, MAX_NESTING)
    except LimitError as exc:
        raise ProtocolError("malformed", _named(data, str(exc))) from None
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise ProtocolError("malformed", f"not JSON ({exc})") from None
    if not isinstance(obj, dict):
        raise ProtocolError("malformed", "expected a JSON object")
    kind = obj.get("type")
    seq = _seq(obj)
    if kind == "strain":
        values = obj.get("strain")
        if not isinstance(values, list) or not values or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
            raise ProtocolError("malformed", "'strain' must be a non-empty list of numbers, one per channel")
        heat = obj.get("temperature")
        if heat is not None and (isinstance(heat, bool) or not isinstance(heat, (int, float)) or not math.isfinite(heat)):
            raise ProtocolError("malformed", f"'temperature' must be a finite number of °C, got {heat!r}")
        strain = tuple(float(v) for v in values)
        if not math.isfinite(sum(strain)):  # 1e400 parses as inf; one sum tells any non-finite value
            raise ProtocolError("malformed", "'strain' holds a number that is not finite (or beyond the float range)")
        return Strain(_time(obj), strain, seq, None if heat is None else float(heat))
    if kind == "joints" and "q" not in obj and any(name in obj for name in ORIENTATION_FIELDS):
        return _orientation(obj, seq)
    if kind == "joints":
        q = obj.get("q")
        if (
            not isinstance(q, dict)
            or not q
            or not all(isinstance(k, str) and isinstance(v, (int, float)) and not isinstance(v, bool) for k, v in q.items())
        ):
            raise ProtocolError("malformed", "'q' must map joint names to numbers (or give the orientation: 'R' or 'quat')")
        joints = {k: float(v) for k, v in q.items()}
        if not math.isfinite(sum(joints.values())):
            raise ProtocolError("malformed", "'q' holds a joint reading that is not finite (or beyond the float range)")
        return Joints(_time(obj), joints, seq)
    if kind == "tool":
        name = obj.get("name")
        if not isinstance(name, str) or not name:
            raise ProtocolError("malformed", "'name' must be a configuration name")
        return ToolChange(_time(obj), name, seq)
    if kind == "end":
        return End(seq)
    raise ProtocolError("malformed", f"unknown type {kind!r}; expected joints, strain, tool or end")


def encode(message: Message) -> bytes:
    """The datagram of a message (compact JSON); ``seq`` only when the message has one."""
    obj: dict[str, object]
    if isinstance(message, Strain):
        obj = {"type": "strain", "t": message.t, "strain": list(message.strain)}
        if message.temperature is not None:
            obj["temperature"] = message.temperature
    elif isinstance(message, Joints):
        obj = {"type": "joints", "t": message.t, "q": message.q}
    elif isinstance(message, Orientation):
        obj = {"type": "joints", "t": message.t, "R": list(message.R)}
    elif isinstance(message, ToolChange):
        obj = {"type": "tool", "t": message.t, "name": message.name}
    else:
        obj = {"type": "end"}
    if message.seq is not None:
        obj["seq"] = message.seq
    return json.dumps(obj, separators=(",", ":")).encode("utf-8")


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
            f"udp://{shown} would bind every network interface: any host that reaches this one could send datagrams "
            f"into the calibration. Listen on loopback (udp://127.0.0.1:{number}) when the sender runs here; "
            f"otherwise say so: this host's address on the sender's network (udp://192.168.1.20:{number}), or every "
            "interface with --listen-any"
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
        try:
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, _RECV_BUFFER)
            self.sock.bind((host, port))
        except OSError:  # an address in use, or no such host: the socket is not left for the collector to close
            self.sock.close()
            raise
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


def feed_datagram(
    data: bytes,
    sync: Synchronizer | None,
    stats: LiveStats,
    sender: object = None,
    restamp: Callable[[Message], Message | None] | None = None,
) -> Message | None:
    """Decode one datagram, count it and hand it to the synchronizer.

    Args:
        data: The datagram's bytes.
        sync: Where joint, strain and tool messages go; None to only decode and count. One
            that expects no joints (``sync.strain_only``) counts the joint messages and takes the rest.
        stats: Counts to update (received, per kind, malformed, oversized, ended, seq gaps).
        sender: Who sent it (its address), whose ``seq`` numbers it continues.
        restamp: The message as the synchronizer takes it (its time put on another clock), or
            None for one counted but not taken (another source gives that stream); None: as it came.

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
    if restamp is not None and sync is not None and not isinstance(message, End):
        fed = restamp(message)
        if fed is None:  # counted, not taken
            _count(message, stats)
            return message
        _feed(fed, sync, stats)
        return message
    _feed(message, sync, stats)
    return message


def _count(message: Message, stats: LiveStats) -> None:
    """Count a message of the protocol that is not taken."""
    if isinstance(message, Strain):
        stats.strain += 1
    elif isinstance(message, Joints | Orientation):
        stats.joints += 1
    elif isinstance(message, ToolChange):
        stats.tool += 1


def _feed(message: Message, sync: Synchronizer | None, stats: LiveStats) -> None:
    """Count a decoded message and hand it to ``sync`` (None: count only)."""
    if isinstance(message, Strain):
        stats.strain += 1
        if sync is not None:
            sync.add_strain(message.t, message.strain, message.temperature)
    elif isinstance(message, Joints):
        if sync is None or sync.strain_only or sync.add_joints(message.t, message.q):  # counted; no joints expected
            stats.joints += 1
        else:
            stats.malformed += 1  # not exactly the robot's joints
            if stats.first_malformed is None:
                unknown = sorted(set(message.q) - set(sync.joint_names))
                missing = [name for name in sync.joint_names if name not in message.q]
                stats.first_malformed = (
                    f"malformed datagram: a joints message with unknown joints {unknown} and missing {missing} "
                    "(expected exactly the robot's)" + unlogged_joints_hint(missing)
                )
    elif isinstance(message, Orientation):
        _feed_orientation(message, sync, stats)
    elif isinstance(message, ToolChange):
        stats.tool += 1
        if sync is not None:
            sync.add_tool(message.t, message.name)
    elif isinstance(message, End):
        stats.ended = True


def _feed_orientation(message: Orientation, sync: Synchronizer | None, stats: LiveStats) -> None:
    """An orientation datagram as the gimbal's joints (a run without a robot); malformed when a robot's joints are expected."""
    from ..robot.orientation import GIMBAL_JOINTS, gimbal_angles

    if sync is None or sync.strain_only:
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

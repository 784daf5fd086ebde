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
lost on the way (:class:`fts_calib.feeds.udp.SeqGaps`); a datagram without it is valid.
A datagram larger than :data:`MAX_DATAGRAM` bytes, nested deeper than :data:`MAX_NESTING`,
with an integer of more than 20 digits, a number that is not finite (``NaN``, ``Infinity``,
``1e400``), or that is not such an object, raises :class:`ProtocolError`, which a receiver
counts and skips (:mod:`fts_calib.core.bounded` parses it).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

from ..core.bounded import LimitError, loads_json
from ..core.exceptions import ProtocolError

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
    from ..robot.orientation import checked_rotation  # lazily: pinocchio is not for the parser of the command line

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

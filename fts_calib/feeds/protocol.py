"""The live protocol: JSON datagrams over UDP (loopback by default).

::

    {"type": "joints", "t": 12.345, "q": {"shoulder_pan_joint": 0.1, ...}}
    {"type": "strain", "t": 12.346, "strain": [s1, ..., s8]}
    {"type": "tool",   "t": 12.0,   "name": "B"}
    {"type": "end"}

``t`` is the sender's clock in [s], one clock for both streams; joint readings in [rad];
strains raw. A datagram larger than :data:`MAX_DATAGRAM` bytes, or one that is not such an
object, raises :class:`ProtocolError`, which a receiver counts and skips.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

from ..core.exceptions import ProtocolError

#: Largest datagram accepted, in bytes (a joints message of a 7-joint arm is ~250 bytes).
MAX_DATAGRAM = 8192


@dataclass(frozen=True)
class Joints:
    """Joint readings at time ``t`` [s]: joint name -> [rad]."""

    t: float
    q: dict[str, float]


@dataclass(frozen=True)
class Strain:
    """Raw strains of the 8 bridges at time ``t`` [s]."""

    t: float
    strain: tuple[float, ...]


@dataclass(frozen=True)
class ToolChange:
    """The tool configuration mounted from time ``t`` [s] on."""

    t: float
    name: str


@dataclass(frozen=True)
class End:
    """The end of the run."""


Message = Joints | Strain | ToolChange | End


def _time(obj: dict) -> float:
    t = obj.get("t")
    if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t):
        raise ProtocolError("malformed", f"'t' must be a finite number of seconds, got {t!r}")
    return float(t)


def decode(data: bytes) -> Message:
    """Parse one datagram.

    Raises:
        ProtocolError: Oversized, not JSON, or not one of the four messages.
    """
    if len(data) > MAX_DATAGRAM:
        raise ProtocolError("oversized", f"{len(data)} bytes, at most {MAX_DATAGRAM}")
    try:
        obj = json.loads(data)
    except (UnicodeDecodeError, ValueError) as exc:
        raise ProtocolError("malformed", f"not JSON ({exc})") from None
    if not isinstance(obj, dict):
        raise ProtocolError("malformed", "expected a JSON object")
    kind = obj.get("type")
    if kind == "strain":
        values = obj.get("strain")
        if (
            not isinstance(values, list)
            or len(values) != 8
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)
        ):
            raise ProtocolError("malformed", "'strain' must be a list of 8 numbers")
        return Strain(_time(obj), tuple(float(v) for v in values))
    if kind == "joints":
        q = obj.get("q")
        if (
            not isinstance(q, dict)
            or not q
            or not all(isinstance(k, str) and isinstance(v, (int, float)) and not isinstance(v, bool) for k, v in q.items())
        ):
            raise ProtocolError("malformed", "'q' must map joint names to numbers")
        return Joints(_time(obj), {k: float(v) for k, v in q.items()})
    if kind == "tool":
        name = obj.get("name")
        if not isinstance(name, str) or not name:
            raise ProtocolError("malformed", "'name' must be a configuration name")
        return ToolChange(_time(obj), name)
    if kind == "end":
        return End()
    raise ProtocolError("malformed", f"unknown type {kind!r}; expected joints, strain, tool or end")


def encode(message: Message) -> bytes:
    """The datagram of a message (compact JSON)."""
    if isinstance(message, Strain):
        obj = {"type": "strain", "t": message.t, "strain": list(message.strain)}
    elif isinstance(message, Joints):
        obj = {"type": "joints", "t": message.t, "q": message.q}
    elif isinstance(message, ToolChange):
        obj = {"type": "tool", "t": message.t, "name": message.name}
    else:
        obj = {"type": "end"}
    return json.dumps(obj, separators=(",", ":")).encode("utf-8")

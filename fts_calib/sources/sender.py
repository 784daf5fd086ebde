"""The ``replay`` job: send a recording as the live protocol, to test and show the live path.

Every row becomes a strain message; joint messages go at ``joint_rate_hz`` (every row by
default, with the row's readings) and carry stamps late by ``latency_s`` (as a joint feed
with a constant latency would); a tool message announces each configuration when it
starts and is repeated every second (so that a receiver restarted mid-run learns it); an
``end`` message closes the run. A CSV recording that gives the sensor's orientation instead
of joints (columns ``qw,qx,qy,qz``, ``roll,pitch,yaw`` or ``tcp_rx,tcp_ry,tcp_rz``,
:mod:`fts_calib.robot.orientation`) sends it as ``"R"`` (row-major), for ``live`` without a
robot (with its ``--mount`` for the TCP form). Every message carries ``seq``, its number in the
sender's sequence (0, 1, 2, ...), so that the receiver counts what the network loses.
``loss`` drops that fraction of the joint and strain messages (after numbering them: they
show as gaps) and ``reorder`` delays that fraction by one to five messages (seeded).
Messages leave at their recorded times divided by ``speed`` (0: as fast as the socket
takes them). A replay that could place fewer than :data:`~fts_calib.sources.source.MIN_COVERAGE`
of the recording's channel samples (a bag's joints on another clock, say) sends its ``end``
and then fails, saying what was skipped: it tested nothing of the live path.
"""

from __future__ import annotations

import itertools
import socket
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core import arrays as validation
from ..core.exceptions import ConfigError, RecordingError
from .bag import BagTopics
from .source import MIN_COVERAGE, open_recording
from .udp import End, Joints, Message, Orientation, Strain, ToolChange, encode

_TOOL_REPEAT_S = 1.0  # [s] of recording time between tool announcements


@dataclass(frozen=True)
class ReplayOptions:
    """How to replay.

    Attributes:
        speed: Time scale (1: real time, 10: ten times faster, 0: no pacing).
        joint_rate_hz: Rate of the joint messages [Hz]; None for every row.
        latency_s: Joint stamps are late by this [s].
        loss: Fraction of joint and strain messages dropped, in [0, 1).
        reorder: Fraction of messages delayed by one to five places, in [0, 1).
        seed: Seed of the loss and reordering.
    """

    speed: float = 1.0
    joint_rate_hz: float | None = None
    latency_s: float = 0.0
    loss: float = 0.0
    reorder: float = 0.0
    seed: int = 0

    def __post_init__(self):
        object.__setattr__(self, "speed", validation.non_negative("speed", self.speed))
        if self.joint_rate_hz is not None:
            object.__setattr__(self, "joint_rate_hz", validation.positive("joint_rate_hz", self.joint_rate_hz, "Hz"))
        object.__setattr__(self, "latency_s", validation.number("latency_s", self.latency_s, "s"))
        for name in ("loss", "reorder"):
            value = validation.number(name, getattr(self, name))
            if not 0.0 <= value < 1.0:
                raise ConfigError(name, value, "a fraction in [0, 1)")
            object.__setattr__(self, name, value)


def _orientation_columns(names: Sequence[str]):
    """For joint columns that are exactly an orientation form's: the function of one row [its columns] -> R (3, 3); else None."""
    from ..robot.orientation import ORIENTATION_FORMS, orientation_form, rotations

    form = orientation_form(names)
    if form is None or set(names) != set(ORIENTATION_FORMS[form]):
        return None
    order = [list(names).index(column) for column in ORIENTATION_FORMS[form]]
    return lambda row: rotations(form, np.asarray(row, dtype=float)[order][None])[0]


def messages(
    path: str | Path | Sequence[str | Path], options: ReplayOptions, topics: BagTopics | None = None
) -> Iterator[tuple[float, Message]]:
    """(recorded time [s], message) pairs of a recording, before loss and reordering; ``seq`` 0, 1, 2, ...

    Args:
        path: A CSV recording, or ROS 2 bags (:mod:`fts_calib.sources.source`): a bag's
            channel samples with the joints synchronised at their times, as rows.
        options: How to replay.
        topics: Topic names of a bag; the defaults when None.

    Raises:
        RecordingError: After the ``end`` message, when fewer than ``MIN_COVERAGE`` of the
            recording's channel samples could be placed (the message says why they were skipped).
    """
    seq = itertools.count()
    placed = 0
    with open_recording(path, None, None, topics=topics) as reader:
        names = reader.joint_names
        as_rotation = _orientation_columns(names)
        current, next_joint, next_tool, last = None, -np.inf, -np.inf, 0.0
        period = 0.0 if options.joint_rate_hz is None else 1.0 / options.joint_rate_hz
        for chunk in reader:
            tools = reader.tool_names
            heat = [None] * len(chunk) if chunk.temperature is None else chunk.temperature.tolist()
            for t, q, s, code, temperature in zip(chunk.time, chunk.joints, chunk.channels, chunk.configuration, heat, strict=True):
                t = float(t)
                if tools[code] != current or t >= next_tool:
                    # announced at each change and repeated every second: a receiver that
                    # (re)starts mid-run learns the mounted configuration within a second
                    current, next_tool = tools[code], t + _TOOL_REPEAT_S
                    yield t, ToolChange(t, current, next(seq))
                if t >= next_joint:
                    next_joint = t + period if period else t
                    if as_rotation is None:
                        yield t, Joints(t + options.latency_s, dict(zip(names, q.tolist(), strict=True)), next(seq))
                    else:
                        yield t, Orientation(t + options.latency_s, tuple(as_rotation(q).ravel().tolist()), "R", next(seq))
                yield t, Strain(t, tuple(s.tolist()), next(seq), temperature)
                last = t
                placed += 1
    yield last, End(next(seq))
    read = reader.rows_read
    if read and placed < MIN_COVERAGE * read:
        skipped = ", ".join(f"{reason}: {count:,}" for reason, count in reader.skipped.items()) or "no reason counted"
        notes = "; ".join(reader.notes()[:1])
        raise RecordingError(
            reader.path,
            None,
            None,
            f"only {placed:,} of {read:,} channel samples ({100 * placed / read:.3g} %) could be replayed, below "
            f"{100 * MIN_COVERAGE:g} %: the receiver was sent a sliver of the recording (skipped: {skipped})"
            + (f"; {notes}" if notes else ""),
        )


@dataclass(frozen=True)
class ReplayStats:
    """What was sent.

    Attributes:
        sent: Datagrams sent.
        dropped: Messages dropped on purpose (``loss``).
        reordered: Messages sent late on purpose (``reorder``).
        seconds: Wall-clock time [s].
    """

    sent: int
    dropped: int
    reordered: int
    seconds: float


def replay(
    path: str | Path | Sequence[str | Path], host: str, port: int, options: ReplayOptions, topics: BagTopics | None = None
) -> ReplayStats:
    """Send a recording (a CSV or ROS 2 bags, as :func:`messages`) to ``host:port`` (see the module docstring)."""
    rng = np.random.default_rng(options.seed)
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    target = (host, port)
    start = time.monotonic()
    t0 = None
    sent = dropped = reordered = 0
    delayed: list[list] = []  # [messages still to pass, datagram]
    try:
        for t, message in messages(path, options, topics):
            if t0 is None:
                t0 = t
            if options.speed > 0:
                wait = (t - t0) / options.speed - (time.monotonic() - start)
                if wait > 0.0005:
                    time.sleep(wait)
            data = encode(message)
            lossy = isinstance(message, (Joints, Strain))
            if lossy and options.loss and rng.random() < options.loss:
                dropped += 1
                continue
            if lossy and options.reorder and rng.random() < options.reorder:
                delayed.append([int(rng.integers(1, 6)), data])
                reordered += 1
                continue
            if isinstance(message, End):
                for _, late in delayed:
                    sock.sendto(late, target)
                    sent += 1
                delayed = []
            sock.sendto(data, target)
            sent += 1
            for entry in delayed:
                entry[0] -= 1
            for entry in [e for e in delayed if e[0] <= 0]:
                sock.sendto(entry[1], target)
                sent += 1
                delayed.remove(entry)
            if options.speed == 0 and sent % 200 == 0:
                time.sleep(0.001)  # let the receiver keep up
    finally:
        sock.close()
    return ReplayStats(sent, dropped, reordered, time.monotonic() - start)

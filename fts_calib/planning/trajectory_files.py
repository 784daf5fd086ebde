"""Trajectory files (CSV): the planned motion a robot controller plays, one file per tool configuration.

Columns: ``time`` [s], then for every actuated joint ``<joint>`` [rad], ``<joint>_vel``
[rad/s] and ``<joint>_acc`` [rad/s^2], and ``tool`` (the configuration that must be
mounted), one row per controller period. A name ending in ``.gz`` is read and written
gzip-compressed (deterministically: no time stamp in the header). Files are written
atomically.
"""

from __future__ import annotations

import gzip
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.arrays import frozen
from ..core.exceptions import ConfigError, RecordingError
from ..core.files import atomic_write_bytes, is_number


@dataclass(frozen=True)
class TrajectoryFile:
    """A trajectory read back.

    Attributes:
        joint_names: Joints, in column order.
        time: Sample times [s]. Shape (N,).
        q: Positions [rad]. Shape (N, n).
        qd: Velocities [rad/s]. Shape (N, n).
        qdd: Accelerations [rad/s^2]. Shape (N, n).
        tool: The tool configuration of the file.
    """

    joint_names: tuple[str, ...]
    time: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tool: str

    def __post_init__(self):
        for name in ("time", "q", "qd", "qdd"):
            object.__setattr__(self, name, frozen(getattr(self, name)))


def write_trajectory(path: str | Path, joint_names, time, q, qd, qdd, tool: str) -> Path:
    """Write one trajectory file (see the module docstring).

    Args:
        path: Destination (``.csv`` or ``.csv.gz``).
        joint_names: Actuated joints, in order.
        time: Sample times [s], shape (N,).
        q: Positions [rad], shape (N, n).
        qd: Velocities [rad/s], shape (N, n).
        qdd: Accelerations [rad/s^2], shape (N, n).
        tool: Tool configuration name (no comma).

    Raises:
        ConfigError: ``tool`` holds a comma or a line break.
    """
    if "," in tool or "\n" in tool:
        raise ConfigError("tool", tool, "a configuration name without ',' or line breaks (it is written in a CSV column)")
    names = list(joint_names)
    header = ["time"] + [f"{j}{suffix}" for j in names for suffix in ("", "_vel", "_acc")] + ["tool"]
    n = len(names)
    table = np.empty((len(time), 1 + 3 * n))
    table[:, 0] = time
    table[:, 1::3], table[:, 2::3], table[:, 3::3] = q, qd, qdd
    buffer = io.StringIO()
    buffer.write(",".join(header) + "\n")
    fmt = ",".join(["%.6f"] + ["%.9f"] * (3 * n)) + "," + tool.replace("%", "%%")
    np.savetxt(buffer, table, fmt=fmt)
    data = buffer.getvalue().encode("utf-8")
    path = Path(path)
    if path.suffix == ".gz":
        out = io.BytesIO()
        with gzip.GzipFile(filename="", mode="wb", fileobj=out, mtime=0, compresslevel=9) as handle:
            handle.write(data)
        data = out.getvalue()
    return atomic_write_bytes(path, data)


def read_trajectory(path: str | Path) -> TrajectoryFile:
    """Read a trajectory file.

    Raises:
        RecordingError: Missing file or column, a malformed value (the message names the
            line and column), mixed tool names, or time going backwards.
    """
    path = Path(path)
    opener = gzip.open if path.suffix == ".gz" else open
    try:
        with opener(path, "rt", encoding="utf-8") as handle:
            lines = handle.read().splitlines()
    except FileNotFoundError:
        raise RecordingError(path, None, None, "file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise RecordingError(path, None, None, f"cannot read: {exc}") from None
    if not lines:
        raise RecordingError(path, 1, None, "empty file: expected a header line")
    header = lines[0].split(",")
    if header[0] != "time" or header[-1] != "tool" or (len(header) - 2) % 3:
        raise RecordingError(path, 1, None, "expected the header 'time, <joint>, <joint>_vel, <joint>_acc, ..., tool'")
    joints = header[1:-1:3]
    for k, joint in enumerate(joints):
        if header[2 + 3 * k] != f"{joint}_vel" or header[3 + 3 * k] != f"{joint}_acc":
            raise RecordingError(path, 1, header[2 + 3 * k], f"expected '{joint}_vel' and '{joint}_acc' after '{joint}'")
    rows, tools = [], set()
    for number, line in enumerate(lines[1:], start=2):
        cells = line.split(",")
        if len(cells) != len(header):
            raise RecordingError(path, number, None, f"{len(cells)} values but the header has {len(header)} columns")
        try:
            rows.append([float(c) for c in cells[:-1]])
        except ValueError:
            bad = next(i for i, c in enumerate(cells[:-1]) if not is_number(c))
            raise RecordingError(path, number, header[bad], f"'{cells[bad]}' is not a number") from None
        tools.add(cells[-1])
    if len(tools) > 1:
        raise RecordingError(path, None, "tool", f"one tool configuration per file, found {sorted(tools)}")
    table = np.array(rows).reshape(-1, len(header) - 1)
    if np.any(np.diff(table[:, 0]) < 0):
        backwards = int(np.argmax(np.diff(table[:, 0]) < 0)) + 3
        raise RecordingError(path, backwards, "time", "time goes backwards")
    return TrajectoryFile(tuple(joints), table[:, 0], table[:, 1::3], table[:, 2::3], table[:, 3::3], tools.pop() if tools else "")


def save_trajectory(path: str | Path, trajectory: TrajectoryFile) -> Path:
    """Write a :class:`TrajectoryFile` (see :func:`write_trajectory`); returns the path."""
    t = trajectory
    return write_trajectory(path, t.joint_names, t.time, t.q, t.qd, t.qdd, t.tool)

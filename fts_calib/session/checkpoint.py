"""Checkpoint files of a calibration session: its sums, written atomically, read back with checks.

A checkpoint is JSON (``format: fts-calib-checkpoint/1``): the estimator's sums, the counts,
the filter's noise floor, the time of the last sample, the robot and tool it belongs to,
and its ``source``: for a recording ``{kind: recording, path, size (bytes), hashed_bytes,
sha256}``, the SHA-256 of the file's first MiB (header line included); for a live run
``{kind: live, listen: udp://HOST:PORT}``. It is written to a temporary file and renamed,
so a crash leaves the previous one.

Nothing is lost: a run never starts over an existing checkpoint unless told to resume it
or to restart (:func:`check_start`), and a checkpoint is resumed only with its own source:
the same recording (same first MiB, at least as long: a recording that grew is the same one,
continued), or a live feed (:func:`read_checkpoint`).

A calibration session's checkpoint state: what it holds (sums, counts, filter state) and its restoration.

:meth:`fts_calib.session.session.CalibrationSession.resume` reads the checkpoint
(:mod:`fts_calib.session.checkpoint`) and builds the session; this restores what the file
holds into it and refuses a checkpoint of another channel layout or sensor model.
"""

from __future__ import annotations

import hashlib
import json
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .._version import __version__
from ..core.bounded import load_json_file
from ..core.exceptions import ConfigError, FileFormatError, FtsCalibWarning
from ..core.files import atomic_write_text, writing
from ..model.calibration import now_iso
from ..robot.tool import Tool
from ..sources.bag import parse_bag_argument

CHECKPOINT_FORMAT = "fts-calib-checkpoint/1"

#: How much of a recording identifies it in a checkpoint: its first MiB, header line included [bytes].
HASHED_BYTES = 1 << 20


def recording_source(path: str | Path | Sequence[str | Path], hashed_bytes: int = HASHED_BYTES) -> dict[str, Any]:
    """What a checkpoint records of a recording: path, size in bytes, SHA-256 of its first bytes.

    Args:
        path: The recording (as stored: a ``.csv.gz`` is hashed compressed), or ROS 2 bags
            (``BAG`` or ``BAG:CONFIGURATION``; a bag folder's files are taken in name order):
            their files count as one stream, in the order given.
        hashed_bytes: How many of its first bytes to hash.

    Raises:
        OSError: The file cannot be read.
    """
    given = [path] if isinstance(path, (str, Path)) else list(path)
    paths = [Path(p) if Path(p).exists() else parse_bag_argument(p).path for p in given]
    files = [f for p in paths for f in (sorted(x for x in p.iterdir() if x.is_file()) if p.is_dir() else [p])]
    digest, hashed = hashlib.sha256(), 0
    for file in files:
        with file.open("rb") as handle:
            head = handle.read(hashed_bytes - hashed)
        digest.update(head)
        hashed += len(head)
    resolved = [str(p.resolve()) for p in paths]
    return {
        "kind": "recording",
        "path": resolved[0] if len(resolved) == 1 else resolved,
        "size": sum(f.stat().st_size for f in files),
        "hashed_bytes": hashed,
        "sha256": digest.hexdigest(),
    }


def live_source(host: str, port: int) -> dict[str, Any]:
    """What a checkpoint records of a live run: the address it listens on."""
    return {"kind": "live", "listen": f"udp://{host}:{port}"}


def describe_source(source: dict[str, Any] | None) -> str:
    """A source record in words, e.g. ``recording /data/run.csv (1,234,567 bytes, sha256 3f2a9c0d1e4b)``."""
    if not isinstance(source, dict):
        return "an unrecorded source"
    if source.get("kind") == "live":
        return f"live {source.get('listen')}"
    size, digest = source.get("size"), str(source.get("sha256", ""))[:12]
    if not isinstance(size, int):
        return f"recording {source.get('path')}"
    return f"recording {source.get('path')} ({size:,} bytes, sha256 {digest})"


def check_start(path: str | Path | None, resume: bool, restart: bool) -> None:
    """Refuse to start a run over an existing checkpoint unless told what to do with it.

    Args:
        path: The checkpoint file, or None for none.
        resume: The run continues from the checkpoint.
        restart: The run starts afresh and overwrites it.

    Raises:
        ConfigError: Both flags, or neither while ``path`` exists.
    """
    if resume and restart:
        raise ConfigError("restart", True, "", message="--resume and --restart exclude each other: continue a checkpoint, or start afresh")
    if resume and path is None:
        raise ConfigError("resume", True, "", message="--resume continues a checkpoint: give it with --checkpoint FILE")
    if path is not None and not resume and not restart and Path(path).exists():
        raise ConfigError(
            "checkpoint",
            str(path),
            "",
            message=f"checkpoint {path} exists (an earlier run's samples): --resume to continue it, or --restart to overwrite it",
        )


def write_checkpoint(path: str | Path, state: dict[str, Any]) -> Path:
    """Write a session's ``state`` (plain data) as a checkpoint, atomically; returns the path."""
    document = {"format": CHECKPOINT_FORMAT, **state, "written": now_iso(), "software_version": __version__}
    with writing(path):  # a full disk names the checkpoint, not only the reason
        return atomic_write_text(Path(path), json.dumps(document))


#: Largest checkpoint read [bytes]: a checkpoint holds sums, not samples (about 20 kB).
MAX_CHECKPOINT_BYTES = 256 << 20


def read_checkpoint(path: str | Path, robot: str, tool: Tool, source: dict[str, Any] | None = None) -> dict[str, Any]:
    """The state in a checkpoint, after checking that it is one of this robot, tool and source.

    Args:
        path: The checkpoint file.
        robot: Name of the robot definition in use.
        tool: The tool in use.
        source: The source the run reads (:func:`recording_source`, :func:`live_source`), or
            None not to check it. A checkpoint that records no source (an older one) is
            resumed with a warning.

    Raises:
        FileFormatError: Missing, not a checkpoint, or one of another robot, tool or source.
    """
    path = Path(path)
    if not path.exists():
        raise FileFormatError(path, None, "checkpoint not found")
    state = load_json_file(path, "checkpoint", MAX_CHECKPOINT_BYTES, finite=False)
    if not isinstance(state, dict) or state.get("format") != CHECKPOINT_FORMAT:
        raise FileFormatError(path, "format", f"expected {CHECKPOINT_FORMAT!r}")
    names = tool.names
    if state.get("robot") != robot or state.get("tool") != tool.name or state.get("configurations") != names:
        raise FileFormatError(
            path,
            None,
            f"checkpoint of robot {state.get('robot')!r} with tool {state.get('tool')!r} "
            f"{state.get('configurations')}, not of {robot!r} with {tool.name!r} {names}",
        )
    if source is not None:
        _check_source(path, state.get("source"), source)
    return state


def _check_source(path: Path, recorded: Any, current: dict[str, Any]) -> None:
    if recorded is None:
        text = f"{path} records no source (an older checkpoint): cannot check that it is of {describe_source(current)}"
        warnings.warn(text, FtsCalibWarning, stacklevel=3)
        return
    if isinstance(recorded, dict) and recorded.get("kind") == current.get("kind") == "live":
        return  # a live feed may come back on another address; its samples are the run's
    if _same_recording(recorded, current):
        return
    raise FileFormatError(
        path,
        "source",
        f"checkpoint of {describe_source(recorded)}, not of {describe_source(current)}: "
        "resume it with its own source, or --restart to start afresh",
    )


def _same_recording(recorded: Any, current: dict[str, Any]) -> bool:
    if not isinstance(recorded, dict) or recorded.get("kind") != "recording" or current.get("kind") != "recording":
        return False
    hashed, size = recorded.get("hashed_bytes"), recorded.get("size")
    if not isinstance(hashed, int) or not isinstance(size, int):
        return False
    if hashed != current.get("hashed_bytes"):  # the recording was shorter than a MiB: hash as much of this one
        try:
            current = recording_source(current["path"], hashed)
        except (OSError, KeyError):
            return False
    return current.get("sha256") == recorded.get("sha256") and current.get("hashed_bytes") == hashed and current.get("size", -1) >= size

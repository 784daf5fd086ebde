"""Checkpoint files of a calibration session: its sums, written atomically, read back with checks.

A checkpoint is JSON (``format: fts-calib-checkpoint/1``): the estimator's sums, the counts,
the filter's noise floor, the time of the last sample, and the robot and tool it belongs
to. It is written to a temporary file and renamed, so a crash leaves the previous one.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from .._version import __version__
from ..core.exceptions import FileFormatError
from ..core.fileio import atomic_write_text
from ..model.calibration import now_iso
from ..robot.tool import Tool

CHECKPOINT_FORMAT = "fts-calib-checkpoint/1"


def write_checkpoint(path: str | Path, state: dict[str, Any]) -> Path:
    """Write a session's ``state`` (plain data) as a checkpoint, atomically; returns the path."""
    document = {"format": CHECKPOINT_FORMAT, **state, "written": now_iso(), "software_version": __version__}
    return atomic_write_text(Path(path), json.dumps(document))


def read_checkpoint(path: str | Path, robot: str, tool: Tool) -> dict[str, Any]:
    """The state in a checkpoint, after checking that it is one of this robot and tool.

    Args:
        path: The checkpoint file.
        robot: Name of the robot definition in use.
        tool: The tool in use.

    Raises:
        FileFormatError: Missing, not a checkpoint, or one of another robot or tool.
    """
    path = Path(path)
    try:
        state = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise FileFormatError(path, None, "checkpoint not found") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise FileFormatError(path, None, f"not a checkpoint: {exc}") from None
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
    return state

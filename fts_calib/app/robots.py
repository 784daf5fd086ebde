"""The ``robots`` command: the shipped robot definitions, or the details of one."""

from __future__ import annotations

from pathlib import Path

from .exit_codes import ExitCode
from .report import robot_details, robots_list


def run(*, name: str | Path | None = None) -> int:
    """Print the shipped robot definitions, or one robot's joints, limits, frames and sensor mount (``fts-calib robots``).

    Args:
        name: A shipped robot name (e.g. 'ur5') or a robot YAML path; None lists the shipped robots.

    Returns:
        0.
    """
    print(robots_list() if name is None else robot_details(str(name)))
    return ExitCode.OK

"""Where shipped files live: robot definitions, configs and trajectories of the project.

A name given on the command line is a path when such a file exists; otherwise it is
looked up among the shipped files: ``ur5`` means ``robots/ur5.yaml``. The shipped
folders are those of the source checkout the package runs from, or of the current
folder.
"""

from __future__ import annotations

from pathlib import Path

from .exceptions import FtsCalibError


class ResourceNotFound(FtsCalibError, FileNotFoundError):
    """Neither a file nor a shipped name.

    Attributes:
        name: What was asked for.
        available: The shipped names of that kind.
    """

    def __init__(self, name: str, kind: str, available: list[str]):
        self.name = name
        self.available = available
        super().__init__(f"no file '{name}' and no shipped {kind} of that name; shipped: {', '.join(available) or 'none'}")


def project_root() -> Path:
    """The folder holding ``robots/``, ``configs/`` and ``trajectories/``.

    The source checkout of the package when it has them (an editable install, the
    usual case), else the current folder.
    """
    checkout = Path(__file__).resolve().parents[1]
    if (checkout / "configs").is_dir() and (checkout / "robots").is_dir():
        return checkout
    return Path.cwd()


def shipped(kind: str) -> list[str]:
    """Names of the shipped YAML files of a kind ('robots' or 'configs'), sorted."""
    folder = project_root() / kind
    return sorted(p.stem for p in folder.glob("*.yaml")) if folder.is_dir() else []


def resolve(name_or_path: str | Path, kind: str) -> Path:
    """A path to an existing file: ``name_or_path`` itself, or ``<root>/<kind>/<name>.yaml``.

    Args:
        name_or_path: A file path, or the stem of a shipped file (e.g. 'ur5').
        kind: 'robots' or 'configs'.

    Raises:
        ResourceNotFound: Neither exists; lists the shipped names.
    """
    path = Path(name_or_path)
    if path.is_file():
        return path
    candidate = project_root() / kind / f"{path.name}.yaml"
    if path.suffix == "" and candidate.is_file():
        return candidate
    raise ResourceNotFound(str(name_or_path), kind.rstrip("s"), shipped(kind))

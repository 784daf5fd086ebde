"""Where shipped files live: robot definitions, configs and trajectories of the project.

A name given on the command line is a path when such a file exists; otherwise it is
looked up among the shipped files: ``ur5`` means ``robots/ur5.yaml``.

The folders ``robots/``, ``configs/`` and ``trajectories/`` stay at the repository's top
level and are installed inside the package at build time (``pyproject.toml`` maps them
to ``fts_calib/robots`` and so on), so an installed wheel finds them through
:mod:`importlib.resources` wherever it lives. An editable install maps only the Python
package, so there they are read from the source checkout beside it.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

from .exceptions import ResourceNotFound, RobotDataNotFound

#: The kinds of shipped data, one folder each.
KINDS = ("robots", "configs", "trajectories")


def data_dir(kind: str) -> Path:
    """The folder of shipped data of one kind.

    Args:
        kind: 'robots', 'configs' or 'trajectories'.

    Returns:
        ``<package>/<kind>`` of an installed wheel, else ``<checkout>/<kind>`` of the
        source checkout an editable install runs from.

    Raises:
        ValueError: ``kind`` is not one of :data:`KINDS` (a programming error).
    """
    if kind not in KINDS:  # the callers pass literals, never a user's text: a programming error
        raise ValueError(f"kind={kind!r} but expected one of {KINDS}")
    installed = files("fts_calib").joinpath(kind)
    if installed.is_dir():
        return Path(str(installed))
    return Path(__file__).resolve().parents[2] / kind


def shipped(kind: str) -> list[str]:
    """Names of the shipped entries of a kind, sorted.

    For 'robots' and 'configs' the stems of the YAML files (``ur5``); for 'trajectories'
    the robot folders that hold a planned run.
    """
    folder = data_dir(kind)
    if not folder.is_dir():
        return []
    if kind == "trajectories":
        return sorted(p.name for p in folder.iterdir() if (p / "plan.yaml").is_file())
    return sorted(p.stem for p in folder.glob("*.yaml"))


def resolve(name_or_path: str | Path, kind: str) -> Path:
    """A path to an existing file: ``name_or_path`` itself, or the shipped ``<kind>/<name>.yaml``.

    Args:
        name_or_path: A file path, or the stem of a shipped file (e.g. 'ur5').
        kind: 'robots' or 'configs'.

    Raises:
        ResourceNotFound: Neither exists; lists the shipped names.
    """
    path = Path(name_or_path)
    if path.is_file():
        return path
    candidate = data_dir(kind) / f"{path.name}.yaml"
    if path.suffix == "" and candidate.is_file():
        return candidate
    raise ResourceNotFound(str(name_or_path), kind.rstrip("s"), shipped(kind))


def locate(name_or_path: str | Path, kind: str) -> Path:
    """A file a loader reads: a shipped name (no folder, no suffix, no such file: ``ur5``) or a path as given.

    Unlike :func:`resolve`, a path that does not exist is returned as it is, so that its
    loader reports the missing file by name.

    Args:
        name_or_path: A file path, or the stem of a shipped file (e.g. 'ur5').
        kind: 'robots' or 'configs'.

    Raises:
        ResourceNotFound: A bare name that is neither a file nor shipped; lists the shipped names.
    """
    path = Path(name_or_path)
    if path.exists() or path.suffix or len(path.parts) != 1:
        return path
    return resolve(path, kind)


#: Environment variable naming the example-robot-data folder (the one holding ``robots/``).
ROBOT_DATA_ENV = "EXAMPLE_ROBOT_DATA_DIR"


def _from_metadata() -> list[Path]:
    """Candidates from the installed distribution's file list (pip, uv, conda's pip)."""
    try:
        from importlib.metadata import PackageNotFoundError, distribution
    except ImportError:  # pragma: no cover - Python >= 3.8 has it
        return []
    try:
        dist = distribution("example-robot-data")
    except PackageNotFoundError:
        return []
    found = []
    for entry in dist.files or []:
        parts = entry.parts
        if len(parts) >= 3 and parts[-3:] == ("share", "example-robot-data", "package.xml"):
            found.append(Path(str(dist.locate_file(entry))).parent)
    return found


def _from_python_module() -> list[Path]:
    """Candidates from the Python loader that example-robot-data 4.x shipped."""
    try:
        from example_robot_data.path import EXAMPLE_ROBOT_DATA_MODEL_DIR  # type: ignore[import-not-found]
    except ImportError:
        return []
    return [Path(EXAMPLE_ROBOT_DATA_MODEL_DIR).parent]


def _from_prefixes() -> list[Path]:
    """Candidates from ROS and system install prefixes."""
    import os

    prefixes = []
    for var in ("AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH", "CONDA_PREFIX"):
        prefixes += [p for p in os.environ.get(var, "").split(os.pathsep) if p]
    for entry in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep):
        if entry:
            prefixes.append(str(Path(entry).parent))
    prefixes += ["/opt/openrobots", "/usr/local", "/usr"]
    return [Path(p) / "share" / "example-robot-data" for p in prefixes]


def example_robot_data_dir() -> Path:
    """The example-robot-data folder, the one that holds ``robots/``.

    Looked up, in order: the environment variable ``EXAMPLE_ROBOT_DATA_DIR``; the installed
    distribution's file list (example-robot-data 6.x on PyPI ships only data, under
    ``<prefix>/share/example-robot-data``); the Python module of older releases; ROS and
    system prefixes (``AMENT_PREFIX_PATH``, ``CMAKE_PREFIX_PATH``, ``CONDA_PREFIX``,
    ``ROS_PACKAGE_PATH``, /opt/openrobots, /usr/local, /usr). No site-packages path is
    hard-coded.

    Raises:
        RobotDataNotFound: None of these holds a ``robots/`` folder; says what to install.
    """
    import os

    override = os.environ.get(ROBOT_DATA_ENV)
    if override:
        path = Path(override)
        if (path / "robots").is_dir():
            return path
        raise RobotDataNotFound(f"{ROBOT_DATA_ENV}={override} has no robots/ folder: point it at the folder that holds robots/")
    for candidate in (*_from_metadata(), *_from_python_module(), *_from_prefixes()):
        if (candidate / "robots").is_dir():
            return candidate
    raise RobotDataNotFound(
        "example-robot-data is not installed: run 'pip install example-robot-data' in this environment "
        f"(or set {ROBOT_DATA_ENV} to the folder that holds its robots/ folder)"
    )

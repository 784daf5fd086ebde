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

import os
import reprlib
from importlib.resources import files
from pathlib import Path

from .exceptions import ConfigError, FileFormatError, ResourceNotFound, RobotDataNotFound

#: The kinds of shipped data, one folder each.
KINDS = ("robots", "configs", "trajectories")

#: The roles of the files in ``configs/``, by the end of their names (``paper_tool``,
#: ``factory_sensor``, ``paper_table1_calibration``): what a "no such tool" lists.
ROLES = {"tool": "_tool", "sensor": "sensor", "calibration": "_calibration", "pipeline": "pipeline"}


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


def shipped(kind: str, role: str | None = None) -> list[str]:
    """Names of the shipped entries of a kind, sorted.

    For 'robots' and 'configs' the stems of the YAML files (``ur5``); for 'trajectories'
    the robot folders that hold a planned run.

    Args:
        kind: One of :data:`KINDS`.
        role: For 'configs', only the files of this role (a key of :data:`ROLES`: 'tool',
            'sensor', 'calibration', 'pipeline'); None for all.
    """
    folder = data_dir(kind)
    if not folder.is_dir():
        return []
    if kind == "trajectories":
        return sorted(p.name for p in folder.iterdir() if (p / "plan.yaml").is_file())
    return sorted(p.stem for p in folder.glob("*.yaml") if role is None or p.stem.endswith(ROLES[role]))


def resolve(name_or_path: str | Path, kind: str, role: str | None = None) -> Path:
    """A path to an existing file: ``name_or_path`` itself, or the shipped ``<kind>/<name>.yaml``.

    Args:
        name_or_path: A file path, or the stem of a shipped file (e.g. 'ur5').
        kind: 'robots' or 'configs'.
        role: What the file is for ('tool', 'sensor'...: :data:`ROLES`), named in the errors
            and choosing the shipped names they list; None: the kind's.

    Raises:
        ConfigError: ``name_or_path`` is neither a string nor a path (None, a number).
        FileFormatError: A path (with a folder or a suffix) that does not exist, or a folder.
        ResourceNotFound: A bare name that is neither a file nor shipped; lists the shipped
            names of the role.
    """
    path = _as_path(name_or_path, role or kind.rstrip("s"))
    if path.is_file():
        return path
    if path.is_dir():
        raise FileFormatError(path, None, f"is a folder, not a {role or kind.rstrip('s')} YAML file")
    candidate = data_dir(kind) / f"{path.name}.yaml"
    if path.suffix == "" and len(path.parts) == 1 and candidate.is_file():
        return candidate
    if path.suffix or len(path.parts) != 1:  # a path, not a name: the shipped names are beside the point
        raise FileFormatError(path, None, "file not found")
    raise ResourceNotFound(str(name_or_path), role or kind.rstrip("s"), shipped(kind, role))


def locate(name_or_path: str | Path, kind: str, role: str | None = None) -> Path:
    """A file a loader reads: a shipped name (no folder, no suffix, no such file: ``ur5``) or a path as given.

    Unlike :func:`resolve`, a path that does not exist is returned as it is, so that its
    loader reports the missing file by name.

    Args:
        name_or_path: A file path, or the stem of a shipped file (e.g. 'ur5').
        kind: 'robots' or 'configs'.
        role: See :func:`resolve`.

    Raises:
        ConfigError: ``name_or_path`` is neither a string nor a path (None, a number).
        ResourceNotFound: A bare name that is neither a file nor shipped; lists the shipped names.
    """
    path = _as_path(name_or_path, role or kind.rstrip("s"))
    if path.exists() or path.suffix or len(path.parts) != 1:
        return path
    return resolve(path, kind, role)


def locate_trajectory(name_or_path: str | Path) -> Path:
    """A planned run a command reads: a path as given, or a shipped plan by its robot's name.

    ``ur5`` means the shipped folder ``trajectories/ur5`` (its CSVs and ``plan.yaml``) and
    ``ur5/A.csv.gz`` one file of it, from any working folder; a path that exists wins over a
    shipped name.

    Args:
        name_or_path: A folder or file of trajectory CSVs, or a shipped plan's name
            (:func:`shipped` 'trajectories'), optionally followed by ``/FILE``.

    Returns:
        The path itself when it exists or is not a shipped name (its reader reports it
        missing), else the shipped folder or file.

    Raises:
        ConfigError: ``name_or_path`` is neither a string nor a path.
        ResourceNotFound: A bare name (no folder, no suffix) that is neither a path nor a
            shipped plan; lists the shipped plans.
    """
    path = _as_path(name_or_path, "trajectory")
    if path.exists() or path.is_absolute():
        return path
    names = shipped("trajectories")
    if path.parts and path.parts[0] in names:
        return data_dir("trajectories").joinpath(*path.parts)
    if path.suffix or len(path.parts) != 1:
        return path
    raise ResourceNotFound(str(name_or_path), "trajectory", names)


def shown(path: str | Path) -> str:
    """A path as a printout shows it: a shipped file as ``shipped KIND/NAME`` (the same on every machine), else as given."""
    resolved = Path(path).resolve()
    for kind in KINDS:
        folder = data_dir(kind).resolve()
        if resolved.is_relative_to(folder):
            return f"shipped {kind}/{resolved.relative_to(folder).as_posix()}"
    return str(path)


def _as_path(name_or_path: object, what: str) -> Path:
    """``name_or_path`` as a Path; ConfigError naming ``what`` when it is neither a string nor a path."""
    if not isinstance(name_or_path, (str, os.PathLike)):
        expected = f"a shipped {what} name or the path of a {what} YAML file"
        raise ConfigError(what, name_or_path, expected, message=f"{what}={reprlib.repr(name_or_path)} but expected {expected}")
    return Path(name_or_path)


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

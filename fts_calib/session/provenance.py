"""Where a calibration came from: its robot file and tool file (by path and SHA-256, or by shipped name), its tool, its source.

The commands that use a calibration later (``validate``, ``report``, ``tare``, ``monitor``)
read the robot and tool files again from what is recorded here
(:meth:`fts_calib.app.setup.Setup.recorded`) and name a file that moved or changed.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from ..core.files import file_sha256
from ..core.resources import data_dir
from ..filters.settings import FilterConfig
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool


def file_provenance(path: Path | None, kind: str) -> dict[str, str | None]:
    """Where a robot or tool file was read from, for a calibration's provenance.

    Args:
        path: The file read, or None (a robot from a recording's orientations, a tool made in code).
        kind: Where its shipped files live: 'robots' or 'configs'.

    Returns:
        ``{"shipped": name, "sha256": hex}`` for a shipped file (its path differs from one
        installation to another, its name does not); ``{"file": absolute path, "sha256": hex}``
        for a user's file (``"sha256"`` left out of a file that can no longer be read);
        ``{"file": None}`` without a file.
    """
    if path is None:
        return {"file": None}
    absolute = Path(path).absolute()
    try:
        digest = file_sha256(absolute)
    except OSError:  # read a moment ago, gone now: the path still says where it came from
        return {"file": str(absolute)}
    if absolute.suffix == ".yaml" and absolute.resolve().parent == data_dir(kind).resolve():
        return {"shipped": absolute.stem, "sha256": digest}
    return {"file": str(absolute), "sha256": digest}


def session_provenance(kin: Kinematics, tool: Tool, kept: np.ndarray, source: str, filter_settings: FilterConfig | None) -> dict:
    """The provenance of a session's calibration, as plain data.

    The robot file and the tool file are recorded by absolute path and SHA-256
    (:func:`file_provenance`): the commands that use the calibration later (``validate``,
    ``report``, ``tare``, ``monitor``) read them again from there and name a file that moved
    or changed.

    Args:
        kin: The robot's kinematics (its definition and sensor mount: xyz in [m], rpy in [rad]).
        tool: The calibration tool (masses in [kg], centres of mass in [m]).
        kept: Kept samples per configuration, the tool's order. Shape (k,).
        source: What the samples came from.
        filter_settings: The quasi-static filter's settings, or None without the filter.
    """
    robot, mount = kin.robot, kin.robot.sensor
    return {
        "robot": {"name": robot.name, "urdf": robot.urdf_spec or str(robot.urdf), **file_provenance(robot.source, "robots")},
        "sensor_frame": {"name": mount.name, "parent_frame": mount.parent_frame, "xyz": mount.xyz.tolist(), "rpy": mount.rpy.tolist()},
        "tools": {
            "name": tool.name,
            **file_provenance(tool.source, "configs"),
            "gravity": tool.gravity,
            "configurations": [
                {"name": c.name, "mass": c.mass, "com": c.p_sensor_com.tolist(), "samples": int(n)}
                for c, n in zip(tool.configurations, kept, strict=True)
            ],
        },
        "source": source,
        "filter": None if filter_settings is None else dataclasses.asdict(filter_settings),
    }

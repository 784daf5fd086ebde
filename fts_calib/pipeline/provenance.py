"""Where a session's calibration came from: robot, sensor frame, tools, source and filter (the file's ``provenance``)."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..robot.kinematics import Kinematics
from ..robot.tool import Tool
from .settings import FilterConfig


def session_provenance(kin: Kinematics, tool: Tool, kept: np.ndarray, source: str, filter_settings: FilterConfig | None) -> dict:
    """The provenance of a session's calibration, as plain data.

    Args:
        kin: The robot's kinematics (its definition and sensor mount: xyz in [m], rpy in [rad]).
        tool: The calibration tool (masses in [kg], centres of mass in [m]).
        kept: Kept samples per configuration, the tool's order. Shape (k,).
        source: What the samples came from.
        filter_settings: The quasi-static filter's settings, or None without the filter.
    """
    robot, mount = kin.robot, kin.robot.sensor
    return {
        "robot": {"name": robot.name, "urdf": robot.urdf_spec or str(robot.urdf)},
        "sensor_frame": {"name": mount.name, "parent_frame": mount.parent_frame, "xyz": mount.xyz.tolist(), "rpy": mount.rpy.tolist()},
        "tools": {
            "name": tool.name,
            "file": str(tool.source) if tool.source else None,
            "gravity": tool.gravity,
            "configurations": [
                {"name": c.name, "mass": c.mass, "com": c.p_sensor_com.tolist(), "samples": int(n)}
                for c, n in zip(tool.configurations, kept, strict=True)
            ],
        },
        "source": source,
        "filter": None if filter_settings is None else dataclasses.asdict(filter_settings),
    }

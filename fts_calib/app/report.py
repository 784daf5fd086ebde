"""Text reports for the command line: tables with units, for people to read."""

from __future__ import annotations

import math

import numpy as np

from ..core.resources import resolve, shipped
from ..core.text import table
from ..robot.definition import load_robot
from ..robot.kinematics import Kinematics


def _limit(value: float) -> str:
    return "none" if not math.isfinite(value) else f"{value:+.4f}"


def robots_list() -> str:
    """The shipped robot definitions, one line each."""
    rows = []
    for name in shipped("robots"):
        robot = load_robot(resolve(name, "robots"))
        kin = Kinematics(robot)
        rows.append([name, str(kin.n_joints), ", ".join(kin.sweep_joints), robot.sensor.parent_frame, robot.urdf_spec])
    return "shipped robot definitions (robots/*.yaml):\n" + table(["name", "joints", "sweep joints", "sensor on", "URDF"], rows)


def robot_details(name_or_path: str) -> str:
    """Joints, limits, frames and the sensor mount of one robot definition."""
    path = resolve(name_or_path, "robots")
    robot = load_robot(path)
    kin = Kinematics(robot)
    lim = kin.limits
    out = [f"{robot.name} ({path})", f"  URDF: {robot.urdf_spec} -> {robot.urdf}"]
    rows = []
    for k, joint in enumerate(kin.joints):
        rows.append(
            [
                joint.name,
                joint.kind,
                _limit(lim.lower[k]),
                _limit(lim.upper[k]),
                f"{lim.velocity[k]:.3f}",
                f"{joint.velocity:.3f}",
                f"{lim.acceleration[k]:.2f}",
                f"{lim.jerk[k]:.1f}",
            ]
        )
    out.append(f"  actuated joints ({kin.n_joints}) and the limits used for planning:")
    out.append(
        table(
            ["joint", "kind", "lower [rad]", "upper [rad]", "velocity [rad/s]", "URDF velocity", "accel. [rad/s²]", "jerk [rad/s³]"],
            rows,
            "    ",
        )
    )
    out.append(f"  sweep joints: {', '.join(kin.sweep_joints)}")
    locked = ", ".join(f"{k} = {v:g}" for k, v in robot.locked_joints.items()) or "none"
    out.append(f"  locked joints: {locked}")
    home = "planned automatically (none given)" if robot.home is None else ", ".join(f"{k} {v:+.4f}" for k, v in robot.home.items())
    out.append(f"  home [rad]: {home}")
    mount = robot.sensor
    out.append(
        f"  sensor frame '{mount.name}' on '{mount.parent_frame}': xyz {np.round(mount.xyz, 4).tolist()} m, "
        f"rpy {np.round(mount.rpy, 4).tolist()} rad"
    )
    neutral = np.clip(np.zeros(kin.n_joints), lim.lower, lim.upper)
    pose = kin.sensor_pose(neutral)
    out.append(
        f"    at zero readings (clipped to limits): p_world_sensor {np.round(pose.translation, 4).tolist()} m, "
        f"sensor X axis in world {np.round(pose.rotation[:, 0], 4).tolist()}"
    )
    out.append(f"  collision: floor at z = {robot.floor_z} m; links left out: {', '.join(robot.ignore_links) or 'none'}")
    frames = [f.name for f in kin.model.frames]
    out.append(f"  frames ({len(frames)}): {', '.join(frames)}")
    return "\n".join(out)

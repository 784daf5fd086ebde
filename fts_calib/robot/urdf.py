"""The robot's URDF read into Pinocchio's model, with the checks a calibration needs of it.

A file that is not a URDF is named as such before Pinocchio parses it (its XML parser
prints to the terminal), and a robot with fewer than the two joints a sweep turns is
refused, naming the joints it has.
"""

from __future__ import annotations

import pinocchio as pin

from ..core.bounded import read_bounded
from ..core.exceptions import FileFormatError, JointError
from .definition import RobotDefinition


def build_model(robot: RobotDefinition) -> pin.Model:
    """Pinocchio's model of the robot definition's URDF.

    Raises:
        FileFormatError: The file is not a URDF Pinocchio can read (the message names it and
            the robot file's ``urdf`` field).
    """
    where = robot.source if robot.source is not None else robot.urdf
    head = read_bounded(robot.urdf, "URDF")
    if b"<robot" not in head:  # before Pinocchio, whose XML parser prints to the terminal
        raise FileFormatError(
            where, "urdf", f"{robot.urdf} is not a URDF: it holds no <robot> element (expected the robot's URDF XML file)"
        )
    try:
        return pin.buildModelFromUrdf(str(robot.urdf))
    except (ValueError, RuntimeError) as exc:  # Pinocchio's "does not contain a valid URDF model", a parse error
        reason = " ".join(str(exc).split()) or type(exc).__name__
        message = f"{robot.urdf} is not a URDF that Pinocchio can read ({reason}): expected a <robot> XML file"
        raise FileFormatError(where, "urdf", message) from None


def require_sweep_joints(robot: RobotDefinition, joint_names: tuple[str, ...]) -> None:
    """Refuse a robot with fewer than two actuated joints when the sweep joints are not named.

    Args:
        robot: The robot definition (its ``sweep_joints``, None for the last two).
        joint_names: The model's actuated joints, in order.

    Raises:
        JointError: Fewer than two actuated joints; the message names them.
    """
    if robot.sweep_joints is None and len(joint_names) < 2:  # the sweeps turn two joints: the last two by default
        found = ", ".join(f"'{name}'" for name in joint_names) or "none"
        message = (
            f"{robot.urdf} has {len(joint_names)} actuated joint(s) ({found}) but a calibration sweeps two "
            "(the last two actuated joints, or the robot file's sweep_joints)"
        )
        raise JointError(message, list(joint_names), [])

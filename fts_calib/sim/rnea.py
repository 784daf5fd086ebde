"""The tool's wrench on the sensor by Pinocchio's RNEA: a dynamics model independent of the calibration's.

The calibration's expected wrench is the classical Newton-Euler of
:mod:`fts_calib.robot.tool` on the sensor motion of the vectorised chain
(:mod:`fts_calib.robot.kinematics`). To test it against something else, the tool here is a body
of a Pinocchio model: the robot's actuated joints, then a joint at the sensor frame held at
zero (its position, velocity and acceleration), carrying the tool's spatial inertia
``pin.Inertia(m, c, I_c)``. Pinocchio's recursive Newton-Euler (``pin.rnea``, spatial
algebra, gravity through the base acceleration) then gives the force that joint transmits
to the tool, ``f`` in the sensor frame; the tool's wrench on the sensor is ``-f``
(``[F, M]``, moment about the origin of S, [N, N m]). Nothing of the calibration's
Newton-Euler is shared: not its kinematics, not its formula.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..robot.kinematics import Kinematics
from ..robot.tool import Tool


def rnea_tool_wrench(kin: Kinematics, tool: Tool, configuration: str, q, qd, qdd) -> np.ndarray:
    """The wrench a tool configuration exerts on the sensor along a motion, by Pinocchio's RNEA.

    Args:
        kin: Kinematics (its Pinocchio model and sensor frame).
        tool: The tool (gravity, mass, centre of mass, inertia).
        configuration: Configuration name.
        q: Joint positions [rad], shape (N, n_joints).
        qd: Joint velocities [rad/s], shape (N, n_joints).
        qdd: Joint accelerations [rad/s^2], shape (N, n_joints).

    Returns:
        ``[Fx, Fy, Fz, Mx, My, Mz]`` in [N, N m], shape (N, 6).
    """
    body = tool.configuration(configuration)
    model = pin.Model(kin.model)
    frame = model.frames[kin.sensor_frame_id]
    parent = frame.parentJoint if hasattr(frame, "parentJoint") else frame.parent
    mount = model.addJoint(parent, pin.JointModelRZ(), frame.placement, "fts_calib_tool_mount")
    inertia = np.zeros((3, 3)) if body.inertia_com is None else np.asarray(body.inertia_com)
    model.appendBodyToJoint(mount, pin.Inertia(body.mass, np.asarray(body.p_sensor_com), inertia), pin.SE3.Identity())
    model.gravity = pin.Motion(np.asarray(kin.g_world(tool.gravity), dtype=float), np.zeros(3))
    data = model.createData()
    joints = np.asarray(q, dtype=float)
    out = np.zeros((len(joints), 6))
    for i in range(len(joints)):
        config = np.append(kin.q_from_joints(joints[i]), 0.0)
        pin.rnea(model, data, config, np.append(qd[i], 0.0), np.append(qdd[i], 0.0))
        out[i] = -data.f[mount].vector
    return out

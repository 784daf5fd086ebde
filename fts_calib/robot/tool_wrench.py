r"""The tool's wrench on the sensor along a motion: the one function every stage calls.

Session, simulation, validation, tare, demo and planning all get the calibration tool's
load from :func:`tool_load`: forward kinematics once (:class:`Kinematics`, the only forward
kinematics), gravity in the sensor frame, then the static wrench of each sample's tool
configuration (paper eqs 17-18) and, when joint rates are given, the Newton-Euler wrench of
the moving tool (:mod:`fts_calib.robot.wrench`).

Frames and units: everything in the sensor frame S, moment about the origin of S;
``g_sensor = R_world_sensor.T @ g_world`` with ``|g_world|`` the tool file's gravity.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.exceptions import ShapeError
from .kinematics import Kinematics
from .motion import SensorMotion
from .tool import Tool


@dataclass(frozen=True)
class ToolLoad:
    """The tool's load on the sensor at each sample.

    Attributes:
        g_sensor: Gravity in S, in [m/s^2]. Shape (N, 3).
        static: The weight alone (eqs 17-18), ``[F, c x F]`` in [N, N m]. Shape (N, 6).
        moving: The Newton-Euler wrench of the moving tool in [N, N m], shape (N, 6), or
            None when no joint rates were given.
        motion: The sensor's motion the moving wrench comes from (N rows), or None.
    """

    g_sensor: np.ndarray
    static: np.ndarray
    moving: np.ndarray | None = None
    motion: SensorMotion | None = None

    @property
    def w_sensor(self) -> np.ndarray:
        """The best-known wrench: ``moving`` when computed, else ``static``. Shape (N, 6)."""
        return self.static if self.moving is None else self.moving


def tool_load(
    kin: Kinematics,
    tool: Tool,
    joints: np.ndarray,
    configuration: np.ndarray | int | str,
    joint_velocity: np.ndarray | None = None,
    joint_acceleration: np.ndarray | None = None,
) -> ToolLoad:
    """The calibration tool's wrench on the sensor at each sample of a motion.

    Args:
        kin: Kinematics of the robot.
        tool: The tool (its gravity, and the mass, centre of mass and inertia of each
            configuration).
        joints: Joint readings in [rad]. Shape (N, n_joints).
        configuration: Index of each sample's tool configuration, shape (N,) int (every
            index valid), or one index or name for all samples.
        joint_velocity: Joint velocities in [rad/s], shape (N, n_joints), with
            ``joint_acceleration`` in [rad/s^2]: the moving wrench is computed too. None for
            the static wrench alone.
        joint_acceleration: See ``joint_velocity``.

    Returns:
        :class:`ToolLoad` with arrays of N rows.

    Raises:
        ShapeError: The arrays do not have one row per sample.
        UnknownToolConfiguration: A configuration name that is not in the tool file.
    """
    joints = np.asarray(joints, dtype=float)
    n = len(joints)
    if isinstance(configuration, str):
        configuration = tool.names.index(tool.configuration(configuration).name)
    codes = np.broadcast_to(np.asarray(configuration, dtype=np.int64), (n,))
    if n == 0:
        return ToolLoad(np.zeros((0, 3)), np.zeros((0, 6)), None if joint_velocity is None else np.zeros((0, 6)))
    if (joint_velocity is None) != (joint_acceleration is None):
        raise ShapeError("give both joint_velocity and joint_acceleration, or neither")
    if joint_velocity is None:
        g = kin.g_sensor(joints, tool.gravity).reshape(n, 3)
        return ToolLoad(g, weight_wrench(tool, g, codes))
    motion = kin.sensor_motion(joints, joint_velocity, joint_acceleration)
    g = np.einsum("nji,j->ni", motion.R_world_sensor.reshape(n, 3, 3), kin.g_world(tool.gravity))
    static = weight_wrench(tool, g, codes)
    if codes[0] == codes[-1] and np.all(codes == codes[0]):  # one configuration (the usual block): no copies
        moving = tool.configurations[int(codes[0])].dynamic_wrench(g, motion.omega, motion.alpha, motion.a)
        return ToolLoad(g, static, moving, motion)
    moving = np.zeros((n, 6))
    for k, tool_configuration in enumerate(tool.configurations):
        mine = codes == k
        if mine.any():
            moving[mine] = tool_configuration.dynamic_wrench(g[mine], motion.omega[mine], motion.alpha[mine], motion.a[mine])
    return ToolLoad(g, static, moving, motion)


def weight_wrench(tool: Tool, g_sensor: np.ndarray, configuration: np.ndarray) -> np.ndarray:
    """The weight alone of the tool's configurations (eqs 17-18): ``[m g; c x m g]``.

    Args:
        tool: The tool.
        g_sensor: Gravity in the sensor frame [m/s^2], shape (N, 3).
        configuration: Configuration index of each sample, shape (N,) int.

    Returns:
        Shape (N, 6), [N, N, N, N m, N m, N m].
    """
    matrices = np.stack([c.wrench_matrix for c in tool.configurations])  # (k, 6, 3): W = M g
    return np.einsum("nij,nj->ni", matrices[np.asarray(configuration, dtype=np.int64)], np.asarray(g_sensor, dtype=float).reshape(-1, 3))


def dynamic_fraction(tool: Tool, configuration: np.ndarray, dynamic_part: np.ndarray) -> np.ndarray:
    """How large the dynamic part of the tool's wrench is, relative to its weight.

    Args:
        tool: The tool (the weight and lever of each configuration).
        configuration: Configuration index of each sample, shape (N,).
        dynamic_part: The moving wrench less the static one [N, N m], shape (N, 6).

    Returns:
        Per sample, the larger of ``|force part| / (m g)`` and ``|moment part| / (m g |c|)``
        (``|c|`` at least 1 mm), shape (N,).
    """
    fraction = np.zeros(len(configuration))
    for c, tool_configuration in enumerate(tool.configurations):
        mine = configuration == c
        weight = tool_configuration.mass * tool.gravity
        lever = max(float(np.linalg.norm(tool_configuration.p_sensor_com)), 1e-3)
        fraction[mine] = np.maximum(
            np.linalg.norm(dynamic_part[mine, :3], axis=1) / weight, np.linalg.norm(dynamic_part[mine, 3:], axis=1) / (weight * lever)
        )
    return fraction

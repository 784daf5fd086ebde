"""The motion of the sensor frame: its velocity and classical acceleration, expressed in the sensor frame.

:meth:`fts_calib.robot.kinematics.Kinematics.sensor_motion` computes it from joint readings,
rates and accelerations (it is re-exported from :mod:`fts_calib.robot.kinematics`); the tool's
dynamic load is computed from it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SensorMotion:
    """Velocity and classical acceleration of the sensor frame, expressed in the sensor frame.

    Attributes:
        omega: Angular velocity [rad/s]. Shape (3,) or (N, 3).
        alpha: Angular acceleration [rad/s^2]. Shape (3,) or (N, 3).
        v: Linear velocity of the origin of S [m/s]. Shape (3,) or (N, 3).
        a: Classical linear acceleration of the origin of S [m/s^2]. Shape (3,) or (N, 3).
        R_world_sensor: Orientation of S. Shape (3, 3) or (N, 3, 3).
    """

    omega: np.ndarray
    alpha: np.ndarray
    v: np.ndarray
    a: np.ndarray
    R_world_sensor: np.ndarray

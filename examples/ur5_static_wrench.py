"""Sensor orientation and the calibration tool's static wrench on a UR5 (paper eqs 17-18)."""

import numpy as np

from fts_calib.core.resources import resolve
from fts_calib.robot.definition import load_robot
from fts_calib.robot.kinematics import Kinematics
from fts_calib.robot.tool import load_tool


def _r(x):
    return (np.round(x, 3) + 0.0).tolist()  # + 0.0 turns -0.0 into 0.0


def main():
    """Point the tool straight down, then turn the wrist by 90°, and print what the sensor carries."""
    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    tool = load_tool(resolve("paper_tool", "configs"))
    down = np.array([0.0, -np.pi / 2, np.pi / 2, -np.pi / 2, -np.pi / 2, 0.0])  # [rad], tool axis pointing down
    tilted = down.copy()
    tilted[4] += np.pi / 2  # wrist_2 by +90°: the tool axis becomes horizontal
    for label, reading in (("tool pointing down", down), ("wrist_2 + 90°", tilted)):
        T_world_sensor = kin.sensor_pose(reading)
        g_sensor = kin.g_sensor(reading, tool.gravity)
        print(f"{label}: sensor at {_r(T_world_sensor.translation)} m, g_sensor = {_r(g_sensor)} m/s²")
        for config in tool.configurations:
            w = config.static_wrench(g_sensor)
            print(
                f"  tool {config.name} (m = {config.mass} kg, c = {config.p_sensor_com.tolist()} m): F = {_r(w[:3])} N, M = {_r(w[3:])} N·m"
            )
    print(
        "expected, tool down: F = [19.62, 0, 0] N for every configuration (2 kg along +X of S); "
        "M = c × F = [0, 0, 0], [0, 0, -1.177], [0, 1.177, 0] N·m for A, B, C"
    )


if __name__ == "__main__":
    main()

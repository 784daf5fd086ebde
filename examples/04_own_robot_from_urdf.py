"""Your own robot from a URDF: the sensor's orientation and the calibration tool's static wrench.

No robot YAML needed to start: ``Kinematics.from_urdf`` takes a URDF path and where the
sensor sits (the parent frame, ``xyz`` in m, ``rpy`` in rad); fixed fingers are locked.
The arm here is the Unitree Z1 shipped with example-robot-data (not one of fts-calib's
robots). For two poses the example prints the sensor's pose, gravity in the sensor frame
and the paper's tool wrench of each configuration (eqs 17-18: ``F = m g_sensor``,
``M = c × F``), beside what those equations give. A ``pin.Model`` one already holds works
the same way through ``Kinematics.from_model``.
"""

import numpy as np

import fts_calib
from fts_calib.core.resources import example_robot_data_dir


def _r(x):
    return (np.round(x, 3) + 0.0).tolist()  # + 0.0 turns -0.0 into 0.0


def main():
    """Build the kinematics from the URDF, then print the tool's wrench at two poses."""
    urdf = example_robot_data_dir() / "robots" / "z1_description" / "urdf" / "z1.urdf"
    kin = fts_calib.Kinematics.from_urdf(
        urdf,
        parent_frame="link06",  # the last link: its X axis is joint6's axis, the tool axis (as the paper's S)
        xyz=(0.05, 0.0, 0.0),  # [m] the sensor's origin 5 cm out along the tool axis
        rpy=(0.0, 0.0, 0.0),  # [rad] S = link06's axes
        locked_joints={"jointGripper": 0.0},  # [rad] the gripper stays closed
    )
    tool = fts_calib.load_tool("paper_tool")
    print(f"{kin.robot.name}: joints {', '.join(kin.joint_names)}; sensor on link06")
    for label, joints in (("all joints at 0", np.zeros(6)), ("wrist turned", np.array([0.3, 0.8, -0.6, 0.4, 1.1, 0.5]))):  # [rad]
        T_world_sensor = kin.sensor_pose(joints)
        g_sensor = kin.g_sensor(joints, tool.gravity)  # [m/s²]
        print(f"{label}: sensor at {_r(T_world_sensor.translation)} m, g_sensor = {_r(g_sensor)} m/s²")
        for config in tool.configurations:
            w = config.static_wrench(g_sensor)
            print(
                f"  tool {config.name} (m = {config.mass} kg, c = {config.p_sensor_com.tolist()} m): F = {_r(w[:3])} N, M = {_r(w[3:])} N·m"
            )
    print(f"expected: |F| = m |g| = {tool.configurations[0].mass * tool.gravity:.2f} N at every pose, M = c × F (eqs 17-18)")


if __name__ == "__main__":
    main()

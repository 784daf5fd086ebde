"""Kinematics against the URDF multiplied by hand, finite differences and eqs 17-18."""

import math

import numpy as np
import pinocchio as pin
import pytest

from fts_calib import FrameNotFound, FtsCalibWarning
from fts_calib.core.exceptions import JointError
from fts_calib.core.resources import resolve
from fts_calib.robot.definition import load_robot
from fts_calib.robot.kinematics import Kinematics
from fts_calib.robot.tool import ToolConfiguration

from .conftest import random_readings
from .urdf_chain import UrdfChain, homogeneous, rot_rpy

ATOL_ROTATION = 1e-12  # [-]
ATOL_POSITION = 1e-12  # [m]
SHIPPED = ["ur5", "ur10", "panda", "kinova", "xarm7"]


@pytest.mark.parametrize("name", ["ur5", "panda"])
def test_sensor_pose_matches_the_urdf_multiplied_by_hand(name, robot_kinematics, rng):
    kin = robot_kinematics(name)
    chain = UrdfChain(kin.robot.urdf)
    mount = kin.robot.sensor
    T_parent_sensor = homogeneous(rot_rpy(*mount.rpy), mount.xyz)
    readings = random_readings(kin, 40, rng)
    R_batch, p_batch = kin.sensor_poses(readings)
    for i, reading in enumerate(readings):
        angles = dict(zip(kin.joint_names, reading, strict=True))
        expected = chain.pose(mount.parent_frame, angles) @ T_parent_sensor
        single = kin.sensor_pose(reading)
        np.testing.assert_allclose(single.rotation, expected[:3, :3], atol=ATOL_ROTATION, err_msg=f"{name} sample {i}, Pinocchio path")
        np.testing.assert_allclose(single.translation, expected[:3, 3], atol=ATOL_POSITION)
        np.testing.assert_allclose(R_batch[i], expected[:3, :3], atol=ATOL_ROTATION, err_msg=f"{name} sample {i}, batch path")
        np.testing.assert_allclose(p_batch[i], expected[:3, 3], atol=ATOL_POSITION)


@pytest.mark.parametrize("name", SHIPPED)
def test_batch_and_single_paths_agree_and_rotations_stay_orthonormal(name, robot_kinematics, rng):
    kin = robot_kinematics(name)
    readings = random_readings(kin, 30, rng)
    R = kin.R_world_sensor(readings)
    np.testing.assert_allclose(R @ np.swapaxes(R, 1, 2), np.broadcast_to(np.eye(3), R.shape), atol=1e-13)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-13)
    for i in (0, 7, 29):
        np.testing.assert_allclose(kin.R_world_sensor(readings[i]), R[i], atol=ATOL_ROTATION)
    velocities, accelerations = rng.standard_normal((2, 30, kin.n_joints))
    batch = kin.sensor_motion(readings, velocities, accelerations)
    for i in (0, 13):
        one = kin.sensor_motion(readings[i], velocities[i], accelerations[i])
        for field in ("omega", "alpha", "v", "a"):
            np.testing.assert_allclose(getattr(batch, field)[i], getattr(one, field), atol=1e-12, err_msg=f"{name} {field}")


def test_sensor_x_axis_is_the_tool_axis_of_the_flange(ur5, rng):
    """The mount's rpy makes S's X the flange's Z (the tool axis), as the definition says."""
    reading = random_readings(ur5, 1, rng)[0]
    q = ur5.q_from_joints(reading)
    data = ur5.model.createData()
    pin.framesForwardKinematics(ur5.model, data, q)
    flange = data.oMf[ur5.model.getFrameId("tool0")]
    np.testing.assert_allclose(ur5.sensor_pose(reading).rotation[:, 0], flange.rotation[:, 2], atol=1e-12)
    np.testing.assert_allclose(ur5.sensor_pose(reading).translation, flange.translation + 0.02 * flange.rotation[:, 2], atol=1e-12)


def test_kinova_continuous_joints_take_angles_in_rad(kinova, rng):
    reading = random_readings(kinova, 1, rng)[0]
    for joint in ("j2s6s200_joint_1", "j2s6s200_joint_4", "j2s6s200_joint_6"):
        k = kinova.joint_names.index(joint)
        a, b = reading.copy(), reading.copy()
        a[k], b[k] = 3.5, 3.5 - 2 * math.pi  # -2.7832 rad: the same angle
        np.testing.assert_allclose(kinova.sensor_pose(a).homogeneous, kinova.sensor_pose(b).homogeneous, atol=1e-12)
        np.testing.assert_allclose(kinova.sensor_poses(np.array([a, b]))[0][0], kinova.sensor_poses(np.array([a, b]))[0][1], atol=1e-12)
    q = kinova.q_from_joints(reading)
    assert q.shape == (kinova.model.nq,) == (9,)


def test_static_wrench_from_kinematics_is_eqs_17_18_by_hand(ur5, paper_tool, rng):
    readings = random_readings(ur5, 25, rng)
    g_world = np.array([0.0, 0.0, -paper_tool.gravity])
    for config in paper_tool.configurations:
        W = config.static_wrench(ur5.g_sensor(readings, paper_tool.gravity))
        for i, reading in enumerate(readings):
            R = ur5.sensor_pose(reading).rotation
            F = config.mass * (R.T @ g_world)  # eq 17
            c = config.p_sensor_com
            M = np.array([c[1] * F[2] - c[2] * F[1], c[2] * F[0] - c[0] * F[2], c[0] * F[1] - c[1] * F[0]])  # eq 18
            np.testing.assert_allclose(W[i], np.concatenate([F, M]), atol=1e-12)
            np.testing.assert_allclose(config.static_wrench(ur5.g_sensor(reading, paper_tool.gravity)), W[i], atol=1e-12)


def test_dynamic_wrench_equals_static_at_rest(ur5, paper_tool, rng):
    readings = random_readings(ur5, 10, rng)
    zero = np.zeros_like(readings)
    motion = ur5.sensor_motion(readings, zero, zero)
    g = ur5.g_sensor(readings, paper_tool.gravity)
    for config in paper_tool.configurations:
        np.testing.assert_allclose(config.dynamic_wrench(g, motion.omega, motion.alpha, motion.a), config.static_wrench(g), atol=1e-12)


def _log3(R):
    return pin.log3(R)


@pytest.mark.parametrize("name", ["ur5", "panda"])
def test_motion_and_dynamic_wrench_match_finite_differences_of_the_pose(name, robot_kinematics, paper_tool, rng):
    """q(t) = q0 + A sin(w t): velocities, accelerations and the tool wrench from poses at t +- h, 2h."""
    kin = robot_kinematics(name)
    q0 = random_readings(kin, 1, rng)[0]
    amp, freq, phase = rng.uniform(0.2, 0.6, kin.n_joints), rng.uniform(0.5, 2.0, kin.n_joints), rng.uniform(0, 6, kin.n_joints)

    def q_at(t):
        return q0 + amp * np.sin(freq * t + phase)

    t0, h = 0.3, 1e-4  # [s]
    q, qd, qdd = q_at(t0), amp * freq * np.cos(freq * t0 + phase), -amp * freq**2 * np.sin(freq * t0 + phase)
    motion = kin.sensor_motion(q, qd, qdd)
    poses = {k: kin.sensor_pose(q_at(t0 + k * h)) for k in (-2, -1, 0, 1, 2)}
    R, p = poses[0].rotation, poses[0].translation

    def omega_world(k):  # central difference of the orientation around t0 + k h
        return _log3(poses[k + 1].rotation @ poses[k - 1].rotation.T) / (2 * h)

    w_world = omega_world(0)
    alpha_world = (omega_world(1) - omega_world(-1)) / (2 * h)
    v_world = (poses[1].translation - poses[-1].translation) / (2 * h)
    a_world = (poses[1].translation - 2 * p + poses[-1].translation) / h**2
    tol = dict(rtol=1e-5, atol=1e-5)  # O(h^2) truncation and 1e-16/h^2 round-off
    np.testing.assert_allclose(motion.omega, R.T @ w_world, **tol)
    np.testing.assert_allclose(motion.v, R.T @ v_world, **tol)
    np.testing.assert_allclose(motion.a, R.T @ a_world, rtol=1e-4, atol=1e-4)
    np.testing.assert_allclose(motion.alpha, R.T @ alpha_world, rtol=1e-4, atol=1e-4)

    g_world = np.array([0.0, 0.0, -paper_tool.gravity])
    for config in paper_tool.configurations:
        c = config.p_sensor_com
        p_com = {k: poses[k].translation + poses[k].rotation @ c for k in (-1, 0, 1)}
        a_com = (p_com[1] - 2 * p_com[0] + p_com[-1]) / h**2
        F_world = config.mass * (g_world - a_com)
        I_world = R @ config.inertia_com @ R.T
        M_world = np.cross(p_com[0] - p, F_world) - (I_world @ alpha_world + np.cross(w_world, I_world @ w_world))
        expected = np.concatenate([R.T @ F_world, R.T @ M_world])
        got = config.dynamic_wrench(R.T @ g_world, motion.omega, motion.alpha, motion.a)
        np.testing.assert_allclose(got, expected, rtol=1e-4, atol=1e-4, err_msg=f"configuration {config.name}")


def test_tool_wrench_matrix_equals_the_pure_function(rng):
    from fts_calib.robot.tool import static_wrench

    config = ToolConfiguration("X", 1.7, np.array([0.1, -0.02, 0.05]))
    g = rng.standard_normal((5, 3))
    expected = static_wrench(1.7, [0.1, -0.02, 0.05], g)
    # a product and a difference of two: a few eps of the largest entry (moments can be near zero)
    np.testing.assert_allclose(config.static_wrench(g), expected, rtol=0, atol=1e-14 * np.abs(expected).max())


# -- bad input -----------------------------------------------------------------------------


def test_unknown_sensor_frame_lists_the_frames(tmp_path):
    text = resolve("ur5", "robots").read_text().replace("parent_frame: tool0", "parent_frame: flange")
    path = tmp_path / "ur5.yaml"
    path.write_text(text)
    with pytest.raises(FrameNotFound, match="frame 'flange' is not in the model; frames that exist: universe, .*tool0") as info:
        Kinematics(load_robot(path))
    assert "wrist_3_link" in info.value.available


def test_unknown_and_missing_joint_names_list_the_expected_ones(ur5):
    readings = dict.fromkeys(ur5.joint_names, 0.0)
    readings["shoulder_pan"] = readings.pop("shoulder_pan_joint")
    with pytest.raises(
        JointError,
        match=r"unknown joints \['shoulder_pan'\]; missing joints \['shoulder_pan_joint'\]; "
        r"expected joints, in order: shoulder_pan_joint, shoulder_lift_joint",
    ):
        ur5.R_world_sensor(readings)


def test_wrong_number_of_readings_is_a_clear_error(ur5):
    with pytest.raises(JointError, match=r"shape \(5,\) but the robot has 6 actuated joints"):
        ur5.R_world_sensor(np.zeros(5))
    with pytest.raises(JointError, match=r"shape \(3, 7\)"):
        ur5.g_sensor(np.zeros((3, 7)))


def test_mapping_of_arrays_is_a_batch(ur5, rng):
    readings = random_readings(ur5, 4, rng)
    as_map = {name: readings[:, k] for k, name in enumerate(ur5.joint_names)}
    np.testing.assert_allclose(ur5.R_world_sensor(as_map), ur5.R_world_sensor(readings), atol=0)


def test_readings_in_degrees_are_warned_about(ur5):
    readings = np.array([[0.0, -90.0, 90.0, -90.0, -90.0, 0.0]])
    with pytest.warns(FtsCalibWarning) as record:
        check = ur5.check_readings(readings)
    messages = [str(w.message) for w in record]
    assert any("look like degrees: shoulder_lift_joint reaches 90.0, elbow_joint reaches 90.0" in m for m in messages), messages
    assert any("outside the joint limits" in m for m in messages), messages
    assert set(check.degrees_suspected) >= {"shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint"}


def test_readings_outside_limits_are_warned_and_counted(panda):
    readings = np.zeros((5, 7))
    readings[:, 3] = -1.0  # inside panda_joint4's [-3.07, -0.07]
    readings[1, 3] = 0.5  # outside
    readings[3, 5] = 4.0  # outside panda_joint6's [-0.0175, 3.7525]
    with pytest.warns(FtsCalibWarning, match=r"2 reading\(s\) outside the joint limits \(panda_joint4: 1, panda_joint6: 1\)"):
        check = panda.check_readings(readings)
    assert check.outside_limits == 2 and check.outside_by_joint == {"panda_joint4": 1, "panda_joint6": 1}


def test_continuous_joints_have_no_limits_to_break(kinova):
    readings = np.zeros((1, 6))
    readings[0, 1], readings[0, 2], readings[0, 4] = 3.0, 3.0, 3.0  # bounded joints inside their limits
    readings[0, 0] = 7.0  # continuous: one turn and a bit
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert kinova.check_readings(readings).outside_limits == 0


def test_locked_panda_fingers_are_removed(panda):
    assert "panda_finger_joint1" not in panda.joint_names and panda.n_joints == 7 and panda.model.nq == 7


def test_unknown_sweep_or_locked_joint_is_a_clear_error(tmp_path):
    text = resolve("panda", "robots").read_text()
    path = tmp_path / "panda.yaml"
    path.write_text(text.replace("sweep_joints: [panda_joint6, panda_joint7]", "sweep_joints: [panda_joint6, panda_joint9]"))
    with pytest.raises(JointError, match=r"sweep joint \['panda_joint9'\] not among the actuated joints"):
        Kinematics(load_robot(path))
    path.write_text(text.replace("panda_finger_joint2: 0.0", "panda_finger_joint3: 0.0"))
    with pytest.raises(JointError, match=r"locked joint 'panda_finger_joint3' is not in the URDF"):
        Kinematics(load_robot(path))

"""Recordings that give the sensor's orientation instead of joint angles (issue 23, item 1)."""

import numpy as np
import pandas as pd
import pinocchio as pin
import pytest

from fts_calib.core.exceptions import RecordingError
from fts_calib.core.resources import resolve
from fts_calib.pipeline.calibrate import calibrate_recording
from fts_calib.planning.trajectory_io import TrajectoryFile
from fts_calib.robot.orientation import orientation_kinematics
from fts_calib.sim.recording import simulate_recording
from fts_calib.sim.sensor import load_simulated_sensor

MOUNT = np.array([0.1, -0.2, 0.3])  # TCP -> sensor of the tcp form [rad]


@pytest.fixture(scope="module")
def still_run(tmp_path_factory, short_plan, seed):
    """The short plan's still poses on a UR5, with noise and ADC: the joints file and its rotations."""
    from fts_calib import Kinematics, load_robot, load_tool

    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    tool = load_tool(resolve("paper_tool", "configs"))
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    p = short_plan
    trajectories = [TrajectoryFile(p.joint_names, p.time, p.q, p.qd, p.qdd, c.name) for c in tool.configurations]
    folder = tmp_path_factory.mktemp("orientation")
    path = simulate_recording(folder / "joints.csv", kin, tool, trajectories, sensor, np.random.default_rng(seed), poses_only=True)
    table = pd.read_csv(path)
    R = kin.R_world_sensor(table[list(kin.joint_names)].to_numpy())
    return kin, tool, folder, table, R, path


def _write(folder, table, name, columns):
    strains = [c for c in table.columns if c.startswith("strain_")]
    out = pd.concat([table[["time"]], pd.DataFrame(columns), table[[*strains, "tool"]]], axis=1)
    path = folder / f"{name}.csv"
    out.to_csv(path, index=False, float_format="%.17g")
    return path


@pytest.mark.parametrize("form", ["quaternion", "roll-pitch-yaw", "tcp"])
def test_each_orientation_form_gives_the_joints_calibration(still_run, form):
    """The same still run written with joints and with an orientation: C equal to 1e-9 relative
    (only the rotations' round-off, 1e-16, and the file's 17 digits differ between the two)."""
    kin, tool, folder, table, R, joints_path = still_run
    if form == "quaternion":
        q = np.array([pin.Quaternion(r).coeffs() for r in R])  # x, y, z, w
        q *= np.where(np.arange(len(q)) % 2, -1.0, 1.0)[:, None]  # q and -q: the same rotation
        columns = {"qw": q[:, 3], "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2]}
        gimbal = orientation_kinematics()
    elif form == "roll-pitch-yaw":
        rpy = np.array([pin.rpy.matrixToRpy(r) for r in R])
        columns = {"roll": rpy[:, 0], "pitch": rpy[:, 1], "yaw": rpy[:, 2]}
        gimbal = orientation_kinematics()
    else:  # the TCP's rotation vector, the sensor turned from it by the mount
        tcp = R @ pin.rpy.rpyToMatrix(*MOUNT).T
        rv = np.array([pin.log3(r) for r in tcp])
        columns = {"tcp_rx": rv[:, 0], "tcp_ry": rv[:, 1], "tcp_rz": rv[:, 2]}
        gimbal = orientation_kinematics(MOUNT)
    path = _write(folder, table, form, columns)
    reference = calibrate_recording(joints_path, kin, tool)  # default options: the quasi-static filter on
    found = calibrate_recording(path, gimbal, tool)
    assert reference.calibration is not None and found.calibration is not None, (reference.error, found.error)
    assert np.array_equal(found.session.kept, reference.session.kept)  # the filter keeps the same samples
    scale = np.abs(reference.calibration.C).max()
    np.testing.assert_allclose(found.calibration.C, reference.calibration.C, rtol=1e-9, atol=1e-9 * scale)  # seen: 2e-14
    np.testing.assert_allclose(found.calibration.D, reference.calibration.D, rtol=1e-9, atol=1e-9 * np.abs(reference.calibration.D).max())


def test_a_recording_without_orientation_names_the_forms(still_run):
    kin, tool, folder, table, R, joints_path = still_run
    with pytest.raises(
        RecordingError, match=r"must give the sensor's orientation: columns qw,qx,qy,qz or roll,pitch,yaw or tcp_rx,tcp_ry,tcp_rz"
    ):
        calibrate_recording(joints_path, orientation_kinematics(), tool, use_filter=False)


def test_calibrate_and_validate_without_a_robot_from_the_command_line(still_run, tmp_path, capsys):
    """The tcp form with its mount, no --robot: calibrate writes the joints run's C, and
    validate of the same recording is at the noise (the true C within 0.1 % FS)."""
    from fts_calib import load_calibration
    from fts_calib.app.cli import main
    from fts_calib.app.exit_codes import ExitCode

    kin, tool, folder, table, R, joints_path = still_run
    rv = np.array([pin.log3(r) for r in R @ pin.rpy.rpyToMatrix(*MOUNT).T])
    path = _write(tmp_path, table, "tcp", {"tcp_rx": rv[:, 0], "tcp_ry": rv[:, 1], "tcp_rz": rv[:, 2]})
    mount = [f"{v:.17g}" for v in MOUNT]
    out = tmp_path / "cal.yaml"
    assert main(["calibrate", str(path), "--tool", "paper_tool", "--mount", *mount, "-o", str(out), "--quiet"]) == 0
    reference = calibrate_recording(joints_path, kin, tool).calibration
    np.testing.assert_allclose(load_calibration(out).C, reference.C, rtol=1e-9, atol=1e-9 * np.abs(reference.C).max())
    capsys.readouterr()
    assert (
        main(
            ["validate", str(path), "--calibration", str(out), "--tool", "paper_tool", "--mount", *mount, "--static", "--max-error", "0.1"]
        )
        == 0
    )
    assert "validation of 1 calibration(s)" in capsys.readouterr().out
    assert main(["calibrate", str(joints_path), "--tool", "paper_tool", "-o", str(tmp_path / "x.yaml")]) == ExitCode.RECORDING
    assert "no --robot given, so the recording must give the sensor's orientation" in capsys.readouterr().err
    assert (
        main(["calibrate", str(path), "--robot", "ur5", "--tool", "paper_tool", "--mount", "0", "0", "0", "-o", str(tmp_path / "y.yaml")])
        != 0
    )
    assert "no --mount with --robot" in capsys.readouterr().err

"""A factory-calibrated 6-axis sensor (layout wrench-6) re-calibrated in situ, end to end.

The simulated sensor of ``configs/factory_sensor.yaml`` reports a wrench whose factory matrix
is 3 % off in gain and rotated by 2°: the recording (strain_1..strain_6) goes through the
same filter, session and fit check as the paper's sensor, and the calibration finds the
correction C_bar and the offsets.
"""

import numpy as np
import pytest

from fts_calib.app.cli import main
from fts_calib.app.exit_codes import ExitCode
from fts_calib.core.exceptions import ShapeError
from fts_calib.core.resources import resolve
from fts_calib.model.calibration import load_calibration
from fts_calib.model.channels import MALTESE_CROSS_8, WRENCH_6
from fts_calib.model.sensor_config import load_sensor_config
from fts_calib.session.calibration_run import calibrate_recording
from fts_calib.sim.sensor import simulated_sensor
from tests.helpers import random_gravity, tool_wrench

#: Largest error accepted, in standard errors of the coefficient (36 + 6 coefficients at 5
#: sigma: P(any outside) < 42 x 6e-7 = 3e-5 for a seed).
MAX_Z = 5.0


@pytest.fixture(scope="module")
def factory():
    path = resolve("factory_sensor", "configs")
    return simulated_sensor(load_sensor_config(path), path)


@pytest.fixture(scope="module")
def factory_recording(tmp_path_factory, short_plan, seed, factory):
    from fts_calib.planning.trajectory_files import TrajectoryFile
    from fts_calib.robot.definition import load_robot
    from fts_calib.robot.kinematics import Kinematics
    from fts_calib.robot.tool import load_tool
    from fts_calib.sim.runs import simulate_recording

    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    tool = load_tool(resolve("paper_tool", "configs"))
    p = short_plan
    trajectories = [TrajectoryFile(p.joint_names, p.time, p.q, p.qd, p.qdd, c.name) for c in tool.configurations]
    path = tmp_path_factory.mktemp("factory") / "wrench.csv"
    return simulate_recording(path, kin, tool, trajectories, factory, np.random.default_rng(seed))


def test_the_factory_sensor_is_three_percent_off_and_rotated_two_degrees(factory):
    assert factory.layout == WRENCH_6
    scale = np.cbrt(np.linalg.det(factory.C_bar[:3, :3]))
    R = factory.C_bar[:3, :3] / scale
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-8)
    assert scale == pytest.approx(1.03, abs=1e-8)
    assert np.degrees(np.arccos((np.trace(R) - 1) / 2)) == pytest.approx(2.0, abs=1e-6)
    np.testing.assert_array_equal(factory.C_bar[3:, 3:], factory.C_bar[:3, :3])


def test_recalibration_finds_the_truth(ur5, paper_tool, factory_recording, factory):
    header = factory_recording.read_text().splitlines()[0].split(",")
    assert [c for c in header if c.startswith("strain_")] == [f"strain_{k}" for k in range(1, 7)]
    result = calibrate_recording(factory_recording, ur5, paper_tool, layout=WRENCH_6)
    cal = result.calibration
    assert cal is not None, result.error
    assert cal.layout == WRENCH_6 and cal.C.shape == (6, 6)
    assert cal.quality.fit["verdict"] == "consistent", cal.quality.fit
    # the factory wrench itself (C_bar = I) is off by up to 0.0298 in a coefficient
    factory_error = np.abs(np.eye(6) - factory.C_bar).max()
    assert factory_error > 0.029
    z_C = np.abs(cal.C_bar - factory.C_bar) / cal.quality.stderr_C_bar
    z_D = np.abs(cal.D - factory.D) / cal.quality.stderr_D
    assert z_C.max() <= MAX_Z and z_D.max() <= MAX_Z, (z_C.max(), z_D.max())
    # over the tool's loads in every orientation: the factory wrench, even ideally tared, is
    # off by up to 3 % of the load (0.84 N, 0.084 N m); the re-calibrated one by its
    # coefficients' standard errors (at most 2.6e-3 N and 1.7e-4 N m, 0.3 % of that, over 30 seeds)
    rng = np.random.default_rng(0)
    W = np.vstack([tool_wrench(c.mass, c.p_sensor_com, random_gravity(300, rng)) for c in paper_tool.configurations])
    tared_factory = np.abs(np.linalg.solve(factory.C_bar, W.T).T - W).max(axis=0)
    recalibrated = np.abs(cal.wrench(factory.channels(W)) - W).max(axis=0)
    assert np.all(recalibrated < tared_factory / 100), (recalibrated, tared_factory)


def test_cli_selects_the_sensor_and_names_both_channel_counts(tmp_path, factory_recording, capsys):
    out = tmp_path / "cal.yaml"
    args = ["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(factory_recording), "-o", str(out)]
    assert main([*args, "--sensor", "factory_sensor"]) == ExitCode.OK
    text = capsys.readouterr().out
    assert "Δ6" in text and "Δ7" not in text
    assert load_calibration(out).layout == WRENCH_6
    out.unlink()
    assert main(args) == ExitCode.ARRAY  # the default sensor: the paper's 8 bridges
    err = capsys.readouterr().err
    assert f"{factory_recording} has 6 channels but the sensor's layout maltese-cross-8 has 8" in err
    assert "--sensor" in err and not out.exists()


def test_a_session_refuses_samples_of_another_width(ur5, paper_tool):
    from fts_calib.session.session import CalibrationSession

    session = CalibrationSession(ur5, paper_tool, source="robot", layout=MALTESE_CROSS_8)
    with pytest.raises(ShapeError, match=r"robot has 6 channels but the sensor's layout maltese-cross-8 has 8"):
        session.add_batch(np.zeros(3), np.zeros((3, 6)), np.zeros((3, 6)), "A")
    with pytest.raises(ShapeError, match=r"channels.shape=\(6,\) but expected \(8,\)"):
        session.add(0.0, np.zeros(6), np.zeros(6), "A")


def test_live_counts_and_names_strain_datagrams_of_another_length():
    from fts_calib.session.calibration_run import format_stats
    from fts_calib.sources.synchronizer import Synchronizer
    from fts_calib.sources.udp import Joints, LiveStats, Strain, ToolChange, encode, feed_datagram

    sync, stats = Synchronizer(["a"], n_channels=6, configurations=["A"]), LiveStats()
    feed_datagram(encode(ToolChange(0.0, "A")), sync, stats)
    for k in range(10):
        feed_datagram(encode(Joints(0.01 * k, {"a": 0.0})), sync, stats)
    for k, n in enumerate([6, 8, 6, 8, 8]):  # a paper sensor's datagrams mixed in
        feed_datagram(encode(Strain(0.01 * k + 0.005, (0.1,) * n)), sync, stats)
    batch = sync.pop(final=True)
    assert batch.channels.shape == (2, 6) and stats.strain == 5
    text = format_stats(stats, sync)
    assert "strain message of another length than the sensor's channels: expected 6: 3" in text

"""Validation: at the noise floor with the true calibration, the perturbation with a wrong one."""

import numpy as np
import pytest

from fts_calib import Calibration, load_calibration
from fts_calib.core.resources import resolve
from fts_calib.model.sensor_config import load_sensor_config
from fts_calib.planning.motion import sample_motion
from fts_calib.planning.trajectory_files import TrajectoryFile
from fts_calib.robot.tool import load_tool
from fts_calib.service.validation import validate_recording
from fts_calib.sim.runs import simulate_recording
from fts_calib.sim.sensor import SimulatedSensor

from .paper import ROUNDING, TABLE_1, TABLE_2

HOME = np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0])
JOINTS = ("wrist_1_joint", "wrist_2_joint", "wrist_3_joint")


@pytest.fixture(scope="module")
def setup(tmp_path_factory, _kinematics_cache, seed):
    from .conftest import _kinematics

    kin = _kinematics(_kinematics_cache, "ur5")
    tool = load_tool(resolve("validation_tool", "configs"))
    spec = load_sensor_config(resolve("sensor", "configs"))
    sensor = SimulatedSensor.from_spec(spec.simulated)
    rng = np.random.default_rng([seed, 0])  # the motion; [seed, 1] and [seed, 2] the noise of the recordings
    stops = HOME[[3, 4, 5]] + rng.uniform(-1.0, 1.0, (8, 3))
    t, q, qd, qdd = sample_motion(kin, HOME, JOINTS, stops, 0.0, 500.0)
    traj = [TrajectoryFile(kin.joint_names, t, q, qd, qdd, "V")]
    folder = tmp_path_factory.mktemp("validation")
    static = simulate_recording(folder / "static.csv", kin, tool, traj, sensor, np.random.default_rng([seed, 1]), dynamic=False)
    moving = simulate_recording(folder / "moving.csv", kin, tool, traj, sensor, np.random.default_rng([seed, 2]))
    return kin, tool, spec, static, moving


def test_the_true_calibration_validates_at_the_noise_floor(setup):
    """With the tool's weight as the truth on both sides, only the strain noise is left: the
    RMS error per axis is the predicted sigma_W = sqrt((C diag(s^2) C^T)_jj) (to 10 %, the
    sampling error of an RMS over 10,000 samples being 0.7 %, plus quantization)."""
    kin, tool, spec, static, _ = setup
    sensor = spec.simulated
    true = Calibration(sensor.C_bar, sensor.D)
    result = validate_recording(static, kin, tool, [true], spec.full_scale, dynamic=False)
    sigma_W = np.sqrt(np.diag(sensor.C @ np.diag(sensor.noise_std**2) @ sensor.C.T))
    np.testing.assert_allclose(result.errors[0].rms, sigma_W, rtol=0.1)
    assert np.all(result.errors[0].max_abs < 6 * sigma_W)


def test_the_moving_tool_validates_within_the_target(setup):
    kin, tool, spec, _, moving = setup
    true = Calibration(spec.simulated.C_bar, spec.simulated.D)
    dynamic = validate_recording(moving, kin, tool, [true], spec.full_scale)
    static = validate_recording(moving, kin, tool, [true], spec.full_scale, dynamic=False)
    assert dynamic.errors[0].max_percent.max() < 0.2
    assert static.errors[0].max_percent.max() > 5 * dynamic.errors[0].max_percent.max()  # dynamics uncompensated


def test_a_perturbed_calibration_shows_its_perturbation(setup):
    kin, tool, spec, static, _ = setup
    sensor = spec.simulated
    true = Calibration(sensor.C_bar, sensor.D)
    shift = np.array([0.5, 0.0, 0.0, 0.0, 0.05, 0.0])  # [N, N·m]
    scaled = sensor.C_bar.copy()
    scaled[1] *= 1.01  # Fy 1 % too large
    wrong = Calibration(scaled, sensor.D + shift)
    result = validate_recording(static, kin, tool, [wrong, true], spec.full_scale, dynamic=False)
    errors, between = result.errors[0], result.between
    # offsets: the error is the shift, plus noise (sigma_W << shift)
    assert errors.rms[0] == pytest.approx(0.5, rel=1e-3) and errors.rms[4] == pytest.approx(0.05, rel=1e-2)
    # the Fy row: 1 % of what the true calibration measures without its offset
    expected_fy = result.measured[1][:, 1] - sensor.D[1]
    np.testing.assert_allclose(between.max_abs[1], 0.01 * np.max(np.abs(expected_fy)), rtol=1e-3)
    assert between.max_abs[0] == pytest.approx(0.5, abs=1e-9) and between.max_abs[2] < 1e-9


def test_shipped_paper_tables_are_calibration_files():
    for name, table in (("paper_table1_calibration", TABLE_1), ("paper_table2_calibration", TABLE_2)):
        cal = load_calibration(resolve(name, "configs"))
        np.testing.assert_allclose(cal.C, table, atol=ROUNDING)
        np.testing.assert_array_equal(cal.D, np.zeros(6))


def test_validate_refuses_three_calibrations(setup):
    kin, tool, spec, static, _ = setup
    true = Calibration(spec.simulated.C_bar, spec.simulated.D)
    with pytest.raises(ValueError, match="3 calibrations given but expected one or two"):
        validate_recording(static, kin, tool, [true] * 3, spec.full_scale)
    with pytest.raises(ValueError, match="0 calibrations given"):
        validate_recording(static, kin, tool, [], spec.full_scale)
    # one or two are taken; a calibration against itself differs by exactly nothing
    one = validate_recording(static, kin, tool, [true], spec.full_scale, dynamic=False)
    two = validate_recording(static, kin, tool, [true, true], spec.full_scale, dynamic=False)
    assert one.between is None and two.samples == one.samples > 0
    np.testing.assert_array_equal(two.between.max_abs, np.zeros(6))
    np.testing.assert_array_equal(two.errors[0].rms, one.errors[0].rms)
    np.testing.assert_array_equal(two.errors[1].rms, one.errors[0].rms)


@pytest.mark.parametrize("value", ["-50", "0", "nan"])
def test_a_full_scale_that_is_not_positive_is_refused_before_reading(tmp_path, value, capsys):
    from fts_calib.app.cli import main
    from fts_calib.app.exit_codes import ExitCode

    table1 = str(resolve("paper_table1_calibration", "configs"))
    command = ["validate", "--calibration", table1, "--robot", "ur5", str(tmp_path / "unread.csv"), "--full-scale-force", value]
    assert main(command) == ExitCode.CONFIG
    err = capsys.readouterr().err
    if value == "nan":  # refused while the options are read (every numeric option: options.Number)
        assert err == "fts-calib validate: error: option --full-scale-force: expected a finite number, got 'nan'\n"
    else:
        assert "full_scale=" in err


# --- inside and outside the calibration's load region ----------------------------------------------------------------


@pytest.fixture(scope="module")
def poses(tmp_path_factory, short_plan, seed, _kinematics_cache):
    """A static-pose recording of the short plan (the arm still at each stop), its calibration and the kinematics."""
    from fts_calib.session.calibration_run import calibrate_recording

    from .conftest import _kinematics

    kin = _kinematics(_kinematics_cache, "ur5")
    tool = load_tool(resolve("paper_tool", "configs"))
    sensor = SimulatedSensor.from_spec(load_sensor_config(resolve("sensor", "configs")).simulated)
    p = short_plan
    plan = [TrajectoryFile(p.joint_names, p.time, p.q, p.qd, p.qdd, name) for name in tool.names]
    path = tmp_path_factory.mktemp("poses") / "poses.csv"
    simulate_recording(path, kin, tool, plan, sensor, np.random.default_rng([seed, 3]), poses_only=True)
    result = calibrate_recording(path, kin, tool)
    assert result.calibration is not None, result.error
    return kin, tool, plan, sensor, path, result.calibration


def _check_split(result):
    """The two parts hold every sample, and their sums of squares and maxima make the whole's."""
    split, whole = result.regions[0], result.errors[0]
    assert split.inside_samples + split.outside_samples == result.samples
    # rms^2 n = rms_in^2 n_in + rms_out^2 n_out: the same squares summed in two groups (round-off ~1e-15 relative)
    squares = split.inside.rms**2 * split.inside_samples + split.outside.rms**2 * split.outside_samples
    np.testing.assert_allclose(squares, whole.rms**2 * result.samples, rtol=1e-9)
    np.testing.assert_array_equal(np.maximum(split.inside.max_abs, split.outside.max_abs), whole.max_abs)
    # classified by the expected wrench: every sample is in the plot's series below 20,000 samples
    assert len(result.expected) == result.samples
    assert int(split.region.contains(result.expected).sum()) == split.inside_samples


def test_the_calibrations_own_static_poses_lie_inside_its_region(poses):
    kin, tool, _, _, path, calibration = poses
    full_scale = load_sensor_config(resolve("sensor", "configs")).full_scale
    result = validate_recording(path, kin, tool, [calibration], full_scale, dynamic=False)
    split, quality = result.regions[0], calibration.quality
    # every stop of the sweeps is inside. Each configuration's motion starts and ends with one still sample at the
    # home pose (the plan ends at rest there): too short for the filter's window, neither is kept, and their load
    # (gravity along -Y of S: Fy = -19.62 N) lies beyond the box of the sweeps: the region says so
    assert split.outside_samples == 2 * len(tool.names) == quality.samples_seen - quality.samples_used
    assert split.inside_samples == quality.samples_used > 1000
    _check_split(result)
    home = result.expected[~split.region.contains(result.expected)]
    weight = 2.0 * tool.gravity  # [N]
    np.testing.assert_allclose(home[:, 1], -weight, rtol=0, atol=1e-6 * weight)  # joints as the CSV writes them
    data = result.as_json()
    assert set(data["region"]) == {"inside", "outside"} and data["region"]["outside"]["samples"] == 2 * len(tool.names)
    assert data["region"]["inside"]["samples"] + data["region"]["outside"]["samples"] == data["samples"]


def test_a_heavier_tool_is_outside_the_region_and_the_calibrations_own_motion_partly(poses, ur5_recording, tmp_path):
    kin, tool, plan, sensor, _, calibration = poses
    full_scale = load_sensor_config(resolve("sensor", "configs")).full_scale
    heavy = tmp_path / "heavy_tool.yaml"  # twice the calibration tool's mass (2 kg) at its centres of mass
    configurations = "".join(f"  - {{name: {c.name}, mass: 4.0, com: {c.p_sensor_com.tolist()}}}\n" for c in tool.configurations)
    heavy.write_text(f"name: heavy tool\ngravity: 9.81\nconfigurations:\n{configurations}")
    heavy_tool = load_tool(heavy)
    recording = simulate_recording(tmp_path / "heavy.csv", kin, heavy_tool, plan, sensor, np.random.default_rng(5))
    result = validate_recording(recording, kin, heavy_tool, [calibration], full_scale)
    split = result.regions[0]
    # |F| = 4 kg x 9.81 = 39.2 N everywhere, beyond 19.62 N + |margin| 0.87 N: every sample is outside
    assert split.outside_samples == result.samples > 0 and split.inside_samples == 0
    _check_split(result)
    # the calibration's own moving recording: the stops inside, the motion between them partly outside
    moving = validate_recording(ur5_recording, kin, tool, [calibration], full_scale)
    assert 0 < moving.regions[0].outside_samples < moving.regions[0].inside_samples
    _check_split(moving)
    # a calibration without a region: no split, no json key
    bare = validate_recording(ur5_recording, kin, tool, [Calibration(calibration.C_bar, calibration.D)], full_scale)
    assert bare.regions == [None] and "region" not in bare.as_json()


def test_cli_validate_prints_and_writes_the_region_split(poses, ur5_recording, tmp_path, capsys):
    import json

    from fts_calib.app.cli import main

    calibration = poses[5].save(tmp_path / "cal.yaml")
    command = ["validate", "--calibration", str(calibration), "--robot", "ur5", "--tool", "paper_tool", str(ur5_recording)]
    assert main([*command, "--json", str(tmp_path / "v.json")]) == 0
    out = capsys.readouterr().out
    data = json.loads((tmp_path / "v.json").read_text())
    inside, outside = data["region"]["inside"]["samples"], data["region"]["outside"]["samples"]
    assert inside + outside == data["samples"] and outside > 0
    assert f"inside the calibrated load region: {inside:,} samples" in out and f"outside: {outside:,} samples" in out, out
    assert set(data["region"]["outside"]["axes"]) == set(data["axes"]) == {"Fx", "Fy", "Fz", "Mx", "My", "Mz"}
    table1 = str(resolve("paper_table1_calibration", "configs"))
    assert main([*command[:2], table1, *command[3:], "--json", str(tmp_path / "t.json")]) == 0
    assert "the calibration records no load region" in capsys.readouterr().out
    assert "region" not in json.loads((tmp_path / "t.json").read_text())

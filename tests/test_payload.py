"""Payload identification: exact without noise, honest uncertainties with it, refusals with reasons."""

import numpy as np
import pytest

from fts_calib import ShapeError, identify_payload
from fts_calib.core.exceptions import PayloadError
from fts_calib.robot.tool import load_tool, save_tool
from fts_calib.sim.sensor import load_simulated_sensor

MASS, COM = 1.37, np.array([0.03, -0.01, 0.085])  # [kg], [m]
OFFSETS = np.array([0.3, -0.2, 0.1, 0.01, -0.02, 0.005])  # [N, N·m]


def _poses(rng, per=200):
    """Eight well-spread orientations: the cube's corners (at least 70° apart), turned at random."""
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float) / np.sqrt(3)
    q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    return np.repeat(9.81 * corners @ q.T, per, axis=0)


def _wrench(g, rotation=None):
    g_real = g if rotation is None else g - np.cross(rotation, g)
    return np.hstack([MASS * g_real, np.cross(MASS * COM, g_real)]) + OFFSETS


def test_noiseless_data_give_the_payload_to_1e_9(rng):
    g = _poses(rng)
    est = identify_payload(_wrench(g), g)
    assert abs(est.mass - MASS) < 1e-9 and np.max(np.abs(est.com - COM)) < 1e-9
    assert np.max(np.abs(est.offsets - OFFSETS)) < 1e-9 and len(est.poses) == 8


def test_the_mount_rotation_is_recovered(rng):
    g = _poses(rng)
    rotation = np.array([0.01, -0.02, 0.005])  # [rad]
    est = identify_payload(_wrench(g, rotation), g, mount=True)
    np.testing.assert_allclose(est.mount_rotation, rotation, atol=1e-9)
    assert abs(est.mass - MASS) < 1e-9


def test_with_noise_the_errors_match_the_reported_uncertainty(seed):
    """400 seeds (spawned from ``seed``): the z-scores of mass and centre of mass have a spread of 1
    within 20 %. The spread of 400 z-scores is known to 1/sqrt(800) = 3.5 %, so 20 % is more than
    5.5 sigma either side (chi distribution), for each of the 4: P(fail) < 1e-7 for a seed."""
    z = []
    for child in np.random.SeedSequence(seed).spawn(400):
        rng = np.random.default_rng(child)
        g = _poses(rng, per=20)
        noise = np.hstack([0.02 * rng.standard_normal((len(g), 3)), 0.002 * rng.standard_normal((len(g), 3))])
        est = identify_payload(_wrench(g) + noise, g)
        z.append(np.concatenate([[(est.mass - MASS) / est.stderr_mass], (est.com - COM) / est.stderr_com]))
    spread = np.std(z, axis=0)
    assert np.all((spread > 0.8) & (spread < 1.2)), spread


def test_one_direction_is_refused_naming_what_is_missing(rng):
    g = np.tile([0.0, 0.0, -9.81], (300, 1))
    with pytest.raises(PayloadError, match=r"see it along one direction \(RMS spread 0.00°, below 3°\): the mass cannot be told"):
        identify_payload(_wrench(g), g)


def test_a_swing_about_one_axis_is_refused_naming_the_undetermined_direction(rng):
    """Tilts about the sensor's x axis only: gravity swings in the y-z plane, and the centre of
    mass along the swing (y) changes the moments only through the arc's small curvature."""
    angle = rng.uniform(-0.4, 0.4, 400)
    g = 9.81 * np.stack([np.zeros_like(angle), np.sin(angle), -np.cos(angle)], axis=1)
    # across: the arc's own curvature, 1 - cos(0.4) = 0.08 at most, an RMS below asin(0.04) = 2.3°
    with pytest.raises(
        PayloadError, match=r"swing about one axis only .* along \([+-]0.00, [+-]1.00, [+-]0.00\) in the sensor frame, [0-2]\.\d\d° across"
    ):
        identify_payload(_wrench(g), g)


def test_a_hundred_poses_within_25_degrees_determine_the_payload_with_their_uncertainty(seed):
    """100 poses tilted at random within ±25° about x and y (several pairs closer than the 15° a
    pairwise rule wants): identified, and the errors are within 5 reported standard errors."""
    rng = np.random.default_rng(seed)
    tilt = rng.uniform(-np.radians(25.0), np.radians(25.0), (100, 2))
    down = np.stack([np.sin(tilt[:, 1]), -np.sin(tilt[:, 0]) * np.cos(tilt[:, 1]), -np.cos(tilt[:, 0]) * np.cos(tilt[:, 1])], axis=1)
    g = 9.81 * np.repeat(down, 20, axis=0)
    noise = np.array([0.05, 0.05, 0.05, 0.002, 0.002, 0.002])  # [N, N m]
    est = identify_payload(_wrench(g) + rng.normal(0.0, noise, (len(g), 6)), g)
    assert np.all(est.spread_deg > 10.0), est.spread_deg  # uniform over ±25°: about 14° RMS
    assert abs(est.mass - MASS) < 5 * est.stderr_mass and est.stderr_mass < 1e-3  # seen: 0.0003 kg
    assert np.all(np.abs(est.com - COM) < 5 * est.stderr_com) and np.all(est.stderr_com < 1e-4), est.stderr_com  # seen: 0.02 mm


def test_shapes_are_checked(rng):
    with pytest.raises(ShapeError, match="w_measured has 3 rows but g_sensor has 4"):
        identify_payload(np.zeros((3, 6)), np.ones((4, 3)))


def test_the_payload_is_saved_as_a_tool_file(tmp_path, rng):
    g = _poses(rng)
    est = identify_payload(_wrench(g), g)
    path = save_tool(est.tool("gripper"), tmp_path / "gripper.yaml", header="identified in a test")
    tool = load_tool(path)
    assert tool.names == ["gripper"] and tool.configuration("gripper").mass == pytest.approx(MASS)
    assert path.read_text().startswith("# identified in a test")


def _payload_recording(path, ur5, poses, rng):
    """The validation payload held still 0.3 s in each pose, on the simulated sensor."""
    from fts_calib.core.resources import resolve
    from fts_calib.sources.recording import RecordingWriter

    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    payload = load_tool(resolve("validation_tool", "configs")).configurations[0]
    home = np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0])
    with RecordingWriter(path, ur5.joint_names) as writer:
        for k, (a, b) in enumerate(poses):
            reading = home.copy()
            reading[4], reading[5] = a, b
            t = 1.0 * k + np.arange(300) / 1000.0
            W = payload.static_wrench(ur5.g_sensor(reading, 9.81))
            writer.write(t, np.tile(reading, (300, 1)), sensor.channels(np.tile(W, (300, 1)), rng=rng), "payload")
    return path, payload


def test_cli_payload_identifies_and_refuses(tmp_path, ur5, rng, capsys):
    from fts_calib import Calibration
    from fts_calib.app.cli import main
    from fts_calib.app.exit_codes import ExitCode
    from fts_calib.core.resources import resolve
    from fts_calib.model.calibration import save_calibration

    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    cal = save_calibration(Calibration(sensor.C_bar, sensor.D), tmp_path / "cal.yaml")
    poses = [(0.0, 0.0), (1.2, 0.0), (-1.2, 0.5), (0.6, 2.0), (-0.5, -2.2), (2.2, 1.0)]
    path, payload = _payload_recording(tmp_path / "poses.csv", ur5, poses, rng)
    out = tmp_path / "payload.yaml"
    assert main(["payload", "--calibration", str(cal), "--robot", "ur5", str(path), "-o", str(out), "--name", "gripper"]) == 0
    text = capsys.readouterr().out
    assert "in 6 orientations" in text and "mass 1.4000" in text
    tool = load_tool(out)
    assert tool.configuration("gripper").mass == pytest.approx(payload.mass, rel=1e-4)
    np.testing.assert_allclose(tool.configuration("gripper").p_sensor_com, payload.p_sensor_com, atol=1e-4)
    one, _ = _payload_recording(tmp_path / "one.csv", ur5, [(0.3, 0.3)], rng)
    assert main(["payload", "--calibration", str(cal), "--robot", "ur5", str(one), "-o", str(tmp_path / "p.yaml")]) == ExitCode.PAYLOAD
    assert "see it along one direction (RMS spread 0.00°, below 3°)" in capsys.readouterr().err


def test_a_payload_recording_with_two_configuration_names_is_refused(tmp_path, ur5, ur5_recording, capsys):
    """Before: the rows of every configuration went into one fit (a tool change's B row counted as a 7th orientation of A)."""
    from fts_calib import Calibration
    from fts_calib.app.cli import main
    from fts_calib.app.exit_codes import ExitCode
    from fts_calib.core.resources import resolve
    from fts_calib.model.calibration import save_calibration

    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    cal = save_calibration(Calibration(sensor.C_bar, sensor.D), tmp_path / "cal.yaml")
    out = tmp_path / "p.yaml"
    assert main(["payload", "--calibration", str(cal), "--robot", "ur5", str(ur5_recording), "-o", str(out)]) == ExitCode.PAYLOAD
    err = capsys.readouterr().err
    assert "holds 3 tool configurations (A, B, C): a payload recording holds one payload" in err, err
    assert not out.exists()

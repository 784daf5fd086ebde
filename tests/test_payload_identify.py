"""One payload entry point: still or moving decided from the data and said, one estimate from any source, the old
spellings of the command warned about and giving the same file."""

import warnings

import numpy as np
import pytest

from fts_calib.app.setup import Setup, SourceOptions
from fts_calib.core.exceptions import ConfigError
from fts_calib.core.resources import resolve
from fts_calib.model.calibration import Calibration, save_calibration
from fts_calib.payload.estimate import MOVING, STILL, PayloadEstimate
from fts_calib.payload.identify import identify_payload
from fts_calib.payload.inertia_motion import payload_excitation
from fts_calib.robot.tool import load_tool
from fts_calib.sim.payload_run import simulate_payload_motion
from fts_calib.sim.sensor import load_simulated_sensor
from fts_calib.sources.recording import RecordingReader
from fts_calib.sources.source import ArraySource

from .test_payload import _payload_recording

HOME = np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0])  # [rad] the UR5's payload pose of tests/test_payload.py
POSES = [(0.0, 0.0), (1.2, 0.0), (-1.2, 0.5), (0.6, 2.0), (-0.5, -2.2), (2.2, 1.0)]  # [rad] wrist 2 and 3 of each still pose


@pytest.fixture(scope="module")
def sensor():
    return load_simulated_sensor(resolve("sensor", "configs"))


@pytest.fixture
def still_recording(tmp_path, ur5, rng):
    """The validation payload held still 0.3 s in six orientations: the path and the payload."""
    return _payload_recording(tmp_path / "poses.csv", ur5, POSES, rng)


@pytest.fixture(scope="module")
def motion_recording(tmp_path_factory, sensor):
    """The validation payload turned by the wrist for 9.7 s at 1 kHz (joints 8 ms late): the path and the payload."""
    from fts_calib.robot.definition import load_robot
    from fts_calib.robot.kinematics import Kinematics

    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    payload = load_tool(resolve("validation_tool", "configs")).configurations[0]
    motion = payload_excitation(kin, HOME, seconds=10.0, amplitude=1.0)
    path = tmp_path_factory.mktemp("motion") / "moving.csv"
    simulate_payload_motion(path, kin, payload, sensor, motion, np.random.default_rng(11), 0.008, 1e-5)
    return path, payload


def test_auto_decides_still_poses_on_a_still_recording_and_says_why(ur5, sensor, still_recording):
    path, payload = still_recording
    calibration = Calibration(sensor.C_bar, sensor.D)
    auto = identify_payload(path, ur5, calibration)
    forced = identify_payload(path, ur5, calibration, "still")
    assert isinstance(auto, PayloadEstimate) and auto.motion == STILL and auto.inertia_com is None and auto.latency_s is None
    assert auto.decided.startswith("decided from the data: still poses (1,800 of 1,800 samples still"), auto.decided
    assert "gravity spread" in auto.decided and forced.decided == ""
    assert auto.mass == forced.mass and np.array_equal(auto.com, forced.com)  # the same fit, only the words differ
    assert auto.mass == pytest.approx(payload.mass, rel=1e-3) and auto.source == str(path) and auto.rows == 1800


def test_auto_decides_a_motion_on_a_motion_recording_and_says_why(ur5, sensor, motion_recording):
    path, payload = motion_recording
    calibration = Calibration(sensor.C_bar, sensor.D)
    auto = identify_payload(path, ur5, calibration)
    forced = identify_payload(path, ur5, calibration, "moving")
    assert auto.motion == MOVING and auto.decided.startswith("decided from the data: a continuous motion (only "), auto.decided
    assert auto.mass == forced.mass and np.array_equal(auto.inertia_com, forced.inertia_com)
    assert auto.inertia_com is not None and auto.stderr.shape == (10,) and abs(auto.latency_s - 0.008) < 1e-4
    assert np.linalg.norm(auto.inertia_com - payload.inertia_com, 2) <= 0.1 * np.linalg.norm(payload.inertia_com, 2)


def test_arrays_and_any_source_give_the_recordings_estimate(ur5, sensor, still_recording):
    path, _ = still_recording
    calibration = Calibration(sensor.C_bar, sensor.D)
    reference = identify_payload(path, ur5, calibration)
    with RecordingReader(path, ur5.joint_names, None) as reader:
        batch = next(iter(reader))
        names = reader.tool_names
    for source in (batch, ArraySource(batch, tool_names=names), {"time": batch.time, "joints": batch.joints,
                                                                  "channels": batch.channels, "configuration": "payload"}):  # fmt: skip
        estimate = identify_payload(source, ur5, calibration)
        assert estimate.mass == reference.mass and np.array_equal(estimate.com, reference.com) and estimate.source == "arrays in memory"


def test_the_array_form_of_the_release_before_and_the_refusals(ur5, sensor, still_recording):
    g = np.repeat(9.81 * np.eye(3), 100, axis=0)  # [m/s^2] three orthogonal directions
    W = np.hstack([1.5 * g, np.cross(1.5 * np.array([0.01, 0.02, 0.03]), g)])  # [N, N m] 1.5 kg, no offset
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the array form's call is unchanged: no warning
        estimate = identify_payload(W, g)
        positional = identify_payload(W, g, False, 3.0)
    assert abs(estimate.mass - 1.5) < 1e-9 and estimate.motion == STILL and positional.mass == estimate.mass
    path, _ = still_recording
    calibration = Calibration(sensor.C_bar, sensor.D)
    with pytest.raises(ConfigError, match="'sometimes'"):
        identify_payload(path, ur5, calibration, "sometimes")
    with pytest.raises(ConfigError, match="a mount rotation is estimated from still poses"):
        identify_payload(path, ur5, calibration, "moving", mount=True)
    with pytest.raises(ConfigError, match="the sensor's calibration"):
        identify_payload(path, ur5, None)


def test_the_old_spellings_warn_and_write_the_same_file(tmp_path, ur5, sensor, motion_recording, capsys):
    """A bare --motion (before the recording, or after), and motion=True from Python, give the file of --motion moving."""
    from fts_calib.app import payload as command
    from fts_calib.app.cli import main

    path, _ = motion_recording
    cal = save_calibration(Calibration(sensor.C_bar, sensor.D), tmp_path / "cal.yaml")
    common = ["--calibration", str(cal), "--robot", "ur5"]
    assert main(["payload", "--motion", "moving", *common, str(path), "-o", str(tmp_path / "new.yaml")]) == 0
    captured = capsys.readouterr()
    assert "warning" not in captured.err and "decided from the data" not in captured.out
    assert main(["payload", *common, "--motion", str(path), "-o", str(tmp_path / "bare.yaml")]) == 0  # the recording after it
    assert "fts-calib: warning: --motion without a value is now --motion moving" in capsys.readouterr().err
    with pytest.warns(DeprecationWarning, match="--motion without a value is now --motion moving"):
        command.run(Setup(robot_file="ur5"), SourceOptions(path), calibration=cal, output=tmp_path / "keyword.yaml", motion=True)
    new = (tmp_path / "new.yaml").read_bytes()
    assert (tmp_path / "bare.yaml").read_bytes() == new and (tmp_path / "keyword.yaml").read_bytes() == new


def test_listen_warns_naming_the_new_source(tmp_path, sensor, capsys):
    """--motion --listen HOST:PORT works as before (a silent feed: exit 18) and names payload udp://HOST:PORT."""
    from fts_calib.app.cli import main
    from fts_calib.app.exit_codes import ExitCode

    cal = save_calibration(Calibration(sensor.C_bar, sensor.D), tmp_path / "cal.yaml")
    args = ["payload", "--motion", "moving", "--listen", "127.0.0.1:0", "--idle-timeout", "0.3", "--calibration", str(cal)]
    assert main([*args, "--robot", "ur5", "-o", str(tmp_path / "p.yaml")]) == ExitCode.TIMEOUT
    err = capsys.readouterr().err
    assert "warning: --listen 127.0.0.1:0 is now the source udp://127.0.0.1:0; --listen goes in" in err, err
    new = ["payload", "udp://127.0.0.1:0", "--idle-timeout", "0.3", "--calibration", str(cal), "--robot", "ur5"]
    assert main([*new, "-o", str(tmp_path / "p.yaml")]) == ExitCode.TIMEOUT  # the new spelling: auto, the same wait
    assert "warning" not in capsys.readouterr().err

"""Recordings that give the sensor's orientation instead of joint angles (issue 23, item 1)."""

import dataclasses

import numpy as np
import pandas as pd
import pinocchio as pin
import pytest

from fts_calib.core.exceptions import BagError, RecordingError
from fts_calib.core.resources import resolve
from fts_calib.planning.trajectory_files import TrajectoryFile
from fts_calib.robot.orientation import GIMBAL_LOCK, mount_rpy, orientation_kinematics
from fts_calib.session.calibration_run import calibrate_recording
from fts_calib.sim.runs import simulate_recording
from fts_calib.sim.sensor import load_simulated_sensor

HOME = np.array([1.3485, -2.092, -0.6562, -1.9642, 0.3, 0.7])  # the tare recording's pose (tests/test_tare.py)
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


@pytest.fixture(scope="module")
def real_run(tmp_path_factory, short_plan, seed):
    """The still run again with coarser readings: a 16-bit ADC (channels quantized to 2.4e-4 mV/V, 24
    times the noise) and joints read by 20-bit encoders; the same data then written in each form."""
    from fts_calib import Kinematics, load_robot, load_tool

    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    tool = load_tool(resolve("paper_tool", "configs"))
    sensor = dataclasses.replace(load_simulated_sensor(resolve("sensor", "configs")), adc_bits=16)
    p = short_plan
    trajectories = [TrajectoryFile(p.joint_names, p.time, p.q, p.qd, p.qdd, c.name) for c in tool.configurations]
    folder = tmp_path_factory.mktemp("real")
    rng = np.random.default_rng(seed)
    path = simulate_recording(folder / "raw.csv", kin, tool, trajectories, sensor, rng, poses_only=True)
    table = pd.read_csv(path)
    step = 2 * np.pi / 2**20  # a 20-bit encoder
    table[list(kin.joint_names)] = np.round(table[list(kin.joint_names)] / step) * step
    joints_path = folder / "joints.csv"
    table.to_csv(joints_path, index=False, float_format="%.17g")
    R = kin.R_world_sensor(table[list(kin.joint_names)].to_numpy())
    return kin, tool, folder, table, R, joints_path


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


def test_a_quaternion_that_is_not_a_unit_one_is_skipped_and_noted_with_its_line(still_run):
    """A quaternion of norm 5 (another quantity, not a rotation with few digits) is skipped, not normalised; 1 + 5e-4 is read."""
    kin, tool, folder, table, R, joints_path = still_run
    q = _quaternions(R)
    q[10] *= 5.0
    q[11] *= 1.0 + 5e-4  # a quaternion written with four digits: kept
    path = _write(folder, table, "scaled", {"qw": q[:, 0], "qx": q[:, 1], "qy": q[:, 2], "qz": q[:, 3]})
    result = calibrate_recording(path, orientation_kinematics(), tool)
    assert result.session.skipped["non-finite value"] == 1
    assert any("line 12: columns 'qw,qx,qy,qz': the quaternion's norm is 5," in note for note in result.problems), result.problems


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


def _quaternions(R):
    """[w, x, y, z] of rotations (N, 3, 3), every other one negated (q and -q: the same rotation)."""
    q = np.array([pin.Quaternion(r).coeffs() for r in R])[:, [3, 0, 1, 2]]
    return q * np.where(np.arange(len(q)) % 2, -1.0, 1.0)[:, None]


def _close(found, reference):
    assert reference is not None and found is not None
    np.testing.assert_allclose(found.C, reference.C, rtol=1e-9, atol=1e-9 * np.abs(reference.C).max())
    np.testing.assert_allclose(found.D, reference.D, rtol=1e-9, atol=1e-9 * np.abs(reference.D).max())


def test_a_bag_with_a_pose_topic_gives_the_joints_bag_calibration(real_run, tmp_path):
    """The same still run as a bag of joint states and as a bag of PoseStamped (the sensor's
    quaternion, header-stamped at the channels' times): C equal to 1e-9 relative (seen: 1e-14)."""
    from fts_calib.sim.robot_log import BagWriter, recording_to_bag
    from fts_calib.sources.bag import BagTopics

    kin, tool, folder, table, R, joints_path = real_run
    joints_bag = recording_to_bag(joints_path, tmp_path / "joints_bag")
    strains = table[[c for c in table.columns if c.startswith("strain_")]].to_numpy()
    topics = BagTopics(pose="/robot/sensor_pose")
    with BagWriter(tmp_path / "pose_bag", topics=topics, poses=True) as writer:
        current = None
        for k, (t, q, s, name) in enumerate(zip(table["time"], _quaternions(R), strains, table["tool"], strict=True)):
            if name != current:
                writer.configuration(t, current := name)
            writer.pose(t, q, position=(0.4, -0.1, 0.3))  # the position is not used
            writer.channels(t, s)
            if k in (5, 9):  # a driver's bad messages between two samples: ignored, noted
                writer.pose(t + 1e-4, [2.0, 0.0, 0.0, 0.0] if k == 5 else [float("nan"), 0.0, 0.0, 1.0])
    reference = calibrate_recording(joints_bag, kin, tool).calibration
    result = calibrate_recording(tmp_path / "pose_bag", orientation_kinematics(), tool, topics=topics)
    _close(result.calibration, reference)
    assert any("topic '/robot/sensor_pose'" in p and "'quat' has norm 2, not 1" in p for p in result.problems), result.problems
    assert any("'quat' holds a number that is not finite" in p for p in result.problems), result.problems
    with pytest.raises(BagError, match=r"PoseStamped topic \(name it with --pose-topic: this bag's are /robot/sensor_pose\)"):
        calibrate_recording(tmp_path / "pose_bag", orientation_kinematics(), tool)  # the default topic name: not in this bag


def _live(kin, tool, datagrams):
    """The live path without its socket: datagrams decoded, counted, paired, calibrated."""
    from fts_calib.session.session import CalibrationSession
    from fts_calib.sources.synchronizer import Synchronizer
    from fts_calib.sources.udp import LiveStats, feed_datagram

    sync, stats = Synchronizer(kin.joint_names, kin.continuous, configurations=tool.names, n_channels=8), LiveStats()
    for data in datagrams:
        feed_datagram(data, sync, stats)
    session = CalibrationSession(kin, tool)
    session.add_samples(sync.pop(final=True))
    return session.solve(), stats


def _datagrams(table, orientation):
    """The run's rows as live datagrams: the tool, then an orientation (or joints) message and a strain message per row, one stamp."""
    import json

    strains = table[[c for c in table.columns if c.startswith("strain_")]].to_numpy()
    out, current = [], None
    for t, o, s, name in zip(table["time"], orientation, strains, table["tool"], strict=True):
        if name != current:
            out.append(json.dumps({"type": "tool", "t": t, "name": (current := name)}).encode())
        out.append(json.dumps({"type": "joints", "t": t, **o}).encode())
        out.append(json.dumps({"type": "strain", "t": t, "strain": s.tolist()}).encode())
    return out


@pytest.mark.parametrize("field", ["R", "R rows", "quat"])
def test_live_datagrams_with_an_orientation_give_the_joints_calibration(real_run, field):
    """The same run as joints datagrams and as "R" (9 numbers or 3 rows) or "quat" datagrams, through
    the live path's decoding, pairing and session: C equal to 1e-9 relative (seen: 1e-14)."""
    kin, tool, folder, table, R, joints_path = real_run
    joints = [{"q": dict(zip(kin.joint_names, row.tolist(), strict=True))} for row in table[list(kin.joint_names)].to_numpy()]
    reference, _ = _live(kin, tool, _datagrams(table, joints))
    if field == "quat":
        given = [{"quat": q.tolist()} for q in _quaternions(R)]
    else:
        given = [{"R": r.tolist() if field == "R rows" else r.ravel().tolist()} for r in R]
    found, stats = _live(orientation_kinematics(), tool, _datagrams(table, given))
    assert stats.malformed == 0 and stats.joints == len(table)
    _close(found, reference)


@pytest.mark.parametrize(
    ("orientation", "says"),
    [
        ({"quat": [2.0, 0.0, 0.0, 0.0]}, "'quat' has norm 2, not 1"),
        ({"quat": [1.0, 0.0, 0.0]}, "'quat' must be a unit quaternion [w, x, y, z], got shape (3,)"),
        ({"quat": [1.0, 0.0, "0", 0.0]}, "'quat' must be a list of numbers"),
        ({"R": [1, 0, 0, 0, 1, 0, 0, 0, -1]}, "'R' has determinant -1: a reflection"),
        ({"R": [1.1, 0, 0, 0, 1, 0, 0, 0, 1]}, "'R' is not orthonormal"),
        ({"R": [[1, 0, 0], [0, 1, 0]]}, "'R' must be a rotation matrix, 9 numbers row-major or 3 rows of 3, got shape (2, 3)"),
        ({"R": [1, 0, 0, 0, 1, 0, 0, 0]}, "'R' must be a rotation matrix"),
        ({"R": [1, 0, 0, 0, 1, 0, 0, 0, 1e400]}, "'R' holds a number that is not finite"),
        ({"quat": [1, 0, 0, float("nan")]}, "'quat' holds NaN, not a number fts-calib accepts"),
        ({"R": [1, 0, 0, 0, 1, 0, 0, 0, 1], "quat": [1, 0, 0, 0]}, "gives both 'R' and 'quat'"),
    ],
)
def test_hostile_orientation_datagrams_are_counted_and_named(orientation, says):
    """A bad orientation is one malformed datagram, named in the run's summary; the good ones around it count."""
    import json

    from fts_calib.robot.orientation import GIMBAL_JOINTS
    from fts_calib.sources.synchronizer import Synchronizer
    from fts_calib.sources.udp import LiveStats, feed_datagram

    sync, stats = Synchronizer(GIMBAL_JOINTS, configurations=["A"]), LiveStats()
    good = json.dumps({"type": "joints", "t": 0.0, "quat": [1, 0, 0, 0]}).encode()
    text = json.dumps({"type": "joints", "t": 0.01, **orientation}).replace("Infinity", "1e400").encode()  # json writes NaN as NaN
    for data in (good, text, good):
        feed_datagram(data, sync, stats)
    assert (stats.malformed, stats.joints) == (1, 2)
    assert says in stats.first_malformed, stats.first_malformed


def test_the_gimbal_joints_written_twice_agree():
    from fts_calib.robot.orientation import GIMBAL_JOINTS
    from fts_calib.sources import bag as bag_pose

    assert bag_pose.GIMBAL_JOINTS == GIMBAL_JOINTS


def test_an_orientation_datagram_with_a_robot_is_named():
    import json

    from fts_calib.sources.synchronizer import Synchronizer
    from fts_calib.sources.udp import LiveStats, feed_datagram

    sync, stats = Synchronizer(["a", "b"]), LiveStats()
    feed_datagram(json.dumps({"type": "joints", "t": 0.0, "R": np.eye(3).ravel().tolist()}).encode(), sync, stats)
    assert stats.malformed == 1 and "the orientation 'R' but the robot's joints ['a', 'b'] are expected" in stats.first_malformed


def _as_form(kin, joints_path, form):
    """A joints recording written again with the sensor's orientation: 'quaternion' or 'tcp' (the TCP's rotation vector, MOUNT)."""
    table = pd.read_csv(joints_path)
    R = kin.R_world_sensor(table[list(kin.joint_names)].to_numpy())
    if form == "quaternion":
        q = _quaternions(R)
        return _write(joints_path.parent, table, f"{joints_path.stem}_{form}", {"qw": q[:, 0], "qx": q[:, 1], "qy": q[:, 2], "qz": q[:, 3]})
    rv = np.array([pin.log3(r) for r in R @ pin.rpy.rpyToMatrix(*MOUNT).T])
    return _write(joints_path.parent, table, f"{joints_path.stem}_{form}", {"tcp_rx": rv[:, 0], "tcp_ry": rv[:, 1], "tcp_rz": rv[:, 2]})


def test_tare_and_payload_without_a_robot(tmp_path, ur5, rng, capsys):
    """tare with a mounted configuration and payload, from a quaternion and from a TCP pose with
    --mount: the offsets and the payload of the joints recording, to 1e-9 relative (seen: 1e-15)."""
    from fts_calib import Calibration, load_calibration, load_tool
    from fts_calib.app.cli import main
    from fts_calib.model.calibration import save_calibration
    from tests.test_payload import _payload_recording
    from tests.test_tare import _recording

    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    cal = save_calibration(Calibration(sensor.C_bar, sensor.D), tmp_path / "cal.yaml")
    tool = load_tool(resolve("paper_tool", "configs"))
    tare_path = _recording(tmp_path / "tare.csv", sensor, ur5, tool.configuration("B").static_wrench(ur5.g_sensor(HOME, 9.81)), rng)
    poses = [(0.0, 0.0), (1.2, 0.0), (-1.2, 0.5), (0.6, 2.0), (-0.5, -2.2), (2.2, 1.0)]
    payload_path, _ = _payload_recording(tmp_path / "poses.csv", ur5, poses, rng)
    mount = ["--mount", *(f"{v:.17g}" for v in MOUNT)]
    tare = ["tare", "--calibration", str(cal), "--tool", "paper_tool", "--configuration", "B", "-o"]
    payload = ["payload", "--calibration", str(cal), "-o"]
    assert main([*tare, str(tmp_path / "ref.yaml"), "--robot", "ur5", str(tare_path)]) == 0
    assert main([*payload, str(tmp_path / "ref_payload.yaml"), "--robot", "ur5", str(payload_path)]) == 0
    D = load_calibration(tmp_path / "ref.yaml").D
    reference = load_tool(tmp_path / "ref_payload.yaml").configurations[0]
    for form in ("quaternion", "tcp"):
        given = [] if form == "quaternion" else mount
        assert main([*tare, str(tmp_path / f"{form}.yaml"), *given, str(_as_form(ur5, tare_path, form))]) == 0
        np.testing.assert_allclose(load_calibration(tmp_path / f"{form}.yaml").D, D, rtol=1e-9, atol=1e-9 * np.abs(D).max())
        out = tmp_path / f"{form}_payload.yaml"
        assert main([*payload, str(out), *given, str(_as_form(ur5, payload_path, form))]) == 0
        found = load_tool(out).configurations[0]
        assert found.mass == pytest.approx(reference.mass, rel=1e-9)
        np.testing.assert_allclose(found.p_sensor_com, reference.p_sensor_com, rtol=1e-9, atol=1e-12)
    assert "in 6 orientations" in capsys.readouterr().out


def test_the_frames_picture_is_drawn_by_its_script(tmp_path):
    """docs/img/frames.png (docs/real-sensors.md) comes from docs/img/frames.py: the script runs and draws a PNG of the same size."""
    import runpy
    from pathlib import Path

    script = Path(__file__).parents[1] / "docs" / "img" / "frames.py"
    out = runpy.run_path(str(script))["draw"](tmp_path / "frames.png")
    shipped = script.with_name("frames.png").read_bytes()
    assert out.read_bytes()[:8] == shipped[:8] == b"\x89PNG\r\n\x1a\n"
    assert out.read_bytes()[16:24] == shipped[16:24]  # the IHDR's width and height


def test_live_without_a_robot_takes_orientation_datagrams(tmp_path, monkeypatch, capsys):
    """A live calibration with no --robot: R and quat datagrams are the joints, a reflection is named, 'end' stops the run."""
    import json
    import socket
    import threading

    from fts_calib.app.cli import main
    from fts_calib.sources import source

    bound = []

    class Receiver(source.UdpReceiver):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            bound.append(self.address)

    monkeypatch.setattr(source, "UdpReceiver", Receiver)
    argv = ["calibrate", "udp://127.0.0.1:0", "--tool", "paper_tool", "-o", str(tmp_path / "c.yaml"), "--quiet", "--idle-timeout", "20"]
    result = {}
    thread = threading.Thread(target=lambda: result.update(code=main(argv)), daemon=True)
    thread.start()
    deadline = threading.Event()
    while not bound and thread.is_alive() and not deadline.wait(0.01):
        pass
    datagrams = [{"type": "tool", "t": 0.0, "name": "A"}]
    for k in range(20):
        orientation = {"R": np.eye(3).ravel().tolist()} if k % 2 else {"quat": [1.0, 0.0, 0.0, 0.0]}
        datagrams += [{"type": "joints", "t": 0.01 * k, **orientation}]
    datagrams += [{"type": "joints", "t": 0.2, "R": [1, 0, 0, 0, 1, 0, 0, 0, -1]}, {"type": "end"}]
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        for message in datagrams:
            sock.sendto(json.dumps(message).encode(), bound[0])
    thread.join(timeout=30)
    assert not thread.is_alive() and "code" in result
    out = capsys.readouterr().out
    assert "(20 joints, 0 strain, 1 tool), 1 malformed" in out, out
    assert "the first skipped: malformed datagram: 'R' has determinant -1" in out, out


@pytest.mark.parametrize("form", ["quaternion", "tcp"])
def test_replay_sends_an_orientation_recording_as_R_datagrams(real_run, form):
    """``replay`` of a recording in an orientation form sends "R" datagrams; received without a robot (the TCP
    form with its mount), they give the C of the joints recording replayed, to 1e-9 relative (seen: 7e-14)."""
    from fts_calib.sources.sender import ReplayOptions, messages
    from fts_calib.sources.udp import encode

    kin, tool, folder, table, R, joints_path = real_run
    given = _as_form(kin, joints_path, form)
    sent = [encode(m) for _, m in messages(given, ReplayOptions(speed=0.0))]
    assert sum(b'"R":' in d for d in sent) == len(table) and not any(b'"q":' in d for d in sent)
    reference, _ = _live(kin, tool, [encode(m) for _, m in messages(joints_path, ReplayOptions(speed=0.0))])
    found, stats = _live(orientation_kinematics(MOUNT if form == "tcp" else (0.0, 0.0, 0.0)), tool, sent)
    assert stats.malformed == 0
    _close(found, reference)


def test_re_tare_from_a_live_window_of_quaternion_datagrams(ur5, rng):
    """Configuration B mounted, no robot: "quat" and strain datagrams on loopback during a live window;
    the offsets' shift recovered as from joints (tests/test_tare.py's tolerance: 5 sigma of a 100-sample mean)."""
    import json
    import socket
    import threading
    import time

    from fts_calib import Calibration, load_tool
    from fts_calib.service.retare_job import tare_live
    from tests.test_tare import SHIFT

    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    cal = Calibration(sensor.C_bar, sensor.D)
    tool = load_tool(resolve("paper_tool", "configs"))
    R = ur5.R_world_sensor(HOME[None])[0]
    weight = tool.configuration("B").static_wrench(R.T @ np.array([0.0, 0.0, -tool.gravity]))
    drifted = type(sensor)(**{**sensor.__dict__, "D": sensor.D + SHIFT})
    strains = drifted.channels(np.tile(weight, (2000, 1)), rng=rng)
    quat = _quaternions(R[None])[0].tolist()
    bound, listening, stop = [], threading.Event(), threading.Event()
    rate_hz = 5000.0

    def send():
        if not listening.wait(60.0) or not bound:
            return
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            start = time.monotonic()
            for k, strain in enumerate(strains):
                ahead = start + k / rate_hz - time.monotonic()
                if k % 50 == 0 and ahead > 0 and stop.wait(ahead):
                    return
                t = k / 1000.0  # the sensor's clock: 2 s of 1 kHz samples, sent in 0.4 s
                if k % 5 == 0:
                    sock.sendto(json.dumps({"type": "joints", "t": t, "quat": quat}).encode(), bound[0])
                sock.sendto(json.dumps({"type": "strain", "t": t, "strain": strain.tolist()}).encode(), bound[0])

    def on_listening(address):
        bound.append(address)
        listening.set()

    sender = threading.Thread(target=send)
    sender.start()
    try:
        result = tare_live(cal, "127.0.0.1", 0, 0.8, orientation_kinematics(), tool, "B", on_listening=on_listening)
    finally:
        stop.set()
        listening.set()
        sender.join(timeout=60.0)
    assert result.estimate.samples_used > 100
    np.testing.assert_allclose(result.calibration.D - cal.D, SHIFT, atol=2e-3)


def test_mount_angles_give_the_rotation_back_and_no_split_at_gimbal_lock(rng):
    """R = Rz(yaw) Ry(pitch) Rx(roll) from the angles (to round-off); at pitch -90 deg, yaw 0 (within GIMBAL_LOCK of the turn)."""
    axis = rng.standard_normal(3)
    R = pin.exp3(rng.uniform(0.0, np.pi) * axis / np.linalg.norm(axis))
    np.testing.assert_allclose(pin.rpy.rpyToMatrix(*mount_rpy(R)), R, atol=1e-12)
    locked = pin.rpy.rpyToMatrix(-1.9687, -np.pi / 2 + 1e-5, 0.3979)  # only roll + yaw = -1.5708 is determined
    roll, pitch, yaw = mount_rpy(locked)
    assert (roll, pitch, yaw) == pytest.approx((-1.5708, -np.pi / 2, 0.0), abs=1e-4)
    assert np.linalg.norm(pin.log3(pin.rpy.rpyToMatrix(roll, pitch, yaw).T @ locked)) < GIMBAL_LOCK


def test_a_16_bit_still_recording_calibrates_and_its_health_section_loads_and_monitors(real_run, tmp_path, capsys):
    """The 16-bit still run (every row at a still pose): the quasi-static filter keeps nearly all
    of it, the health covariance is at least what the ADC's step alone gives (step^2 / 12 per
    channel, through N), the file written loads back, and ``monitor`` runs on it."""
    import json

    from fts_calib.app.cli import main
    from fts_calib.model.calibration import load_calibration
    from fts_calib.model.parity import ParityModel

    kin, tool, folder, table, R, joints_path = real_run
    lsb = dataclasses.replace(load_simulated_sensor(resolve("sensor", "configs")), adc_bits=16).lsb
    result = calibrate_recording(joints_path, kin, tool)
    assert result.calibration is not None, result.error
    assert result.session.kept.sum() >= 0.98 * len(table)  # seen: 1,440 of 1,446 for seeds 0-4 (12-58 before)
    health = ParityModel.from_dict(result.calibration.health)
    np.testing.assert_allclose(health.resolution, lsb, rtol=1e-6)  # the ADC's step, detected from the file's 10 digits
    floor = health.N @ np.diag(np.full(8, lsb**2 / 12)) @ health.N.T
    assert np.linalg.eigvalsh(health.covariance - floor).min() >= -1e-9 * np.trace(floor)
    path = result.calibration.save(tmp_path / "cal.yaml")
    loaded = load_calibration(path)
    np.testing.assert_array_equal(np.asarray(loaded.health["covariance"]), health.covariance)
    code = main(["monitor", "--calibration", str(path), str(joints_path), "--json", str(tmp_path / "health.json")])
    out = capsys.readouterr().out
    assert code == 0 and "health: ok, no fault found" in out, out
    assert json.loads((tmp_path / "health.json").read_text())["samples"] == len(table), out

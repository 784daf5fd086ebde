"""ROS 2 bags as a feed: the same run as a bag (MCAP, sqlite3) and as a CSV, topics, joints, errors."""

import numpy as np
import pytest

from fts_calib import Calibration, RecordingError, UnknownToolConfiguration, load_calibration
from fts_calib.app.cli import main
from fts_calib.app.exit_codes import ExitCode
from fts_calib.core.exceptions import BagError
from fts_calib.core.resources import resolve
from fts_calib.model.channels import WRENCH_6
from fts_calib.model.sensor_config import load_sensor_config
from fts_calib.planning.trajectory_files import TrajectoryFile
from fts_calib.service.retare_job import tare_recording
from fts_calib.session.calibration_run import calibrate_recording
from fts_calib.sim.robot_log import BagWriter, recording_to_bag
from fts_calib.sim.runs import simulate_recording
from fts_calib.sim.sensor import load_simulated_sensor, simulated_sensor
from fts_calib.sources.bag import WRENCH_STAMPED, BagReader, BagTopics, parse_bag_argument
from fts_calib.sources.batch import UNKNOWN_TOOL, SampleBatch
from fts_calib.sources.recording import RecordingReader
from fts_calib.sources.sender import ReplayOptions, messages
from fts_calib.sources.source import open_recording
from fts_calib.sources.synchronizer import JOINT_GAP, WRONG_LENGTH

from .test_tare import _recording

JOINTS = ["j1", "j2"]
ATOL_JOINT = 1e-12  # [rad] linear motion, interpolated linearly: exact to rounding
ATOL_TIME = 1e-9  # [s] stamps are integer ns (0.5 ns rounding); log times are 1 to 3 ms off


def _rows(path, kin, tool):
    with RecordingReader(path, kin.joint_names, tool.names) as reader:
        return SampleBatch.concatenate(list(reader))


@pytest.fixture(scope="module")
def bags(tmp_path_factory, ur5_recording):
    """The simulated UR5 run as a bag in each storage, written with rosbags' writer."""
    folder = tmp_path_factory.mktemp("bags")
    return {storage: recording_to_bag(ur5_recording, folder / f"run_{storage}", storage) for storage in ("mcap", "sqlite3")}


def _same_calibration(a, b):
    for name in ("C", "D"):
        x, y = getattr(a, name), getattr(b, name)
        atol = 1e-12 * np.abs(x).max()  # the same samples in the same order: equal to rounding
        assert np.allclose(x, y, rtol=0, atol=atol), f"{name} differs by {np.abs(x - y).max():.3g}"


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_a_bag_and_the_csv_of_the_same_run_give_the_same_calibration(storage, bags, ur5_recording, ur5, paper_tool):
    from_csv = calibrate_recording(ur5_recording, ur5, paper_tool)
    folder = bags[storage]
    targets = [folder, next(folder.glob("*.mcap"))] if storage == "mcap" else [folder]  # a bag folder, or its storage file alone
    for target in targets:
        from_bag = calibrate_recording(target, ur5, paper_tool)
        assert from_bag.rows == from_csv.rows == 9012
        assert from_bag.session.progress().kept == from_csv.session.progress().kept
        _same_calibration(from_csv.calibration, from_bag.calibration)


def test_the_bag_feed_yields_the_csv_rows(bags, ur5_recording, ur5, paper_tool):
    """Joint states stamped like the channels: every sample placed, joints as recorded, times to the float."""
    csv = _rows(ur5_recording, ur5, paper_tool)
    with open_recording(bags["mcap"], ur5.joint_names, paper_tool.names, continuous=ur5.continuous) as reader:
        bag = SampleBatch.concatenate(list(reader))
        assert not reader.skipped and reader.rows_read == len(csv) and reader.bytes_read == reader.size
    np.testing.assert_array_equal(bag.time, csv.time)
    np.testing.assert_array_equal(bag.joints, csv.joints)
    np.testing.assert_array_equal(bag.channels, csv.channels)
    np.testing.assert_array_equal(bag.configuration, csv.configuration)


def _split_by_configuration(csv, names, joint_names, folder):
    """One bag per configuration, without a configuration topic."""
    paths = {}
    for code, name in enumerate(names):
        rows = csv.select(csv.configuration == code)
        with BagWriter(folder / f"bag_{name}", "sqlite3" if code % 2 else "mcap", configuration_topic=False) as writer:
            for t, joints, channels in zip(rows.time, rows.joints, rows.channels, strict=True):
                writer.joints(t, joint_names, joints)
                writer.channels(t, channels)
        paths[name] = writer.path
    return paths


def test_one_bag_per_configuration_named_on_the_command_line(tmp_path, ur5_recording, ur5, paper_tool):
    csv = _rows(ur5_recording, ur5, paper_tool)
    paths = _split_by_configuration(csv, paper_tool.names, ur5.joint_names, tmp_path)
    arguments = [f"{paths[name]}:{name}" for name in ("C", "A", "B")]  # any order: read in time order
    out = tmp_path / "cal.yaml"
    assert main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", *arguments, "-o", str(out), "--quiet"]) == ExitCode.OK
    from_bags = load_calibration(out)
    assert from_bags.provenance["source"] == " ".join(arguments)
    _same_calibration(calibrate_recording(ur5_recording, ur5, paper_tool).calibration, from_bags)
    with pytest.raises(BagError, match="no such topic.*or name the configuration of the whole bag"):
        BagReader([paths["A"]], ur5.joint_names, paper_tool.names)
    with pytest.raises(UnknownToolConfiguration, match="'Q'"):
        BagReader([f"{paths['A']}:Q"], ur5.joint_names, paper_tool.names)


def test_bag_arguments():
    assert parse_bag_argument("run.mcap:A") == parse_bag_argument("run.mcap:A ")
    assert parse_bag_argument("run.mcap:A").configuration == "A" and str(parse_bag_argument("run.mcap:A").path) == "run.mcap"
    assert parse_bag_argument("run.mcap").configuration is None
    assert parse_bag_argument("/data/a:b/run.mcap").configuration is None  # a ':' inside a folder name


def _linear_motion_bag(path, channels_type="std_msgs/msg/Float64MultiArray", width=8, **options):
    """Joints moving linearly at 100 Hz, channels at 250 Hz offset from them; configuration A then B at 1 s."""
    t_joints = np.arange(0.0, 2.0, 0.01)
    t_channels = np.arange(0.002, 1.99, 0.004)
    with BagWriter(path, channels_type=channels_type, **options) as writer:
        writer.configuration(0.0, "A")
        writer.configuration(1.0, "B")
        for t in t_joints:  # the robot's joints among a gripper's
            writer.joints(t, ["finger", "j2", "j1"], [0.0, -t, 0.5 * t], log_t=t + 0.003)
        for k, t in enumerate(t_channels):
            writer.channels(t, np.arange(width) + k, log_t=t + 0.001 * (k % 3))
    return t_channels


def test_wrench_stamped_channels_by_header_stamp_and_joints_by_name(tmp_path):
    """Six channels per WrenchStamped, at their header stamps; joints interpolated at those times, by name."""
    t_channels = _linear_motion_bag(tmp_path / "w", WRENCH_STAMPED, width=6)
    with BagReader([tmp_path / "w"], JOINTS, ["A", "B"]) as reader:
        batch = SampleBatch.concatenate(list(reader))
        assert reader.n_channels == 6 and not reader.skipped
    np.testing.assert_allclose(batch.time, t_channels, rtol=0, atol=ATOL_TIME)
    np.testing.assert_allclose(batch.joints, np.column_stack([0.5 * t_channels, -t_channels]), rtol=0, atol=ATOL_JOINT)
    np.testing.assert_array_equal(batch.channels, np.arange(6) + np.arange(len(t_channels))[:, None])
    np.testing.assert_array_equal(batch.configuration, (t_channels >= 1.0).astype(int))


def test_joint_names_in_the_bag_order_when_none_are_given(tmp_path):
    _linear_motion_bag(tmp_path / "b")
    reader = BagReader([tmp_path / "b"], None, None)
    assert reader.joint_names == ["finger", "j2", "j1"] and next(iter(reader)).joints.shape[1] == 3
    assert reader.tool_names == ["A", "B"]
    reader.close()  # an iteration left before its end: the bag is closed, and can be read again
    assert sum(len(batch) for batch in reader) == len(np.arange(0.002, 1.99, 0.004))


def test_unknown_configurations_are_counted_and_skipped(tmp_path):
    _linear_motion_bag(tmp_path / "b")
    with BagReader([tmp_path / "b"], JOINTS, ["B"]) as reader:
        batch = SampleBatch.concatenate(list(reader))
        assert np.all(batch.configuration == 0) and np.all(batch.time >= 1.0)
        assert reader.skipped[UNKNOWN_TOOL] == np.sum(np.arange(0.002, 1.99, 0.004) < 1.0) == reader.unknown_tools["A"]
        assert any("unknown tool configuration 'A' (known: B)" in note for note in reader.notes())


def test_a_joint_gap_and_channels_of_another_width_are_counted(tmp_path):
    with BagWriter(tmp_path / "b") as writer:
        writer.configuration(0.0, "A")
        for t in [*np.arange(0.0, 0.5, 0.01), *np.arange(0.7, 1.0, 0.01)]:  # 0.2 s without joints
            writer.joints(t, JOINTS, [t, 0.0])
        t_channels = np.arange(0.005, 0.99, 0.01)
        for k, t in enumerate(t_channels):
            writer.channels(t, np.zeros(7 if k == 3 else 8))
    in_gap = int(np.sum((t_channels > 0.49) & (t_channels < 0.7)))  # between the joints at 0.49 s and 0.70 s: 21
    with BagReader([tmp_path / "b"], JOINTS, ["A"]) as reader:
        batch = SampleBatch.concatenate(list(reader))
        assert reader.skipped[f"{WRONG_LENGTH} 8"] == 1 and reader.skipped[JOINT_GAP] == in_gap, reader.skipped
        assert len(batch) + sum(reader.skipped.values()) == reader.rows_read == 99 and reader.n_channels == 8


def test_missing_topics_types_and_joints_are_named(tmp_path):
    _linear_motion_bag(tmp_path / "b")
    with pytest.raises(
        BagError, match=r"topic '/js': no such topic .*the bag has: /ft_sensor/raw \(std_msgs/msg/Float64MultiArray\), /fts_calib"
    ):
        BagReader([tmp_path / "b"], JOINTS, None, BagTopics(joints="/js"))
    with pytest.raises(BagError, match="topic '/fts_calib/configuration': of type std_msgs/msg/String but expected sensor_msgs"):
        BagReader([tmp_path / "b"], JOINTS, None, BagTopics(joints="/fts_calib/configuration"))
    with pytest.raises(BagError, match=r"the robot's joints \['wrist'\]: the messages name \['finger', 'j1', 'j2'\]"):
        BagReader([tmp_path / "b"], ["j1", "wrist"], None)
    with pytest.raises(BagError, match="bag not found"):
        BagReader([tmp_path / "none.mcap"], JOINTS, None)
    (tmp_path / "broken.mcap").write_bytes(b"not a bag")
    with pytest.raises(BagError, match="not a readable ROS 2 bag"):
        BagReader([tmp_path / "broken.mcap"], JOINTS, None)


def test_what_is_neither_a_csv_nor_a_bag_is_refused(tmp_path):
    (tmp_path / "run.txt").write_text("time\n")
    with pytest.raises(RecordingError, match=r"unknown kind of recording '.txt': expected a CSV recording \(.csv, .csv.gz\), or ROS 2"):
        open_recording(tmp_path / "run.txt", None, None)
    with pytest.raises(RecordingError, match="a folder without a metadata.yaml is not a ROS 2 bag"):
        open_recording(tmp_path, None, None)
    with pytest.raises(RecordingError, match="several recordings are either all CSV files or all ROS 2 bags, and this is not a bag"):
        open_recording([tmp_path / "run.txt", tmp_path / "b.mcap"], None, None)
    assert (
        main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(tmp_path / "run.txt"), "-o", str(tmp_path / "c.yaml")])
        == ExitCode.RECORDING
    )


def test_a_bag_without_joint_messages_and_a_path_that_does_not_exist_are_one_line(tmp_path, capsys):
    """Before: 'the messages name []' for a bag whose joint topic is empty, 'unknown kind' for a missing folder."""
    with BagWriter(tmp_path / "quiet") as writer:  # the topics exist, no joint state was logged
        writer.configuration(0.0, "A")
        writer.channels(0.0, np.zeros(8))
    run = ["calibrate", "--robot", "ur5", "--tool", "paper_tool", "-o", str(tmp_path / "c.yaml"), "--quiet"]
    assert main([*run, str(tmp_path / "quiet")]) == ExitCode.RECORDING
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "quiet, topic '/joint_states': no joint message: the bag has the topic but no message on it" in err[0], err
    assert main([*run, str(tmp_path / "run_bag")]) == ExitCode.RECORDING
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "run_bag: file or folder not found (expected a CSV recording" in err[0], err
    assert not (tmp_path / "c.yaml").exists()


def test_replay_sends_a_bag_as_it_sends_the_csv(bags, ur5_recording):
    options = ReplayOptions(joint_rate_hz=50.0, latency_s=0.01)
    assert list(messages(bags["sqlite3"], options)) == list(messages(ur5_recording, options))


def test_validate_a_bag_as_the_csv(tmp_path, bags, ur5_recording, capsys):
    cal = tmp_path / "cal.yaml"
    assert main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(ur5_recording), "-o", str(cal), "--quiet"]) == ExitCode.OK
    reports = []
    for recording in (ur5_recording, bags["mcap"]):
        capsys.readouterr()
        assert main(["validate", "--calibration", str(cal), "--robot", "ur5", str(recording)]) == ExitCode.OK
        reports.append(capsys.readouterr().out.split("\n", 1)[1])  # after the line naming the recording
    assert reports[0] == reports[1] and "Fx" in reports[0]


def test_resume_a_bag_checkpoint_only_with_its_own_bag(tmp_path, ur5_recording, ur5, paper_tool):
    """Two short bags of configuration A (1,000 rows: rank 4, the checkpoint is kept for more)."""
    rows = _rows(ur5_recording, ur5, paper_tool).rows(0, 1000)
    bags = {}
    for storage in ("mcap", "sqlite3"):
        with BagWriter(tmp_path / storage, storage) as writer:
            writer.configuration(rows.time[0], "A")
            for t, joints, channels in zip(rows.time, rows.joints, rows.channels, strict=True):
                writer.joints(t, ur5.joint_names, joints)
                writer.channels(t, channels)
        bags[storage] = str(writer.path)
    checkpoint = tmp_path / "cp.json"
    run = [
        "calibrate",
        "--robot",
        "ur5",
        "--tool",
        "paper_tool",
        "-o",
        str(tmp_path / "cal.yaml"),
        "--checkpoint",
        str(checkpoint),
        "--quiet",
    ]
    assert main([*run, bags["mcap"]]) == ExitCode.EXCITATION and checkpoint.exists()
    assert main([*run, "--resume", bags["mcap"]]) == ExitCode.EXCITATION  # its own bag: resumed
    assert main([*run, "--resume", bags["sqlite3"]]) == ExitCode.FILE  # the same rows in another storage: other bytes


def test_re_tare_from_a_bag_as_from_its_csv(tmp_path, ur5, rng):
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    cal = Calibration(sensor.C_bar, sensor.D, provenance={"method": "test"})
    csv = _recording(tmp_path / "still.csv", sensor, ur5, np.zeros(6), rng, rows=300)
    bag = recording_to_bag(csv, tmp_path / "still_bag", "sqlite3")
    from_csv, from_bag = tare_recording(cal, csv), tare_recording(cal, bag)
    np.testing.assert_allclose(from_bag.calibration.D, from_csv.calibration.D, rtol=0, atol=1e-12 * np.abs(cal.D).max())


def test_a_wrench_stamped_bag_calibrates_a_six_axis_sensor_as_its_csv(tmp_path, short_plan, ur5, paper_tool, seed):
    """The wrench-6 layout end to end: a factory-calibrated sensor's wrench logged as WrenchStamped."""
    path = resolve("factory_sensor", "configs")
    sensor = simulated_sensor(load_sensor_config(path), path)
    p = short_plan
    trajectories = [TrajectoryFile(p.joint_names, p.time, p.q, p.qd, p.qdd, c.name) for c in paper_tool.configurations]
    csv = simulate_recording(tmp_path / "wrench.csv", ur5, paper_tool, trajectories, sensor, np.random.default_rng(seed))
    bag = recording_to_bag(csv, tmp_path / "wrench_bag", "mcap", WRENCH_STAMPED)
    from_csv = calibrate_recording(csv, ur5, paper_tool, layout=WRENCH_6)
    from_bag = calibrate_recording(bag, ur5, paper_tool, layout=WRENCH_6)
    assert from_bag.calibration.layout == WRENCH_6 and from_bag.rows == from_csv.rows
    _same_calibration(from_csv.calibration, from_bag.calibration)
    z = np.abs(from_bag.calibration.C_bar - sensor.C_bar) / from_bag.calibration.quality.stderr_C_bar
    assert z.max() <= 5.0, z.max()  # 36 coefficients at 5 sigma: P(any outside) < 3e-5

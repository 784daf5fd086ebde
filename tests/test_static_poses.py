"""Static-pose datasets: one file per pose (and globs), or one file with gaps, calibrated with default options.

The issue's case, scaled down to keep the suite fast: 12 static poses (4 per configuration of
the paper's tool), one file per pose, each file's time restarting at 0, on the shipped
low-cost sensor (10-bit counts, sub-count noise on three channels, strain_7 at its rail in
some poses, 3 % of full scale of quadratic nonlinearity). The truth is the simulated sensor:
its noiseless reading of the tool's weight at each pose.
"""

import gzip
import json

import numpy as np
import pandas as pd
import pytest

from fts_calib import load_calibration
from fts_calib.app.cli import main
from fts_calib.app.exit_codes import ExitCode
from fts_calib.core.exceptions import RecordingError
from fts_calib.core.resources import resolve
from fts_calib.model.sensor_config import load_sensor_config
from fts_calib.planning.trajectory_files import TrajectoryFile
from fts_calib.robot.tool import tool_load
from fts_calib.session.held_out import held_out_units
from fts_calib.sim.pose_files import simulate_pose_files
from fts_calib.sim.runs import simulate_recording
from fts_calib.sim.sensor import SimulatedSensor
from fts_calib.sources.recording_set import FILE_GAP_S, natural_key
from fts_calib.sources.source import open_recording

HOME = np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0])  # [rad] the UR5's calibration home
RATE_HZ = 250.0
POSE_S = 4.0  # [s] still at each pose
MOVE_S = 1.0  # [s] the move to the next pose (not recorded)
#: Wrist joints (wrist_1, wrist_2, wrist_3) of the four poses of a configuration [rad]: gravity spread over the sensor.
WRISTS = np.array([[-1.96, 0.0, 0.0], [-1.96, 1.5708, 0.7854], [-0.4, -1.5708, 2.3562], [-3.5, 0.7854, -2.3562]])
LOWCOST = ["--sensor", "lowcost_sensor"]


def static_trajectory(kin, tool_name: str, wrists: np.ndarray) -> TrajectoryFile:
    """Still at each pose for POSE_S, a straight move of MOVE_S between poses (velocity nonzero: not recorded)."""
    still, move = int(POSE_S * RATE_HZ), int(MOVE_S * RATE_HZ)
    qs, qds = [], []
    poses = [np.r_[HOME[:3], w] for w in wrists]
    for k, pose in enumerate(poses):
        qs.append(np.tile(pose, (still, 1)))
        qds.append(np.zeros((still, 6)))
        if k + 1 < len(poses):
            ramp = np.linspace(0.0, 1.0, move + 2)[1:-1, None]
            qs.append(pose + ramp * (poses[k + 1] - pose))
            qds.append(np.tile((poses[k + 1] - pose) / MOVE_S, (move, 1)))
    q, qd = np.vstack(qs), np.vstack(qds)
    return TrajectoryFile(tuple(kin.joint_names), np.arange(len(q)) / RATE_HZ, q, qd, np.zeros_like(q), tool_name)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory, seed, _kinematics_cache):
    """The same static poses written as one file per pose and as one file with gaps (same noise)."""
    from fts_calib.robot.tool import load_tool

    from .conftest import _kinematics

    kin, tool = _kinematics(_kinematics_cache, "ur5"), load_tool(resolve("paper_tool", "configs"))
    spec = load_sensor_config(resolve("lowcost_sensor", "configs"))
    sensor = SimulatedSensor.from_spec(spec.simulated)
    trajectories = [static_trajectory(kin, name, WRISTS) for name in tool.names]
    folder = tmp_path_factory.mktemp("static")
    files = simulate_pose_files(folder / "poses", kin, tool, trajectories, sensor, np.random.default_rng(seed), dynamic=False)
    one = simulate_recording(
        folder / "one.csv", kin, tool, trajectories, sensor, np.random.default_rng(seed), dynamic=False, poses_only=True
    )
    return folder, files, one, kin, tool, sensor


def calibrate(recordings, out, *extra) -> tuple[int, str]:
    import contextlib
    import io

    buffer = io.StringIO()
    with contextlib.redirect_stdout(buffer):
        code = main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", *LOWCOST, *map(str, recordings), "-o", str(out), *extra])
    return code, buffer.getvalue()


def railed(path) -> bool:
    """Whether every row of a pose file has a channel at a rail of the 10-bit converter (0 or 1023)."""
    channels = pd.read_csv(path).filter(like="strain_").to_numpy()
    return bool(np.all(np.any((channels <= 0) | (channels >= 1023), axis=1)))


def test_the_simulated_dataset_is_one_file_per_pose_each_from_time_0(dataset):
    _, files, one, *_ = dataset
    assert [p.name for p in files] == [f"pose_{k:02d}.csv" for k in range(1, 13)]
    rows = 0
    for path in files:
        table = pd.read_csv(path)
        assert table["time"].iloc[0] == 0.0 and len(table) == POSE_S * RATE_HZ
        assert table.filter(like="wrist").nunique().max() == 1, "one pose per file"
        assert table["tool"].nunique() == 1
        rows += len(table)
    assert rows == len(pd.read_csv(one))


def test_pose_files_calibrate_with_defaults_within_the_printed_budget_of_the_truth(dataset, tmp_path):
    folder, files, _, kin, tool, sensor = dataset
    code, text = calibrate([folder / "poses" / "*.csv"], tmp_path / "cal.yaml")
    assert code == ExitCode.OK, text
    cal = load_calibration(tmp_path / "cal.yaml")
    # the truth: the noiseless sensor's reading of the tool's weight at every pose whose channels are within the rails
    usable = [p for p in files if not railed(p)]
    assert 0 < len(usable) < len(files), "the low-cost sensor rails in some poses, not in all"
    errors = []
    for path in usable:
        table = pd.read_csv(path).iloc[:1]
        joints = table[list(kin.joint_names)].to_numpy()
        W = tool_load(kin, tool, joints, table["tool"].iloc[0]).static
        errors.append(cal.wrench(sensor.channels(W)) - W)
    rms = np.sqrt(np.mean(np.vstack(errors) ** 2, axis=0))
    budget = np.array(list(cal.quality.budget["total"].values()))
    assert np.all(rms <= budget), f"error {rms} beyond the printed budget {budget}"
    # the files with no still sample are counted and named, and the run went on
    named = f"{len(files) - len(usable)} of {len(files)} files with no still sample kept: " + ", ".join(
        p.name for p in files if p not in usable
    )
    assert named in text, text
    assert f"12 files read in the order given; the times of 11 shifted to follow the previous file {FILE_GAP_S:g} s" in text


def test_held_out_units_are_the_poses_and_one_file_with_gaps_gives_the_same_calibration(dataset, tmp_path):
    folder, files, one, *_ = dataset
    code, _ = calibrate([folder / "poses" / "*.csv"], tmp_path / "files.yaml")
    assert code == ExitCode.OK
    code, text = calibrate([one], tmp_path / "one.yaml")
    assert code == ExitCode.OK, text
    by_files, by_one = load_calibration(tmp_path / "files.yaml"), load_calibration(tmp_path / "one.yaml")
    poses_kept = sum(not railed(p) for p in files)
    assert by_files.model_selection["units"] == poses_kept == by_one.model_selection["units"]
    assert by_files.model_selection["chosen"] == by_one.model_selection["chosen"]
    np.testing.assert_allclose(by_files.C, by_one.C, rtol=0, atol=1e-9 * np.abs(by_one.C).max())
    np.testing.assert_allclose(by_files.D, by_one.D, rtol=0, atol=1e-9 * np.abs(by_one.D).max())
    # validate reads the files as calibrate does: the same samples, the same errors as over the one file
    reports = []
    for name, recordings in (("files", [folder / "poses" / "*.csv"]), ("one", [one])):
        argv = ["validate", *map(str, recordings), "--calibration", str(tmp_path / "files.yaml"), "--robot", "ur5", "--tool", "paper_tool"]
        assert main([*argv, *LOWCOST, "--static", "--json", str(tmp_path / f"{name}.json")]) == ExitCode.OK
        reports.append(json.loads((tmp_path / f"{name}.json").read_text()))
    assert reports[0]["samples"] == reports[1]["samples"] > 0
    for axis, errors in reports[1]["axes"].items():
        assert reports[0]["axes"][axis] == pytest.approx(errors, rel=1e-9), axis


def test_files_given_by_name_in_any_order_of_patterns_and_a_resumed_run_agree(dataset, tmp_path):
    folder, files, *_ = dataset
    # by name, in the natural order a pattern gives (pose_2 before pose_10)
    assert sorted(["p_10.csv", "p_2.csv", "p_1.csv"], key=natural_key) == ["p_1.csv", "p_2.csv", "p_10.csv"]
    code, _ = calibrate(files, tmp_path / "named.yaml")
    assert code == ExitCode.OK
    code, _ = calibrate([folder / "poses" / "*.csv"], tmp_path / "glob.yaml")
    assert code == ExitCode.OK
    np.testing.assert_array_equal(load_calibration(tmp_path / "named.yaml").C, load_calibration(tmp_path / "glob.yaml").C)
    # a checkpoint written over the set, then resumed from: time runs on across files, nothing is counted twice
    checkpoint = tmp_path / "run.ckpt"
    code, _ = calibrate(files, tmp_path / "first.yaml", "--checkpoint", str(checkpoint))
    assert code == ExitCode.OK
    code, text = calibrate(files, tmp_path / "resumed.yaml", "--checkpoint", str(checkpoint), "--resume")
    assert code == ExitCode.OK, text
    first, resumed = load_calibration(tmp_path / "first.yaml"), load_calibration(tmp_path / "resumed.yaml")
    assert first.quality.samples_used == resumed.quality.samples_used > 0
    np.testing.assert_allclose(resumed.C, first.C, rtol=0, atol=1e-9 * np.abs(first.C).max())


def test_times_restarting_or_overlapping_are_shifted_and_later_times_kept(dataset, tmp_path):
    _, files, *_ = dataset
    late = tmp_path / "late.csv"
    table = pd.read_csv(files[1])
    table["time"] += 1000.0  # a clock that runs on: kept as it is
    table.to_csv(late, index=False, float_format="%.9g")
    with open_recording([files[0], late, files[2]], None, None) as reader:
        times = np.concatenate([chunk.time for chunk in reader])
    n = int(POSE_S * RATE_HZ)
    last_first = (n - 1) / RATE_HZ
    np.testing.assert_allclose(times[n], 1000.0)  # the second file keeps its times
    np.testing.assert_allclose(times[2 * n], times[2 * n - 1] + FILE_GAP_S)  # the third restarts at 0: shifted
    assert times[n - 1] == pytest.approx(last_first) and np.all(np.diff(times) > 0)
    assert reader.shifted == 1


def test_bad_inputs_are_refused_naming_the_file(dataset, tmp_path):
    folder, files, *_ = dataset
    out = tmp_path / "cal.yaml"
    code, _ = calibrate([tmp_path / "nothing" / "*.csv"], out)
    assert code == ExitCode.RECORDING
    with pytest.raises(RecordingError, match=r"no file matches the pattern '\*\.csv' \(folder .*nothing does not exist\)"):
        open_recording(str(tmp_path / "nothing" / "*.csv"), None, None)
    (tmp_path / "empty").mkdir()
    with pytest.raises(RecordingError, match=r"no file matches the pattern 'pose_\*\.csv' \(nothing in .*empty matches\)"):
        open_recording(str(tmp_path / "empty" / "pose_*.csv"), None, None)
    # a file of another sensor (6 channels) among the poses
    six = tmp_path / "six.csv"
    table = pd.read_csv(files[0]).drop(columns=["strain_7", "strain_8"])
    table.to_csv(six, index=False)
    with pytest.raises(RecordingError, match=rf"{six}, line 1: 6 channels \(strain_1..6\), but {files[0]} has 8: every file"):
        open_recording([files[0], six], None, None)
    code, _ = calibrate([files[0], six], out)
    assert code == ExitCode.RECORDING and not out.exists()
    # an empty file, and a file with a header only
    empty = tmp_path / "empty.csv"
    empty.write_text("")
    with pytest.raises(RecordingError, match=rf"{empty}, line 1: empty file"):
        open_recording([files[0], empty], None, None)
    header = tmp_path / "header.csv"
    header.write_text(files[0].read_text().splitlines()[0] + "\n")
    code, _ = calibrate([*files, header], out)
    assert code == ExitCode.RECORDING and not out.exists()
    with pytest.raises(RecordingError, match=rf"{header}, line 2: no data rows"):
        open_recording([files[0], header], None, None)  # before any file is read
    gz = tmp_path / "header.csv.gz"
    gz.write_bytes(gzip.compress(header.read_bytes()))
    with pytest.raises(RecordingError, match=rf"{gz}, line 2: no data rows"), open_recording([files[0], gz], None, None) as reader:
        list(reader)  # a compressed one: when it is read
    # the same file twice, by path or as a copy
    with pytest.raises(RecordingError, match=rf"{files[0]}: given twice"):
        open_recording([files[0], files[1], files[0]], None, None)
    copy = tmp_path / "copy.csv"
    copy.write_bytes(files[3].read_bytes())
    with pytest.raises(RecordingError, match=rf"{copy}: the same content as {files[3]} \(a copy\?\)"):
        open_recording([*files, copy], None, None)
    # other joint columns (a file of another robot, read without one: every column but time, strains, tool)
    other = tmp_path / "other.csv"
    pd.read_csv(files[1]).drop(columns=["wrist_3_joint"]).to_csv(other, index=False)
    with pytest.raises(RecordingError, match=rf"{other}, line 1: joint \(or orientation\) columns .* but {files[0]} has"):
        open_recording([files[0], other], None, None)
    # a temperature column in one file and not in another
    warm = tmp_path / "warm.csv"
    pd.read_csv(files[1]).assign(temperature=25.0).to_csv(warm, index=False)
    with pytest.raises(RecordingError, match="has a temperature column and .* has none: give it in every file or in none"):
        open_recording([files[0], warm], None, None)


def test_a_pose_held_long_is_one_unit_a_slow_sweep_is_cut_by_orientation_and_a_revisit_joins_its_unit():
    rng = np.random.default_rng(0)
    g_pose = np.array([0.3, -0.5, -0.81])
    still = g_pose + rng.normal(0.0, 1e-5, (2500, 3))  # 25 s held, joint noise: one orientation
    assert len(np.unique(held_out_units(np.zeros(len(still), dtype=int), still))) == 1
    angle = np.radians(np.linspace(0.0, 35.0, 2500))  # a slow sweep of 35 degrees about x
    sweep = np.stack([np.zeros_like(angle), np.sin(angle), -np.cos(angle)], axis=1) * 9.81
    units = held_out_units(np.zeros(len(sweep), dtype=int), sweep)
    assert 4 <= len(np.unique(units)) <= 5  # cells of 10 degrees
    # the same pose an hour later, or in another file, is the same unit; another configuration is another
    again = held_out_units(np.array([0, 1]), np.array([g_pose, g_pose]))
    assert again[0] == held_out_units(np.array([0]), still[:1])[0] and again[1] != again[0]


def test_simulate_pose_files_writes_one_file_per_pose_and_never_mixes_two_datasets(ur5, tmp_path, capsys):
    from fts_calib.planning.trajectory_files import write_trajectory

    plan = tmp_path / "plan"
    for name in ("A", "B", "C"):
        t = static_trajectory(ur5, name, WRISTS[:2])
        write_trajectory(plan / f"{name}.csv", t.joint_names, t.time, t.q, t.qd, t.qdd, name)
    argv = [
        "simulate",
        "--robot",
        "ur5",
        "--tool",
        "paper_tool",
        "--trajectory",
        str(plan),
        *LOWCOST,
        "--pose-files",
        "-o",
        str(tmp_path / "p"),
    ]
    assert main(argv) == ExitCode.OK
    assert "wrote 6 pose files in" in capsys.readouterr().out
    assert sorted(p.name for p in (tmp_path / "p").iterdir()) == [f"pose_{k:02d}.csv" for k in range(1, 7)]
    assert main(argv) == ExitCode.CONFIG  # a second dataset into the same folder: refused, nothing overwritten
    assert "already holds pose files (pose_01.csv, ... 6 in all)" in capsys.readouterr().err


def test_pose_files_with_roll_pitch_yaw_and_no_robot_give_the_joints_calibration(dataset, tmp_path):
    """The real-world case of the issue: static poses logged as roll/pitch/yaw, one file per pose, no URDF."""
    import pinocchio as pin

    folder, files, _, kin, *_ = dataset
    rpy_folder = tmp_path / "rpy"
    rpy_folder.mkdir()
    for path in files:
        table = pd.read_csv(path)
        R = kin.R_world_sensor(table[list(kin.joint_names)].to_numpy())
        rpy = np.array([pin.rpy.matrixToRpy(r) for r in R])
        strains = [c for c in table.columns if c.startswith("strain_")]
        out = pd.concat([table[["time"]], pd.DataFrame(rpy, columns=["roll", "pitch", "yaw"]), table[[*strains, "tool"]]], axis=1)
        out.to_csv(rpy_folder / path.name, index=False, float_format="%.17g")
    code, text = calibrate([folder / "poses" / "*.csv"], tmp_path / "joints.yaml")
    assert code == ExitCode.OK, text
    argv = ["calibrate", "--tool", "paper_tool", *LOWCOST, str(rpy_folder / "*.csv"), "-o", str(tmp_path / "rpy.yaml"), "--quiet"]
    assert main(argv) == ExitCode.OK
    joints, rpy = load_calibration(tmp_path / "joints.yaml"), load_calibration(tmp_path / "rpy.yaml")
    assert rpy.model_selection["units"] == joints.model_selection["units"]
    np.testing.assert_allclose(rpy.C, joints.C, rtol=0, atol=1e-9 * np.abs(joints.C).max())
    np.testing.assert_allclose(rpy.D, joints.D, rtol=0, atol=1e-9 * np.abs(joints.D).max())

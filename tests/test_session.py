"""The calibration session: checks, progress in words, checkpoints and resume."""

import numpy as np
import pytest

from fts_calib import FtsCalibWarning, InsufficientExcitation
from fts_calib.filters.settings import LiveConfig, PipelineConfig
from fts_calib.robot.tool import Tool, ToolConfiguration
from fts_calib.session.session import BACKWARDS, BEFORE_CHECKPOINT, NON_FINITE, OUTSIDE_LIMITS, UNKNOWN_TOOL, CalibrationSession
from fts_calib.sim.sensor import load_simulated_sensor
from fts_calib.sources.recording import RecordingReader


def _chunks(path, kin, tool, rows=4000):
    with RecordingReader(path, kin.joint_names, tool.names, block_bytes=rows * 220) as reader:
        return list(reader)


def _feed(session, chunks):
    for c in chunks:
        session.add_batch(c.time, c.joints, c.channels, c.configuration)
    session.flush()


def test_single_samples_and_batches_give_the_same_calibration(ur5, paper_tool, ur5_recording):
    chunks = _chunks(ur5_recording, ur5, paper_tool)
    batch = CalibrationSession(ur5, paper_tool)
    _feed(batch, chunks)
    single = CalibrationSession(ur5, paper_tool)
    for c in chunks[:2]:
        for t, q, s, k in zip(c.time, c.joints, c.channels, c.configuration, strict=True):
            single.add(t, q, s, paper_tool.names[k])
    _feed(single, chunks[2:])
    a, b = batch.solve(), single.solve()
    # the same samples summed in another grouping: round-off of the sums (N eps, N ~ 1,000)
    # times the condition number (< 100), of the largest coefficient; C_bar has entries near zero
    np.testing.assert_allclose(a.C_bar, b.C_bar, rtol=0, atol=1e-10 * np.abs(b.C_bar).max())
    assert a.quality.samples_used == b.quality.samples_used > 1000


def test_progress_says_what_is_missing(ur5, paper_tool, ur5_recording):
    chunks = _chunks(ur5_recording, ur5, paper_tool)
    t = np.concatenate([c.time for c in chunks])
    q = np.concatenate([c.joints for c in chunks])
    s = np.concatenate([c.channels for c in chunks])
    k = np.concatenate([c.configuration for c in chunks])
    session = CalibrationSession(ur5, paper_tool)
    assert session.progress().missing.startswith("no quasi-static sample yet")
    words = []
    for config in range(3):
        mine = k == config
        session.add_batch(t[mine], q[mine], s[mine], k[mine])
        session.flush()
        p = session.progress()
        words.append((p.rank, p.missing))
    assert words[0] == (4, "one centre of mass (configuration A); mount two more, not on one line with it (B and C of the tool file)")
    assert words[1] == (6, "centres of mass on one line (configurations A and B); mount one more off that line (C of the tool file)")
    assert words[2] == (7, "")
    assert session.progress().kept_by_configuration["C"] > 300


def test_collinear_tool_is_explained(ur5, ur5_recording, paper_tool):
    """Strains made by a tool whose centres of mass lie on one line: rank 6 at most (eqs 19-20)."""
    from fts_calib.core.resources import resolve

    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    line = Tool(
        "line", 9.81, tuple(ToolConfiguration(n, 2.0, np.array([x, 0.0, 0.0])) for n, x in zip("ABC", (0.05, 0.1, 0.15), strict=True))
    )
    session = CalibrationSession(ur5, line)
    for c in _chunks(ur5_recording, ur5, paper_tool):
        W = np.array([line.configurations[k].static_wrench(g) for k, g in zip(c.configuration, ur5.g_sensor(c.joints), strict=True)])
        session.add_batch(c.time, c.joints, sensor.channels(W), c.configuration)
    session.flush()
    p = session.progress()
    assert p.rank == 6 and "lie on one line" in p.missing
    with pytest.raises(InsufficientExcitation, match="rank 6 of 7.*lie on one line"):
        session.solve()


def test_bad_samples_are_counted_and_the_run_goes_on(ur5, paper_tool, ur5_recording):
    c = _chunks(ur5_recording, ur5, paper_tool, rows=100_000)[0]
    t, q, s, k = c.time.copy(), c.joints.copy(), c.channels.copy(), c.configuration.copy()
    t[100] = t[50]  # backwards
    s[200, 3] = np.nan
    k[300] = -1
    q[400, 2] = 4.0  # outside the elbow's limits of +-pi
    session = CalibrationSession(ur5, paper_tool)
    session.add_batch(t, q, s, k)
    session.flush()
    assert session.skipped == {BACKWARDS: 1, NON_FINITE: 1, UNKNOWN_TOOL: 1, OUTSIDE_LIMITS: 1}
    assert session.solve().quality.rank == 7


def test_readings_in_degrees_are_warned_about_once_and_skipped(ur5, paper_tool, ur5_recording):
    c = _chunks(ur5_recording, ur5, paper_tool, rows=100_000)[0]
    session = CalibrationSession(ur5, paper_tool)
    with pytest.warns(FtsCalibWarning, match="look like degrees"):
        session.add_batch(c.time, np.degrees(c.joints), c.channels, c.configuration)
    assert session.skipped[OUTSIDE_LIMITS] > 0.9 * len(c.time)


def test_checkpoint_and_resume_give_the_uninterrupted_result(tmp_path, ur5, paper_tool, ur5_recording):
    chunks = _chunks(ur5_recording, ur5, paper_tool, rows=3000)
    whole = CalibrationSession(ur5, paper_tool)
    _feed(whole, chunks)
    expected = whole.solve()
    clock = iter(np.arange(0.0, 1000.0, 1.0))
    config = PipelineConfig(live=LiveConfig(checkpoint_interval_s=1.0))
    first = CalibrationSession(ur5, paper_tool, config, checkpoint=tmp_path / "cp.json", clock=lambda: next(clock))
    for c in chunks[:3]:
        first.add_batch(c.time, c.joints, c.channels, c.configuration)
    # a crash here: the checkpoint written after the third chunk is all that is left
    resumed = CalibrationSession.resume(tmp_path / "cp.json", ur5, paper_tool, config)
    _feed(resumed, chunks)  # the whole recording again: what the checkpoint holds is skipped
    assert resumed.skipped[BEFORE_CHECKPOINT] > 0
    got = resumed.solve()
    # the filter's undecided context at the checkpoint (half a window) is lost: a few samples
    assert abs(got.quality.samples_used - expected.quality.samples_used) < 60
    assert np.all(np.abs(got.C - expected.C) < 0.5 * expected.quality.stderr_C)


def test_resume_refuses_another_robot_or_tool(tmp_path, ur5, panda, paper_tool):
    session = CalibrationSession(ur5, paper_tool, checkpoint=tmp_path / "cp.json")
    session.checkpoint()
    from fts_calib import FileFormatError

    with pytest.raises(FileFormatError, match="checkpoint of robot 'ur5'.*not of 'panda'"):
        CalibrationSession.resume(tmp_path / "cp.json", panda, paper_tool)
    (tmp_path / "bad.json").write_text("{")
    with pytest.raises(FileFormatError, match="not a checkpoint"):
        CalibrationSession.resume(tmp_path / "bad.json", ur5, paper_tool)


@pytest.fixture(scope="module")
def shipped_plan_arrays(seed):
    """The shipped UR5 plan (trajectories/ur5) played through the simulated sensor, as arrays (moving tool, noise)."""
    from fts_calib.core.resources import data_dir, resolve
    from fts_calib.planning.trajectory_files import read_trajectory
    from fts_calib.robot.definition import load_robot
    from fts_calib.robot.kinematics import Kinematics
    from fts_calib.robot.tool import load_tool
    from fts_calib.sim.runs import simulate_batches

    kin, tool = Kinematics(load_robot(resolve("ur5", "robots"))), load_tool(resolve("paper_tool", "configs"))
    plan = [read_trajectory(data_dir("trajectories") / "ur5" / f"{name}.csv.gz") for name in tool.names]
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    batches = list(simulate_batches(kin, tool, plan, sensor, np.random.default_rng([seed, 29])))
    return {
        "time": np.concatenate([b.time for b in batches]),  # [s]
        "joints": np.concatenate([b.joints for b in batches]),  # [rad]
        "channels": np.concatenate([b.channels for b in batches]),
        "configuration": np.concatenate([b.configuration for b in batches]),
    }


def test_the_calibration_carries_the_load_region_of_its_kept_samples(ur5, paper_tool, shipped_plan_arrays):
    import fts_calib

    kept = []
    session = CalibrationSession(ur5, paper_tool, on_kept=lambda t, W, *rest: kept.append(W))
    a = shipped_plan_arrays
    session.add_batch(a["time"], a["joints"], a["channels"], a["configuration"])
    session.flush()
    calibration = session.solve()
    region, W = calibration.region, np.vstack(kept)
    # the region is the box of exactly the wrenches that entered the least squares
    np.testing.assert_array_equal(region.low, W.min(axis=0))
    np.testing.assert_array_equal(region.high, W.max(axis=0))
    assert region.samples == len(W) == calibration.quality.samples_used > 300  # about 370 of 4,038 at 100 Hz
    # quasi-static samples enter with the static wrench: |F| = m g (2 kg, 9.81 m/s^2) to rounding
    assert region.force_max == pytest.approx(2.0 * paper_tool.gravity, rel=1e-6)
    assert region.moment_max == pytest.approx(np.linalg.norm(W[:, 3:], axis=1).max(), rel=1e-12)
    np.testing.assert_array_equal(region.margin, 0.01 * session.full_scale)  # 1 % of the sensor's full scale
    # the Python entry point goes through the session: the same region
    names = [paper_tool.names[k] for k in a["configuration"]]
    api = fts_calib.calibrate({**a, "configuration": names}, robot=ur5, tool=paper_tool)
    np.testing.assert_array_equal(api.region.low, region.low)
    np.testing.assert_array_equal(api.region.high, region.high)


def test_a_resumed_session_keeps_the_region_of_the_samples_before_its_checkpoint(tmp_path, ur5, paper_tool, ur5_recording):
    import json

    chunks = _chunks(ur5_recording, ur5, paper_tool, rows=3000)
    whole = CalibrationSession(ur5, paper_tool)
    _feed(whole, chunks)
    expected = whole.solve().region
    clock = iter(np.arange(0.0, 1000.0, 1.0))
    config = PipelineConfig(live=LiveConfig(checkpoint_interval_s=1.0))
    first = CalibrationSession(ur5, paper_tool, config, checkpoint=tmp_path / "cp.json", clock=lambda: next(clock))
    assert len(chunks) >= 3
    for c in chunks[:2]:  # a crash after the second chunk
        first.add_batch(c.time, c.joints, c.channels, c.configuration)
    state = json.loads((tmp_path / "cp.json").read_text())
    assert state["region"]["samples"] == sum(state["kept"]) > 0
    resumed = CalibrationSession.resume(tmp_path / "cp.json", ur5, paper_tool, config)
    _feed(resumed, chunks)
    got = resumed.solve().region
    # the filter's undecided context at the checkpoint is lost (a few samples of one stop): the extremes stay
    assert abs(got.samples - expected.samples) < 60
    np.testing.assert_allclose(got.low, expected.low, rtol=0, atol=1e-3 * np.abs(expected.low).max())
    np.testing.assert_allclose(got.high, expected.high, rtol=0, atol=1e-3 * np.abs(expected.high).max())
    # a checkpoint of an older version, without the region: the region of the resumed part only
    del state["region"]
    (tmp_path / "old.json").write_text(json.dumps(state))
    older = CalibrationSession.resume(tmp_path / "old.json", ur5, paper_tool, config)
    _feed(older, chunks)
    assert older.solve().region.samples == got.samples - sum(state["kept"])

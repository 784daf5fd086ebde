"""Continuous plans: no dwell, limits and clearance kept, fewer configurations refused naming what they reach, files round-trip."""

import dataclasses

import numpy as np
import pytest
import yaml

from fts_calib import TrajectoryError
from fts_calib.app.cli import main
from fts_calib.core.resources import resolve
from fts_calib.planning import sizing
from fts_calib.planning.planner import plan_calibration
from fts_calib.planning.sizing import with_configurations
from fts_calib.planning.sweeps import SweepPattern
from fts_calib.planning.trajectory_files import read_trajectory, save_trajectory
from fts_calib.robot.collision import CollisionChecker
from fts_calib.session.plan_progress import load_plan_progress
from fts_calib.session.session import Progress

PATTERN = SweepPattern(3, 1, 0.0, 0.02, 0.35, continuous=True)  # both wrist joints at once; the first passes its middle level


@pytest.mark.parametrize("robot", ["ur5", "kinova", "xarm7"])
def test_a_continuous_plan_keeps_every_limit_and_its_clearance_and_never_dwells(robot, robot_kinematics, paper_tool):
    """Independent of ruckig: velocity, acceleration, jerk from differences of the positions; clearance re-checked on every 10th sample."""
    kin = robot_kinematics(robot)
    checker = CollisionChecker(kin, paper_tool.shape, kin.sweep_joints[0])
    result = plan_calibration(kin, checker, PATTERN, 200.0)
    plan, h = result.plan, 1 / 200.0
    assert not result.problems, result.problems
    lim = kin.limits
    assert np.all(plan.q >= lim.lower - 1e-9) and np.all(plan.q <= lim.upper + 1e-9)
    for order, name in ((1, "velocity"), (2, "acceleration"), (3, "jerk")):
        peak = np.max(np.abs(np.diff(plan.q, n=order, axis=0)) / h**order, axis=0)
        assert np.all(peak <= getattr(lim, name) * (1 + 1e-6) + 1e-9), f"{name}: {peak} above {getattr(lim, name)}"
    # no dwell: between the start and the end at home, never still for more than an instant (a turning point)
    still = np.all(np.abs(plan.qd) < 1e-9, axis=1)
    inner = still[1:-1]
    runs = np.diff(np.flatnonzero(np.diff(np.concatenate([[0], inner.astype(int), [0]]))))[::2] if inner.any() else np.zeros(0)
    assert np.all(runs <= 1), f"still for {runs.max()} samples inside the motion"
    # a joint passes at least one stop at speed (continuous, not rest to rest)
    index = [kin.joint_names.index(j) for j in kin.sweep_joints]
    at_stops = [np.argmin(np.sum((plan.q[:, index] - w) ** 2, axis=1)) for w in plan.waypoints]
    assert np.max(np.abs(plan.qd[at_stops][:, index])) > 0.1
    clearance = checker.clearance(plan.q[::10], "all")
    assert clearance.distance >= result.min_clearance and result.clearance.distance >= result.min_clearance


def test_dwell_with_continuous_motion_is_refused():
    with pytest.raises(TrajectoryError, match="does not stop"):
        SweepPattern(2, 2, 0.5, continuous=True)


def test_a_configuration_count_outside_the_tool_is_refused(paper_tool):
    with pytest.raises(TrajectoryError, match="expected 1 to 3"):
        with_configurations(paper_tool, 4)


def test_one_configuration_with_an_unreachable_target_is_refused_naming_what_is_reachable(tmp_path, capsys, monkeypatch):
    """The search over every continuous raster, on a grid of two (the refusal is the same for the 60 the command searches)."""
    grid = dataclasses.replace(sizing.MOTION_KINDS["continuous"], levels=(3,), stops=(1, 2), spans=(0.35,))
    monkeypatch.setitem(sizing.MOTION_KINDS, "continuous", grid)
    out = tmp_path / "plan"
    common = ["trajectory", "--robot", "ur5", "--tool", "paper_tool", "-o", str(out), "--rate", "25", "--no-plot"]
    code = main([*common, "--motion", "continuous", "--configurations", "1", "--target-error", "0.05"])
    err = capsys.readouterr().err
    assert code == main([*common, "--target-error", "0.001"]), "the exit code of every unreachable target"
    assert code != 0
    assert "1 configuration reaches" in err and "2 configurations reach" in err and "3 configurations reach" in err, err
    assert "--target-error" in err and "--configurations 3" in err, err
    assert not (out / "A.csv").exists()


def test_fewer_configurations_with_stops_are_refused_with_the_rank(tmp_path, capsys):
    code = main(["trajectory", "--robot", "ur5", "--tool", "paper_tool", "-o", str(tmp_path), "--configurations", "2"])
    assert code != 0 and "rank 4 (one) or 6 (two)" in capsys.readouterr().err


def test_the_continuous_plan_files_round_trip_and_live_reads_its_progress(tmp_path, capsys):
    """Sized continuous plan: CSVs read back as written, plan.yaml states the motion, and live counts moving samples against it."""
    out = tmp_path / "plan"
    code = main(
        ["trajectory", "--robot", "ur5", "--tool", "paper_tool", "-o", str(out), "--rate", "50", "--no-plot"]
        + ["--motion", "continuous", "--target-error", "0.08"]
    )
    assert code == 0, capsys.readouterr()
    plan = yaml.safe_load((out / "plan.yaml").read_text())
    assert plan["motion"] == "continuous" and plan["pattern"]["continuous"] is True and plan["pattern"]["dwell_s"] == 0.0
    assert plan["motion_uncertainty"]["joint_rate_hz"] == 1000.0
    counts = plan["excitation"]["dynamic_samples"]
    for name in ("A", "B", "C"):
        traj = read_trajectory(out / f"{name}.csv")
        assert traj.tool == name and 0 < counts[name] < len(traj.time)  # the samples the trust rule keeps
        again = read_trajectory(save_trajectory(tmp_path / f"{name}.csv.gz", traj))
        for field in ("time", "q", "qd", "qdd"):
            assert np.allclose(getattr(again, field), getattr(traj, field), atol=1e-9)
    progress = load_plan_progress(out / "plan.yaml", 1000.0)
    expected = progress.expected["A"]
    assert expected == pytest.approx(counts["A"] * 1000.0 / 50.0)  # at the channel rate
    half = Progress(0, 0, {"A": int(expected / 2), "B": 0, "C": 0}, 4, float("inf"), "", {}, None)
    status = progress.status(half)
    assert "A 50 %" in status and "mount B next" in status, status
    assert progress.remaining_s(half) == pytest.approx(2.5 * plan["duration_s"], rel=1e-3)


def test_live_shows_the_progress_of_a_continuous_plan_from_moving_samples(tmp_path, ur5, paper_tool, rng):
    """A dynamic-mode session fed configuration A of a continuous plan (simulated, no still stretch): the status line counts it.

    The plan predicts the samples the trust rule keeps from the planned motion; the filter judges
    the estimated one: it keeps 88-96 % of the prediction here (docs/accuracy.md).
    """
    import dataclasses

    from fts_calib.filters.settings import load_pipeline_config
    from fts_calib.model.sensor_config import load_sensor_config
    from fts_calib.session.calibration_run import LiveRunner
    from fts_calib.session.session import CalibrationSession
    from fts_calib.sim.runs import simulate_batches
    from fts_calib.sim.sensor import load_simulated_sensor
    from fts_calib.sources.live_feed import LiveFeed
    from fts_calib.sources.synchronizer import Synchronizer
    from fts_calib.sources.udp import UdpReceiver

    out = tmp_path / "plan"
    common = ["trajectory", "--robot", "ur5", "--tool", "paper_tool", "-o", str(out), "--no-plot", "--motion", "continuous"]
    assert main([*common, "--rate", "1000", "--target-error", "0.08"]) == 0
    spec = load_sensor_config(resolve("sensor", "configs"))
    settings = load_pipeline_config(resolve("pipeline", "configs")).with_filter_mode("dynamic")
    known = dataclasses.replace(settings.filter, joint_noise=1e-5, latency_uncertainty_s=1e-4)  # what the plan assumed
    settings = dataclasses.replace(settings, filter=known, nominal_c=tuple(map(tuple, spec.simulated.C)))
    session = CalibrationSession(ur5, paper_tool, settings, source="test", full_scale=spec.full_scale)
    trajectory = read_trajectory(out / "A.csv")
    for batch in simulate_batches(ur5, paper_tool, [trajectory], load_simulated_sensor(resolve("sensor", "configs")), rng):
        session.add_samples(batch)
    session.flush()
    plan = load_plan_progress(out / "plan.yaml", spec.rate_hz)
    kept = session.progress().kept_by_configuration["A"]
    assert 0.7 * plan.expected["A"] < kept < 1.3 * plan.expected["A"], (kept, plan.expected)  # the plan's count is the filter's
    receiver = UdpReceiver("127.0.0.1", 0)
    try:
        sync = Synchronizer(ur5.joint_names, ur5.continuous, 0.05, 0.0, configurations=paper_tool.names)
        status = LiveRunner(session, LiveFeed(receiver, sync), plan=plan).status_line()
    finally:
        receiver.close()
    fraction = min(1.0, kept / plan.expected["A"])
    assert "mount B" in status and "of motion left" in status, status
    assert f"~{plan.duration_s * (3 - fraction):.0f} s of motion left" in status, status

"""Calibration trajectories: shipped plans re-checked independently, reproduction, checks."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from fts_calib import ConfigError, FileFormatError, TrajectoryError
from fts_calib.budget.propagation import DEFAULT_TARGET_PERCENT
from fts_calib.core.exceptions import JointError
from fts_calib.core.resources import resolve
from fts_calib.filters.settings import load_pipeline_config
from fts_calib.model.sensor_config import load_sensor_config
from fts_calib.planning import sizing
from fts_calib.planning.excitation import predict_excitation
from fts_calib.planning.motion import plan_sweeps
from fts_calib.planning.planner import plan_calibration
from fts_calib.planning.sweeps import SweepPattern, sweep_ranges
from fts_calib.planning.trajectory_files import read_trajectory
from fts_calib.planning.trajectory_run import plan_trajectories
from fts_calib.robot.collision import CollisionChecker
from fts_calib.robot.definition import load_robot
from fts_calib.robot.kinematics import Kinematics
from fts_calib.robot.tool import ToolShape, load_tool

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = ["ur5", "ur10", "panda", "kinova", "xarm7"]
# Positions are printed to 1e-9 rad: rounding adds at most 2^k * 0.5e-9 / dt^k to a k-th difference.
ROUNDING = 0.5e-9  # [rad]


@pytest.fixture(scope="module")
def setup():
    tool = load_tool(resolve("paper_tool", "configs"))
    sensor = load_sensor_config(resolve("sensor", "configs"))
    pipeline = load_pipeline_config(resolve("pipeline", "configs"))
    return tool, sensor, pipeline


@pytest.mark.parametrize("robot", SHIPPED)
def test_every_sample_of_the_shipped_plans_is_within_limits_by_finite_differences(robot, robot_kinematics, paper_tool):
    """Independent of ruckig: velocity, acceleration and jerk from differences of positions only.

    A k-th difference over k steps is a weighted mean of the k-th derivative, so it cannot
    exceed the derivative's limit; the tolerance is the rounding of the printed positions.
    """
    kin = robot_kinematics(robot)
    for config in paper_tool.configurations:
        traj = read_trajectory(ROOT / "trajectories" / robot / f"{config.name}.csv.gz")
        assert traj.joint_names == kin.joint_names and traj.tool == config.name
        dt = np.diff(traj.time)
        assert np.allclose(dt, 0.01), "100 Hz"
        h = 0.01
        lim = kin.limits
        assert np.all(traj.q >= lim.lower - 1e-9) and np.all(traj.q <= lim.upper + 1e-9)
        for order, name in ((1, "velocity"), (2, "acceleration"), (3, "jerk")):
            diff = np.abs(np.diff(traj.q, n=order, axis=0)) / h**order
            tolerance = 2**order * ROUNDING / h**order
            limit = getattr(lim, name)
            excess = diff - (limit * (1 + 1e-9) + tolerance)
            assert np.all(excess <= 0), f"{robot} {config.name}: {name} exceeds its limit by {excess.max():.3g}"
        still = [j for j in kin.joint_names if j not in kin.sweep_joints]
        for joint in still:
            k = kin.joint_names.index(joint)
            assert np.ptp(traj.q[:, k]) == 0.0, f"{joint} must not move"
        # the files' velocity columns agree with the positions (central differences, O(h^2))
        central = (traj.q[2:] - traj.q[:-2]) / (2 * h)
        assert np.max(np.abs(central - traj.qd[1:-1])) < lim.jerk.max() * h**2 + 1e-6


@pytest.mark.parametrize("robot", SHIPPED)
def test_planning_again_reproduces_the_shipped_trajectories(robot, setup):
    """The shipped plans are `make trajectories`: sized to the default target (fts-calib trajectory's default)."""
    tool, sensor, pipeline = setup
    run = plan_trajectories(
        resolve(robot, "robots"), tool, sensor, pipeline.filter, 1e-5, SweepPattern(), 100.0, target_percent=DEFAULT_TARGET_PERCENT
    )
    assert not run.problems, run.problems
    shipped = read_trajectory(ROOT / "trajectories" / robot / "A.csv.gz")
    plan = run.result.plan
    assert len(shipped.time) == len(plan.time)
    # A golden check: the only difference allowed is the files' printing (%.9f, 5e-10), plus 1 %
    # (5e-12) for the last bits of another compiler or CPU (a few eps of 3 rad, about 1e-15).
    # ruckig 0.12.2 (the oldest pyproject allows), 0.17.3 and the locked 0.19.4 give bit-identical
    # q, qd and qdd here. A ruckig with other numerics is only held to its own acceptance
    # thresholds (profile.hpp: p_precision 1e-8 rad, a_precision 1e-10 rad/s^2, t_precision 1e-12 s):
    # it would need ROUNDING + 1e-8 = 1.05e-8 rad on q, and on qdd the jerk (<= 15 rad/s^3) times
    # the phase-time shift (~1e-8 rad / v ~ 6e-9 s) that such a position change implies, ~1e-7
    # rad/s^2. Rather than loosen this, regenerate the shipped files after such an upgrade: the
    # finite-difference test above checks their limits independently of ruckig.
    np.testing.assert_allclose(plan.q, shipped.q, atol=ROUNDING * 1.01, rtol=0)
    np.testing.assert_allclose(plan.qdd, shipped.qdd, atol=ROUNDING * 1.01, rtol=0)
    summary = yaml.safe_load((ROOT / "trajectories" / robot / "plan.yaml").read_text())
    assert summary["duration_s"] == pytest.approx(plan.duration, abs=1e-6)
    assert summary["excitation"]["rank"] == 7
    assert summary["accuracy_budget"]["largest_percent_fs"] <= DEFAULT_TARGET_PERCENT
    # the figures: UR5 <= 15 s and Kinova <= 30 s of motion per configuration (53.4 s and 94.7 s before)
    assert plan.duration <= {"kinova": 30.0}.get(robot, 15.0)
    assert run.budget is not None and run.budget.largest_percent <= DEFAULT_TARGET_PERCENT and run.excitation.rank == 7
    assert run.sized is not None and run.sized.kind == "stop" and run.sized.pattern == plan.pattern


def test_a_target_below_what_the_tool_and_mount_allow_names_the_term(setup):
    tool, sensor, pipeline = setup
    with pytest.raises(TrajectoryError, match=r"no plan meets the target of 0.01 % of full scale: sensor mount alone gives 0.03"):
        plan_trajectories(resolve("ur5", "robots"), tool, sensor, pipeline.filter, 1e-5, SweepPattern(), 50.0, target_percent=0.01)
    for target in (0.0, float("inf")):  # before: inf sized a plan, printed 'inf % on Fx' and 'nan %', and exited 1
        with pytest.raises(TrajectoryError, match=r"target error .* % of full scale \(--target-error\) but expected a finite value > 0"):
            plan_trajectories(resolve("ur5", "robots"), tool, sensor, pipeline.filter, 1e-5, SweepPattern(), 50.0, target_percent=target)


def test_the_sizer_refuses_an_unknown_motion_and_candidates_beyond_the_robots_limits(setup, ur5, monkeypatch):
    """One sizer for every motion: it names the kinds it knows, and the longest candidate when none fits the robot."""
    tool, sensor, pipeline = setup
    checker = CollisionChecker(ur5, tool.shape, ur5.sweep_joints[0])
    sim = sensor.simulated
    nominal = (sim.C_bar, sim.D, np.full(6, 1e-3), sensor.full_scale)
    with pytest.raises(TrajectoryError, match="motion 'spiral' but expected one of stop, continuous, smooth"):
        sizing.size_motion("spiral", ur5, checker, tool, nominal, pipeline.filter, 0.05, 50.0, 1000.0)
    too_short = dataclasses.replace(sizing.MOTION_KINDS["smooth"], durations_s=(0.5, 1.0))  # [s] shorter than the ramps
    monkeypatch.setitem(sizing.MOTION_KINDS, "smooth", too_short)
    smooth = SweepPattern(2, 1, 0.0, continuous=True, smooth=True)
    with pytest.raises(TrajectoryError, match="no smooth motion of at most 1 s fits ur5's limits"):
        plan_trajectories(resolve("ur5", "robots"), tool, sensor, pipeline.filter, 1e-5, smooth, 50.0, target_percent=0.05)


def test_a_noisier_sensor_needs_a_longer_plan(setup):
    """Strain noise is the term a plan can shrink: 30 times the shipped noise makes the shortest raster fall short."""
    tool, sensor, pipeline = setup
    quiet, noisy = (
        plan_trajectories(resolve("ur5", "robots"), tool, sensor, pipeline.filter, noise, SweepPattern(), 50.0, target_percent=0.05)
        for noise in (1e-5, 3e-4)
    )
    assert noisy.result.plan.duration > quiet.result.plan.duration
    assert noisy.budget is not None and noisy.budget.largest_percent <= 0.05


def test_ur5_figures(setup):
    """The issue's figures: <= 60 s per configuration, predicted stderr <= 0.05 % of the row's largest."""
    tool, sensor, pipeline = setup
    run = plan_trajectories(resolve("ur5", "robots"), tool, sensor, pipeline.filter, 1e-5, SweepPattern(), 500.0)
    assert run.result.plan.duration <= 60.0
    assert run.excitation.max_relative_stderr <= 5e-4
    assert run.excitation.rank == 7 and math.isfinite(run.excitation.condition_number)
    assert run.result.clearance.distance >= 0.02 and run.result.limits.ok


def test_one_configuration_gives_rank_4_two_give_6(setup):
    tool, sensor, pipeline = setup
    run = plan_trajectories(resolve("ur5", "robots"), tool, sensor, pipeline.filter, 1e-5, SweepPattern(), 100.0)
    g = run.g_sensor[run.still]
    sim = sensor.simulated
    ranks = [
        predict_excitation({name: g for name in names}, tool, sim.C_bar, sim.D, 1e-5).rank for names in (["A"], ["A", "B"], ["A", "B", "C"])
    ]
    assert ranks == [4, 6, 7]
    single = predict_excitation({"A": g}, tool, sim.C_bar, sim.D, 1e-5)
    assert "rank 4 of 7" in single.advice and np.all(np.isinf(single.stderr_C))


def _robot_file(tmp_path, base, **changes):
    data = yaml.safe_load(resolve(base, "robots").read_text())
    data.update(changes)
    path = tmp_path / f"{base}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_a_home_with_a_vertical_first_sweep_axis_is_flagged(tmp_path, ur5):
    # find the wrist_1 angle that makes the wrist_2 axis vertical, from a typical pose
    home = np.array([0.0, -1.2, 1.6, 0.0, 0.0, 0.0])
    values = np.linspace(-math.pi, math.pi, 721)
    tilts = []
    for v in values:
        home[3] = v
        tilts.append(abs(ur5.joint_axis_world(home, "wrist_2_joint")[2]))
    home[3] = values[int(np.argmax(tilts))]
    assert max(tilts) > 0.999
    path = _robot_file(tmp_path, "ur5", home=dict(zip(ur5.joint_names, home.tolist(), strict=True)))
    kin = Kinematics(load_robot(path))
    checker = CollisionChecker(kin, load_tool(resolve("paper_tool", "configs")).shape, kin.sweep_joints[0])
    with pytest.raises(
        TrajectoryError,
        match=r"poor home: the axis of wrist_2_joint is (89|90)\.\d° from horizontal .* "
        r"gravity would stay near one circle.*Change wrist_1_joint",
    ) as info:
        plan_calibration(kin, checker, SweepPattern(), 100.0)
    assert info.value.result == "poor home"


def test_a_very_large_tool_is_rejected_with_the_pair_named(setup):
    tool, sensor, pipeline = setup
    import dataclasses

    huge = dataclasses.replace(tool, shape=ToolShape(radius=0.45, length=0.6))
    with pytest.raises(TrajectoryError, match=r"'\w+' and '\w+'") as info:
        plan_trajectories(resolve("ur5", "robots"), huge, sensor, pipeline.filter, 1e-5, SweepPattern(), 100.0)
    assert "'tool'" in str(info.value) and "m" in str(info.value)


def test_home_outside_the_joint_limits_is_a_clear_error(tmp_path):
    home = {"panda_joint4": 0.5}
    path = _robot_file(tmp_path, "panda", home=home)
    kin = Kinematics(load_robot(path))
    checker = CollisionChecker(kin, ToolShape(0.05, 0.1), kin.sweep_joints[0])
    with pytest.raises(TrajectoryError, match=r"home outside the joint limits: panda_joint4 = \+0.5000 rad not in \[-3.0718, -0.0698\]"):
        plan_calibration(kin, checker, SweepPattern(), 100.0)


def test_bad_rate_pattern_limits_and_sweep_joint(tmp_path, ur5):
    home = np.array([0.0, -1.2, 1.6, -1.97, 0.0, 0.0])
    ranges = sweep_ranges(ur5, home, 0.02)
    for rate in (0.0, -5.0, math.nan):
        with pytest.raises(TrajectoryError, match="rate=.* Hz but expected a finite rate > 0"):
            plan_sweeps(ur5, home, ranges, SweepPattern(), rate)
    with pytest.raises(TrajectoryError, match="levels=1 and stops=6 but expected at least 2 each"):
        SweepPattern(levels=1)
    with pytest.raises(TrajectoryError, match="dwell=-1 s"):
        SweepPattern(dwell=-1)
    with pytest.raises(FileFormatError, match=r"'limits.acceleration': is 0.0 but expected a finite value > 0"):
        load_robot(_robot_file(tmp_path, "ur5", limits={"acceleration": 0}))
    with pytest.raises(FileFormatError, match=r"'limits.jerk': is -3.0 but expected a finite value > 0"):
        load_robot(_robot_file(tmp_path, "ur5", limits={"jerk": -3}))
    with pytest.raises(JointError, match=r"sweep joint \['wrist_9_joint'\] not among the actuated joints"):
        Kinematics(load_robot(_robot_file(tmp_path, "ur5", sweep_joints=["wrist_2_joint", "wrist_9_joint"])))


def test_ruckig_errors_become_trajectory_errors(ur5):
    import dataclasses

    home = np.array([0.0, -1.2, 1.6, -1.97, 0.0, 0.0])
    broken = dataclasses.replace(ur5.limits, jerk=np.full(6, np.nan))
    object.__setattr__(ur5, "limits", broken)
    try:
        with pytest.raises(TrajectoryError, match="ruckig (rejected|could not plan) the segment") as info:
            plan_sweeps(ur5, home, sweep_ranges(ur5, home, 0.02), SweepPattern(), 100.0)
        assert info.value.result
    finally:
        object.__setattr__(ur5, "limits", Kinematics(ur5.robot).limits)


def test_planning_without_a_nominal_sensor_model_is_refused_before_planning(setup):
    import dataclasses

    tool, sensor, pipeline = setup
    bare = dataclasses.replace(sensor, simulated=None)
    with pytest.raises(ConfigError, match=r"the sensor configuration needs a 'simulation' section \(a nominal C\)"):
        plan_trajectories(resolve("ur5", "robots"), tool, bare, pipeline.filter, 1e-5, SweepPattern(), 100.0)


@pytest.mark.parametrize(
    ("robot", "rate", "dwell", "continuous"), [("ur5", 100.0, 0.3, False), ("panda", 137.0, 0.0, True), ("xarm7", 250.0, 0.05, False)]
)
def test_a_freshly_sampled_motion_ends_at_rest_at_home_on_the_first_sample_at_or_after_its_end(
    robot, rate, dwell, continuous, robot_kinematics
):
    """A property on any stops and rate: the last row is home with velocity and acceleration 0 (round-off), at the motion's
    length (ruckig's segment durations plus the dwells, summed without sampling) rounded up to the sample grid."""
    from fts_calib.planning.motion import passing_velocities, sample_motion, segment_durations

    kin = robot_kinematics(robot)
    rng = np.random.default_rng(7)
    index = [kin.joint_names.index(name) for name in kin.sweep_joints]
    home = np.where(np.isfinite(kin.limits.lower), (kin.limits.lower + kin.limits.upper) / 2, 0.0)
    stops = home[index] + rng.uniform(-0.6, 0.6, size=(5, 2))
    velocities = passing_velocities(kin, home, kin.sweep_joints, stops) if continuous else None
    time, q, qd, qdd = sample_motion(kin, home, kin.sweep_joints, stops, dwell, rate, velocities)
    length = sum(segment_durations(kin, home, stops, continuous)) + dwell * len(stops)
    assert time[-2] < length - 1e-9 / rate and time[-1] >= length - 1e-9 / rate  # the end rounded up to the grid: no row missing
    assert time[-1] - length < 1 / rate
    np.testing.assert_array_equal(q[-1], home)
    np.testing.assert_allclose(qd[-1], 0.0, atol=1e-12)
    np.testing.assert_allclose(qdd[-1], 0.0, atol=1e-12)
    # the row before is ruckig's, one step or less from the end: within what the jerk limit allows there
    lim = kin.limits
    assert np.all(np.abs(qdd[-2, index]) <= lim.jerk[index] / rate * (1 + 1e-9))


@pytest.mark.parametrize("robot", SHIPPED)
def test_the_shipped_plans_end_at_rest(robot):
    """Every configuration's last row: at home (the first row's pose), velocity and acceleration 0 as printed (%.9f)."""
    for config in "ABC":
        traj = read_trajectory(ROOT / "trajectories" / robot / f"{config}.csv.gz")
        np.testing.assert_allclose(traj.q[-1], traj.q[0], atol=ROUNDING * 1.01)
        np.testing.assert_allclose(traj.qd[-1], 0.0, atol=ROUNDING * 1.01)
        np.testing.assert_allclose(traj.qdd[-1], 0.0, atol=ROUNDING * 1.01)

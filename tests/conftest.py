"""Shared fixtures: robots are loaded once per session; each test gets fresh Pinocchio data."""

import numpy as np
import pytest

from fts_calib.kinematics import Kinematics
from fts_calib.resources import resolve
from fts_calib.robot import load_robot
from fts_calib.tool import load_tool


@pytest.fixture
def rng():
    """A seeded generator: every random test is reproducible."""
    return np.random.default_rng(20261122)


@pytest.fixture(scope="session")
def _kinematics_cache():
    return {}


def _kinematics(cache, name):
    if name not in cache:
        cache[name] = Kinematics(load_robot(resolve(name, "robots")))
    kin = cache[name]
    kin.data = kin.model.createData()  # fresh data for every test
    return kin


@pytest.fixture
def ur5(_kinematics_cache):
    return _kinematics(_kinematics_cache, "ur5")


@pytest.fixture
def panda(_kinematics_cache):
    return _kinematics(_kinematics_cache, "panda")


@pytest.fixture
def kinova(_kinematics_cache):
    return _kinematics(_kinematics_cache, "kinova")


@pytest.fixture
def robot_kinematics(_kinematics_cache):
    """Kinematics of a shipped robot by name (for parametrised tests)."""
    return lambda name: _kinematics(_kinematics_cache, name)


@pytest.fixture(scope="session")
def paper_tool():
    return load_tool(resolve("paper_tool", "configs"))


def random_readings(kin, n, rng):
    """Uniform joint readings within the limits ([-pi, pi] for continuous joints), (n, n_joints)."""
    lo = np.where(np.isfinite(kin.limits.lower), kin.limits.lower, -np.pi)
    hi = np.where(np.isfinite(kin.limits.upper), kin.limits.upper, np.pi)
    return rng.uniform(lo, hi, (n, kin.n_joints))


@pytest.fixture(scope="session")
def short_plan():
    """A short UR5 calibration motion (3 levels x 4 stops, 100 Hz) for all three configurations."""
    from fts_calib.collision import CollisionChecker
    from fts_calib.planner import SweepPattern, plan_sweeps, sweep_ranges, wrist_ranges

    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    tool = load_tool(resolve("paper_tool", "configs"))
    pattern = SweepPattern(levels=3, stops=4, dwell=0.4)
    checker = CollisionChecker(kin, tool.shape, kin.sweep_joints[0])
    home = np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0])
    ranges = wrist_ranges(kin, checker, home, sweep_ranges(kin, home, pattern.margin), 0.02).ranges
    return plan_sweeps(kin, home, ranges, pattern, 100.0)


@pytest.fixture(scope="session")
def ur5_recording(tmp_path_factory, short_plan):
    """A simulated UR5 recording of the short plan: noise, 24-bit ADC, moving tool (Newton-Euler)."""
    from fts_calib.sensor_config import load_sensor_config
    from fts_calib.simulate import simulate_recording
    from fts_calib.trajectory_io import TrajectoryFile

    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    tool = load_tool(resolve("paper_tool", "configs"))
    sensor = load_sensor_config(resolve("sensor", "configs")).simulated
    p = short_plan
    trajectories = [TrajectoryFile(p.joint_names, p.time, p.q, p.qd, p.qdd, c.name) for c in tool.configurations]
    path = tmp_path_factory.mktemp("recordings") / "ur5.csv"
    return simulate_recording(path, kin, tool, trajectories, sensor, np.random.default_rng(7))

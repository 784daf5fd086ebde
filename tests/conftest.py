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

"""Shared fixtures: robots are loaded once per session; each test gets fresh Pinocchio data."""

import numpy as np
import pytest

from fts_calib.core.resources import resolve
from fts_calib.planning.trajectory_files import TrajectoryFile
from fts_calib.robot.definition import load_robot
from fts_calib.robot.kinematics import Kinematics
from fts_calib.robot.tool import load_tool
from fts_calib.sim.sensor import load_simulated_sensor

from .rtde_case import factory_runs_of, short_ur5_plan

#: The one seed of the normal suite. ``--seed S`` runs the suite with another one, and
#: ``--seeds N`` (or ``--seeds A:B``) runs every randomized test once per seed in range(N):
#: a randomized test must pass for any seed (tests/seed_sweep.py checks a few hundred).
DEFAULT_SEED = 20261122


def pytest_addoption(parser):
    group = parser.getgroup("fts_calib", "fts_calib seeds")
    group.addoption("--seed", type=int, default=DEFAULT_SEED, help=f"seed of every randomized test (default {DEFAULT_SEED})")
    group.addoption("--seeds", metavar="N|A:B", help="run every randomized test once per seed in range(N) or range(A, B)")


def pytest_configure(config):
    config.addinivalue_line("markers", "randomized: draws its data from the `seed` fixture (marked on collection); tests/seed_sweep.py")
    config.addinivalue_line("markers", "slow: takes more than a second a seed; left out of the seed sweep (the reason is at the test)")


def seed_range(text: str) -> range:
    """``"N"`` is range(N), ``"A:B"`` is range(A, B)."""
    first, _, last = text.rpartition(":")
    try:
        seeds = range(int(first or 0), int(last))
    except ValueError:
        raise pytest.UsageError(f"--seeds {text!r} but expected N or A:B, e.g. 200 or 0:100") from None
    if not seeds:
        raise pytest.UsageError(f"--seeds {text!r} is an empty range")
    return seeds


def pytest_generate_tests(metafunc):
    text = metafunc.config.getoption("seeds")
    if text is not None and "seed" in metafunc.fixturenames:
        seeds = seed_range(text)
        # session scope: the seeded session and module fixtures (the simulated recordings) are
        # built once per seed, and pytest groups the tests of one seed together
        metafunc.parametrize("seed", seeds, ids=[f"seed{s}" for s in seeds], scope="session")


@pytest.hookimpl(tryfirst=True)  # before -m selects on the marker
def pytest_collection_modifyitems(items):
    for item in items:
        if "seed" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.randomized)


@pytest.fixture(scope="session")
def seed(request):
    """The seed of every random draw in a test: ``--seed`` (default DEFAULT_SEED), or one of ``--seeds``."""
    return request.config.getoption("seed")


@pytest.fixture
def rng(seed):
    """A generator seeded by ``seed``: every random test is reproducible, and passes for any seed."""
    return np.random.default_rng(seed)


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
    return short_ur5_plan()


@pytest.fixture(scope="session")
def ur5_recording(tmp_path_factory, short_plan, seed):
    """A simulated UR5 recording of the short plan: noise, 24-bit ADC, moving tool (Newton-Euler)."""
    from fts_calib.sim.runs import simulate_recording

    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    tool = load_tool(resolve("paper_tool", "configs"))
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    p = short_plan
    trajectories = [TrajectoryFile(p.joint_names, p.time, p.q, p.qd, p.qdd, c.name) for c in tool.configurations]
    path = tmp_path_factory.mktemp("recordings") / "ur5.csv"
    return simulate_recording(path, kin, tool, trajectories, sensor, np.random.default_rng(seed))


@pytest.fixture(scope="session")
def factory_runs(short_plan, seed):
    """The short UR5 plan through the simulated factory-calibrated sensor: (sensor, per configuration (time, q, wrench))."""
    return factory_runs_of(short_plan, seed)

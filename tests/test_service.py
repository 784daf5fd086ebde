"""In service: the fast wrench path, and gravity compensation against a simulated payload."""

import tracemalloc

import numpy as np
import pytest

from fts_calib import Calibration, ShapeError
from fts_calib.core.resources import resolve
from fts_calib.robot.tool import load_tool
from fts_calib.service.reader import GravityCompensator, WrenchReader
from fts_calib.sim.sensor import load_simulated_sensor

from .conftest import random_readings
from .helpers import strains_eq22

FULL_SCALE = np.array([50.0, 50.0, 50.0, 5.0, 5.0, 5.0])  # [N, N, N, N m, N m, N m], the paper's sensor


@pytest.fixture(scope="module")
def world():
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    payload = load_tool(resolve("validation_tool", "configs")).configurations[0]
    return sensor, Calibration(sensor.C_bar, sensor.D), payload


def test_single_and_batch_paths_give_the_wrench_that_made_the_strains(world, rng):
    """Noiseless strains of known wrenches (eq 22 with the paper's P, typed in helpers.py)."""
    _, cal, _ = world
    reader = WrenchReader(cal)
    W = rng.uniform(-1.0, 1.0, (20, 6)) * FULL_SCALE
    strains = strains_eq22(cal.C_bar, cal.D, W)
    # eq 22 solves with C_bar (condition number about 100) and the reader sums 8 products:
    # round-off of 100 eps of the largest entry, whatever the order of the sums
    atol = 1e-12 * np.abs(W).max()
    np.testing.assert_allclose(reader.wrench_batch(strains), W, rtol=0, atol=atol)
    for s, w in zip(strains[:3], W[:3], strict=True):
        np.testing.assert_allclose(reader.wrench(s), w, rtol=0, atol=atol)
    with pytest.raises(ShapeError, match=r"channels.shape=\(7,\) but expected \(8,\)"):
        reader.wrench(np.zeros(7))
    reader.set_offsets(cal.D + 1.0)  # after a re-tare, in a running loop: every component reads 1 more
    np.testing.assert_allclose(reader.wrench(strains[0]), W[0] + 1.0, rtol=0, atol=atol)
    np.testing.assert_allclose(reader.wrench_batch(strains), W + 1.0, rtol=0, atol=atol)


@pytest.mark.parametrize(("frame", "point"), [("sensor", None), ("world", None), ("sensor", (0.0, 0.02, 0.1)), ("world", (0.0, 0.02, 0.1))])
def test_one_sample_allocates_no_array_in_steady_state(world, rng, frame, point):
    _, cal, payload = world
    comp = GravityCompensator(cal, payload)
    strain, R = rng.standard_normal(8) * 0.1, np.eye(3)
    point = None if point is None else np.array(point)
    for _ in range(100):
        comp.external(strain, R, frame=frame, point=point)
    tracemalloc.start()
    tracemalloc.reset_peak()
    start, _ = tracemalloc.get_traced_memory()
    for _ in range(5000):
        comp.external(strain, R, frame=frame, point=point)
    end, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    # the peak counts every temporary: a (6,) array is ~150 bytes, a Python float 24; the
    # buffers are reused, so neither the peak nor what is held may grow by an array per call
    assert peak - start <= 1024 and end - start <= 1024, f"peak +{peak - start} B, held +{end - start} B over 5000 calls"


def test_a_slowly_moving_payload_compensates_to_the_noise_floor(world, ur5, rng):
    """Many poses, the payload's weight only: the external wrench is the strain noise
    (RMS within 15 % of sigma_W = sqrt((C diag(s^2) C^T)_jj), 5,000 samples)."""
    sensor, cal, payload = world
    readings = random_readings(ur5, 5000, rng)
    R = ur5.R_world_sensor(readings)
    g = np.einsum("nji,j->ni", R, ur5.g_world(9.81))
    strains = sensor.channels(payload.static_wrench(g), rng=rng)
    comp = GravityCompensator(cal, payload, ur5.g_world(9.81))
    external = comp.external_batch(strains, R)
    sigma_W = np.sqrt(np.diag(sensor.C @ np.diag(sensor.noise_std**2) @ sensor.C.T))
    np.testing.assert_allclose(np.sqrt(np.mean(external**2, axis=0)), sigma_W, rtol=0.15)
    np.testing.assert_allclose(comp.external(strains[7], R[7]), external[7], atol=1e-12)


def test_a_push_appears_with_its_true_size_in_every_frame(world, ur5, rng):
    sensor, cal, payload = world
    reading = random_readings(ur5, 1, rng)[0]
    R = ur5.R_world_sensor(reading)
    push_world = np.array([3.0, -7.0, 12.0])  # [N] on the tool tip
    tip = np.array([0.15, 0.02, 0.0])  # [m] in S
    f_s = R.T @ push_world
    truth = payload.static_wrench(R.T @ ur5.g_world(9.81)) + np.concatenate([f_s, np.cross(tip, f_s)])
    strains = sensor.channels(np.tile(truth, (200, 1)), rng=rng)
    comp = GravityCompensator(cal, payload, ur5.g_world(9.81))
    sensor_frame = comp.external_batch(strains, np.tile(R, (200, 1, 1))).mean(axis=0)
    world_frame = comp.external_batch(strains, np.tile(R, (200, 1, 1)), frame="world").mean(axis=0)
    at_tip = comp.external_batch(strains, np.tile(R, (200, 1, 1)), point=tip).mean(axis=0)
    # noise of a 200-sample mean, from the sensor's (covariance C diag(s^2) C^T / 200): at most
    # 2.7e-4 N and 4e-6 N m at the sensor; about the tip, the moment also carries tip x (the force's
    # noise), up to 4e-5 N m. Each check is 5 sigma or more of its noise, for any seed.
    cov = sensor.C @ np.diag(sensor.noise_std**2) @ sensor.C.T / 200
    tx, ty, tz = tip
    to_tip = np.eye(6)
    to_tip[3:, :3] = -np.array([[0.0, -tz, ty], [tz, 0.0, -tx], [-ty, tx, 0.0]])  # M_tip = M - tip x F
    sigma_tip = np.sqrt(np.diag(to_tip @ cov @ to_tip.T))
    np.testing.assert_allclose(world_frame[:3], push_world, atol=2e-3)
    np.testing.assert_allclose(sensor_frame[:3], f_s, atol=2e-3)
    np.testing.assert_allclose(sensor_frame[3:], np.cross(tip, f_s), atol=1e-4)
    np.testing.assert_allclose(at_tip[3:], 0.0, atol=5 * sigma_tip[3:].max())  # a pure force at the tip: no moment about it
    np.testing.assert_allclose(world_frame[3:], R @ sensor_frame[3:], atol=1e-12)
    with pytest.raises(ValueError, match="frame='tool' but expected one of"):
        comp.external(strains[0], R, frame="tool")

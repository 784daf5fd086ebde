"""Experiment design: predicted standard errors against the estimator's, and coverage."""

import numpy as np
import pytest

from fts_calib import OnlineEstimator
from fts_calib.core.resources import resolve
from fts_calib.planning.excitation import coverage_angle, predict_excitation
from fts_calib.sim.sensor import load_simulated_sensor

from .helpers import random_gravity


def test_predicted_standard_errors_match_those_of_a_simulated_calibration(paper_tool, rng):
    """The estimator reports standard errors from its residuals; with N = 3 x 2000 samples the
    residual variance is estimated to about 1/sqrt(2 N) = 0.9 %, so both agree within 5 %."""
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    noise = 2e-4
    g = {c.name: random_gravity(2000, rng) for c in paper_tool.configurations}
    predicted = predict_excitation(g, paper_tool, sensor.C_bar, sensor.D, noise)
    est = OnlineEstimator()
    for config in paper_tool.configurations:
        W = config.static_wrench(g[config.name])
        est.update_batch(W, sensor.channels(W) + noise * rng.standard_normal((len(W), 8)))
    q = est.solve().quality
    np.testing.assert_allclose(predicted.stderr_C_bar, q.stderr_C_bar, rtol=0.05)
    np.testing.assert_allclose(predicted.stderr_D, q.stderr_D, rtol=0.05)
    np.testing.assert_allclose(predicted.stderr_C, q.stderr_C, rtol=0.05)
    assert predicted.rank == q.rank == 7
    assert predicted.condition_number == pytest.approx(q.condition_number, rel=0.01)  # noise adds to S_XX


def test_predicted_standard_errors_of_a_factory_wrench_sensor(paper_tool, rng):
    """The same agreement for the 6-channel layout (P = I): noise per channel of 0.01 N and 5e-4 N m."""
    from fts_calib.model.channels import WRENCH_6

    sensor = load_simulated_sensor(resolve("factory_sensor", "configs"))
    noise = np.array([0.01] * 3 + [5e-4] * 3)
    g = {c.name: random_gravity(2000, rng) for c in paper_tool.configurations}
    predicted = predict_excitation(g, paper_tool, sensor.C_bar, sensor.D, noise, layout=WRENCH_6)
    est = OnlineEstimator(layout=WRENCH_6)
    for config in paper_tool.configurations:
        W = config.static_wrench(g[config.name])
        est.update_batch(W, sensor.channels(W) + noise * rng.standard_normal((len(W), 6)))
    q = est.solve().quality
    assert predicted.stderr_C.shape == (6, 6) and predicted.noise_std.shape == (6,)
    np.testing.assert_allclose(predicted.stderr_C_bar, q.stderr_C_bar, rtol=0.05)
    np.testing.assert_allclose(predicted.stderr_D, q.stderr_D, rtol=0.05)


def test_coverage_of_the_six_axis_directions_is_the_cube_corner_angle():
    axes = np.vstack([np.eye(3), -np.eye(3)])
    # the farthest directions are the cube's corners, acos(1/sqrt(3)) = 54.74 deg from an axis
    assert coverage_angle(axes) == pytest.approx(np.degrees(np.arccos(1 / np.sqrt(3))), abs=1.5)
    assert coverage_angle(np.array([[0.0, 0.0, 1.0]])) == pytest.approx(180.0, abs=3)

"""Latency of the joint stream: the one regression on synthetic signals (from samples, from blocks, from sums, fitted
with the calibration), and the estimate from a recording's moving samples: simulated lags recovered."""

import numpy as np
import pytest

from fts_calib.core.resources import resolve
from fts_calib.filters.latency import LatencyFit, estimate_latency, latency_regression, latency_sums, wrench_rate
from fts_calib.model.calibration import Calibration
from fts_calib.model.sensor_config import load_sensor_config
from fts_calib.robot.tool import tool_load
from fts_calib.sim.sensor import load_simulated_sensor

ENCODER_STEP = 2 * np.pi / 2**20  # [rad] the readings are quantized as a 20-bit encoder's
# Observed over seeds: errors of 1-2 us with a standard error of about 1 us (100 Hz, ~10k moving samples);
# 20 us is ten times that and a fortieth of the 0.8 ms a 10 % latency error would be.
ATOL_S = 2e-5  # [s]
DT = 1e-3  # [s]
FULL_SCALE = np.array([50.0, 50.0, 50.0, 5.0, 5.0, 5.0])  # [N, N m]
OMEGA = 2 * np.pi * np.array([0.3, 0.5, 0.7, 1.1, 1.3, 1.7])  # [rad/s] each axis's frequency
# noiseless, the regression is exact to second order in tau: r = tau s + tau^2/2 W'' + tau^3/6 W^(3) (the
# W'' term averages out over whole periods), so tau is off by about (tau omega)^2 / 6 of itself: 1.2e-3 at
# 8 ms and 1.7 Hz; the central differences of the rate add (omega dt)^2 / 6 = 2e-5
RTOL_NOISELESS = 2e-3


def synthetic(t: np.ndarray, tau: float) -> tuple[np.ndarray, np.ndarray]:
    """A smooth wrench on six axes [N, N m]: ``(measured, predicted)``, the prediction from joints read tau late (its value of t - tau)."""
    amplitude, phase = np.array([5.0, 5.0, 5.0, 0.5, 0.5, 0.5]), np.array([0.1, 0.7, 1.3, 2.0, 2.9, 4.1])
    return amplitude * np.sin(OMEGA * t[:, None] + phase), amplitude * np.sin(OMEGA * (t[:, None] - tau) + phase)


def test_the_regression_recovers_a_known_latency_on_a_synthetic_signal():
    t = np.arange(0.0, 20.0, DT)  # whole periods of every axis
    for tau in (0.008, -0.003):
        measured, predicted = synthetic(t, tau)
        step = latency_regression(*latency_sums(measured - predicted, wrench_rate(t, predicted)))
        assert step is not None and abs(step.latency_s - tau) <= RTOL_NOISELESS * abs(tau), (tau, step)
        assert step.stderr_s == np.inf and step.groups == 1  # no groups, no sums of squares: no standard error


def test_the_standard_errors_from_blocks_and_from_sums_are_the_noises(rng):
    """Noisy measurements, 20 blocks of 1 s: the estimate within 4 standard errors, both standard errors that of the noise.

    With axis weights 1 / sigma_j^2 the latency's standard error is ``1 / sqrt(sum w s^2)`` (1.4 us here).
    The blocks' is the spread of 20 estimates of unequal weights: over 2,000 seeds 0.99 of it on average, with
    a spread of 0.16 (0.49-1.68 seen), so within 0.3-1.8 (4.5 spreads); the sums' takes the residuals'
    variance over 120,000 of them: within 3 %.
    """
    t = np.arange(0.0, 20.0, DT)
    tau, sigma = 0.001, np.array([0.01, 0.01, 0.01, 0.001, 0.001, 0.001])  # [s], [N, N m]; the bias (tau omega)^2/6 tau is 2e-8 s
    measured, predicted = synthetic(t, tau)
    measured = measured + sigma * rng.standard_normal(measured.shape)
    rate, weight = wrench_rate(t, predicted), 1.0 / sigma**2
    residual = measured - predicted
    rs, ss = latency_sums(residual, rate, weight)
    expected = 1.0 / np.sqrt(np.sum(ss))
    blocks = latency_regression(rs, ss, np.arange(0, len(t), 1000))
    assert blocks is not None and blocks.groups == 20
    assert abs(blocks.latency_s - tau) <= 4 * expected, (blocks, expected)
    assert 0.3 * expected <= blocks.stderr_s <= 1.8 * expected, (blocks.stderr_s, expected)
    sums = latency_regression(float(np.sum(rs)), float(np.sum(ss)), rr=float(np.sum(residual**2 * weight)), dof=residual.size - 1)
    assert sums is not None and sums.latency_s == pytest.approx(blocks.latency_s, rel=1e-12, abs=0)
    assert sums.stderr_s == pytest.approx(expected, rel=0.03)
    assert latency_regression(rs * 0, ss * 0) is None  # a wrench that does not change shows no latency


def test_the_latency_fitted_with_the_calibration_is_the_same_regression(rng):
    """The dynamic filter's sums: channels that read the true wrench, the prediction from late joints; tau recovered."""
    t = np.arange(0.0, 20.0, DT)
    tau = 0.004
    measured, predicted = synthetic(t, tau)
    C, d = rng.normal(size=(6, 6)) + 5.0 * np.eye(6), rng.normal(size=6)
    projected = np.linalg.solve(C, (measured - d).T).T  # the channels' P Delta: the sensor reads C P Delta + d
    fit = LatencyFit(1, FULL_SCALE)
    fit.add(projected, np.zeros(len(t), dtype=np.int64), predicted, wrench_rate(t, predicted), np.ones(len(t)))
    solved = fit.solve()
    assert solved is not None and abs(solved[0] - tau) <= RTOL_NOISELESS * tau, solved


def test_the_wrench_rate_has_no_slope_at_a_repeated_time_stamp():
    t = np.array([0.0, 0.001, 0.001, 0.003])
    w = np.outer(np.arange(4.0), np.ones(6))
    assert not np.all(np.isfinite(wrench_rate(t, w)[1:3]))
    assert np.all(wrench_rate(t[:1], w[:1]) == 0.0) and wrench_rate(t[:1], w[:1]).shape == (1, 6)


def lagged_recording(kin, tool, plan, lag_s, rng):
    """The plan for every configuration: joints read lag_s late (and quantized), true wrench through the simulated sensor."""
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    time, joints, channels, codes = [], [], [], []
    for c in range(len(tool.configurations)):
        W = tool_load(kin, tool, plan.q, c, plan.qd, plan.qdd).w_sensor
        t = plan.time + 100.0 * c
        late = np.stack([np.interp(plan.time - lag_s, plan.time, plan.q[:, k]) for k in range(kin.n_joints)], axis=1)
        time.append(t)
        joints.append(np.round(late / ENCODER_STEP) * ENCODER_STEP)
        channels.append(sensor.channels(W, time=t, rng=rng))
        codes.append(np.full(len(t), c))
    return np.concatenate(time), np.vstack(joints), np.vstack(channels), np.concatenate(codes)


@pytest.mark.parametrize("lag_s", [0.008, 0.0, -0.003])
def test_a_simulated_lag_of_the_joint_stream_is_recovered(lag_s, ur5, paper_tool, short_plan, rng):
    spec = load_sensor_config(resolve("sensor", "configs"))
    calibration = Calibration(spec.simulated.C_bar, spec.simulated.D)
    data = lagged_recording(ur5, paper_tool, short_plan, lag_s, rng)
    estimate = estimate_latency(ur5, paper_tool, calibration, *data, spec.full_scale)
    assert estimate is not None and estimate.moves >= 10
    assert abs(estimate.latency_s - lag_s) <= ATOL_S, estimate.summary()
    assert estimate.stderr_s <= ATOL_S / 2, estimate.summary()
    assert " ms (from " in estimate.summary() and estimate.as_dict()["latency_ms"] == pytest.approx(1e3 * lag_s, abs=1e3 * ATOL_S)


def test_no_move_gives_no_estimate(ur5, paper_tool, short_plan):
    spec = load_sensor_config(resolve("sensor", "configs"))
    still = np.repeat(short_plan.q[:1], 200, axis=0)
    W = tool_load(ur5, paper_tool, still, 0).static
    strain = np.linalg.lstsq(spec.simulated.C, (W - spec.simulated.D).T, rcond=None)[0].T
    calibration = Calibration(spec.simulated.C_bar, spec.simulated.D)
    assert estimate_latency(ur5, paper_tool, calibration, np.arange(200) * 0.01, still, strain, np.zeros(200), spec.full_scale) is None


def test_repeated_time_stamps_leave_the_estimate_finite(ur5, paper_tool, short_plan, rng):
    """Two samples with one time stamp (a logger's duplicate) have no slope: left out, not a NaN estimate."""
    spec = load_sensor_config(resolve("sensor", "configs"))
    calibration = Calibration(spec.simulated.C_bar, spec.simulated.D)
    time, joints, channels, codes = lagged_recording(ur5, paper_tool, short_plan, 0.008, rng)
    time[1001::997] = time[1000::997][: len(time[1001::997])]
    estimate = estimate_latency(ur5, paper_tool, calibration, time, joints, channels, codes, spec.full_scale)
    assert estimate is not None and np.isfinite(estimate.latency_s) and abs(estimate.latency_s - 0.008) <= 10 * ATOL_S

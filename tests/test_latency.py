"""Latency of the joint stream, estimated from moving samples: simulated lags recovered."""

import numpy as np
import pytest

from fts_calib.core.resources import resolve
from fts_calib.filters.latency import estimate_latency
from fts_calib.model.calibration import Calibration
from fts_calib.model.sensor_config import load_sensor_config
from fts_calib.robot.tool import tool_load
from fts_calib.sim.sensor import load_simulated_sensor

ENCODER_STEP = 2 * np.pi / 2**20  # [rad] the readings are quantized as a 20-bit encoder's
# Observed over seeds: errors of 1-2 us with a standard error of about 1 us (100 Hz, ~10k moving samples);
# 20 us is ten times that and a fortieth of the 0.8 ms a 10 % latency error would be.
ATOL_S = 2e-5  # [s]


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

"""Offsets tracked in service without contact: drift followed, pushes refused, re-tare kept in the history."""

from __future__ import annotations

import numpy as np
import pytest

from fts_calib.core.exceptions import ConfigError
from fts_calib.model.calibration import load_calibration
from fts_calib.monitor.offset_watch import OffsetWatch
from fts_calib.sim.service_run import offset_watch_trial

FULL_SCALE = np.array([50.0, 50.0, 50.0, 5.0, 5.0, 5.0])  # [N, N m]
NOISE = np.array([2e-3] * 3 + [2e-4] * 3)  # wrench noise per sample [N, N m]: the paper's sensor's
DRIFT = np.array([1.0, -1.0, 0.5, 1e-3, 1e-3, -1e-3]) / 60  # 1 N/min on Fx [N/s, N m/s]


def run(seconds: float, contacts: int, seed: int):
    """The watch after a simulated service, the largest offset error outside contacts (% FS), the updates in contact."""
    return offset_watch_trial(seconds, contacts, np.random.default_rng(seed), NOISE, DRIFT, FULL_SCALE)


def test_drift_is_followed_and_pushes_never_move_the_offset():
    watch, worst, updated_in_contact = run(90.0, 6, seed=3)
    assert updated_in_contact == 0 and watch.contacts >= 6 * 15, (updated_in_contact, watch.contacts)
    # target 0.05 % FS; the alpha-beta tracker's noise is ~sigma/sqrt(B) x sqrt(alpha) ~ 1e-4 N (2e-4 % FS)
    assert np.all(worst <= 0.05), worst
    np.testing.assert_allclose(watch.rate, DRIFT, atol=0.01 * np.abs(DRIFT).max())


def test_forecast_and_retare_in_the_history():
    watch, _, _ = run(30.0, 0, seed=4)
    threshold = 0.0005 * FULL_SCALE  # 0.05 % FS: 0.025 N, reached by Fx drifting 1 N/min within ~1.5 s
    offset_now = watch.predicted(watch.last_time)
    # 0.05 % FS beyond where each axis is now: the first axis there is the one whose drift covers it fastest
    forecast = watch.forecast_s(np.abs(offset_now) + threshold)
    assert forecast == pytest.approx(min(threshold / np.abs(DRIFT)), rel=0.05)  # the rate is learnt to ~1 %
    assert watch.forecast_s(np.abs(offset_now) / 2) == 0.0  # already beyond
    calibration = load_calibration("paper_table1_calibration")
    offset = watch.offset.copy()
    tared = watch.retare(calibration)
    np.testing.assert_allclose(tared.D, calibration.D - offset)
    assert tared.offset_history[-1]["D"] == calibration.D.tolist() and "re-tared in service" in tared.offset_history[-1]["reason"]
    assert np.all(watch.offset == 0)


def test_bad_noise_is_refused():
    with pytest.raises(ConfigError, match="noise"):
        OffsetWatch([1.0, 1.0, 1.0])


def test_a_window_is_motion_by_the_filters_joint_speed_rule(rng):
    """The joints turning at 0.02 rad/s (twice the quasi-static filter's 0.01 rad/s) over quiet wrenches: every
    window is motion, refused; with a pipeline whose filter allows 0.03 rad/s the same windows update the tracker."""
    from fts_calib.filters.settings import FilterConfig

    time = np.arange(2000) / 1000.0  # [s] 20 windows of 100 samples
    measured = NOISE * rng.standard_normal((2000, 6))  # [N, N m] no contact, no offset error
    joints = np.outer(time, [0.0, 0.02, 0.0])  # [rad]
    default, loose = OffsetWatch(NOISE), OffsetWatch(NOISE, still=FilterConfig(max_joint_speed=0.03))
    for watch in (default, loose):
        watch.update_batch(time, measured, np.zeros((2000, 6)), joints)
    assert default.updates == 0 and default.contacts == 20, (default.updates, default.contacts)
    assert loose.updates == 20 and loose.contacts == 0, (loose.updates, loose.contacts)


def test_a_drift_free_run_forecasts_nothing_and_the_rates_noise_is_the_trackers(rng):
    """No drift, noise only: the rate wanders at its noise (the alpha-beta steady state, against a Monte Carlo over time)
    and the forecast stays 'never' (it once said "exceeds 0.05 % in 33 s" from such a rate)."""
    watch = OffsetWatch(NOISE)
    threshold = 0.0005 * FULL_SCALE  # 0.05 % FS
    rates, finite = [], 0
    for k in range(1200):  # 120 s of 100-sample windows at 1 kHz
        time = (k * 100 + np.arange(100)) / 1000.0  # [s]
        watch.update_batch(time, NOISE * rng.standard_normal((100, 6)), np.zeros((100, 6)))
        if k >= 100:  # past the tracker's settling (10 time constants)
            rates.append(watch.rate.copy())
            finite += np.isfinite(watch.forecast_s(threshold))
    measured = np.std(rates, axis=0)  # ~110 independent stretches: the std to about 7 %
    np.testing.assert_allclose(measured, watch.rate_std, rtol=0.3)
    assert np.all(np.abs(watch.rate) > 0)  # a rate at the noise level, never exactly zero: the old forecast extrapolated it
    assert finite <= 0.01 * len(rates), f"{finite} of {len(rates)} looks forecast a crossing on a drift-free run"

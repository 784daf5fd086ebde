"""A quiet quantized sensor in service: its stays in one ADC code, learnt at calibration, are no fault; a stuck channel is."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from fts_calib.model.parity import MIN_SEGMENT, CodeDwell, ParityModel, code_dwell, fit_parity
from fts_calib.monitor.health import QUIET_FROZEN_S, HealthMonitor
from fts_calib.sim.sensor import load_simulated_sensor
from fts_calib.sim.service_run import inject_fault, still_poses, still_weights

RATE_HZ = 150.0
#: Analog noise of the 8 channels [counts], below one step of the 10-bit ADC, as on the real sensor.
ANALOG_NOISE = np.linspace(0.14, 0.46, 8)
FULL_SCALE = np.array([50.0, 50.0, 50.0, 5.0, 5.0, 5.0])
STOP_S = 2.0  # [s] still at each calibration stop
#: The noisiest channel (0.46 counts) stuck is reported within this long [s] (bench/bench_code_dwell.py: at most 1.33 s over 20 seeds).
CAUGHT_WITHIN_S = 3.0


def _sensor():
    base = load_simulated_sensor("lowcost_sensor")  # 10-bit, counts 0 ... 1023
    offset = np.array(base.channel_offset, dtype=float)
    offset[6] = 505.0  # mid-range: its 985 puts channel 7 on the rail under some loads, a fault of its own
    return dataclasses.replace(base, noise_std=ANALOG_NOISE, channel_offset=offset)


def _calibration_parity(seed: int) -> ParityModel:
    """The parity model of 40 still stops of 2 s, with the dwell learnt from them and the noise measured within the stops."""
    rng = np.random.default_rng(seed)
    sensor = _sensor()
    _, channels, stop = still_poses(sensor, still_weights(40, rng), STOP_S, RATE_HZ, rng)
    within = np.sqrt(np.mean([np.var(channels[stop == s], axis=0) for s in range(40)], axis=0))  # what the still filter measures
    C = sensor.C_bar @ sensor.layout.projection
    n = sensor.layout.n_channels
    low, high = sensor.adc_codes
    dwell = code_dwell(channels, stop, RATE_HZ)
    parity = fit_parity(
        sensor.layout, C, sensor.D_readings, channels, FULL_SCALE, within, np.ones(n), np.full(n, low), np.full(n, high), dwell
    )
    assert parity is not None
    return parity


def _longest_run(x: np.ndarray) -> int:
    """The longest run of one value in x [samples]."""
    edges = np.concatenate([[0], np.flatnonzero(np.diff(x) != 0) + 1, [len(x)]])
    return int(np.diff(edges).max())


def _gaussian_thresholds(parity: ParityModel) -> np.ndarray:
    """The frozen thresholds of the Gaussian model with the noise floored at step / sqrt(12) (the rule before the dwell) [samples]."""
    probability = (1e-3 / 3.0) / (3600.0 * RATE_HZ * 8)
    stay = np.array([math.erf(1.0 / (2.0 * math.sqrt(2.0) * s)) for s in parity.channel_noise])
    return np.ceil(math.log(probability) / np.log(stay))


@pytest.fixture(scope="module", params=[3, 4], ids=["cal3", "cal4"])
def parity(request):
    return _calibration_parity(request.param)


def test_the_dwell_of_a_noiseless_stair_is_its_run_lengths():
    """Independent truth: a channel stepping one code every 10 samples stays 10; one constant over a stop is held."""
    steps = np.repeat(np.arange(10.0), 10)  # 100 samples, one stop
    channels = np.column_stack([steps, np.full(100, 7.0), np.r_[np.zeros(70), np.ones(30)]])
    dwell = code_dwell(channels, np.zeros(100, dtype=int), 150.0)
    assert dwell is not None and dwell.segments == 1
    np.testing.assert_array_equal(dwell.longest, [10, 100, 70])
    np.testing.assert_array_equal(dwell.held, [0, 100, 0])
    assert dwell.mean[0] == 10 and math.isnan(dwell.mean[1]) and dwell.mean[2] == 70  # the stays in the most frequent code
    assert code_dwell(channels[: MIN_SEGMENT - 1], np.zeros(MIN_SEGMENT - 1), 150.0) is None  # too short a stop to say
    again = CodeDwell.from_dict(dwell.to_dict())
    np.testing.assert_array_equal(again.longest, dwell.longest) and np.testing.assert_array_equal(again.held, dwell.held)


def test_the_health_section_keeps_the_dwell(parity):
    again = ParityModel.from_dict(parity.to_dict())
    assert again.dwell is not None
    np.testing.assert_array_equal(again.dwell.longest, parity.dwell.longest)
    old = {k: v for k, v in parity.to_dict().items() if k != "dwell"}  # a file written before the dwell
    assert ParityModel.from_dict(old).dwell is None


@pytest.mark.parametrize("service_seed", [21, 22])
def test_a_quiet_quantized_sensor_held_still_raises_no_fault(parity, service_seed):
    """60 s still at each of 3 poses never seen at calibration, every channel mid-code (the real sensor: all 'frozen' within 35 s)."""
    rng = np.random.default_rng(service_seed)
    for wrench in still_weights(3, rng):
        time, channels, _ = still_poses(_sensor(), wrench, 60.0, RATE_HZ, rng, mid_code=True)
        monitor = HealthMonitor(parity, RATE_HZ)
        monitor.update_batch(time, channels)
        assert monitor.events == [], (monitor.events, monitor.freeze_words)
        longest = np.array([_longest_run(channels[:, k]) for k in range(8)])
        assert np.any(longest > _gaussian_thresholds(parity)), "the Gaussian model alone would have reported nothing either"


def test_a_stuck_channel_is_still_caught(parity):
    """One channel stuck at 20 s of a still minute: the first event names it, within its frozen threshold (<= 3 s at 0.46 counts).

    The parity's gain or jump test may name it first (its reading no longer follows the noise the others share).
    """
    rng = np.random.default_rng(31)
    time, channels, _ = still_poses(_sensor(), still_weights(1, rng), 60.0, RATE_HZ, rng)
    probe = HealthMonitor(parity, RATE_HZ)
    learnt = [k for k in range(8) if parity.dwell is not None and not math.isnan(parity.dwell.mean[k])]
    assert 7 in learnt and probe.freeze_samples[7] / RATE_HZ <= CAUGHT_WITHIN_S, probe.freeze_words  # 0.46 counts: moves at every stop
    for k in learnt:
        threshold_s = probe.freeze_samples[k] / RATE_HZ
        if threshold_s > 35.0:  # a stay the calibration saw that long: not within this minute
            continue
        monitor = HealthMonitor(parity, RATE_HZ)
        monitor.update_batch(time, inject_fault(channels, time, "frozen", k + 1, 20.0))
        assert monitor.events and {e.channel for e in monitor.events} == {k + 1}, monitor.events
        assert monitor.events[0].detected_s <= 20.0 + threshold_s + 100 / RATE_HZ, (monitor.events[0], threshold_s)  # + one block
    for k in set(range(8)) - set(learnt):  # quiet: said, and a long default
        assert probe.freeze_samples[k] >= QUIET_FROZEN_S * RATE_HZ
        assert any(f"strain_{k + 1}" in line and "quiet" in line for line in probe.freeze_words)

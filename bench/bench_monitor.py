"""Health monitor figures: naming a 1 % gain loss, false alarms in clean service, cost per sample.

Simulated 1 kHz service (:mod:`fts_calib.sim.service_run`): a 1 kg payload, centre of mass off
the tool axis, turned through random orientations with pauses; the paper's simulated sensor
(Table 1, 1e-5 mV/V noise, 24-bit ADC, null content). The parity model is learnt from one
minute of such service with the true C (what a calibration's kept samples give).

Usage: ``python bench/bench_monitor.py [--trials 160] [--hours 2]``
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from fts_calib.model.parity import fit_parity
from fts_calib.monitor.health import HealthMonitor
from fts_calib.sim.sensor import load_simulated_sensor
from fts_calib.sim.service_run import inject_fault, service_wrenches

FULL_SCALE = np.array([50.0, 50.0, 50.0, 5.0, 5.0, 5.0])  # [N, N m]
RATE_HZ = 1000.0


def learnt_parity(sensor, seed: int = 1):
    """The parity model from a minute of simulated service with the sensor's true C."""
    rng = np.random.default_rng(seed)
    t, w = service_wrenches(60.0, RATE_HZ, rng)
    channels = sensor.channels(w, t, rng)
    C = sensor.C_bar @ sensor.layout.projection
    return fit_parity(sensor.layout, C, sensor.D, channels, FULL_SCALE, resolution=np.full(sensor.layout.n_channels, sensor.lsb))


def gain_trials(sensor, parity, trials: int, size: float = -0.01, within_s: float = 2.0) -> tuple[float, float, float]:
    """Rate of trials whose first event names the faulty channel within ``within_s``; rate of kind 'gain'; us per sample."""
    right = kind = 0
    cost = 0.0
    samples = 0
    for trial in range(trials):
        rng = np.random.default_rng(1000 + trial)
        t, w = service_wrenches(7.0, RATE_HZ, rng)
        channels = sensor.channels(w, t, rng)
        channel = trial % sensor.layout.n_channels + 1
        start = float(rng.uniform(3.0, 4.0))
        broken = inject_fault(channels, t, "gain", channel, start, size)
        monitor = HealthMonitor(parity, RATE_HZ)
        clock = time.perf_counter()
        for i in range(len(t)):  # sample by sample, as in a controller
            monitor.update(t[i], broken[i])
        cost += time.perf_counter() - clock
        samples += len(t)
        first = monitor.events[0] if monitor.events else None
        if first is not None and first.channel == channel and start <= first.detected_s <= start + within_s:
            right += 1
            kind += first.kind == "gain"
    return right / trials, kind / trials, cost / samples * 1e6


def clean_hours(sensor, parity, hours: float) -> tuple[int, float]:
    """False alarms over ``hours`` of clean service, simulated in 10-minute pieces (each a fresh monitor: none reset within)."""
    alarms, simulated = 0, 0.0
    piece = 600.0
    for k in range(int(round(hours * 3600 / piece))):
        rng = np.random.default_rng(50_000 + k)
        t, w = service_wrenches(piece, RATE_HZ, rng)
        monitor = HealthMonitor(parity, RATE_HZ)
        monitor.update_batch(t, sensor.channels(w, t, rng))
        alarms += len(monitor.events)
        simulated += piece / 3600
    return alarms, simulated


def main() -> None:
    """Print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=160, help="gain-loss trials (over the 8 channels in turn)")
    parser.add_argument("--hours", type=float, default=2.0, help="hours of clean service for the false-alarm rate")
    args = parser.parse_args()
    sensor = load_simulated_sensor("sensor")
    parity = learnt_parity(sensor)
    monitor = HealthMonitor(parity, RATE_HZ)
    rate, gain_kind, us = gain_trials(sensor, parity, args.trials)
    print(f"1 % gain loss named within 2 s: {rate:.1%} of {args.trials} trials (kind 'gain': {gain_kind:.1%})")
    print(f"cost: {us:.1f} us per sample, sample by sample ({us * RATE_HZ / 1e4:.2f} % of one core at 1 kHz)")
    alarms, hours = clean_hours(sensor, parity, args.hours)
    print(f"clean service: {alarms} false alarms in {hours:.1f} h ({alarms / hours:.3g} per hour)")
    print(
        f"theory: at most 1e-3 per hour (thresholds z^2 > {monitor.gain_threshold:.1f} for the gain test, chi-square(1); "
        f"{monitor.jump_threshold:.1f} for the jump test, chi-square({parity.n_parity}); Bonferroni over the tests per hour)"
    )


if __name__ == "__main__":
    main()

"""Frozen test of a quiet quantized sensor: false alarms while still, and how soon a stuck channel is reported.

A 10-bit sensor at 150 Hz (the shipped low-cost sensor's model, channel 7's offset mid-range)
whose 8 channels have analog noise 0.14 to 0.46 counts, below one ADC step. Each seed: a
calibration of 40 still stops of 2 s (the parity model and the channels' stays in one code,
:func:`fts_calib.model.parity.code_dwell`), then service held still for ``--minutes`` at
random poses with every channel's mean moved mid-code (its longest stays), and one still
minute per channel with that channel stuck at 20 s.

Per channel: the learnt mean stay in one code, the frozen threshold [s] (the Gaussian rule
of the noise floored at step/sqrt(12) before, and now), frozen false alarms while still (before:
runs longer than the Gaussian threshold; now: the monitor's events), and the delay from the
channel sticking to the first event that names it [s] (frozen, or a jump: its reading leaves the
load's), with the kinds, and the events that named another channel.

Usage: ``python bench/bench_code_dwell.py [--seeds 20] [--minutes 3]``
"""

from __future__ import annotations

import argparse
import dataclasses
import math
from collections import Counter

import numpy as np

from fts_calib.model.parity import code_dwell, fit_parity
from fts_calib.monitor.health import HealthMonitor
from fts_calib.sim.sensor import load_simulated_sensor
from fts_calib.sim.service_run import inject_fault, still_poses, still_weights

RATE_HZ = 150.0
NOISE = np.linspace(0.14, 0.46, 8)  # [counts]
FULL_SCALE = np.array([50.0, 50.0, 50.0, 5.0, 5.0, 5.0])
STUCK_AT_S = 20.0


def sensor():
    base = load_simulated_sensor("lowcost_sensor")
    offset = np.array(base.channel_offset, dtype=float)
    offset[6] = 505.0
    return dataclasses.replace(base, noise_std=NOISE, channel_offset=offset)


def calibrate(s, rng):
    _, channels, stop = still_poses(s, still_weights(40, rng), 2.0, RATE_HZ, rng)
    within = np.sqrt(np.mean([np.var(channels[stop == k], axis=0) for k in range(40)], axis=0))
    n = s.layout.n_channels
    low, high = s.adc_codes
    dwell = code_dwell(channels, stop, RATE_HZ)
    C = s.C_bar @ s.layout.projection
    return fit_parity(s.layout, C, s.D_readings, channels, FULL_SCALE, within, np.ones(n), np.full(n, low), np.full(n, high), dwell)


def gaussian(parity) -> np.ndarray:
    """The frozen thresholds of the rule before the dwell [samples]."""
    p = (1e-3 / 3.0) / (3600.0 * RATE_HZ * 8)
    stay = np.array([math.erf(1.0 / (2.0 * math.sqrt(2.0) * v)) for v in parity.channel_noise])
    return np.ceil(math.log(p) / np.log(stay))


def longest_runs(x: np.ndarray) -> np.ndarray:
    out = []
    for k in range(x.shape[1]):
        edges = np.concatenate([[0], np.flatnonzero(np.diff(x[:, k]) != 0) + 1, [len(x)]])
        out.append(np.diff(edges).max())
    return np.array(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--minutes", type=int, default=3)
    args = parser.parse_args()
    s = sensor()
    stays, before_s, now_s, delays = [], [], [], [[] for _ in range(8)]
    alarms_before, alarms_now, quiet, wrong = np.zeros(8, int), np.zeros(8, int), np.zeros(8, int), np.zeros(8, int)
    kinds: list[Counter] = [Counter() for _ in range(8)]
    for seed in range(args.seeds):
        rng = np.random.default_rng(seed)
        parity = calibrate(s, rng)
        probe = HealthMonitor(parity, RATE_HZ)
        stays.append(parity.dwell.mean)
        before_s.append(gaussian(parity) / RATE_HZ)
        now_s.append(probe.freeze_samples / RATE_HZ)
        quiet += np.isnan(parity.dwell.mean)
        for wrench in still_weights(args.minutes, rng):
            time, channels, _ = still_poses(s, wrench, 60.0, RATE_HZ, rng, mid_code=True)
            alarms_before += longest_runs(channels) >= gaussian(parity)
            monitor = HealthMonitor(parity, RATE_HZ)
            monitor.update_batch(time, channels)
            for event in monitor.events:
                if event.kind == "frozen":
                    alarms_now[event.channel - 1] += 1
        time, channels, _ = still_poses(s, still_weights(1, rng), 60.0, RATE_HZ, rng)
        for k in range(8):
            monitor = HealthMonitor(parity, RATE_HZ)
            monitor.update_batch(time, inject_fault(channels, time, "frozen", k + 1, STUCK_AT_S))
            found = [e for e in monitor.events if e.channel == k + 1]
            delays[k].append(found[0].detected_s - STUCK_AT_S if found else math.nan)
            kinds[k].update([found[0].kind] if found else [])
            wrong[k] += sum(e.channel != k + 1 for e in monitor.events)
    minutes = args.seeds * args.minutes
    print(f"10-bit sensor at {RATE_HZ:g} Hz, {args.seeds} calibrations (40 still stops of 2 s), {minutes} still minutes mid-code")
    print("ch  noise   mean stay  quiet  threshold before [s]  threshold now [s]     frozen alarms      stuck: named after [s]")
    print("    counts  samples    seeds  median               min / median / max    before / now       median / max (missed) kinds; others")
    stays_a, before_a, now_a = np.array(stays), np.array(before_s), np.array(now_s)
    for k in range(8):
        d = np.array(delays[k])
        seen = d[np.isfinite(d)]
        delay = f"{np.median(seen):.2f} / {seen.max():.2f}" if len(seen) else "-"
        stay = np.nanmedian(stays_a[:, k]) if np.any(np.isfinite(stays_a[:, k])) else math.nan
        print(
            f"{k + 1:<3} {NOISE[k]:.2f}    {stay:8.3g}   {quiet[k]:>3}    {np.median(before_a[:, k]):8.3g}             "
            f"{now_a[:, k].min():6.3g} / {np.median(now_a[:, k]):6.3g} / {now_a[:, k].max():6.3g}   "
            f"{alarms_before[k]:>4} / {alarms_now[k]:<4}      {delay} ({int(np.sum(~np.isfinite(d)))}) "
            f"{', '.join(f'{n} {c}' for c, n in kinds[k].items())}; {wrong[k]}"
        )


if __name__ == "__main__":
    main()

"""Offsets that stay right: 1 N/min drift and random 15 N pushes of 2 s; the offset error outside contacts.

Simulated 1 kHz service (a 1 kg payload turned and paused, the paper's sensor's wrench noise),
the offsets drifting 1 N/min on Fx (and -1, 0.5 N/min, 1e-3 N m/min on the others), a push every
``--every`` seconds on average. Target: the error stays <= 0.05 % FS outside contacts, and no
window touched by a push updates the offset.

Usage: ``python bench/bench_offset_watch.py [--minutes 30] [--every 30]``
"""

from __future__ import annotations

import argparse

import numpy as np

from fts_calib.sim.service_run import offset_watch_trial

FULL_SCALE = np.array([50.0, 50.0, 50.0, 5.0, 5.0, 5.0])  # [N, N m]
NOISE = np.array([2e-3] * 3 + [2e-4] * 3)  # [N, N m] per sample
DRIFT = np.array([1.0, -1.0, 0.5, 1e-3, 1e-3, -1e-3]) / 60  # [N/s, N m/s]


def main() -> None:
    """Print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=30.0, help="length of the simulated service [min]")
    parser.add_argument("--every", type=float, default=30.0, help="mean time between pushes [s]")
    args = parser.parse_args()
    seconds = 60.0 * args.minutes
    contacts = int(seconds / args.every)
    watch, worst, updated = offset_watch_trial(seconds, contacts, np.random.default_rng(0), NOISE, DRIFT, FULL_SCALE)
    print(f"{args.minutes:g} min, {contacts} pushes of 15 N for 2 s, drift 1 N/min")
    print("largest offset error outside contacts: " + ", ".join(f"{v:.4f}" for v in worst) + " % FS (Fx Fy Fz Mx My Mz; target 0.05)")
    print(f"windows touched by a push that updated the offset: {updated} (target 0); refused as contact: {watch.contacts:,}")


if __name__ == "__main__":
    main()

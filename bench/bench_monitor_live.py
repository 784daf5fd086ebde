"""CPU of ``fts-calib monitor udp://127.0.0.1:PORT`` fed 1 kHz of strain datagrams over loopback UDP.

Starts the command on a free port, sends 10 s of simulated service (the paper's sensor,
8 channels) at 1 kHz, then 'end', and prints the command's CPU time per second of feed:
the target is at most 50 % of one core.

Usage: ``python bench/bench_monitor_live.py [--seconds 10]``
"""

from __future__ import annotations

import argparse
import os
import re
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from fts_calib.model.calibration import load_calibration
from fts_calib.sources.udp import End, Strain, encode

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_monitor import RATE_HZ, learnt_parity  # noqa: E402

from fts_calib.sim.sensor import load_simulated_sensor
from fts_calib.sim.service_run import service_wrenches


def main() -> None:
    """Print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="length of the feed [s]")
    args = parser.parse_args()
    sensor = load_simulated_sensor("sensor")
    parity = learnt_parity(sensor)
    folder = Path(tempfile.mkdtemp())
    calibration = load_calibration("paper_table1_calibration")
    from dataclasses import replace

    path = replace(calibration, health=parity.to_dict()).save(folder / "cal.yaml")
    rng = np.random.default_rng(0)
    t, w = service_wrenches(args.seconds, RATE_HZ, rng)
    datagrams = [encode(Strain(float(ti), tuple(float(v) for v in row))) for ti, row in zip(t, sensor.channels(w, t, rng), strict=True)]
    command = [sys.executable, "-m", "fts_calib.app.cli", "monitor", "--calibration", str(path), "udp://127.0.0.1:0", "--quiet"]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, text=True)
    assert process.stdout is not None
    port = int(re.search(r":(\d+);", process.stdout.readline()).group(1))
    start = time.perf_counter()
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        for i, data in enumerate(datagrams):
            sock.sendto(data, ("127.0.0.1", port))
            wait = start + (i + 1) / RATE_HZ - time.perf_counter()
            if wait > 0:
                time.sleep(wait)
        sock.sendto(encode(End()), ("127.0.0.1", port))
    out = process.stdout.read()
    _, _, usage = os.wait4(process.pid, 0)
    elapsed = time.perf_counter() - start
    cpu = usage.ru_utime + usage.ru_stime
    samples = re.search(r"([\d,]+) samples", out)
    print(f"fed {len(datagrams):,} datagrams in {elapsed:.1f} s; the monitor took {samples.group(1) if samples else '?'} samples")
    print(f"CPU of the monitor: {cpu:.2f} s, {100 * cpu / elapsed:.1f} % of one core (start-up included)")


if __name__ == "__main__":
    main()

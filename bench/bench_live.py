"""Benchmark: the live path under 5 kHz strain plus 1 kHz joint messages on loopback.

Starts `fts-calib calibrate udp://127.0.0.1:PORT` in a child process, sends it the two streams for DURATION seconds
(default 20) from this process, paced in 1 ms bursts, then `end`; prints what was sent,
what the live process received and used, and its CPU use. Asserts nothing.
Run: .venv/bin/python bench/bench_live.py [DURATION]
"""

import json
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HOME = [1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0]
JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def main():
    duration = float(sys.argv[1]) if len(sys.argv) > 1 else 20.0
    port = free_port()
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "cal.yaml"
        live = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "fts_calib.app.cli",
                "calibrate",
                f"udp://127.0.0.1:{port}",
                "--robot",
                "ur5",
                "--tool",
                "paper_tool",
                "-o",
                str(out),
                "--quiet",
                "--idle-timeout",
                "5",
            ],
            stdout=subprocess.PIPE,
            text=True,
        )
        for line in live.stdout:
            if line.startswith("listening"):
                break
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        target = ("127.0.0.1", port)
        sent = {"joints": 0, "strain": 0}
        sock.sendto(json.dumps({"type": "tool", "t": 0.0, "name": "A"}).encode(), target)
        start = time.monotonic()
        k = 0
        while True:
            t = k / 1000.0  # one 1 ms burst: 5 strain messages and 1 joint message
            if t >= duration:
                break
            wait = t - (time.monotonic() - start)
            if wait > 0:
                time.sleep(wait)
            q = dict(zip(JOINTS, (np.array(HOME) + 1e-6 * rng.standard_normal(6)).tolist(), strict=True))
            sock.sendto(json.dumps({"type": "joints", "t": t, "q": q}, separators=(",", ":")).encode(), target)
            sent["joints"] += 1
            for j in range(5):
                strain = (0.1 + 1e-5 * rng.standard_normal(8)).tolist()
                sock.sendto(json.dumps({"type": "strain", "t": t + j * 0.0002, "strain": strain}, separators=(",", ":")).encode(), target)
                sent["strain"] += 1
            k += 1
        elapsed = time.monotonic() - start
        sock.sendto(b'{"type":"end"}', target)
        output = live.communicate(timeout=60)[0]
    total = sent["joints"] + sent["strain"] + 2
    print(
        f"sent {sent['strain']:,} strain ({sent['strain'] / elapsed:,.0f} Hz) and {sent['joints']:,} joint messages "
        f"({sent['joints'] / elapsed:,.0f} Hz) in {elapsed:.1f} s, {total:,} datagrams with tool and end"
    )
    for line in output.splitlines():
        if line.startswith(("messages:", "strain samples not paired", "samples:")):
            print("live:", line)
    # the live process has only one tool configuration: it cannot calibrate, which is not the point here


if __name__ == "__main__":
    main()

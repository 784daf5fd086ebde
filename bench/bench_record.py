"""Benchmark: `fts-calib record` of 8 channels at 1 kHz (a serial line) and 6 joints at 500 Hz (UDP) on one clock.

Starts `fts-calib record serial://PTY?channels=8 udp://127.0.0.1:PORT` in a child process; from
this process writes 8 integer channels per line to a pseudo-terminal at 1 kHz (channel 1: the
host's monotonic time of the write, in µs) and sends joint datagrams at 500 Hz stamped with a
clock SHIFT s behind the host's, both paced in 2 ms steps, for DURATION seconds (default 600);
then SIGTERM. Prints: samples written and recorded per stream (lost), the child's CPU use over
the run (% of one core), the joint clock offset recovered against SHIFT (ms), and the delay of
the recorded channel stamps behind their write times (ms). Asserts nothing.
Run: .venv/bin/python bench/bench_record.py [DURATION]
"""

import os
import resource
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]
SHIFT = 123.456  # the joint sender's clock, behind the host's [s]


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def main() -> None:
    duration = float(sys.argv[1]) if len(sys.argv) > 1 else 600.0
    port = free_port()
    master, slave = os.openpty()
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "run.csv"
        command = [sys.executable, "-m", "fts_calib.app.cli", "record", f"serial://{os.ttyname(slave)}?channels=8"]
        command += [f"udp://127.0.0.1:{port}", "--robot", "ur5", "--configuration", "A", "-o", str(out), "--quiet"]
        child = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        time.sleep(3.0)  # the child imports and opens the port (pyserial empties the input on opening)
        lines = joints = 0
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        start = time.monotonic()
        step = 0
        while (now := time.monotonic()) - start < duration:
            t = now - SHIFT
            q = ",".join(f'"{name}": {0.1 * k + 0.01 * t:.9f}' for k, name in enumerate(JOINTS))
            sock.sendto(f'{{"type": "joints", "t": {t:.9f}, "q": {{{q}}}, "seq": {joints}}}'.encode(), ("127.0.0.1", port))
            joints += 1
            stamp = int(now * 1e6)
            os.write(master, b"".join(b"%d,%d,1,2,3,4,5,6\n" % (stamp, lines + k) for k in range(2)))
            lines += 2
            step += 1
            ahead = start + step * 0.002 - time.monotonic()
            if ahead > 0:
                time.sleep(ahead)
        time.sleep(0.2)
        child.send_signal(signal.SIGTERM)
        stdout, stderr = child.communicate(timeout=120)
        usage = resource.getrusage(resource.RUSAGE_CHILDREN)
        sock.close()
        figures = yaml.safe_load((Path(folder) / "run.streams.yaml").read_text())
        table = np.loadtxt(out, delimiter=",", skiprows=1, usecols=range(1 + 6 + 2))
    os.close(master)
    os.close(slave)
    channels, stream = figures["streams"]["channels"], figures["streams"]["joints"]
    recorded_lines = channels["samples"] + sum(v for k, v in figures["skipped"].items() if "partial" in k)
    delay_ms = 1e3 * (table[:, 0] - table[:, 7] * 1e-6)
    cpu = usage.ru_utime + usage.ru_stime
    print(f"duration {duration:g} s; exit {child.returncode}; {figures['rows']:,} rows recorded; ended by {figures['ended_by']}")
    print("| stream | sent | received | lost | rate [Hz] | interval jitter [ms] | latency [ms] |")
    print("|---|---|---|---|---|---|---|")
    for name, sent, got in (("channels (serial)", lines, recorded_lines), ("joints (UDP)", joints, stream["samples"])):
        figure = channels if name.startswith("channels") else stream
        latency = "n/a" if figure["latency_s"] is None else f"{1e3 * figure['latency_s']:.3f}"
        jitter = 1e3 * figure["interval_jitter_s"]
        print(f"| {name} | {sent:,} | {got:,} | {sent - got:,} | {figure['rate_hz']:.1f} | {jitter:.3f} | {latency} |")
    print(f"child CPU: {cpu:.1f} s over {duration + 3:.0f} s = {100 * cpu / (duration + 3):.1f} % of one core (imports included)")
    error_ms = 1e3 * (stream["clock_offset_s"] - SHIFT)
    print(f"joint clock offset recovered: {stream['clock_offset_s']:.6f} s, true {SHIFT} s: error {error_ms:+.3f} ms")
    median, p99 = np.median(delay_ms), np.percentile(delay_ms, 99)
    print(f"recorded channel stamp behind its write: median {median:.3f} ms, 99th percentile {p99:.3f} ms")
    skipped = figures["skipped"]
    print(f"skipped: {skipped or 'nothing'}; lost datagrams (seq gaps): {figures['lost_datagrams']}")
    if child.returncode:
        print(stderr[-2000:])


if __name__ == "__main__":
    main()

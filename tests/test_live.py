"""The live path end to end over a real UDP socket on loopback."""

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from fts_calib import load_calibration
from fts_calib.calibrate import calibrate_recording
from fts_calib.live import LiveRunner, UdpReceiver
from fts_calib.replay import ReplayOptions, replay
from fts_calib.session import CalibrationSession
from fts_calib.sync import Synchronizer

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def reference(ur5_recording, _kinematics_cache, paper_tool):
    from .conftest import _kinematics

    return calibrate_recording(ur5_recording, _kinematics(_kinematics_cache, "ur5"), paper_tool).calibration


def _run_live(kin, tool, recording, options, garbage=()):
    receiver = UdpReceiver("127.0.0.1", 0)
    session = CalibrationSession(kin, tool, source="test")
    sync = Synchronizer(kin.joint_names, [j.kind == "continuous" for j in kin.joints], 0.05, options.latency_s)
    runner = LiveRunner(session, receiver, sync)
    result = {}
    thread = threading.Thread(target=lambda: result.update(stats=runner.run(idle_timeout_s=10.0)))
    thread.start()
    try:
        host, port = receiver.address
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            for data in garbage:
                sock.sendto(data, (host, port))
        replay(recording, host, port, options)
        thread.join(timeout=60)
    finally:
        receiver.close()
    assert not thread.is_alive(), "the live run did not end"
    return result["stats"], session, sync, runner


def test_replay_into_live_gives_the_calibration_of_calibrate(ur5, paper_tool, ur5_recording, reference):
    stats, session, sync, runner = _run_live(ur5, paper_tool, ur5_recording, ReplayOptions(speed=40.0))
    assert stats.ended and stats.malformed == 0 and not sync.dropped
    got = session.solve()
    # the same samples by another path; the filter learns its noise floor batch by batch
    # (20 ms live, 65,536 rows from a file), so a few borderline samples differ: the kept
    # counts agree within 1 % and the coefficients within a quarter of their standard error
    assert abs(got.quality.samples_used - reference.quality.samples_used) <= 0.01 * reference.quality.samples_used
    assert np.all(np.abs(got.C - reference.C) <= 0.25 * reference.quality.stderr_C)
    line = runner.status_line()
    assert "rank 7" in line and "kept" in line and "A " in line


def test_loss_reordering_and_bad_datagrams(ur5, paper_tool, ur5_recording, reference):
    garbage = [b"not json"] * 12 + [b'{"type": "strain", "t": 1}'] * 5 + [b"{" + b" " * 9000 + b"}"] * 3
    options = ReplayOptions(speed=40.0, joint_rate_hz=50.0, loss=0.05, reorder=0.05, latency_s=0.02, seed=1)
    receiver_latency = options.latency_s
    stats, session, sync, _ = _run_live(ur5, paper_tool, ur5_recording, options, garbage)
    assert stats.malformed == 17 and stats.oversized == 3
    got = session.solve()
    assert got.quality.rank == 7 and receiver_latency == 0.02
    # fewer samples than the reference (lost, or unpaired across joint gaps), but the same
    # calibration within the reported standard errors (4 sigma over 48 coefficients)
    assert got.quality.samples_used < reference.quality.samples_used
    assert np.all(np.abs(got.C - reference.C) <= 4 * got.quality.stderr_C)


def _free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_a_live_process_killed_and_resumed_gives_the_uninterrupted_result(tmp_path, ur5_recording, reference):
    pipeline = yaml.safe_load((ROOT / "configs" / "pipeline.yaml").read_text())
    pipeline["live"]["checkpoint_interval_s"] = 0.2
    (tmp_path / "pipeline.yaml").write_text(yaml.safe_dump(pipeline))
    port = _free_port()
    out = tmp_path / "cal.yaml"
    command = [
        sys.executable,
        "-m",
        "fts_calib.cli",
        "live",
        "--robot",
        "ur5",
        "--listen",
        f"127.0.0.1:{port}",
        "-o",
        str(out),
        "--pipeline",
        str(tmp_path / "pipeline.yaml"),
        "--idle-timeout",
        "20",
        "--quiet",
    ]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}

    def start(extra=()):
        proc = subprocess.Popen([*command, *extra], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
        for line in proc.stdout:  # wait until it listens
            if line.startswith("listening"):
                return proc
        raise AssertionError("the live process did not start")

    first = start()
    sender = threading.Thread(target=replay, args=(ur5_recording, "127.0.0.1", port, ReplayOptions(speed=6.0)))
    sender.start()
    time.sleep(7.0)  # configuration A (about 30 s of recording) has gone by
    first.send_signal(signal.SIGKILL)  # a crash: no clean shutdown
    first.wait()
    assert (tmp_path / "cal.yaml.checkpoint.json").exists() and not out.exists()
    second = start(["--resume"])
    sender.join(timeout=60)
    output = second.communicate(timeout=60)[0]
    assert second.returncode == 0, output
    got = load_calibration(out)
    assert got.quality.rank == 7
    assert np.all(np.abs(got.C - reference.C) <= 4 * got.quality.stderr_C)
    assert got.quality.samples_used > 0.5 * reference.quality.samples_used

"""The live path end to end over a real UDP socket on loopback."""

import json
import math
import os
import queue
import re
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

from fts_calib import ConfigError, load_calibration
from fts_calib.session.calibration_run import LiveRunner, calibrate_recording
from fts_calib.session.session import CalibrationSession
from fts_calib.sources.live_feed import LiveFeed, StreamEnd
from fts_calib.sources.sender import ReplayOptions, messages, replay
from fts_calib.sources.synchronizer import Synchronizer
from fts_calib.sources.udp import UdpReceiver, encode

from .helpers import DEADLINE_S, live_calibrate, wait_for
from .report_checks import check_page

ROOT = Path(__file__).resolve().parents[1]

# Left out of the seed sweep: each test streams the whole simulated recording over loopback,
# paced in wall-clock time (2 to 7 s a seed). The seeded data are the recording's noise, which
# test_calibrate.py and test_session.py sweep on the same calibration paths without the socket.
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def reference(ur5_recording, _kinematics_cache, paper_tool):
    from .conftest import _kinematics

    return calibrate_recording(ur5_recording, _kinematics(_kinematics_cache, "ur5"), paper_tool).calibration


def _run_live(kin, tool, recording, options, garbage=()):
    receiver = UdpReceiver("127.0.0.1", 0)
    session = CalibrationSession(kin, tool, source="test")
    sync = Synchronizer(kin.joint_names, kin.continuous, 0.05, options.latency_s, configurations=tool.names)
    runner = LiveRunner(session, LiveFeed(receiver, sync, end=StreamEnd(idle_timeout_s=10.0)))
    result = {}
    thread = threading.Thread(target=lambda: result.update(stats=runner.run()))
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
    assert "rank 7 of 7" in line and "kept" in line and "A " in line


def test_loss_reordering_and_bad_datagrams(ur5, paper_tool, ur5_recording, reference, seed):
    garbage = [b"not json"] * 12 + [b'{"type": "strain", "t": 1}'] * 5 + [b"{" + b" " * 9000 + b"}"] * 3
    options = ReplayOptions(speed=40.0, joint_rate_hz=50.0, loss=0.05, reorder=0.05, latency_s=0.02, seed=seed)
    stats, session, sync, _ = _run_live(ur5, paper_tool, ur5_recording, options, garbage)
    assert stats.malformed == 17 and stats.oversized == 3
    # one strain message per row, each dropped by the replay with probability `loss`: a
    # Binomial(rows, 0.95) count (sd about 21); loopback may lose a few more under load, never add
    rows = reference.quality.samples_seen
    sd = math.sqrt(rows * options.loss * (1 - options.loss))
    assert 0.9 * rows < stats.strain <= (1 - options.loss) * rows + 5 * sd, f"{stats.strain} strain messages of {rows} rows"
    got = session.solve()
    assert got.quality.rank == 7
    # fewer samples than the reference (lost, or unpaired across joint gaps), but the same
    # calibration within the reported standard errors (4 sigma over 48 coefficients)
    assert got.quality.samples_used < reference.quality.samples_used
    assert np.all(np.abs(got.C - reference.C) <= 4 * got.quality.stderr_C)


class _Process:
    """A ``fts-calib live`` process; its output read on a thread, so that waits have deadlines."""

    def __init__(self, command, env):
        self.proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
        self.lines = queue.Queue()
        self.seen = []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        for line in self.proc.stdout:
            self.lines.put(line)
        self.lines.put(None)

    def line(self, prefix, timeout_s=DEADLINE_S):
        """The next output line starting with ``prefix``."""
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                line = self.lines.get(timeout=max(deadline - time.monotonic(), 0.0))
            except queue.Empty:
                raise AssertionError(f"no line {prefix!r} within {timeout_s:g} s; output so far:\n{''.join(self.seen)}") from None
            if line is None:
                raise AssertionError(f"the process ended without a line {prefix!r}:\n{''.join(self.seen)}")
            self.seen.append(line)
            if line.startswith(prefix):
                return line

    def port(self):
        """The port the process bound (it was given port 0), from its 'listening on' line."""
        return int(re.match(r"listening on udp://[\d.]+:(\d+) ", self.line("listening on")).group(1))

    def output(self, timeout_s=DEADLINE_S):
        self.proc.wait(timeout=timeout_s)
        while (line := self.lines.get(timeout=timeout_s)) is not None:
            self.seen.append(line)
        return "".join(self.seen)


class _Feed:
    """The robot's feed, from a recording: paced at ``speed``, held while no process listens
    (the paced schedule resumes where it stopped)."""

    def __init__(self, path, speed):
        self.path, self.speed = path, speed
        self.target = None
        self.listening, self.quit = threading.Event(), threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def to(self, port):
        self.target = ("127.0.0.1", port)
        self.listening.set()

    def hold(self):
        self.listening.clear()
        self.target = None

    def _run(self):
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            start, t0, held = time.monotonic(), None, 0.0
            for t, message in messages(self.path, ReplayOptions()):
                while (target := self.target) is None:
                    began = time.monotonic()
                    if not self.listening.wait(DEADLINE_S) or self.quit.is_set():
                        return
                    held += time.monotonic() - began
                t0 = t if t0 is None else t0
                ahead = start + held + (t - t0) / self.speed - time.monotonic()
                if ahead > 0 and self.quit.wait(ahead):  # the feed's schedule, or the end of the test
                    return
                sock.sendto(encode(message), target)


def test_a_live_process_killed_and_resumed_gives_the_uninterrupted_result(tmp_path, ur5_recording, reference):
    """A crash (SIGKILL) after configuration A, then --resume: the feed is held while no
    process listens, so the samples lost are those received after the last checkpoint (at
    most 0.2 s, 4 s of recording at speed 20) and those before the next tool message (1 s)."""
    pipeline = yaml.safe_load((ROOT / "configs" / "pipeline.yaml").read_text())
    pipeline["live"]["checkpoint_interval_s"] = 0.2
    (tmp_path / "pipeline.yaml").write_text(yaml.safe_dump(pipeline))
    out = tmp_path / "cal.yaml"
    checkpoint = tmp_path / "cal.yaml.checkpoint.json"
    command = [
        sys.executable,
        "-m",
        "fts_calib.app.cli",
        *live_calibrate(out),
    ]
    command += ["--pipeline", str(tmp_path / "pipeline.yaml"), "--idle-timeout", "20", "--quiet"]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}

    def kept():
        """Samples kept per configuration in the checkpoint (written atomically), or None."""
        return json.loads(checkpoint.read_text())["kept"] if checkpoint.exists() else None

    feed, processes = _Feed(ur5_recording, speed=20.0), []
    try:
        first = _Process(command, env)
        processes.append(first.proc)
        feed.to(first.port())
        wait_for(lambda: (k := kept()) is not None and k[1] > 0, "a checkpoint with samples of configuration B")
        feed.hold()
        first.proc.send_signal(signal.SIGKILL)  # a crash: no clean shutdown
        first.proc.wait(timeout=DEADLINE_S)
        assert not out.exists()
        at_crash = kept()
        assert at_crash[0] > 300, f"configuration A is in the checkpoint: {at_crash}"
        second = _Process([*command, "--resume", "--report", str(tmp_path / "live.html")], env)
        processes.append(second.proc)
        resumed = second.line("resumed from")
        assert f": {sum(at_crash):,} samples kept so far" in resumed, resumed
        feed.to(second.port())
        output = second.output()
    finally:
        feed.quit.set()
        feed.listening.set()
        for proc in processes:  # a failed wait leaves nothing running
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    assert second.proc.returncode == 0, output
    got = load_calibration(out)
    assert got.quality.rank == 7
    assert np.all(np.abs(got.C - reference.C) <= 4 * got.quality.stderr_C)
    # the resumed run's report: the calibration's verdict; no pictures of the samples before the checkpoint
    page = (tmp_path / "live.html").read_text()
    check_page(page)
    assert "GOOD" in page and "not recorded: no sample at hand" in page
    # at most 5 s of the 90 s recording lost: two or three of its 0.4 s dwells (one every 2.5 s),
    # about 120 of the 1,130 samples kept (1,125 kept in a typical run)
    assert got.quality.samples_used > 0.8 * reference.quality.samples_used, (got.quality.samples_used, reference.quality.samples_used)


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"speed": -1.0}, r"speed=-1.0 but expected a finite value >= 0"),
        ({"joint_rate_hz": 0.0}, r"joint_rate_hz=0.0 Hz but expected a finite value > 0"),
        ({"latency_s": float("nan")}, r"latency_s=nan s but expected a finite value"),
        ({"loss": 1.0}, r"loss=1.0 but expected a fraction in \[0, 1\)"),
        ({"reorder": -0.1}, r"reorder=-0.1 but expected a fraction in \[0, 1\)"),
    ],
)
def test_bad_replay_options_are_refused(changes, match):
    with pytest.raises(ConfigError, match=match):
        ReplayOptions(**changes)


def test_a_live_run_that_received_nothing_leaves_no_checkpoint_in_the_way_of_the_next(tmp_path, capsys):
    """Before: a run on the wrong port kept an empty checkpoint, and the next run was refused (exit 3) until --restart."""
    from fts_calib.app.cli import main
    from fts_calib.app.exit_codes import ExitCode

    output = tmp_path / "cal.yaml"
    run = live_calibrate(output, "--idle-timeout", "0.2")
    for _ in range(2):  # the second run starts as the first did
        assert main([*run, "--quiet"]) == ExitCode.CHECK_FAILED
        out = capsys.readouterr().out
        assert "NO CALIBRATION: insufficient data: no sample was given; no checkpoint kept (it would hold nothing)" in out, out
        assert not list(tmp_path.iterdir()), "a calibration, a checkpoint or a lock was left"


def test_a_status_line_into_a_file_is_a_line_every_few_seconds_and_rewritten_on_a_terminal():
    """Into a file (no terminal): no carriage returns, one line per LOG_INTERVAL_S (it once wrote hundreds of '\\r' lines)."""
    import io

    from fts_calib.session.calibration_run import LOG_INTERVAL_S, StatusLine

    now = [0.0]
    into_file = io.StringIO()
    status = StatusLine(into_file, clock=lambda: now[0])
    for k in range(200):  # 20 s of status every 0.1 s (the feed's rate of calls)
        now[0] = 0.1 * k
        status.show(f"t {now[0]:.1f} s")
    status.show("t 20.0 s, the end", end="\n")
    status.close()
    lines = into_file.getvalue().split("\n")
    assert "\r" not in into_file.getvalue() and lines[-1] == ""
    assert lines[:-1] == ["t 0.0 s", "t 5.0 s", "t 10.0 s", "t 15.0 s", "t 20.0 s, the end"], lines
    assert LOG_INTERVAL_S == 5.0

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    terminal = Terminal()
    status = StatusLine(terminal, clock=lambda: 0.0)
    status.show("a longer line")
    status.show("short")
    status.close()
    assert terminal.getvalue() == "\ra longer line\rshort        \n"

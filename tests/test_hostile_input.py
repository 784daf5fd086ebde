"""Hostile and careless input, round 3 (issue 21, part A): no traceback, no hang, each case one clear line.

Each test is a case that died, hung or counted samples twice before, run through the
command line's entry point (``main``) where a user meets it: the first line of the message
and the exit code are asserted. The unit tests at the end check the bounded parsers of
:mod:`fts_calib.core.bounded` on their own.
"""

import dataclasses
import json
import math
import os
import re
import signal
import socket
import struct
import subprocess
import sys
import textwrap
import threading
import time
import types
import warnings

import numpy as np
import pytest

from fts_calib import FileFormatError, FtsCalibWarning
from fts_calib.app.cli import main
from fts_calib.app.exit_codes import ExitCode
from fts_calib.core.bounded import MAX_CHANNELS, MAX_COLUMNS, MAX_DEPTH, LimitError, json_depth, loads_json, parse_yaml
from fts_calib.core.tables import utf8_safe
from fts_calib.model.calibration import load_calibration
from fts_calib.session.calibration_run import LiveRunner
from fts_calib.session.session import CalibrationSession
from fts_calib.sources.batch import repeated_rows
from fts_calib.sources.live_feed import LiveFeed, StreamEnd
from fts_calib.sources.synchronizer import Synchronizer
from fts_calib.sources.udp import MAX_NESTING, LiveStats, SeqGaps, Strain, UdpReceiver, encode, feed_datagram, listen_host

from .helpers import DEADLINE_S, FakeRtdeServer, live_calibrate, wait_for


def _error(capsys):
    """The one line a failed command printed on stderr (after any warnings)."""
    lines = [line for line in capsys.readouterr().err.strip().splitlines() if "warning:" not in line]
    assert len(lines) == 1, lines
    return lines[0]


def _calibrate(tmp_path, recording, *extra, robot="ur5"):
    return main(
        ["calibrate", "--robot", robot, "--tool", "paper_tool", str(recording), "-o", str(tmp_path / "cal.yaml"), "--quiet", *extra]
    )


@pytest.fixture(scope="module")
def calibration_file(tmp_path_factory, ur5_recording):
    """A calibration of the simulated UR5 run, written by calibrate."""
    out = tmp_path_factory.mktemp("cal") / "cal.yaml"
    assert main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(ur5_recording), "-o", str(out), "--quiet"]) == ExitCode.OK
    return out


# -- the program dies: files --------------------------------------------------------------


@pytest.mark.parametrize(
    ("name", "text", "expected"),
    [
        (
            "laughs.yaml",
            "format: fts-calib/1\na: &a [1, 1, 1, 1, 1, 1, 1, 1, 1]\nb: &b [*a, *a, *a, *a, *a, *a, *a, *a, *a]\nc: [*b, *b, *b]\n",
            r"laughs\.yaml: line 3, column 8: a YAML alias \(\*a\) is not accepted: fts-calib files use no anchors or aliases; "
            "write the values out",
        ),
        (
            "deep.yaml",
            "C: " + "[" * 20_000 + "]" * 20_000 + "\n",
            # libyaml's scanner stops at 1,000 levels before any event; PyYAML's own parser meets our limit first
            r"deep\.yaml: (not valid YAML at line 1, column 1003: exceeded maximum nesting depth|line 1, column 67: nested more than 64)",
        ),
        (
            "deep_block.yaml",
            "".join("  " * k + "- \n" for k in range(200)),
            rf"deep_block\.yaml: line {MAX_DEPTH + 1}, column {2 * MAX_DEPTH + 1}: nested more than {MAX_DEPTH} levels deep",
        ),
        ("digits.yaml", "D: [" + "9" * 400 + ", 0]\n", r"digits\.yaml: line 1, column 5: an integer of 400 digits \(at most 20\)"),
        ("overflow.yaml", "D: [1.0e+400, 0]\n", r"overflow\.yaml: line 1, column 5: the number 1\.0e\+400 is beyond the float range"),
    ],
)
def test_a_hostile_calibration_yaml_is_one_line(tmp_path, capsys, name, text, expected):
    path = tmp_path / name
    path.write_text(text)
    code = main(["export", "--format", "json", "--calibration", str(path), "-o", str(tmp_path / "out.json")])
    assert code == ExitCode.FILE
    line = _error(capsys)
    assert re.match(f"fts-calib export: error: {re.escape(str(tmp_path))}/{expected}", line), line
    assert not (tmp_path / "out.json").exists()


def test_a_file_larger_than_any_fts_calib_file_is_refused_before_it_is_read(tmp_path, capsys):
    path = tmp_path / "huge.yaml"
    with open(path, "wb") as handle:
        handle.truncate(17 << 20)  # sparse: 17 MiB of zeros without writing them
    assert main(["export", "--format", "json", "--calibration", str(path), "-o", str(tmp_path / "o.json")]) == ExitCode.FILE
    assert (
        _error(capsys) == f"fts-calib export: error: {path}: larger than 16 MiB, the most a YAML file of fts-calib may be: not such a file"
    )


def _ati(n, gauges=None):
    rows = "\n".join(
        f'    <UserAxis Name="{axis}" values="{" ".join("1" if i == k else "0" for i in range(n))}" max="100"/>'
        for k, axis in enumerate(("Fx", "Fy", "Fz", "Tx", "Ty", "Tz"))
    )
    head = f'<FTSensor Serial="FT1" NumGages="{gauges or n}">\n  <Calibration ForceUnits="N" TorqueUnits="N-m">\n'
    return head + rows + "\n  </Calibration>\n</FTSensor>\n"


def test_a_matrix_of_30000_channels_is_refused_before_any_svd(tmp_path, ur5_recording, capsys):
    """A 6 x 30,000 ATI matrix (a full SVD would need 7 GB): refused from its width."""
    ati = tmp_path / "FT_wide.cal"
    ati.write_text(_ati(30_000))
    assert _calibrate(tmp_path, ur5_recording, "--sensor", str(ati)) == ExitCode.FILE
    assert _error(capsys) == (
        f"fts-calib calibrate: error: {ati}: field 'UserAxis.values': 30,000 gauges but fts-calib reads at most {MAX_CHANNELS}: "
        "not a sensor's calibration"
    )
    # the sensor YAML's projection: the same limit, in the channel layout itself (100 columns: the rule, not the size)
    sensor = tmp_path / "wide_sensor.yaml"
    rows = [[1.0 if i == k else 0.0 for i in range(100)] for k in range(6)]
    sensor.write_text(f"name: wide\nchannels:\n  projection: {rows}\n")
    assert _calibrate(tmp_path, ur5_recording, "--sensor", str(sensor)) == ExitCode.FILE
    assert _error(capsys) == (
        f"fts-calib calibrate: error: {sensor}: field 'channels.projection': has 100 columns but expected at most {MAX_CHANNELS} "
        "channels (columns)"
    )


def test_a_header_of_a_megabyte_of_columns_is_refused_at_once(tmp_path, capsys):
    path = tmp_path / "wide.csv"
    path.write_text("time," + ",".join(f"column_{k}" for k in range(100_000)) + "\n0.0\n")
    assert _calibrate(tmp_path, path) == ExitCode.RECORDING
    assert _error(capsys) == (
        f"fts-calib calibrate: error: {path}, line 1: the header has more than {MAX_COLUMNS:,} columns, the most a recording may have "
        f"(time, the joints, at most {MAX_CHANNELS} strain columns, tool, temperature): not a recording's header"
    )
    path.write_text("time,strain_100,tool\n0.0,1.0,A\n")
    assert _calibrate(tmp_path, path) == ExitCode.RECORDING
    assert _error(capsys).endswith(
        f"line 1, column 'strain_100': a channel number beyond {MAX_CHANNELS}, the most channels a sensor may have"
    )


def test_a_repeated_column_among_many_is_found(tmp_path, ur5_recording, capsys):
    """The repeated-column check is linear now; it still names the column."""
    lines = ur5_recording.read_text().splitlines(keepends=True)[:50]
    header = lines[0].rstrip("\n") + "," + ",".join(f"extra_{k}" for k in range(900)) + ",strain_3\n"
    path = tmp_path / "repeated.csv"
    path.write_text(header + "".join(line.rstrip("\n") + ",0" * 901 + "\n" for line in lines[1:]))
    assert _calibrate(tmp_path, path) == ExitCode.RECORDING
    assert _error(capsys).endswith("line 1, column 'strain_3': column repeated: ['strain_3']")


@pytest.fixture(scope="module")
def bag(tmp_path_factory, ur5_recording):
    from fts_calib.sim.robot_log import recording_to_bag

    return recording_to_bag(ur5_recording, tmp_path_factory.mktemp("bag") / "run", "mcap")


def test_a_bag_whose_metadata_is_binary_is_one_line(tmp_path, bag, capsys):
    broken = tmp_path / "broken"
    broken.mkdir()
    for file in bag.iterdir():
        os.symlink(file, broken / file.name)
    (broken / "metadata.yaml").unlink()
    (broken / "metadata.yaml").write_bytes(bytes([0x83, 0xFF, 0x00, 0x12]) * 200)
    assert _calibrate(tmp_path, broken) == ExitCode.RECORDING
    assert _error(capsys) == (
        f"fts-calib calibrate: error: {broken}: not a readable ROS 2 bag: {broken}/metadata.yaml: not a text file "
        "(byte 0x83 at offset 0 is not UTF-8): expected YAML"
    )


def test_a_bag_given_with_its_own_storage_file_is_refused(tmp_path, bag, capsys):
    mcap = next(bag.glob("*.mcap"))
    code = main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(bag), str(mcap), "-o", str(tmp_path / "cal.yaml"), "--quiet"])
    assert code == ExitCode.RECORDING
    assert _error(capsys) == (
        f"fts-calib calibrate: error: {mcap}: given twice: the same bag as {bag} (which holds {mcap.name}); "
        "its samples would count twice: give each bag once"
    )


def test_a_csv_with_every_row_doubled_gives_the_calibration_of_the_rows_once(tmp_path, ur5_recording, calibration_file, capsys):
    """Each row twice (ZeroDivisionError in the latency estimate before): the repeats are dropped and counted."""
    lines = ur5_recording.read_text().splitlines(keepends=True)
    doubled = tmp_path / "doubled.csv"
    doubled.write_text(lines[0] + "".join(line + line for line in lines[1:]))
    capsys.readouterr()
    assert main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(doubled), "-o", str(tmp_path / "cal.yaml")]) == ExitCode.OK
    out = capsys.readouterr().out
    rows = len(lines) - 1
    assert re.search(rf"\n  duplicate sample +{rows:,}\n", out), out  # the column as wide as the longest reason
    assert f"{doubled}, line 3: the same values as the row before it: dropped (counted once)" in out
    once, twice = load_calibration(calibration_file), load_calibration(tmp_path / "cal.yaml")
    # the same rows in the same order: the same sums, the same calibration to rounding
    assert twice.quality.samples_used == once.quality.samples_used
    np.testing.assert_allclose(twice.C, once.C, rtol=0, atol=1e-9 * np.abs(once.C).max())


def test_a_prior_weight_of_1e308_is_refused(tmp_path, ur5_recording, calibration_file, capsys):
    assert _calibrate(tmp_path, ur5_recording, "--prior", str(calibration_file), "--prior-weight", "1e308") == ExitCode.CONFIG
    assert _error(capsys) == (
        "fts-calib calibrate: error: --prior-weight 1e+308 but expected at most 1e+12: there the result is already the prior's "
        "C_bar to rounding (a larger weight only overflows the solve); to use the prior as it is, use that calibration"
    )


ONE_JOINT_URDF = """\
<robot name="one">
  <link name="base"/>
  <link name="arm"/>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/>
  </joint>
</robot>
"""


def _robot(tmp_path, urdf):
    path = tmp_path / "robot.yaml"
    path.write_text(f"name: one\nurdf: {urdf}\nsensor:\n  parent_frame: arm\n  xyz: [0, 0, 0]\n  rpy: [0, 0, 0]\n")
    return path


def test_a_urdf_with_one_joint_names_the_joint_and_asks_for_two(tmp_path, ur5_recording, capsys):
    (tmp_path / "one.urdf").write_text(ONE_JOINT_URDF)
    robot = _robot(tmp_path, "one.urdf")
    assert _calibrate(tmp_path, ur5_recording, robot=str(robot)) == ExitCode.ROBOT
    assert _error(capsys) == (
        f"fts-calib calibrate: error: {tmp_path}/one.urdf has 1 actuated joint(s) ('shoulder') but a calibration sweeps two "
        "(the last two actuated joints, or the robot file's sweep_joints)"
    )


def test_a_urdf_field_pointing_at_a_csv_names_the_file(tmp_path, ur5_recording, capsys):
    robot = _robot(tmp_path, str(ur5_recording))
    assert main(["robots", str(robot)]) == ExitCode.FILE
    assert _error(capsys) == (
        f"fts-calib robots: error: {robot}: field 'urdf': {ur5_recording} is not a URDF: it holds no <robot> element "
        "(expected the robot's URDF XML file)"
    )


def test_a_file_name_that_is_not_utf8_is_written_escaped(tmp_path, ur5_recording, capsys):
    """The provenance of a recording named with a byte that is not UTF-8: the calibration and its exports are written."""
    name = os.fsdecode(b"run\xff.csv")
    recording = tmp_path / name
    recording.write_bytes(ur5_recording.read_bytes())
    assert (
        main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(recording), "-o", str(tmp_path / "cal.yaml"), "--quiet"])
        == ExitCode.OK
    )
    cal = load_calibration(tmp_path / "cal.yaml")  # readable again: the byte is written as \xff
    assert cal.provenance["source"].endswith("run\\xff.csv"), cal.provenance["source"]
    for kind in ("json", "c-header", "ati"):
        out = tmp_path / f"export.{kind}"
        assert main(["export", "--format", kind, "--calibration", str(tmp_path / "cal.yaml"), "-o", str(out)]) == ExitCode.OK
        out.read_text(encoding="utf-8")  # valid UTF-8
    assert "run\\\\xff.csv" in (tmp_path / "export.json").read_text()


# -- the program dies: live datagrams -------------------------------------------------------

HOSTILE_DATAGRAMS = {
    "nested 4,000 deep": b"[" * 4000 + b"]" * 4000,
    "400-digit channel": b'{"type":"strain","t":1.0,"strain":[' + b"9" * 400 + b',0,0,0,0,0,0,0],"seq":1}',
    "1e400 channel": b'{"type":"strain","t":1.0,"strain":[1e400,0,0,0,0,0,0,0]}',
    "NaN channel": b'{"type":"strain","t":1.0,"strain":[NaN,0,0,0,0,0,0,0]}',
    "1e400 joint": b'{"type":"joints","t":1.0,"q":{"a":1e400}}',
    "NaN quaternion": b'{"type":"joints","t":1.0,"quat":[NaN,0,0,1]}',
    "reflection R": b'{"type":"joints","t":1.0,"R":[1,0,0,0,1,0,0,0,-1]}',
}
REASONS = {
    "nested 4,000 deep": f"malformed datagram: nested 4000 levels deep (at most {MAX_NESTING})",
    "400-digit channel": "malformed datagram: an integer of 400 digits (at most 20)",
    "1e400 channel": "malformed datagram: 'strain' holds a number that is not finite (or beyond the float range)",
    "NaN channel": "malformed datagram: 'strain' holds NaN, not a number fts-calib accepts (expected finite numbers)",
    "1e400 joint": "malformed datagram: 'q' holds a joint reading that is not finite (or beyond the float range)",
    "NaN quaternion": "malformed datagram: 'quat' holds NaN, not a number fts-calib accepts (expected finite numbers)",
    "reflection R": "malformed datagram: 'R' has determinant -1: a reflection, not a rotation (expected det +1)",
}


@pytest.mark.parametrize("case", list(HOSTILE_DATAGRAMS))
def test_a_hostile_datagram_is_counted_with_its_reason_and_skipped(case):
    stats = LiveStats()
    assert feed_datagram(HOSTILE_DATAGRAMS[case], None, stats) is None
    assert stats.malformed == 1 and stats.first_malformed == REASONS[case]
    assert feed_datagram(encode(Strain(2.0, (1.0,) * 8)), None, stats) is not None  # the next one is read
    assert stats.strain == 1


def test_hostile_datagrams_do_not_end_a_live_run(ur5, paper_tool):
    """Every hostile datagram at a running receiver, then 'end': the run ends on it, each counted."""
    receiver = UdpReceiver("127.0.0.1", 0)
    session = CalibrationSession(ur5, paper_tool, source="test")
    sync = Synchronizer(ur5.joint_names, ur5.continuous, 0.05, 0.0, configurations=paper_tool.names)
    runner = LiveRunner(session, LiveFeed(receiver, sync, end=StreamEnd(idle_timeout_s=DEADLINE_S)))
    result = {}
    thread = threading.Thread(target=lambda: result.update(stats=runner.run()))
    thread.start()
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            for data in HOSTILE_DATAGRAMS.values():
                sock.sendto(data, receiver.address)
            wait_for(lambda: runner.stats.received >= len(HOSTILE_DATAGRAMS), "the hostile datagrams to arrive")
            sock.sendto(b'{"type":"end"}', receiver.address)
        thread.join(timeout=DEADLINE_S)
    finally:
        receiver.close()
    assert not thread.is_alive(), "the live run did not end"
    assert result["stats"].ended and result["stats"].malformed == len(HOSTILE_DATAGRAMS)


def test_every_datagram_twice_counts_each_once():
    """A sender (or a network) that sends every datagram twice: duplicates by seq dropped and counted."""
    stats = LiveStats()
    for seq in range(372):
        data = encode(Strain(seq * 0.001, (float(seq),) * 8, seq))
        feed_datagram(data, None, stats, ("127.0.0.1", 9))
        feed_datagram(data, None, stats, ("127.0.0.1", 9))
    assert stats.received == 744 and stats.strain == 372 and stats.duplicates == 372 and stats.gaps == 0


def test_a_late_datagram_fills_its_gap_and_a_repeat_of_it_is_dropped():
    gaps = SeqGaps()
    assert all(gaps.observe("a", seq) for seq in (0, 1, 3, 4))
    assert gaps.missing == 1
    assert gaps.observe("a", 2) and gaps.missing == 0  # late (reordered): used
    assert not gaps.observe("a", 2) and not gaps.observe("a", 4)  # repeats: dropped
    assert gaps.observe("b", 2)  # another sender: its own numbers
    assert gaps.observe("a", 0 + 10_000) and gaps.observe("a", 0)  # far back: a sender that started again


# -- the program hangs: network waits -------------------------------------------------------


def _fake_rtde_module(monkeypatch, receiver):
    monkeypatch.setitem(sys.modules, "rtde_receive", types.SimpleNamespace(RTDEReceiveInterface=lambda host: receiver))


def _live_ur(tmp_path, *extra):
    return [
        "calibrate",
        "ur://127.0.0.1",
        "udp://127.0.0.1:0",
        "--robot",
        "ur5",
        "--tool",
        "paper_tool",
        "-o",
        str(tmp_path / "c.yaml"),
        *extra,
    ]


def _in_thread(argv):
    """``main(argv)`` on a thread joined with a deadline (a hang fails the test instead of stalling it)."""
    result = {}
    thread = threading.Thread(target=lambda: result.update(code=main(argv)), daemon=True)
    thread.start()
    thread.join(timeout=DEADLINE_S)
    assert not thread.is_alive(), f"fts-calib {' '.join(argv)} did not return within {DEADLINE_S} s"
    return result["code"]


def test_a_host_that_accepts_and_says_nothing_is_named_within_the_timeout(tmp_path, monkeypatch, capsys):
    _fake_rtde_module(monkeypatch, None)
    with FakeRtdeServer(answer=False) as server:
        monkeypatch.setattr("fts_calib.sources.ur.RTDE_PORT", server.port)
        code = _in_thread(_live_ur(tmp_path, "--ur-timeout", "0.3"))
    assert code == ExitCode.TIMEOUT == 18
    assert not list(tmp_path.iterdir())
    assert capsys.readouterr().err.strip() == (
        f"fts-calib calibrate: error: no answer within 0.3 s: waited for the UR controller at 127.0.0.1:{server.port} (RTDE) to answer "
        "RTDE's protocol request; is HOST the robot's controller, with RTDE enabled? (--ur-timeout sets the wait)"
    )


def test_a_controller_that_connects_and_never_publishes_is_named(tmp_path, monkeypatch, capsys):
    class Silent:  # connected, but no sample ever comes (its time never moves past the start)
        def getTimestamp(self):  # noqa: N802
            return -math.inf

    _fake_rtde_module(monkeypatch, Silent())
    with FakeRtdeServer() as server:
        monkeypatch.setattr("fts_calib.sources.ur.RTDE_PORT", server.port)
        code = _in_thread(_live_ur(tmp_path, "--ur-timeout", "0.3", "--quiet"))
    assert code == ExitCode.TIMEOUT
    expected = "no answer within 0.3 s: waited for the first sample of the UR controller at 127.0.0.1:30004 (RTDE)"
    assert _error(capsys) == f"fts-calib calibrate: error: {expected}"
    assert not list(tmp_path.iterdir()), "nothing written: the next run starts afresh"


def test_ctrl_c_ends_a_wait_on_a_silent_controller(tmp_path):
    """SIGINT while the handshake waits (60 s): the process ends at once with 130, no traceback."""
    with FakeRtdeServer(answer=False) as server:
        script = textwrap.dedent(
            f"""
            import sys, types
            sys.modules["rtde_receive"] = types.SimpleNamespace(RTDEReceiveInterface=lambda host: None)
            import fts_calib.sources.ur
            fts_calib.sources.ur.RTDE_PORT = {server.port}
            from fts_calib.app.cli import main
            sys.exit(main({_live_ur(tmp_path, "--ur-timeout", "60")!r}))
            """
        )
        proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            assert proc.stdout.readline().startswith("connecting to the UR at 127.0.0.1"), "no 'connecting' line"
            wait_for(lambda: server._clients, "the probe to connect")
            proc.send_signal(signal.SIGINT)
            _, err = proc.communicate(timeout=DEADLINE_S)
        finally:
            proc.kill()
    assert proc.returncode == ExitCode.INTERRUPTED, err
    assert err.strip() == "fts-calib calibrate: interrupted"


# -- exposure -----------------------------------------------------------------------------


@pytest.mark.parametrize("address", ["0:5005", "0.0.0.0:5005"])
def test_binding_every_interface_needs_listen_any(tmp_path, capsys, address):
    code = main(["calibrate", f"udp://{address}", "--robot", "ur5", "--tool", "paper_tool", "-o", str(tmp_path / "c.yaml")])
    assert code == ExitCode.CONFIG
    assert _error(capsys) == (
        f"fts-calib calibrate: error: udp://{address} would bind every network interface: any host that reaches this one could send "
        "datagrams into the calibration. Listen on loopback (udp://127.0.0.1:5005) when the sender runs here; "
        "otherwise say so: this host's address on the sender's network (udp://192.168.1.20:5005), or every interface with "
        "--listen-any"
    )
    assert not (tmp_path / "c.yaml.checkpoint.json").exists()


def test_listen_any_reaches_the_socket_and_is_warned_about(tmp_path, monkeypatch, capsys):
    """`live --listen-any`: the flag reaches the receiver, which warns; the socket itself stays on loopback here."""
    from fts_calib.sources import udp

    def loopback_instead(host, listen_any=False, port=None):  # the flag checked, then loopback
        assert listen_any, f"--listen-any did not reach the receiver ({host})"
        return "127.0.0.1"

    monkeypatch.setattr(udp, "listen_host", loopback_instead)
    monkeypatch.setattr(udp, "_is_loopback", lambda host: False)
    argv = live_calibrate(tmp_path / "c.yaml", "--listen-any", "--idle-timeout", "0.1", "--quiet")
    assert main(argv) == ExitCode.CHECK_FAILED  # no data came: no calibration
    err = capsys.readouterr().err
    assert re.search(r"fts-calib: warning: listening on udp://127\.0\.0\.1:\d+, beyond loopback: any host that reaches this one", err)


def test_listen_any_binds_every_interface_and_a_network_address_is_warned_about(monkeypatch):
    assert listen_host("0", listen_any=True) == listen_host("127.0.0.1", listen_any=True) == "0.0.0.0"
    assert listen_host("192.168.1.20", listen_any=True) == "192.168.1.20"
    assert listen_host("127.0.0.1") == "127.0.0.1" and listen_host("192.168.1.20") == "192.168.1.20"
    # the warning, on a socket that only pretends to be beyond loopback (tests bind 127.0.0.1)
    monkeypatch.setattr("fts_calib.sources.udp._is_loopback", lambda host: False)
    with pytest.warns(FtsCalibWarning, match=r"listening on udp://127\.0\.0\.1:\d+, beyond loopback: any host that reaches"):
        UdpReceiver("127.0.0.1", 0).close()
    monkeypatch.undo()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        UdpReceiver("127.0.0.1", 0).close()  # loopback: no warning


# -- round 4 (issue 33, cases 12-15): the dynamic filter, the latency, continuous plans, numeric options ------------


def _stamps_repeated(source, path):
    """``source`` with every second row stamped as the row before it: two samples per time stamp."""
    head, *rows = source.read_text().splitlines(keepends=True)
    stamps = [row.split(",", 1)[0] for row in rows]
    path.write_text(head + "".join(stamps[k - k % 2] + "," + row.split(",", 1)[1] for k, row in enumerate(rows)))
    return path


def test_two_samples_per_time_stamp_are_refused_by_the_dynamic_filter(tmp_path, ur5_recording, capsys):
    """Case 12: the jitter term was millions of % of full scale and 95 % of the samples kept, exit 0; now exit 5, nothing written."""
    recording = _stamps_repeated(ur5_recording, tmp_path / "twice.csv")
    code = _calibrate(tmp_path, recording, "--filter", "dynamic")
    assert code == ExitCode.RECORDING == 5
    line = _error(capsys)
    assert line.startswith(f"fts-calib calibrate: error: {recording}, column 'time': "), line
    assert re.search(r": [\d,]+ of [\d,]+ consecutive rows of the first [\d,]+ have the same time stamp as the row before", line), line
    assert line.endswith(
        "so it needs one time stamp per sample; record the time at the sample rate, or calibrate the still samples (--filter quasi-static)"
    )
    assert not (tmp_path / "cal.yaml").exists()
    assert _calibrate(tmp_path, recording) == ExitCode.OK, "the quasi-static filter reads such a clock (it judges still samples only)"


def test_a_few_repeated_stamps_are_dropped_by_the_dynamic_filter_without_a_numpy_warning(tmp_path, ur5_recording, capsys):
    """Case 12: one row in 20 stamped as the row before: 0 x inf leaked 'invalid value encountered in multiply' and trusted them."""
    head, *rows = ur5_recording.read_text().splitlines(keepends=True)
    stamps = [row.split(",", 1)[0] for row in rows]
    recording = tmp_path / "repeats.csv"
    recording.write_text(
        head + "".join((stamps[k - 1] if k % 20 == 1 else stamps[k]) + "," + row.split(",", 1)[1] for k, row in enumerate(rows))
    )
    kept = {}
    for name, path in (("clean", ur5_recording), ("repeats", recording)):
        argv = ["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(path), "-o", str(tmp_path / "cal.yaml"), "--filter", "dynamic"]
        assert main(argv) == ExitCode.OK  # 5 % repeated: under the clock check's 10 % (not --quiet: the counts are read)
        out, err = capsys.readouterr()
        assert "warning" not in err, err
        kept[name] = int(re.search(r"^samples: [\d,]+ seen, ([\d,]+) kept", out, re.MULTILINE).group(1).replace(",", ""))
    # a stamp that says nothing of its sample never adds one (it added 22 % on a simulated UR5 run)
    assert kept["repeats"] < kept["clean"], kept


def test_swapped_rows_under_the_dynamic_filter_are_named_and_the_fit_checked(tmp_path, ur5_recording, capsys):
    """Case 12: 29 row pairs swapped: each late row is skipped and counted, and the fit is judged (not 'unchecked')."""
    head, *rows = ur5_recording.read_text().splitlines(keepends=True)
    for k in range(200, 200 + 29 * 100, 100):
        rows[k], rows[k + 1] = rows[k + 1], rows[k]
    recording = tmp_path / "swapped.csv"
    recording.write_text(head + "".join(rows))
    argv = ["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(recording), "-o", str(tmp_path / "c.yaml"), "--filter", "dynamic"]
    assert main(argv) == ExitCode.OK
    out = capsys.readouterr().out
    assert re.search(r"time going backwards\s+29\n", out), out
    assert re.search(r"^fit consistent: largest residual [\d.]+x the expected noise", out, re.MULTILINE), out
    assert load_calibration(tmp_path / "c.yaml").quality.fit["verdict"] == "consistent"


@pytest.mark.parametrize("command", ["live", "calibrate"])
def test_a_latency_of_nan_is_refused_at_start_naming_the_option(tmp_path, capsys, command):
    """Case 13: refused before the socket opens (it named the internal field 'live.latency_s'), exit 3, nothing written."""
    argv = live_calibrate(tmp_path / "c.yaml", "--latency", "nan")
    if command == "live":  # the old spelling: live --listen HOST:PORT
        argv = ["live", "--listen", "127.0.0.1:0", *argv[2:]]
    assert main(argv) == ExitCode.CONFIG == 3
    assert _error(capsys) == f"fts-calib {command}: error: option --latency: expected a finite number, got 'nan'"
    assert not list(tmp_path.iterdir())


@pytest.fixture
def two_continuous_plans(monkeypatch):
    """The continuous search on a grid of two motions (the command searches 60; the refusal's words are the same)."""
    from fts_calib.planning import sizing

    grid = dataclasses.replace(sizing.MOTION_KINDS["continuous"], levels=(3,), stops=(1, 2), spans=(0.35,))
    monkeypatch.setitem(sizing.MOTION_KINDS, "continuous", grid)


def _continuous(tmp_path, *extra):
    out = tmp_path / "plan"
    argv = ["trajectory", "--robot", "ur5", "--tool", "paper_tool", "--motion", "continuous", "-o", str(out), "--no-plot", *extra]
    return main(argv), out


@pytest.mark.parametrize(
    ("option", "value", "term"),
    [
        ("--latency-uncertainty", "10", "the latency uncertainty (--latency-uncertainty 10 s; "),
        ("--inertia-tolerance", "1e9", "the inertia tolerance (--inertia-tolerance 1e+09; "),
    ],
)
def test_a_continuous_plan_whose_samples_are_all_untrusted_names_the_option(tmp_path, capsys, two_continuous_plans, option, value, term):
    """Case 14: it said 'tool mass alone gives at least inf %': now the stated term that drops the samples."""
    code, out = _continuous(tmp_path, option, value)
    assert code == ExitCode.TRAJECTORY == 9
    line = _error(capsys)
    assert line.startswith("fts-calib trajectory: error: no continuous plan of up to 3 levels × 2 stops determines the calibration: "), line
    assert re.search(r"the dynamic filter's trust rule keeps [\d,]+ of the [\d,]+ samples of the longest motion screened", line), line
    assert f"set by {term}" in line and line.endswith(f"State a smaller {option} (know it better), or plan still samples (--motion stop)")
    assert "inf" not in line.replace("1e+09", "")
    assert not out.exists()


def test_a_continuous_target_far_below_the_tool_and_mount_is_refused_after_one_motion(tmp_path, capsys, monkeypatch):
    """Case 14: --target-error 1e-6 searched all 60 continuous plans (74 s) before refusing; now after the first."""
    from fts_calib.planning import sizing

    screened = []
    add = sizing.Screening.add
    monkeypatch.setattr(sizing.Screening, "add", lambda self, plan, budget: (screened.append(plan), add(self, plan, budget)))
    code, out = _continuous(tmp_path, "--target-error", "1e-6")
    assert code == ExitCode.TRAJECTORY
    line = _error(capsys)
    assert re.fullmatch(
        r"fts-calib trajectory: error: no plan meets the target of 1e-06 % of full scale: (tool mass|tool centre of mass|sensor mount) "
        r"alone gives ([\d.]+) % on [FM][xyz] on the motions screened so far, and no moving motion takes those terms below 0\.5 of "
        r"that \(([\d.]+) %\) \(tool tolerance and sensor mount: .*\)\. "
        r"State a larger --target-error, or know the tool and the mount better\.",
        line,
    ), line
    assert len(screened) == 1 and not out.exists()


@pytest.mark.parametrize(
    ("command", "option"),
    [
        ("monitor --calibration c.yaml --robot ur5 --tool paper_tool r.csv", "--false-alarms"),
        ("report c.yaml r.csv", "--target-error"),
        ("payload --calibration c.yaml r.csv", "--seconds"),
        ("calibrate --robot ur5 --tool paper_tool r.csv", "--prior-weight"),
        ("trajectory --robot ur5 --tool paper_tool", "--levels"),
    ],
)
def test_a_numeric_option_given_no_number_is_a_usage_error_naming_it(tmp_path, capsys, command, option):
    """Case 15: ``--x=--`` ended in a TypeError traceback (argparse dropped the '--' and stored []); 'abc' alike."""
    name, *rest = command.split()
    expected = "an integer" if option == "--levels" else "a number"
    for text in ("--", "abc", ""):
        with pytest.raises(SystemExit) as exit_:
            main([name, *rest, f"{option}={text}", "-o", str(tmp_path / "out")])
        assert exit_.value.code == ExitCode.USAGE == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert err[0].startswith(f"usage: fts-calib {name} ") and "Traceback" not in "".join(err)
        assert err[-1] == f"fts-calib {name}: error: argument {option}: expected {expected}, got {text!r}"
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "1e999"])
def test_a_numeric_option_refuses_a_number_that_is_not_finite(tmp_path, capsys, value):
    """Case 15: every numeric option goes through the one converter (options.Number): nan and inf are refused at start, exit 3."""
    argv = ["calibrate", "--robot", "ur5", "--tool", "paper_tool", "r.csv", "-o", str(tmp_path / "c.yaml")]
    assert main([*argv, f"--prior-weight={value}"]) == ExitCode.CONFIG
    assert _error(capsys) == f"fts-calib calibrate: error: option --prior-weight: expected a finite number, got {value!r}"
    if not value.startswith("-"):  # argparse reads '-inf' after --mount as an option
        assert main([*argv, "--mount", "0", value, "0"]) == ExitCode.CONFIG
        assert _error(capsys) == f"fts-calib calibrate: error: option --mount: expected a finite number, got {value!r}"


def test_every_numeric_option_is_declared_through_the_checked_converter():
    from fts_calib.app.options import OPTIONS, Number

    numeric = [o.name for o in OPTIONS.values() if isinstance(o.type, Number)]
    assert len(numeric) >= 30 and {"latency", "false-alarms", "seconds", "prior-weight", "target-error", "levels", "seed"} <= set(numeric)
    assert not [o.name for o in OPTIONS.values() if o.type in (float, int)], "a numeric option beside the converter"


# -- the bounded parsers on their own ------------------------------------------------------


def test_json_depth_counts_brackets_outside_strings_only():
    assert json_depth(b'{"a": [1, 2]}') == 2
    assert json_depth(b'{"a": "[[[[{{{{"}') == 1  # brackets in a string do not nest
    assert json_depth(b'{"a": "\\"[[[", "b": [[[]]]}') == 4  # an escaped quote does not end the string
    assert json_depth(b"[" * 5000 + b"]" * 5000) == 5000
    assert json_depth(b"12") == 0


def test_loads_json_limits():
    assert loads_json(b'{"a": [1, 2.5, "x"]}') == {"a": [1, 2.5, "x"]}
    with pytest.raises(LimitError, match="nested 3 levels deep"):
        loads_json(b"[[[1]]]", max_depth=2)
    with pytest.raises(LimitError, match="an integer of 21 digits"):
        loads_json(b"[" + b"1" * 21 + b"]")
    with pytest.raises(LimitError, match="Infinity is not a number"):
        loads_json(b"[-Infinity]")
    assert math.isnan(loads_json(b"[NaN]", finite=False)[0])  # our own checkpoints may hold them
    with pytest.raises(json.JSONDecodeError):
        loads_json(b"{")


def test_parse_yaml_keeps_what_a_real_file_holds_and_refuses_the_rest(tmp_path):
    text = "a: [1, -2.5e-3, .inf, 12345678901234567890]\nb: {c: [[1, 2], [3, 4]]}\nd: text with * and & inside\n"
    assert parse_yaml(text, "f.yaml") == {
        "a": [1, -2.5e-3, math.inf, 12345678901234567890],
        "b": {"c": [[1, 2], [3, 4]]},
        "d": "text with * and & inside",
    }
    deep = "x: " + "[" * (MAX_DEPTH - 1) + "]" * (MAX_DEPTH - 1)  # the mapping and 63 lists: at the limit, read
    assert parse_yaml(deep, "f.yaml")["x"] is not None
    with pytest.raises(FileFormatError, match="nested more than 64 levels deep"):
        parse_yaml("x: " + "[" * MAX_DEPTH + "]" * MAX_DEPTH, "f.yaml")
    with pytest.raises(FileFormatError, match=r"f\.yaml: line 2, column 4: a YAML alias \(\*base\)"):
        parse_yaml("a: &base {m: 1}\nb: *base\n", "f.yaml")


def test_our_yaml_writer_never_writes_an_alias(tmp_path):
    from fts_calib.core.files import dump_yaml, load_yaml

    shared = [1.0, 2.0]
    path = tmp_path / "shared.yaml"
    path.write_text(dump_yaml({"a": shared, "b": shared, "c": {"d": shared}}))
    assert load_yaml(path) == {"a": shared, "b": shared, "c": {"d": shared}}


def test_utf8_safe_escapes_only_what_utf8_cannot_hold():
    assert utf8_safe("plain µ °C") == "plain µ °C"
    assert utf8_safe(os.fsdecode(b"run\xff\xfe.csv")) == "run\\xff\\xfe.csv"
    assert utf8_safe("lone \ud800 surrogate") == "lone \\ud800 surrogate"


def test_repeated_rows_are_equal_in_every_column_and_across_chunks():
    table = np.array([[0.0, 1.0], [0.0, 1.0], [0.0, 2.0], [0.1, 2.0], [0.1, 2.0]])
    np.testing.assert_array_equal(repeated_rows(table, None), [False, True, False, False, True])
    np.testing.assert_array_equal(repeated_rows(table[3:], table[2]), [False, True])
    np.testing.assert_array_equal(repeated_rows(table[1:2], table[0]), [True])
    nan = np.array([[np.nan, 1.0], [np.nan, 1.0]])
    np.testing.assert_array_equal(repeated_rows(nan, None), [False, False])  # NaN rows: the checks count them, not this


def test_an_rtde_server_that_answers_as_another_protocol_is_named(monkeypatch):
    from fts_calib.sources.ur import probe_rtde

    with socket.socket() as srv:
        srv.bind(("127.0.0.1", 0))
        srv.listen(1)
        port = srv.getsockname()[1]

        def serve():
            client, _ = srv.accept()
            with client:
                client.recv(5)
                client.sendall(struct.pack(">HBB", 4, 84, 0))  # a text-message package, not the version answer

        thread = threading.Thread(target=serve, daemon=True)
        thread.start()
        with pytest.raises(ConnectionError, match=rf"127\.0\.0\.1:{port} \(RTDE\) answered, but not as an RTDE server"):
            probe_rtde("127.0.0.1", port, 5.0)
        thread.join(timeout=DEADLINE_S)


# -- round 4 (issue 33, cases 1, 2, 4 and 8-11): monitor's input checks ---------------------------------------------

R = ["--robot", "ur5", "--tool", "paper_tool"]


def _monitor(calibration, *extra):
    return main(["monitor", "--calibration", str(calibration), *extra])


def _rewrite(source, target, change):
    """A copy of the recording ``source`` with ``change(header, row) -> row`` applied to every data row (strings)."""
    lines = source.read_text().splitlines()
    header = lines[0].split(",")
    rows = [",".join(change(header, line.split(","))) for line in lines[1:]]
    target.write_text("\n".join([lines[0], *rows]) + "\n")
    return target


@pytest.fixture
def own_calibration(tmp_path, calibration_file):
    """A copy of the calibration (with its health section) that a run may re-tare."""
    copy = tmp_path / "at.yaml"
    copy.write_bytes(calibration_file.read_bytes())
    return copy


def test_monitor_refuses_to_retare_with_a_payload_other_than_the_one_mounted(tmp_path, ur5_recording, own_calibration, capsys):
    """Case 1: the calibration run (A, then B, then C mounted) watched as if C were mounted throughout: the still windows
    of A disagree with those of C by the moments of their centres of mass; before, the first pose's offset was written."""
    before = own_calibration.read_bytes()
    code = _monitor(own_calibration, *R, "--configuration", "C", "--auto-tare", str(ur5_recording))
    line = _error(capsys)
    assert code == ExitCode.RESULT_REFUSED, line
    assert re.match(
        rf"fts-calib monitor: error: refused to re-tare \({re.escape(str(own_calibration))} untouched\): the load does not fit "
        r"'RIM calibration tool' configuration C mounted: \d+ still windows \(no joint moving, noise-level scatter\) disagree "
        r"with the offset tracked at the other \d+, by up to [\d.]+ N·m on M[xyz] \(\d+(\.\d+)? % FS\)",
        line,
    ), line
    # the centres of mass of A and C are centimetres apart under a 2 kg tool: the disagreement is a tenth of a N·m or more
    worst = float(re.search(r"by up to ([\d.]+) N·m", line).group(1))
    assert worst > 0.1, line
    assert own_calibration.read_bytes() == before
    # the same recording with each row's configuration (its tool column): the load fits, nothing refused, nothing re-tared
    assert _monitor(own_calibration, *R, "--auto-tare", str(ur5_recording)) == ExitCode.OK
    assert own_calibration.read_bytes() == before


@pytest.mark.parametrize("threshold", ["0", "-1", "nan"])
def test_a_tare_threshold_of_zero_or_below_is_refused_naming_the_option(ur5_recording, own_calibration, capsys, threshold):
    """Case 2: before, --tare-threshold 0 re-tared every window (307 times in 42.6 s) and -1 did not end."""
    before = own_calibration.read_bytes()
    assert _monitor(own_calibration, *R, "--auto-tare", "--tare-threshold", threshold, str(ur5_recording)) == ExitCode.CONFIG
    expected = (  # nan: the numeric options' one converter refuses it first
        "fts-calib monitor: error: option --tare-threshold: expected a finite number, got 'nan'"
        if threshold == "nan"
        else f"fts-calib monitor: error: --tare-threshold={float(threshold)} but expected a finite offset error in % of full scale "
        "above 0 and at most 100 (default 0.05): at 0 or below every window would re-tare"
    )
    assert _error(capsys) == expected
    assert own_calibration.read_bytes() == before


def test_the_tare_history_keeps_the_first_entry_and_the_latest(calibration_file):
    from fts_calib.model.calibration import MAX_OFFSET_HISTORY

    cal = load_calibration(calibration_file)
    for k in range(MAX_OFFSET_HISTORY + 50):
        cal = cal.with_offsets(cal.D + 0.001, f"tare {k}", time=f"t{k}")
    history = cal.offset_history
    assert len(history) == MAX_OFFSET_HISTORY == 100
    assert history[0]["reason"] == "tare 0" and history[0]["D"] == load_calibration(calibration_file).D.tolist()
    assert [h["reason"] for h in history[1:]] == [f"tare {k}" for k in range(51, 150)]


def test_monitor_gives_no_verdict_over_a_recording_whose_channel_is_never_a_number(tmp_path, ur5_recording, calibration_file, capsys):
    """Case 4: strain_3 empty on every row: before, 'health: ok' over 0 samples."""

    def blank(header, row):
        row[header.index("strain_3")] = ""
        return row

    path = _rewrite(ur5_recording, tmp_path / "blank.csv", blank)
    assert _monitor(calibration_file, str(path)) == ExitCode.RECORDING
    rows = len(path.read_text().splitlines()) - 1
    assert _error(capsys) == (
        f"fts-calib monitor: error: {path}: no sample to watch: all {rows:,} rows were skipped (malformed line: {rows:,}); "
        f"the first: {path}, line 2: column 'strain_3': '' is not a number; a health verdict needs 8 finite channels"
    )


def test_monitor_refuses_a_negative_idle_timeout(calibration_file, capsys):
    """Case 4: --idle-timeout=-1 ended the listening at once with 'health: ok'."""
    assert _monitor(calibration_file, "udp://127.0.0.1:0", "--idle-timeout=-1") == ExitCode.CONFIG
    assert "idle_timeout_s=-1.0 s but expected a finite value >= 0" in _error(capsys)


def _listen_and_send(calibration, capsys, width, count, skipped_seq=()):
    """``monitor`` on udp://127.0.0.1:0 (on a thread) fed ``count`` strain datagrams of ``width`` values numbered by seq,
    those in ``skipped_seq`` not sent, then 'end'; returns the exit code, the standard output and error."""
    from fts_calib.sources.udp import End

    result, printed = {}, []
    argv = ["monitor", "--calibration", str(calibration), "udp://127.0.0.1:0", "--quiet", "--idle-timeout", "20"]
    thread = threading.Thread(target=lambda: result.update(code=main(argv)), daemon=True)
    thread.start()

    def bound():
        printed.append(capsys.readouterr().out)
        return re.search(r"listening on udp://127\.0\.0\.1:(\d+)", "".join(printed))

    wait_for(bound, "monitor listening")
    port = int(bound().group(1))
    rng = np.random.default_rng(3)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        for i in range(count):
            if i not in skipped_seq:
                values = tuple(float(v) for v in rng.normal(0.0, 1e-5, width))  # the paper's noise about a zero load
                sock.sendto(encode(Strain(i / 1000.0, values, seq=i)), ("127.0.0.1", port))
            if i % 200 == 0:
                time.sleep(0.002)  # the receiver keeps up on a busy machine: only the gaps sent are lost
        sock.sendto(encode(End(seq=count)), ("127.0.0.1", port))
    thread.join(timeout=DEADLINE_S)
    assert not thread.is_alive(), "monitor did not end on 'end'"
    rest = capsys.readouterr()
    return result["code"], "".join(printed) + rest.out, rest.err


def test_monitor_names_datagrams_of_another_sensor_instead_of_a_verdict_over_none(calibration_file, capsys):
    """Case 4: 6-value strain datagrams for an 8-channel calibration: before, 'health: ok' over 0 samples."""
    code, _, err = _listen_and_send(calibration_file, capsys, 6, 300)
    line = err.strip()
    assert code == ExitCode.PROTOCOL, line
    assert re.fullmatch(
        r"fts-calib monitor: error: malformed datagram: no strain sample of 8 channels to watch on udp://127\.0\.0\.1:\d+: "
        r"301 datagrams received, all 300 skipped \(strain message of another length than the sensor's channels: expected 8: 300\); "
        r"the calibration has 8 channels: is the sender's sensor the calibration's\?",
        line,
    ), line


def test_monitor_reports_the_datagrams_lost_by_their_seq_numbers(calibration_file, capsys):
    """Case 10: 3,000 datagrams numbered 0-2,999 with 37 numbers never sent (single ones and a run of 10): the summary
    says 37 lost; before, the gaps in seq were never reported."""
    skipped = {*range(100, 2800, 100), *range(2900, 2910)}
    assert len(skipped) == 37
    code, out, _ = _listen_and_send(calibration_file, capsys, 8, 3000, skipped)
    assert code in (ExitCode.OK, ExitCode.CHECK_FAILED), out  # the verdict on random channels is not this test's
    assert re.search(r"monitor of udp://127\.0\.0\.1:\d+: 2,963 samples", out), out
    assert "datagrams: 2,964 received, 37 lost on the way (gaps in their seq numbers), not watched" in out, out


def test_monitor_names_the_line_a_recording_was_cut_at(tmp_path, ur5_recording, calibration_file, capsys):
    """Case 8: a recording cut in the middle of a row: before, exit 0 and '0 skipped'."""
    text = ur5_recording.read_text()
    cut = text.index("\n", len(text) // 2) + 40  # 40 characters into a row
    path = tmp_path / "cut.csv"
    path.write_text(text[:cut])
    line_number = text[:cut].count("\n") + 1
    assert _monitor(calibration_file, str(path)) == ExitCode.OK
    out = capsys.readouterr().out
    assert "skipped: 1 samples (malformed line: 1)" in out, out
    assert f"  {path}, line {line_number}: truncated (no line end): " in out, out
    assert f"monitor of {path}: {line_number - 2:,} samples" in out, out  # the rows before the cut one, all watched


@pytest.mark.parametrize(
    ("scale", "equal", "expected"),
    [
        (1000.0, False, r"10 s between samples \(0\.1 Hz\), longer than a sensor's sample period \(at most 0\.01 s, 100 Hz; .*\): "
         r"the time column looks like ms \(0\.01 s, 100 Hz when read as ms\); write the time in s \(divide it by 1000\)"),
        (1.0, True, r"all [\d,]+ time stamps of the first rows are equal \(5\): the column holds no clock; write the time in s"),
        # a 10 Hz log is a clock in s, too slow for the monitor: told so, not "looks like ms"
        (10.0, False, r"0\.1 s between samples \(10 Hz\), longer than a sensor's sample period \(at most 0\.01 s, 100 Hz; .*\): "
         r"record at 100 Hz or more \(the time in s\)"),
    ],
)  # fmt: skip
def test_monitor_refuses_a_time_column_in_ms_or_without_a_clock(tmp_path, ur5_recording, calibration_file, capsys, scale, equal, expected):
    """Case 9: before, 'health: ok' with the thresholds of a 0.1 Hz sensor (gain z^2 > 19.2), or of a guessed 1 kHz."""

    def retime(header, row):
        row[0] = "5.0" if equal else repr(float(row[0]) * scale)
        return row

    path = _rewrite(ur5_recording, tmp_path / "clock.csv", retime)
    assert _monitor(calibration_file, str(path)) == ExitCode.RECORDING
    line = _error(capsys)
    assert re.fullmatch(rf"fts-calib monitor: error: {re.escape(str(path))}, column 'time': {expected}", line), line


@pytest.mark.parametrize("value", ["0", "nan", "1e9", "-1e-3"])
def test_a_false_alarm_budget_out_of_range_names_the_option(ur5_recording, calibration_file, capsys, value):
    """Case 11: before, exit 3 naming internal values ('monitor=[100.0, 100, 15, 5]', 'probability=11574.07')."""
    assert _monitor(calibration_file, f"--false-alarms={value}", str(ur5_recording)) == ExitCode.CONFIG
    expected = (  # nan: the numeric options' one converter refuses it first
        "fts-calib monitor: error: option --false-alarms: expected a finite number, got 'nan'"
        if value == "nan"
        else f"fts-calib monitor: error: --false-alarms={float(value)} but expected a finite budget of false alarms per hour of "
        "service above 0 and at most 100 (default 1e-3)"
    )
    assert _error(capsys) == expected


def _still_service(path, calibration, ur5, paper_tool, poses, shift, rng, seconds=1.5):
    """A recording of configuration A held still at each of ``poses`` (joints [rad], (6,)) for ``seconds`` at 100 Hz, every
    wrench shifted by ``shift`` [N, N m] (an offset that moved since the calibration), channel noise 1e-5 (the paper's)."""
    from fts_calib.robot.tool import tool_load

    cal = load_calibration(calibration)
    header = "time," + ",".join(ur5.joint_names) + "," + ",".join(f"strain_{k + 1}" for k in range(8)) + ",tool"
    rows, n = [], int(round(seconds * 100))
    for k, q in enumerate(poses):
        load = tool_load(ur5, paper_tool, np.tile(q, (n, 1)), np.zeros(n, dtype=int)).static
        strain = (load + shift - cal.D) @ np.linalg.pinv(cal.C).T + rng.normal(0.0, 1e-5, (n, 8))
        for i in range(n):
            values = [repr((k * n + i) / 100.0), *(repr(float(v)) for v in q), *(repr(float(v)) for v in strain[i]), "A"]
            rows.append(",".join(values))
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


def test_monitor_holds_a_retare_seen_at_one_orientation_and_writes_it_at_two(tmp_path, own_calibration, ur5, paper_tool, rng, capsys):
    """Case 1: an offset of 0.5 N on Fx (1 % FS) seen at one orientation only could be a payload other than the one named:
    held, the file untouched; seen at a second orientation (wrist 3 turned 0.5 rad: the payload's force turns by it) it is
    an offset: re-tared to D - 0.5 N."""
    before = own_calibration.read_bytes()
    shift = np.array([0.5, 0.0, 0.0, 0.0, 0.0, 0.0])
    home = np.array([1.3485, -2.092, -0.6562, -1.9642, 0.5, 0.0])
    one = _still_service(tmp_path / "one.csv", own_calibration, ur5, paper_tool, [home], shift, rng)
    assert _monitor(own_calibration, *R, "--auto-tare", str(one)) == ExitCode.OK
    out = capsys.readouterr().out
    assert re.search(
        r"a re-tare is due but held: the 1\d windows without contact since the start saw the payload turn by 0\.0 deg, at least "
        r"11\.5 deg is needed to tell an offset from a payload other than the one named",
        out,
    ), out
    assert own_calibration.read_bytes() == before
    turned = home + np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.5])
    two = _still_service(tmp_path / "two.csv", own_calibration, ur5, paper_tool, [home, turned], shift, rng)
    assert _monitor(own_calibration, *R, "--auto-tare", str(two)) == ExitCode.OK
    assert "re-tared 1 time(s)" in capsys.readouterr().out
    D = load_calibration(own_calibration).D
    # the tracker's offset: windows of 10 samples of noise ~2 mN through C, averaged by the alpha-beta filter: 0.02 N is > 5 sigma
    np.testing.assert_allclose(D, load_calibration(_copy(before, tmp_path)).D - shift, atol=0.02)


def _copy(data, folder):
    path = folder / "before.yaml"
    path.write_bytes(data)
    return path

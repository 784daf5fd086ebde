"""fts-calib record: joints and channels on one clock into a whole recording, against real protocols on loopback."""

from __future__ import annotations

import os
import signal
import socket
import threading
import time

import numpy as np
import pytest
import yaml

from fts_calib.app.cli import main
from fts_calib.sources.recording import RecordingReader
from fts_calib.sources.serial_line import PARTIAL
from fts_calib.sources.udp import Joints, Strain, encode

from .netft_box import NetFtBox, Script

UR5 = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _q(t: float) -> dict[str, float]:
    """The joints at the sender's time t [s]: slow ramps (rad), the truth the recording is checked against."""
    return {name: 0.1 * k + 0.05 * t for k, name in enumerate(UR5)}


def _read(path):
    with RecordingReader(path, list(UR5), None) as reader:
        batches = list(reader)
    return (
        np.concatenate([b.time for b in batches]),
        np.concatenate([b.joints for b in batches]),
        np.concatenate([b.channels for b in batches]),
        reader,
    )


def _send_joints(port: int, stop: threading.Event, clock_shift_s: float, then=None, count: int = 600) -> threading.Thread:
    """Joint datagrams every 2 ms on a clock ``clock_shift_s`` behind the host's; ``then(k)`` after each."""

    def send() -> None:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            for k in range(count):
                if stop.is_set():
                    return
                t = time.monotonic() - clock_shift_s
                sock.sendto(encode(Joints(t, _q(t), seq=k)), ("127.0.0.1", port))
                if then is not None and then(k):
                    return
                time.sleep(0.002)

    thread = threading.Thread(target=send, daemon=True)
    return thread


def test_record_serial_and_joint_datagrams_until_the_cable_is_pulled(tmp_path, capsys):
    master, slave = os.openpty()
    path, port, stop = os.ttyname(slave), _free_port(), threading.Event()
    written: list[tuple[float, int]] = []

    def then(k: int) -> bool:
        if k >= 50 and k % 2 == 0:  # the channels start 0.1 s after the joints: every channel sample can be placed
            now = time.monotonic()
            os.write(master, b"%d,%d,%d\n" % (int(now * 1e6), k, -k))
            written.append((now, k))
        if k == 400:
            time.sleep(0.05)
            os.close(master)  # the cable pulled
            return True
        return False

    sender = _send_joints(port, stop, 500.0, then)
    timer = threading.Timer(0.5, sender.start)
    timer.start()
    os.write(master, b"\n")
    out = tmp_path / "a.csv"
    try:
        sources = [f"serial://{path}?channels=3", f"udp://127.0.0.1:{port}"]
        code = main(["record", *sources, "--robot", "ur5", "--configuration", "A", "-o", str(out), "--quiet"])
    finally:
        stop.set()
        os.close(slave)
    captured = capsys.readouterr()
    assert code == 0, captured.err
    t, q, channels, reader = _read(out)
    assert reader.tool_names == ["A"] and channels.shape[1] == 3
    sent = {k for _, k in written}
    assert set(channels[:, 1].astype(int)) <= sent and len(channels) >= len(sent) - 3  # the last ones may pass the joints' end
    assert np.all(np.abs(t - channels[:, 0] * 1e-6) < 0.05)  # stamped on arrival, on the host's clock
    expected = np.array([list(_q(ti - 500.0).values()) for ti in t])
    np.testing.assert_allclose(q, expected, atol=5e-4)  # the joints' clock (500 s behind) mapped onto the host's: 10 ms at 0.05 rad/s
    figures = yaml.safe_load((tmp_path / "a.streams.yaml").read_text())
    assert figures["ended_by"] == "channel device stopped" and figures["rows"] == len(t)
    assert figures["streams"]["joints"]["clock_offset_s"] == pytest.approx(500.0, abs=0.05)
    partial = figures["skipped"].get(PARTIAL, 0)  # pyserial empties the input on opening: the first line may come cut
    assert figures["streams"]["channels"]["samples"] + partial == len(sent) and partial <= 1
    assert figures["streams"]["channels"]["latency_s"] is None  # no stamps of its own: the arrival is its time
    assert "the run ends with what it has" in captured.out and "A: " in captured.out


def test_record_udp_ended_by_sigterm_leaves_a_whole_recording(tmp_path, capsys):
    port, stop = _free_port(), threading.Event()

    def then(k: int) -> bool:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            t = time.monotonic() - 20.0
            sock.sendto(encode(Strain(t - 0.01, (float(k), 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0), seq=10_000 + k)), ("127.0.0.1", port))
        if k == 300:
            os.kill(os.getpid(), signal.SIGTERM)
            return True
        return False

    sender = _send_joints(port, stop, 20.0, then)
    timer = threading.Timer(0.5, sender.start)
    timer.start()
    out = tmp_path / "b.csv.gz"
    try:
        code = main(["record", f"udp://127.0.0.1:{port}", "--robot", "ur5", "--configuration", "B", "-o", str(out), "--quiet"])
    finally:
        stop.set()
    captured = capsys.readouterr()
    assert code == 0, captured.err
    t, q, channels, reader = _read(out)
    assert len(t) > 200 and reader.tool_names == ["B"] and np.all(np.diff(t) > 0)
    figures = yaml.safe_load((tmp_path / "b.streams.yaml").read_text())
    assert figures["ended_by"] == "interrupted" and figures["rows"] == len(t)
    assert set(figures["streams"]) == {"joints", "channels"}
    assert figures["streams"]["channels"]["clock_offset_s"] == pytest.approx(20.0, abs=0.05)


def test_record_netft_box_with_joint_datagrams(tmp_path, capsys):
    port, stop = _free_port(), threading.Event()
    counts = np.arange(6 * 3000).reshape(3000, 6) - 9000
    box = NetFtBox(Script(counts, drop={400}, status={500: 0x80000000}, silent_after=600, period_s=0.001))
    sender = _send_joints(port, stop, 3.0, count=3000)
    sender.start()
    out = tmp_path / "c.csv"
    try:
        code = main(["record", box.url, f"udp://127.0.0.1:{port}", "--robot", "ur5", "--configuration", "C", "-o", str(out), "--quiet"])
    finally:
        stop.set()
        box.close()
    captured = capsys.readouterr()
    assert code == 0, captured.err
    _, _, channels, _ = _read(out)
    rows = ((channels[:, 0] + 9000) // 6).astype(int)
    np.testing.assert_array_equal(channels, counts[rows])  # the counts as sent, in order
    assert 400 not in rows and 500 not in rows and np.all(np.diff(rows) > 0)
    assert f"127.0.0.1:{box.port}" in captured.out and "status 0x80000000" in captured.out


@pytest.mark.parametrize(
    "sources",
    [["netft://127.0.0.1", "serial:///dev/null"], ["netft://127.0.0.1"], ["ur://127.0.0.1"], ["run.csv"], []],
)
def test_record_refuses_sources_that_are_not_channels_and_joints(tmp_path, capsys, sources):
    code = main(["record", *sources, "--robot", "ur5", "-o", str(tmp_path / "x.csv")]) if sources else None
    if code is None:
        with pytest.raises(SystemExit):
            main(["record", "--robot", "ur5", "-o", str(tmp_path / "x.csv")])
        return
    assert code == 3
    assert "expected the joints (ur://HOST, or udp://HOST:PORT datagrams) and the channels" in capsys.readouterr().err
    assert not (tmp_path / "x.csv").exists()


@pytest.mark.parametrize(
    ("sources", "words"),
    [
        (["serial:///dev/ttyUSB0"], "serial:///dev/ttyUSB0 gives the channels: calibrate needs the joints too"),
        (["serial:///dev/ttyUSB0", "netft://10.0.0.2", "udp://127.0.0.1:0"], "one channel device at a time"),
        (["netft://10.0.0.2", "ur://10.0.0.7", "udp://127.0.0.1:0"], "not both"),
    ],
)
def test_calibrate_takes_a_channel_device_with_the_joints(tmp_path, capsys, sources, words):
    code = main(["calibrate", *sources, "--robot", "ur5", "--tool", "paper_tool", "-o", str(tmp_path / "c.yaml")])
    assert code == 3 and words in capsys.readouterr().err


def test_calibrate_names_a_serial_device_that_cannot_be_opened(tmp_path, capsys):
    code = main(
        [
            "calibrate",
            "serial:///dev/no-such-tty",
            "udp://127.0.0.1:0",
            "--robot",
            "ur5",
            "--tool",
            "paper_tool",
            "-o",
            str(tmp_path / "c.yaml"),
        ]
    )
    err = capsys.readouterr().err
    assert code == 14 and "cannot open /dev/no-such-tty" in err, err


def test_tare_and_payload_say_how_to_read_a_channel_device(tmp_path, capsys):
    """tare reads a device alone (nothing mounted); payload reads it with the joints' source (exit 3 without, naming the device)."""
    cal = tmp_path / "cal.yaml"
    cal.write_text("x")
    code = main(["payload", "netft://10.0.0.2", "--calibration", str(cal), "--robot", "ur5", "-o", str(tmp_path / "p.yaml")])
    err = capsys.readouterr().err
    assert code == 3 and "netft://10.0.0.2 gives the channels: payload needs the joints too: add ur://HOST or udp://HOST:PORT" in err, err
    code = main(["tare", "serial:///dev/ttyUSB0", "udp://127.0.0.1:0", "--calibration", str(cal)])
    assert code == 3 and "one source to re-tare from, not 2" in capsys.readouterr().err


class _RealTimeController:
    """The methods of rtde_receive.RTDEReceiveInterface of a controller publishing every 2 ms, its clock 1000 s behind the host's."""

    def getTimestamp(self):  # noqa: N802 (ur_rtde's names)
        return float(np.floor((time.monotonic() - 1000.0) / 0.002) * 0.002)

    def getActualQ(self):  # noqa: N802
        return list(_q(self.getTimestamp()).values())

    def getFtRawWrench(self):  # noqa: N802
        return [0.0] * 6


def test_record_netft_with_ur_joints(tmp_path, capsys, monkeypatch):
    """netft:// channels with ur:// joints (ur_rtde's interface replaced, its handshake answered on loopback): one clock."""
    import sys
    import types

    from .test_rtde import FakeRtdeServer

    server = FakeRtdeServer()
    monkeypatch.setattr("fts_calib.sources.ur.RTDE_PORT", server.port)
    monkeypatch.setitem(sys.modules, "rtde_receive", types.SimpleNamespace(RTDEReceiveInterface=lambda host: _RealTimeController()))
    counts = np.arange(6 * 800).reshape(800, 6)
    box = NetFtBox(Script(counts, silent_after=800, period_s=0.001))
    out = tmp_path / "d.csv"
    try:
        code = main(["record", box.url, "ur://127.0.0.1", "--robot", "ur5", "--configuration", "A", "-o", str(out), "--quiet"])
    finally:
        box.close()
        server.close()
    captured = capsys.readouterr()
    assert code == 0, captured.err
    t, q, channels, _ = _read(out)
    assert len(t) > 300
    expected = np.array([list(_q(ti - 1000.0).values()) for ti in t])
    np.testing.assert_allclose(q, expected, atol=5e-4)  # the controller's clock put on the host's (10 ms at 0.05 rad/s)
    figures = yaml.safe_load((tmp_path / "d.streams.yaml").read_text())
    assert figures["streams"]["joints"]["source"] == "RTDE"
    assert figures["streams"]["joints"]["clock_offset_s"] == pytest.approx(1000.0, abs=0.01)


def test_record_follows_tool_datagrams_per_configuration(tmp_path, capsys):
    """Tool datagrams on the joint sender's clock switch the configuration at their time, put on the host's clock."""
    from fts_calib.sources.udp import ToolChange

    port, stop = _free_port(), threading.Event()
    switch: list[float] = []

    def then(k: int) -> bool:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            t = time.monotonic() - 50.0
            if k in (0, 150):
                sock.sendto(encode(ToolChange(t, "A" if k == 0 else "B", seq=20_000 + k)), ("127.0.0.1", port))
                switch.append(t + 50.0)
            sock.sendto(encode(Strain(t - 0.001, (float(k),) * 8, seq=10_000 + k)), ("127.0.0.1", port))
        return k == 300

    sender = _send_joints(port, stop, 50.0, then, count=301)
    timer = threading.Timer(0.5, sender.start)
    timer.start()
    out = tmp_path / "e.csv"
    try:
        code = main(["record", f"udp://127.0.0.1:{port}", "--robot", "ur5", "-o", str(out), "--idle-timeout", "0.5", "--quiet"])
    finally:
        stop.set()
    captured = capsys.readouterr()
    assert code == 0, captured.err
    with RecordingReader(out, list(UR5), None) as reader:
        batches = list(reader)
        names = reader.tool_names
    t = np.concatenate([b.time for b in batches])
    tools = np.array(names)[np.concatenate([b.configuration for b in batches])]
    k = np.concatenate([b.channels for b in batches])[:, 0]
    assert set(tools) == {"A", "B"} and np.all(tools[k < 149] == "A") and np.all(tools[k > 150] == "B")
    assert abs(t[np.argmax(tools == "B")] - switch[1]) < 0.05  # the switch where the sender said, on the host's clock
    assert "A: " in captured.out and "B: " in captured.out


def _plan_folder(tmp_path, seconds: float):
    """The shipped UR5 plan with its motion shortened to ``seconds`` [s] per configuration, configurations A, B (in order)."""
    from fts_calib.core.resources import locate_trajectory

    plan = yaml.safe_load((locate_trajectory("ur5") / "plan.yaml").read_text())
    plan["duration_s"] = seconds
    plan["configurations"] = ["A", "B"]
    plan["excitation"]["quasi_static_samples"] = {"A": 10, "B": 10}
    folder = tmp_path / "plan"
    folder.mkdir()
    (folder / "plan.yaml").write_text(yaml.safe_dump(plan, sort_keys=False))
    return folder


def _record_plan(tmp_path, monkeypatch, stdin, enter=None):
    """record --plan from a pseudo-terminal serial device and joint datagrams; ``enter(k)`` after the k-th joint datagram."""
    master, slave = os.openpty()
    path, port, stop = os.ttyname(slave), _free_port(), threading.Event()

    def then(k: int) -> bool:
        if k >= 20 and k % 2 == 0:
            os.write(master, b"%d,%d\n" % (k, -k))
        if enter is not None:
            enter(k)
        return False

    sender = _send_joints(port, stop, 20.0, then, count=3000)
    timer = threading.Timer(0.3, sender.start)
    timer.start()
    os.write(master, b"\n")
    monkeypatch.setattr("sys.stdin", stdin)
    out = tmp_path / "p.csv"
    try:
        sources = [f"serial://{path}?channels=2", f"udp://127.0.0.1:{port}"]
        code = main(
            [
                "record",
                *sources,
                "--robot",
                "ur5",
                "--plan",
                str(_plan_folder(tmp_path, 0.3)),
                "-o",
                str(out),
                "--quiet",
                "--idle-timeout",
                "2",
            ]
        )
    finally:
        stop.set()
        os.close(master)
        os.close(slave)
    with RecordingReader(out, list(UR5), None) as reader:
        batches = list(reader)
        names = reader.tool_names
    t = np.concatenate([b.time for b in batches])
    tools = np.array(names)[np.concatenate([b.configuration for b in batches])]
    k = np.concatenate([b.channels for b in batches])[:, 0]
    return code, t, tools, k, yaml.safe_load((tmp_path / "p.streams.yaml").read_text())


def test_record_plan_asks_for_each_configuration_on_a_terminal(tmp_path, capsys, monkeypatch):
    """On a terminal: nothing written before Enter; each configuration for the plan's 0.3 s; the run ends after B."""
    keyboard, terminal = os.openpty()
    pressed: list[float] = []

    def enter(k: int) -> None:
        if k in (150, 600):  # 0.3 s after the channels start, and long after A's 0.3 s ended
            pressed.append(time.monotonic())
            os.write(keyboard, b"\n")

    with open(terminal, encoding="utf-8", closefd=False) as stdin:
        code, t, tools, k, figures = _record_plan(tmp_path, monkeypatch, stdin, enter)
    os.close(keyboard)
    os.close(terminal)
    out = capsys.readouterr().out
    assert code == 0
    assert "mount configuration A, start the plan's motion and press Enter" in out
    assert "mount configuration B, start the plan's motion and press Enter" in out
    assert list(dict.fromkeys(tools)) == ["A", "B"]
    for name, after in zip("AB", pressed, strict=True):
        held = t[tools == name]
        assert held[0] >= after  # nothing of the tool change before Enter
        assert 0.25 <= held[-1] - held[0] <= 0.3  # the plan's 0.3 s, to a channel interval (4 ms) or a late batch
    assert np.all(k[tools == "A"] > 150) and np.all(k[tools == "B"] > 600)
    assert figures["ended_by"] == "the plan's last configuration" and figures["rows"] >= len(t)
    assert figures["skipped"]["not in a configuration of the plan (tool changes)"] > 0
    assert "A: " in out and "of 0.3 s" in out


def test_record_plan_follows_the_plan_order_unasked_when_stdin_is_not_a_terminal(tmp_path, capsys, monkeypatch):
    read, write = os.pipe()
    with open(read, encoding="utf-8") as stdin:
        code, t, tools, k, figures = _record_plan(tmp_path, monkeypatch, stdin)
    os.close(write)
    out = capsys.readouterr().out
    assert code == 0 and "standard input is not a terminal: nothing asked" in out and "press Enter" not in out
    a, b = t[tools == "A"], t[tools == "B"]
    assert list(dict.fromkeys(tools)) == ["A", "B"] and a[-1] < b[0]
    assert 0.25 <= a[-1] - a[0] <= 0.3 and 0.25 <= b[-1] - b[0] <= 0.3
    assert b[0] - a[-1] < 0.05  # B starts where A ended
    assert figures["ended_by"] == "the plan's last configuration"


def test_record_plan_is_refused_with_a_configuration_or_another_robots_plan(tmp_path, capsys):
    plan = _plan_folder(tmp_path, 0.3)
    code = main(
        [
            "record",
            "serial:///dev/null",
            "udp://127.0.0.1:0",
            "--robot",
            "ur5",
            "--plan",
            str(plan),
            "--configuration",
            "A",
            "-o",
            str(tmp_path / "x.csv"),
        ]
    )
    assert code == 3 and "leave out --configuration A" in capsys.readouterr().err
    code = main(
        ["record", "serial:///dev/null", "udp://127.0.0.1:0", "--robot", "ur10", "--plan", str(plan), "-o", str(tmp_path / "x.csv")]
    )
    assert code == 3 and "is a plan for ur5, but --robot is ur10" in capsys.readouterr().err

"""Channel devices against their protocols: a pseudo-terminal as the serial device, a Net F/T box on loopback."""

from __future__ import annotations

import os
import sys
import time

import numpy as np
import pytest

from fts_calib.core.exceptions import ConfigError, FeedTimeout
from fts_calib.sources.devices import DeviceLost, StreamClock
from fts_calib.sources.netft import FAULT, REORDERED, NetFtChannels, PyNetFtChannels, open_netft, parse_netft_url, pynetft_installed
from fts_calib.sources.serial_line import GARBAGE, PARTIAL, SerialChannels, parse_serial_url

from .netft_box import NetFtBox, Script


def _wait(condition, timeout_s: float = 5.0) -> None:
    """Wait until ``condition()`` holds (the devices read in threads); fail after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, "the condition did not hold in time"
        time.sleep(0.01)


@pytest.fixture
def pty():
    """A pseudo-terminal: (master fd, slave device path); the master closed after (if not already)."""
    master, slave = os.openpty()
    yield master, os.ttyname(slave)
    for fd in (master, slave):
        try:
            os.close(fd)
        except OSError:
            pass


def test_serial_lines_partial_garbage_wrong_count_and_cable_pulled(pty):
    master, path = pty
    rng = np.random.default_rng(3)
    counts = rng.integers(-(2**23), 2**23, size=(40, 8))
    device = SerialChannels(f"serial://{path}?baud=115200&channels=8")
    device.start()
    text = b"12,-5\n" + b"".join(b",".join(b"%d" % v for v in row) + b"\r\n" for row in counts[:20])  # a partial first line
    text += b"\xff\x00\x93junk\n" + b"1,2,3\n"  # garbage bytes, a wrong channel count
    for k in range(0, len(text), 7):  # lines split across reads
        os.write(master, text[k : k + 7])
    os.write(master, b"".join(b",".join(b"%d" % v for v in row) + b"\n" for row in counts[20:]))
    _wait(lambda: device.samples == 40)
    os.close(master)  # the cable pulled
    _wait(lambda: device.error is not None)
    got = np.array([values for _, values in device.drain()])
    np.testing.assert_array_equal(got, counts)
    assert device.skipped == {PARTIAL: 1, GARBAGE: 1, "sample of another channel count (expected 8)": 1}
    assert isinstance(device.error, DeviceLost) and path in str(device.error) and "ends with what it has" in str(device.error)
    notes = "\n".join(device.notes())
    assert "junk" in notes and "3 values" in notes
    device.stop()


def test_serial_wrong_baud_junk_is_counted_not_fatal(pty):
    master, path = pty
    device = SerialChannels(f"serial://{path}?baud=9600&sep=space")
    device.start()
    os.write(master, b"\n" + bytes(range(128, 256)).replace(b"\n", b"") + b"\n" + b"1 2 3\n4 5 6\n")
    _wait(lambda: device.samples == 2)
    assert device.skipped[GARBAGE] == 1 and device.error is None
    assert [v for _, v in device.drain()] == [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]
    device.stop()


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("serial://", "no device"),
        ("serial:///dev/ttyUSB0?baud=fast", "baud='fast'"),
        ("serial:///dev/ttyUSB0?parity=E", "unknown parameter 'parity'"),
        ("serial:///dev/ttyUSB0?channels=0", "channels='0'"),
        ("serial:///dev/ttyUSB0?scale=-1", "scale='-1'"),
    ],
)
def test_serial_urls_refused(text, words):
    with pytest.raises(ConfigError, match=words):
        parse_serial_url(text)
    assert parse_serial_url("serial:///dev/ttyACM1?baud=230400&sep=;&channels=6") == ("/dev/ttyACM1", 230400, ";", 6, 1.0)


def test_serial_missing_device_named():
    device = SerialChannels("serial:///dev/no-such-tty")
    with pytest.raises(DeviceLost, match="/dev/no-such-tty"):
        device.start()


def _run_faulty_box(open_device):
    """A box that loses records 5 and 30, swaps 10 and 11, flags 20 with bit 31, and falls silent after 60.

    Returns:
        (counts, shape (80, 6); the device, stopped after its silence timeout; the box, closed).
    """
    rng = np.random.default_rng(5)
    counts = rng.integers(-(2**20), 2**20, size=(80, 6))
    box = NetFtBox(Script(counts, drop={5, 30}, swap={10}, status={20: 0x80000000}, silent_after=60), 1_000_000, 2_000_000)
    device = open_device(box.url, timeout_s=0.5)
    try:
        device.start()
        _wait(lambda: device.error is not None)
    finally:
        device.stop()
        box.close()
    assert device.calibration is not None and device.calibration.scale() == [1e-6] * 3 + [5e-7] * 3
    assert isinstance(device.error, FeedTimeout) and f"127.0.0.1:{box.port}" in str(device.error)
    assert "0x80000000" in "\n".join(device.notes())
    assert box.requests[0] == (0x1234, 2, 0) and box.requests[-1] == (0x1234, 0, 0)
    return counts, device, box


def test_netft_loss_reorder_fault_and_silence():
    counts, device, _ = _run_faulty_box(NetFtChannels)
    kept = [k for k in range(60) if k not in {5, 30, 10, 20}]  # 10 came after 11: out of order; 20: a fault
    np.testing.assert_array_equal(np.array([v for _, v in device.drain()]), counts[kept])
    assert device.skipped == {REORDERED: 1, FAULT: 1} and device.lost == 2


@pytest.mark.skipif(not pynetft_installed(), reason="pynetft (the netft extra) is not installed: netft:// reads RDT directly")
def test_netft_through_pynetft_loss_reorder_fault_and_silence():
    """The same box through pynetft: the same counts up to the fault, after it a restarted stream; stamps on the host's monotonic clock."""
    before = time.monotonic()
    counts, device, _ = _run_faulty_box(open_netft)
    assert isinstance(device, PyNetFtChannels)
    got = device.drain()
    values, times = np.array([v for _, v in got]), np.array([t for t, _ in got])
    np.testing.assert_array_equal(values[:18], counts[[k for k in range(20) if k not in {5, 10}]])
    after = [k for k in range(21, 60) if k != 30]  # the fault restarts the stream: records sent meanwhile may be lost
    rows = {tuple(row) for row in counts[after]}
    assert len(values) - 18 >= 30 and all(tuple(row) in rows for row in values[18:])
    assert before <= times[0] and np.all(np.diff(times) > 0) and times[-1] <= time.monotonic()
    assert device.skipped[REORDERED] == 1 and device.skipped[FAULT] == 1 and device.lost >= 2


def test_netft_reader_without_pynetft(monkeypatch):
    """Without pynetft (its import fails) netft:// reads RDT directly."""
    monkeypatch.setitem(sys.modules, "pynetft", None)
    assert not pynetft_installed()
    device = open_netft("netft://127.0.0.1:5000?http=8080", timeout_s=0.3)
    assert type(device) is NetFtChannels and (device.port, device.http_port, device.timeout_s) == (5000, 8080, 0.3)


def test_netft_silent_box_and_no_calibration_page():
    box = NetFtBox(Script(np.zeros((0, 6))), serve_page=False)
    device = NetFtChannels(box.url, timeout_s=0.3)
    try:
        device.start()
        _wait(lambda: device.error is not None)
    finally:
        device.stop()
        box.close()
    assert device.samples == 0 and device.calibration is None
    assert f"the Net F/T at 127.0.0.1:{box.port}" in str(device.error)
    assert "the calibration page could not be read" in device.notes()[0]
    assert sum(1 for r in box.requests if r[1] == 2) >= 1  # the start request repeated while nothing came


def test_netft_urls():
    assert parse_netft_url("netft://192.168.1.1") == ("192.168.1.1", 49152, 80)
    assert parse_netft_url("netft://10.0.0.2:5000?http=8080") == ("10.0.0.2", 5000, 8080)
    for text in ("netft://", "netft://h:99999", "netft://h?x=1", "netft://h/a"):
        with pytest.raises(ConfigError, match="netft://HOST"):
            parse_netft_url(text)


def test_stream_clock_recovers_offset_rate_and_jitter():
    """Stamped samples with delays >= 0: the offset is the smallest arrival - stamp; an independent figure."""
    rng = np.random.default_rng(11)
    stamps = 1000.0 + np.arange(2000) / 500.0
    delays = 0.002 + rng.exponential(0.0005, stamps.size)
    arrivals = stamps + 7.25 + delays
    clock = StreamClock("joints")
    placed = [clock.arrive(a, s) for a, s in zip(arrivals, stamps, strict=True)]
    assert clock.offset_s == pytest.approx(7.25 + delays.min(), abs=1e-12)
    assert placed[-1] == pytest.approx(stamps[-1] + 7.25 + delays.min(), abs=1e-9)
    assert clock.rate_hz == pytest.approx((arrivals.size - 1) / (arrivals[-1] - arrivals[0]), rel=1e-12)
    assert clock.jitter_s == pytest.approx(np.std(np.diff(arrivals), ddof=1), rel=1e-9)
    assert clock.latency_s == pytest.approx(np.mean(delays) - delays.min(), abs=1e-12)


def test_serial_channels_with_joint_datagrams_on_one_clock(pty):
    """Joints stamped on another clock (1000 s behind) are put on the host's: each placed sample's joints are q(its time).

    The serial line carries the host time of its writing (µs) as a channel and the joints are
    q(t) = 0.1 t on the sender's clock; placed on the host's clock, they must agree (an
    independent truth) to the delays of the loopback, far below 0.05 s.
    """
    import socket
    import threading

    from fts_calib.sources.live_feed import DEVICE_LOST, StreamEnd
    from fts_calib.sources.source import open_source
    from fts_calib.sources.udp import Joints, ToolChange, encode

    master, path = pty
    feed = open_source(
        f"serial://{path}?channels=2", ["a", "b"], ["A"], joints="udp://127.0.0.1:0", end=StreamEnd(idle_timeout_s=5.0), max_gap_s=0.2
    )
    address = feed.receiver.address
    stop = threading.Event()

    def sender() -> None:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            sock.sendto(encode(ToolChange(time.monotonic() - 1000.0 - 1.0, "A")), address)
            for k in range(400):
                if stop.is_set():
                    return
                t_sender = time.monotonic() - 1000.0
                sock.sendto(encode(Joints(t_sender, {"a": 0.1 * t_sender, "b": -0.1 * t_sender}, seq=k)), address)
                if k % 2 == 0:
                    now = time.monotonic()
                    os.write(master, b"%d,%d\n" % (int(now * 1e6), k))
                if k == 300:
                    os.close(master)  # the cable pulled mid-run
                    return
                time.sleep(0.002)

    os.write(master, b"\n")
    thread = threading.Thread(target=sender, daemon=True)
    thread.start()
    batches = list(feed)
    stop.set()
    thread.join()
    time_s = np.concatenate([b.time for b in batches])
    joints = np.concatenate([b.joints for b in batches])
    written = np.concatenate([b.channels for b in batches])[:, 0] * 1e-6
    assert feed.ended_by == DEVICE_LOST and len(time_s) > 100
    assert np.all(np.abs(time_s - written) < 0.05)  # stamped on arrival, on the host's clock
    np.testing.assert_allclose(joints[:, 0], 0.1 * (time_s - 1000.0), atol=0.005)  # the sender's clock mapped onto the host's
    assert feed.clocks["joints"].offset_s == pytest.approx(1000.0, abs=0.05)
    assert feed.clocks["channels"].rate_hz is not None and "the run ends with what it has" in "\n".join(feed.notes())


def test_netft_source_alone_and_silent_box_raises():
    """netft:// through open_source: the counts alone (no joints); a box that never answers is a FeedTimeout naming it."""
    from fts_calib.sources.source import open_source

    counts = np.arange(60).reshape(10, 6) - 30
    box = NetFtBox(Script(counts, silent_after=10))
    try:
        with open_source(box.url, None, None, device_timeout_s=0.3, n_channels=6, hold_s=0.0) as feed:
            got = np.concatenate([b.channels for b in feed])
        np.testing.assert_array_equal(got, counts)
    finally:
        box.close()
    silent = NetFtBox(Script(np.zeros((0, 6))))
    try:
        with pytest.raises(FeedTimeout, match=f"127.0.0.1:{silent.port}"), open_source(silent.url, device_timeout_s=0.3) as feed:
            list(feed)
    finally:
        silent.close()
    with pytest.raises(ConfigError, match="gives 6 channels"):
        open_source("netft://127.0.0.1", n_channels=8)

"""The one live loop: what ends a stream (each end, in one place), what it keeps, what it counts and shows."""

import math
import os
import signal
import socket
import threading

import numpy as np
import pytest

from fts_calib.core.exceptions import ConfigError, FeedTimeout, FtsCalibError
from fts_calib.sources.live_feed import (
    DURATION,
    END,
    IDLE,
    INTERRUPTED,
    MALFORMED,
    RTDE_LOST,
    SILENT_HINT,
    STREAM,
    LiveFeed,
    StreamEnd,
)
from fts_calib.sources.synchronizer import LATE, Synchronizer
from fts_calib.sources.udp import End, Joints, LiveStats, Strain, ToolChange, UdpReceiver, encode, feed_datagram
from fts_calib.sources.ur import RtdePoller

from .helpers import DEADLINE_S

NAMES = ["a", "b"]
STRAIN = (0.5,) * 8


def _paired(n, t0=0.0, seq=None):
    """n joint and strain datagrams 10 ms apart on one clock, with the tool announced first."""
    out = [encode(ToolChange(t0, "A"))]
    for k in range(n):
        t = t0 + 0.01 * k
        out += [encode(Joints(t, {"a": t, "b": 0.0})), encode(Strain(t, STRAIN))]
    return out


def _feed(end=None, joints=True, **options):
    sync = Synchronizer(NAMES if joints else [], configurations=["A"], n_channels=8, hold_s=None if joints else 0.0)
    return LiveFeed(UdpReceiver("127.0.0.1", 0), sync, end=end or StreamEnd(idle_timeout_s=DEADLINE_S), **options)


def _send(feed, datagrams):
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        for data in datagrams:
            sock.sendto(data, feed.address)


def _sending_when_listening(datagrams):
    """An on_listening that sends ``datagrams`` to the port the feed bound (port 0 given)."""
    bound = []

    def on_listening(address):
        bound.append(address)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            for data in datagrams:
                sock.sendto(data, address)

    return on_listening, bound


def test_the_senders_end_ends_the_stream_and_every_sample_is_kept():
    """200 samples then 'end': the stream ends on it, every strain placed (the last ones by the final placement)."""
    on_listening, bound = _sending_when_listening([*_paired(200), encode(End())])
    with _feed(on_listening=on_listening) as feed:
        batches = list(feed)
    assert bound[0][1] != 0 and feed.description == f"udp://127.0.0.1:{bound[0][1]}"
    assert feed.ended_by == END and feed.stats.ended
    assert sum(len(b) for b in batches) == feed.samples == 200 and not feed.sync.dropped
    times = np.concatenate([b.time for b in batches])
    assert np.all(np.diff(times) > 0), "batches in time order"
    assert feed.stream_s == pytest.approx(1.99) and feed.stream_rate_hz() == pytest.approx(100.0)


@pytest.mark.parametrize(
    ("end", "why"),
    [
        (StreamEnd(idle_timeout_s=0.2), IDLE),
        (StreamEnd(duration_s=0.2), DURATION),
        (StreamEnd(stream_s=0.5, idle_timeout_s=DEADLINE_S), STREAM),
    ],
)
def test_idle_time_wall_time_and_stream_time_each_end_the_stream_keeping_what_came(end, why):
    """100 samples (1 s of the sender's clock), sent when the stream starts, and no 'end': each limit ends the stream,
    and every sample that came is kept (those still held placed at the end)."""
    on_listening, _ = _sending_when_listening(_paired(100))
    with _feed(end, on_listening=on_listening) as feed:
        placed = sum(len(b) for b in feed)
    assert feed.ended_by == why and not feed.stats.ended
    assert placed == feed.samples == 100 and feed.stream_s == pytest.approx(0.99)


def test_a_feed_that_sends_nothing_times_out_naming_its_address_and_what_to_check():
    before = signal.getsignal(signal.SIGTERM)
    feed = _feed(StreamEnd(idle_timeout_s=0.1, first_timeout_s=0.1))
    with feed, pytest.raises(FeedTimeout) as caught:
        list(feed)
    text = str(caught.value)
    assert text.startswith(f"no answer within 0.1 s: waited for the first datagram on {feed.description}; ") and SILENT_HINT in text
    assert signal.getsignal(signal.SIGTERM) is before, "the previous handler is restored"


def test_without_first_timeout_a_silent_feed_ends_on_its_idle_timeout():
    with _feed(StreamEnd(idle_timeout_s=0.1)) as feed:
        assert list(feed) == []
    assert feed.ended_by == IDLE and feed.stats.received == 0


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_ctrl_c_and_sigterm_end_the_stream_keeping_what_came_and_restore_the_handlers(sig):
    """The signal sent to this process once 50 samples are placed: no KeyboardInterrupt, the stream ends, the samples
    stay, the handlers in place before are back."""
    before = signal.getsignal(sig)
    sent, handlers = [], []

    def on_status(counts):
        handlers.append(signal.getsignal(sig))
        if counts.samples >= 50 and not sent:
            sent.append(counts.samples)
            os.kill(os.getpid(), sig)  # Python runs the handler in this (the main) thread, at once

    on_listening, _ = _sending_when_listening(_paired(100))
    with _feed(on_listening=on_listening, on_status=on_status, status_interval_s=0.0) as feed:
        batches = list(feed)
    assert sent and feed.ended_by == INTERRUPTED and not feed.stats.ended
    assert all(getattr(h, "__self__", None) is feed for h in handlers), "the feed's handler while it runs"
    assert sum(len(b) for b in batches) == feed.samples >= sent[0]
    assert signal.getsignal(sig) is before


def test_ctrl_c_raised_in_a_callback_ends_the_stream_too():
    """A KeyboardInterrupt raised inside the loop (a status callback, as a terminal's Ctrl-C before the handler was
    in place) ends the stream: what came is kept."""

    def on_status(counts):
        if counts.samples >= 20:
            raise KeyboardInterrupt

    on_listening, _ = _sending_when_listening(_paired(100))
    with _feed(on_listening=on_listening, on_status=on_status, status_interval_s=0.0) as feed:
        placed = sum(len(b) for b in feed)
    assert feed.ended_by == INTERRUPTED and placed == feed.samples >= 20


def test_no_handler_is_installed_outside_the_main_thread():
    before = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    seen = []
    on_listening, _ = _sending_when_listening([*_paired(10), encode(End())])
    feed = _feed(on_listening=on_listening, on_status=lambda _: seen.append({s: signal.getsignal(s) for s in before}))
    thread = threading.Thread(target=lambda: list(feed))
    thread.start()
    thread.join(timeout=DEADLINE_S)
    assert not thread.is_alive() and feed.ended_by == END
    assert all(handlers == before for handlers in seen)


def test_a_lost_rtde_connection_ends_the_stream_with_what_was_read():
    class Lost:
        calls = 0

        def getTimestamp(self):  # noqa: N802 (ur_rtde's names)
            Lost.calls += 1
            if Lost.calls > 30:
                raise RuntimeError("RTDE receive interface: connection lost")
            return 100.0 + 0.002 * Lost.calls

        def getActualQ(self):  # noqa: N802
            return [0.1] * 6

        def getFtRawWrench(self):  # noqa: N802
            return [1.0] * 6

    joints = [f"j{k}" for k in range(6)]
    sync = Synchronizer(joints, configurations=["A"])
    sync.add_tool(-math.inf, "A")
    poller = RtdePoller(Lost(), joints, wrench=True)
    with LiveFeed(None, sync, poller, end=StreamEnd(idle_timeout_s=DEADLINE_S), description="ur://test") as feed:
        placed = sum(len(b) for b in feed)
    assert feed.ended_by == RTDE_LOST and "connection lost" in str(poller.error)
    assert poller.samples == 30 and placed == 30 and feed.stats.joints == feed.stats.strain == 30


def test_the_status_gives_the_counts_per_kind_the_bad_and_the_lost_datagrams():
    """Counted as they come: kinds, malformed, oversized, duplicates and the seq gaps; once a status per step."""
    datagrams = [encode(ToolChange(0.0, "A", 0)), encode(Joints(0.0, {"a": 0.0, "b": 0.0}, 1)), encode(Strain(0.0, STRAIN, 2))]
    datagrams += [encode(Strain(0.01, STRAIN, 5)), encode(Strain(0.01, STRAIN, 5)), b"not json", b"{" + b" " * 9000 + b"}"]
    statuses = []
    on_listening, _ = _sending_when_listening([*datagrams, encode(End(6))])
    with _feed(on_listening=on_listening, on_status=statuses.append, status_interval_s=0.0) as feed:
        list(feed)
    last = feed.status()
    assert statuses and (last.received, last.joints, last.strain, last.tool) == (8, 1, 2, 1)
    assert (last.malformed, last.oversized, last.duplicates, last.lost) == (1, 1, 1, 2), last  # 3 and 4 never came
    assert feed.skipped[MALFORMED] == 1 and "the first skipped: malformed datagram: not JSON" in feed.notes()[0]
    assert last.joints_hz >= 0 and last.strain_hz >= 0


def test_the_strains_alone_count_joint_datagrams_and_place_each_strain_on_arrival():
    """No joints expected (a re-tare with nothing mounted, the monitor): joint and orientation datagrams are counted,
    never malformed; a strain behind the newest one is late."""
    datagrams = [encode(Joints(0.0, {"x": 1.0})), b'{"type": "joints", "t": 0.0, "quat": [1, 0, 0, 0]}']
    datagrams += [encode(Strain(t, STRAIN)) for t in (0.0, 0.02, 0.01, 0.03)]
    on_listening, _ = _sending_when_listening([*datagrams, encode(End())])
    with _feed(joints=False, on_listening=on_listening) as feed:
        batches = list(feed)
    assert feed.stats.joints == 2 and feed.stats.malformed == 0
    assert np.concatenate([b.time for b in batches]).tolist() == [0.0, 0.02, 0.03] and feed.sync.dropped == {LATE: 1}
    assert all(b.joints.shape[1] == 0 for b in batches)
    stats = LiveStats()  # the same through the decoder alone
    feed_datagram(encode(Joints(0.0, {"x": 1.0})), Synchronizer([]), stats)
    assert stats.joints == 1 and stats.malformed == 0


def test_a_live_stream_is_read_once_and_its_limits_are_checked():
    on_listening, _ = _sending_when_listening([encode(End())])
    with _feed(on_listening=on_listening) as feed:
        list(feed)
        with pytest.raises(FtsCalibError, match="was read already: a live stream is read once"):
            iter(feed)
    with pytest.raises(ConfigError, match="idle_timeout_s=-1.0 s but expected"):
        StreamEnd(idle_timeout_s=-1.0)
    with pytest.raises(FtsCalibError, match="neither was given"):
        LiveFeed(None, Synchronizer(NAMES))

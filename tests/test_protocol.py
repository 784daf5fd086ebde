"""The live protocol: round trip, and malformed or oversized datagrams."""

import pytest

from fts_calib.core.exceptions import ProtocolError
from fts_calib.sources.udp import MAX_DATAGRAM, End, Joints, Strain, ToolChange, decode, encode


@pytest.mark.parametrize(
    "message",
    [
        Joints(1.5, {"j1": 0.1, "j2": -2.0}),
        Strain(2.0, tuple(range(8))),
        ToolChange(0.0, "B"),
        End(),
        Joints(1.5, {"j1": 0.1}, seq=7),
        Strain(2.0, tuple(range(8)), seq=0),
        ToolChange(0.0, "B", seq=12),
        End(seq=13),
    ],
)
def test_round_trip(message):
    assert decode(encode(message)) == message


def test_seq_is_optional_and_written_only_when_given():
    assert b"seq" not in encode(End()) and decode(b'{"type": "end"}').seq is None
    assert decode(b'{"type": "strain", "t": 1, "strain": [0,0,0,0,0,0,0,0], "seq": 41}').seq == 41


def test_documented_examples_decode():
    assert decode(b'{"type": "joints", "t": 12.345, "q": {"shoulder_pan_joint": 0.1}}') == Joints(12.345, {"shoulder_pan_joint": 0.1})
    assert decode(b'{"type": "tool", "t": 12.0, "name": "B"}') == ToolChange(12.0, "B")


@pytest.mark.parametrize(
    ("data", "reason", "match"),
    [
        (b"\xff\xfe", "malformed", "not JSON"),
        (b"[1, 2]", "malformed", "expected a JSON object"),
        (b'{"type": "strain", "t": 1, "strain": []}', "malformed", "non-empty list of numbers, one per channel"),
        (b'{"type": "strain", "t": 1, "strain": [1, "2"]}', "malformed", "non-empty list of numbers, one per channel"),
        (b'{"type": "strain", "t": "now", "strain": [0,0,0,0,0,0,0,0]}', "malformed", "'t' must be a finite number"),
        (b'{"type": "joints", "t": 1, "q": {"j": "x"}}', "malformed", "'q' must map joint names to numbers"),
        (b'{"type": "tool", "t": 1}', "malformed", "'name'"),
        (b'{"type": "torque", "t": 1}', "malformed", "unknown type 'torque'"),
        (b"x" * (MAX_DATAGRAM + 1), "oversized", f"at most {MAX_DATAGRAM}"),
        (b'{"type": "end", "seq": -1}', "malformed", "'seq' must be an integer >= 0"),
        (b'{"type": "end", "seq": 1.5}', "malformed", "'seq' must be an integer >= 0"),
        (b'{"type": "end", "seq": "3"}', "malformed", "'seq' must be an integer >= 0"),
        (b'{"type": "end", "seq": true}', "malformed", "'seq' must be an integer >= 0"),
    ],
)
def test_bad_datagrams(data, reason, match):
    with pytest.raises(ProtocolError, match=match) as info:
        decode(data)
    assert info.value.reason == reason


def test_the_live_summary_names_why_the_first_malformed_datagram_was_skipped():
    """Before: '3 malformed' and no word on why (a sender writing "temperature": "hot")."""
    from fts_calib.session.calibration_run import format_stats
    from fts_calib.sources.synchronizer import Synchronizer
    from fts_calib.sources.udp import LiveStats, feed_datagram

    sync, stats = Synchronizer(["j1", "j2"], [False, False], 0.05, 0.0), LiveStats()
    for k in range(3):
        feed_datagram(b'{"type": "strain", "t": %d, "strain": [0, 0, 0, 0, 0, 0], "temperature": "hot"}' % k, sync, stats)
    feed_datagram(encode(Joints(1.0, {"j1": 0.0, "j3": 0.0})), sync, stats)
    assert stats.malformed == 4
    text = format_stats(stats, sync)
    assert "  the first skipped: malformed datagram: 'temperature' must be a finite number of °C, got 'hot'" in text, text
    stats = LiveStats()
    feed_datagram(encode(Joints(1.0, {"j1": 0.0, "j3": 0.0})), sync, stats)
    expected = "the first skipped: malformed datagram: a joints message with unknown joints ['j3'] and missing ['j2'] (expected"
    assert expected in format_stats(stats, sync)

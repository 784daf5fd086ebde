"""Sources: every kind is a Source; one name a user types opens each; a name that is none is refused naming it."""

import socket
import sys
import types
import warnings

import numpy as np
import pytest

from fts_calib.core.exceptions import ConfigError, FtsCalibWarning, ShapeError, UnknownToolConfiguration
from fts_calib.sim.robot_log import recording_to_bag
from fts_calib.sources.bag import BagReader
from fts_calib.sources.batch import SampleBatch
from fts_calib.sources.live_feed import LiveFeed, StreamEnd
from fts_calib.sources.recording import RecordingReader
from fts_calib.sources.recording_set import RecordingSet
from fts_calib.sources.source import ArraySource, Source, open_source
from fts_calib.sources.udp import End, Strain, encode

from .helpers import DEADLINE_S, FakeRtdeServer


def _csv(path, n, t0=0.0, tool="A"):
    header = ["time", "a", "b", *[f"strain_{k + 1}" for k in range(8)], "tool"]
    rows = [",".join([f"{t0 + 0.01 * i:.2f}", "0.1", "0.2", *["0.5"] * 8, tool]) for i in range(n)]
    path.write_text("\n".join([",".join(header), *rows]) + "\n")
    return path


def test_recordings_bags_arrays_and_live_streams_are_sources(tmp_path, ur5, ur5_recording):
    a, b = _csv(tmp_path / "a.csv", 5), _csv(tmp_path / "b.csv", 5, 1.0)
    bag = recording_to_bag(ur5_recording, tmp_path / "run_bag", "mcap")
    with open_source(str(a)) as one, open_source([a, b]) as two, open_source(str(tmp_path / "*.csv")) as pattern:
        assert isinstance(one, RecordingReader) and isinstance(two, RecordingSet) and isinstance(pattern, RecordingSet)
        assert one.description == str(a) and two.description == f"{a} {b}" and pattern.description == two.description
        assert all(isinstance(s, Source) for s in (one, two, pattern))
        assert sum(len(batch) for batch in two) == 10 and not two.skipped
    with open_source(f"{bag}:A", ur5.joint_names) as reader:
        assert isinstance(reader, BagReader) and isinstance(reader, Source) and reader.description == f"{bag}:A"
    arrays = ArraySource({"time": [0.0, 0.01], "joints": np.zeros((2, 2)), "channels": np.ones((2, 8)), "configuration": "B"})
    assert isinstance(arrays, Source) and arrays.tool_names == ["B"] and arrays.notes() == [] and not arrays.skipped
    with open_source("udp://127.0.0.1:0", end=StreamEnd(idle_timeout_s=0.01)) as live:
        assert isinstance(live, LiveFeed) and isinstance(live, Source)
        assert live.address[1] != 0 and live.description == f"udp://127.0.0.1:{live.address[1]}"


def test_arrays_in_memory_give_one_batch_checked_as_the_api_checks_them(ur5):
    n = 4
    arrays = {"time": 0.01 * np.arange(n), "joints": dict.fromkeys(ur5.joint_names, np.zeros(n)), "channels": np.ones((n, 8))}
    source = ArraySource({**arrays, "configuration": ["B", "A", "B", "B"]}, ur5.joint_names, ["A", "B", "C"])
    (batch,) = list(source)
    assert batch.configuration.tolist() == [1, 0, 1, 1] and batch.joints.shape == (n, 6) and source.tool_names == ["A", "B", "C"]
    given = SampleBatch(arrays["time"], np.zeros((n, 6)), arrays["channels"], np.zeros(n, dtype=np.int64))
    assert next(iter(ArraySource(given))) is given
    with pytest.raises(ShapeError, match=r"arrays in memory has no \['configuration'\]: expected time, joints, channels"):
        ArraySource(arrays)
    with pytest.raises(ShapeError, match=r"4 times, 4 joint readings, 3 rows of channels and 4 configurations"):
        ArraySource({**arrays, "channels": np.ones((3, 8)), "configuration": "A"}, ur5.joint_names)
    with pytest.raises(UnknownToolConfiguration, match="'Z' is not in the tool file"):
        ArraySource({**arrays, "configuration": "Z"}, ur5.joint_names, ["A", "B", "C"])
    with pytest.raises(ShapeError, match="is a list: expected a SampleBatch or a mapping of arrays"):
        ArraySource([1, 2])  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("text", "says"),
    [
        ("ftp://host/run.csv", "ftp://host/run.csv: unknown kind of source 'ftp://': expected a CSV recording"),
        ("udp://127.0.0.1:abc", "udp://127.0.0.1:abc: the port 'abc' is not a number from 0 to 65535"),
        ("udp://127.0.0.1:70000", "udp://127.0.0.1:70000: the port '70000' is not a number from 0 to 65535"),
        ("udp://:5005", "udp://:5005: no host: expected udp://HOST:PORT"),
        ("udp://127.0.0.1", "udp://127.0.0.1: no port: expected udp://HOST:PORT"),
        ("udp://127.0.0.1:5005/x", "udp://127.0.0.1:5005/x: nothing may follow the address"),
        ("ur://10.0.0.7:x", "ur://10.0.0.7:x: the port 'x' is not a number from 0 to 65535"),
        ("ur://", "ur://: no host: expected ur://HOST"),
        ("ur://10.0.0.7:5005", "ur://10.0.0.7:5005: RTDE listens on port 30004"),
        ("ur://10.0.0.7", "ur://10.0.0.7: RTDE gives the joints; the strains come as datagrams: give their address"),
    ],
)
def test_a_name_that_is_no_source_is_refused_naming_it(text, says):
    with pytest.raises(ConfigError) as caught:
        open_source(text, ["a"] * 6)
    assert str(caught.value).startswith(says), str(caught.value)


def test_a_wildcard_host_needs_listen_any():
    with pytest.raises(ConfigError, match="udp://0.0.0.0:0 would bind every network interface"):
        open_source("udp://0.0.0.0:0")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FtsCalibWarning)  # beyond loopback: warned about
        with open_source("udp://0.0.0.0:0", listen_any=True) as feed:
            assert feed.address[0] == "0.0.0.0"


def test_udp_with_no_joints_gives_the_strains_alone():
    with open_source("udp://127.0.0.1:0", n_channels=8, hold_s=0.0, end=StreamEnd(idle_timeout_s=DEADLINE_S)) as feed:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            for k in range(5):
                sock.sendto(encode(Strain(0.01 * k, (0.5,) * 8)), feed.address)
            sock.sendto(encode(End()), feed.address)
        batches = list(feed)
    assert sum(len(b) for b in batches) == 5 and all(b.joints.shape == (len(b), 0) for b in batches)


def test_ur_names_a_controller_read_through_rtde(monkeypatch, ur5):
    """``ur://HOST`` with the built-in sensor: the controller's samples are the stream (a fake ur_rtde here)."""
    from .test_rtde import FakeUR, _linear_run

    time, q, wrench, _ = _linear_run(200)
    fake = FakeUR(time, q, wrench, reads=1)
    monkeypatch.setitem(sys.modules, "rtde_receive", types.SimpleNamespace(RTDEReceiveInterface=lambda host: fake))
    with FakeRtdeServer() as server:
        monkeypatch.setattr("fts_calib.sources.ur.RTDE_PORT", server.port)
        end = StreamEnd(idle_timeout_s=0.5)
        with open_source("ur://127.0.0.1", ur5.joint_names, ["A"], ur_wrench=True, configuration="A", end=end) as feed:
            placed = sum(len(b) for b in feed)
    assert feed.description == "ur://127.0.0.1" and feed.rtde is not None and feed.rtde.samples == 200
    assert placed == 200 and feed.stats.joints == feed.stats.strain == 200

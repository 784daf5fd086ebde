"""Sources of samples: what every one offers (:class:`Source`), and the one place a name becomes one.

A source yields :class:`fts_calib.sources.batch.SampleBatch` es in time order and says what it
skipped and why, so that the jobs (calibrate, validate, replay, tare, payload, monitor) take any
of them without knowing which:

- recordings: :class:`fts_calib.sources.recording.RecordingReader` (a CSV file),
  :class:`fts_calib.sources.recording_set.RecordingSet` (several) and
  :class:`fts_calib.sources.bag.BagReader` (ROS 2 bags), by :func:`open_recording`;
- arrays in memory (the Python API): :class:`ArraySource`;
- live streams: :class:`fts_calib.sources.live_feed.LiveFeed` (UDP datagrams, a UR arm
  through RTDE).

:func:`open_source` takes the text a user types and opens the source it names:

- ``RUN.csv`` or ``RUN.csv.gz``: a CSV recording; several paths, or a pattern such as
  ``'poses/*.csv'`` (expanded here): a static-pose dataset of one file per pose;
- ``RUN.mcap``, ``RUN.db3``, a bag folder (with its ``metadata.yaml``), or several of them,
  each optionally ``:CONFIGURATION`` (the tool configuration it holds throughout): ROS 2 bags;
- ``udp://HOST:PORT``: the live protocol on that address (port 0: any free port; a wildcard
  host such as ``0.0.0.0`` only with ``listen_any``);
- ``ur://HOST``: a UR controller's joints (and with ``ur_wrench`` its built-in sensor's wrench)
  through RTDE (``ur_rtde``), with the datagrams of ``udp`` for what RTDE does not give;
- ``serial://DEVICE?baud=...&sep=...&channels=...`` (:mod:`fts_calib.sources.serial_line`) and
  ``netft://HOST`` (:mod:`fts_calib.sources.netft`): channel devices, with the joints of
  ``joints`` (``udp://HOST:PORT`` datagrams, or ``ur://HOST``), every stream on the host's
  monotonic clock; without ``joints``, the channels alone (a re-tare, the monitor).

Recordings count what they skip in ``skipped`` (by reason) and ``notes()`` (the first problems
with file and line), and tell ``rows_read``, ``bytes_read`` of ``size`` for progress.
"""

from __future__ import annotations

import math
import re
import time
from collections import Counter
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Protocol, runtime_checkable
from urllib.parse import urlsplit

import numpy as np

from ..core.arrays import as_floats, as_rows
from ..core.exceptions import ConfigError, RecordingError, ShapeError
from .bag import BagReader, BagTopics, is_bag, parse_bag_argument
from .batch import SampleBatch, configuration_codes
from .live_feed import FeedStatus, LiveFeed, StreamEnd
from .recording_set import RecordingSet, expand_patterns
from .synchronizer import Synchronizer
from .udp import UdpReceiver
from .ur import RTDE_PORT, TIMEOUT_S

if TYPE_CHECKING:
    from .recording import RecordingReader


@runtime_checkable
class Source(Protocol):
    """What every source of samples offers (see the module docstring).

    Iterate it for its batches, in time order (a live source's come as they are placed and
    end when its stream ends: :mod:`fts_calib.sources.live_feed`); then ``skipped`` and
    ``notes()`` say what did not reach the caller. Close it (or use it in a ``with``) when done.
    """

    @property
    def description(self) -> str:
        """The source in words, for messages and provenance (a path, ``udp://HOST:PORT``)."""
        ...

    @property
    def tool_names(self) -> list[str]:
        """The tool configuration names that the batches' ``configuration`` indexes."""
        ...

    @property
    def skipped(self) -> Counter[str]:
        """What was skipped so far (rows, messages, samples), by reason."""
        ...

    def notes(self) -> list[str]:
        """The problems found, in words (the first ones, each with where it was)."""
        ...

    def __iter__(self) -> Iterator[SampleBatch]: ...

    def close(self) -> None:
        """Release the file or socket (an iteration stopped early included)."""
        ...

    def __enter__(self): ...

    def __exit__(self, *exc) -> None: ...


#: The arrays :class:`ArraySource` takes from a mapping; ``temperature`` is optional.
ARRAY_KEYS = ("time", "joints", "channels", "configuration")


def array_batch(
    time, joints, channels, configuration, temperature=None, joint_names=None, tool_names=None, where: str = "arrays"
) -> tuple[SampleBatch, list[str]]:
    """Arrays as one :class:`SampleBatch` (the Python API's form of samples), checked.

    Args:
        time: Times [s], shape (N,).
        joints: Joint readings [rad], shape (N, n_joints) in ``joint_names`` order, or a
            mapping joint name -> (N,) (then ``joint_names`` orders them).
        channels: Raw channels, shape (N, n_channels).
        configuration: One configuration name, a name per sample, or indices in ``tool_names``.
        temperature: Sensor temperatures [°C], shape (N,), or None.
        joint_names: The robot's joints, in order; None takes ``joints`` as an array as it is.
        tool_names: The tool's configuration names, in order; None: the names given, in
            order of first appearance (indices without names are named ``'0'``, ``'1'``, ...).
        where: What the arrays are, for the messages.

    Returns:
        The batch, and the configuration names its ``configuration`` indexes.

    Raises:
        ShapeError: Not numbers, or not one row of each per time.
        JointError: Unknown or missing joint names, or the wrong number of joints.
        UnknownToolConfiguration: A configuration not in ``tool_names``.
    """
    if joint_names is not None:
        from ..robot.joints import reading_array

        readings, _ = reading_array(joints, joint_names)
    t = as_floats(time, "t").reshape(-1)
    if joint_names is None:
        readings = as_rows(joints, len(t), "joints")
    names = list(tool_names) if tool_names is not None else _names_given(configuration)
    codes = configuration_codes(configuration, len(t), names)
    rows = as_rows(channels, len(t), "channels")  # its width is check_channels' to name, with the sensor
    if not (len(readings) == len(t) == len(rows) == len(codes)):
        counts = f"{len(t)} times, {len(readings)} joint readings, {len(rows)} rows of channels and {len(codes)} configurations"
        raise ShapeError(f"{where}: {counts}: expected one of each per sample")
    return SampleBatch(t, readings, rows, codes, temperature), names


def _names_given(configuration) -> list[str]:
    """The configuration names given (in order of first appearance), or ``'0'``, ``'1'``, ... for indices."""
    given = np.asarray(configuration)
    if given.dtype.kind in "iu":
        return [str(k) for k in range(int(given.max(initial=-1)) + 1)]
    return list(dict.fromkeys(str(name) for name in given.reshape(-1)))


class ArraySource:
    """Arrays in memory as a :class:`Source`: one batch (the Python API's ``calibrate(arrays)``).

    Args:
        arrays: A :class:`SampleBatch`, or a mapping with ``time`` [s] (N,), ``joints`` [rad]
            (N, n_joints) (or a mapping joint name -> (N,)), ``channels`` (N, n) raw,
            ``configuration`` (one name, one per sample, or indices) and optionally
            ``temperature`` [°C] (N,).
        joint_names: The robot's joints, in order (to order a mapping of joints); None for
            an array as it is.
        tool_names: The tool's configuration names, in order; None: the names given.
        description: The arrays in words, for messages and provenance.

    Raises:
        ShapeError: Not a batch nor a mapping, a mapping without one of :data:`ARRAY_KEYS`
            (the message lists the keys given), or arrays of inconsistent lengths.
        UnknownToolConfiguration: A configuration not in ``tool_names``.
    """

    def __init__(
        self,
        arrays: SampleBatch | Mapping,
        joint_names: Sequence[str] | None = None,
        tool_names: Sequence[str] | None = None,
        description: str = "arrays in memory",
    ):
        self.description = description
        if isinstance(arrays, SampleBatch):
            self.batch = arrays
            self.tool_names = list(tool_names) if tool_names is not None else _names_given(arrays.configuration)
        elif isinstance(arrays, Mapping):
            missing = [key for key in ARRAY_KEYS if key not in arrays]
            if missing:
                given = ", ".join(map(str, arrays)) or "none"
                raise ShapeError(f"{description} has no {missing}: expected time, joints, channels and configuration (given: {given})")
            self.batch, self.tool_names = array_batch(
                arrays["time"],
                arrays["joints"],
                arrays["channels"],
                arrays["configuration"],
                arrays.get("temperature"),
                joint_names,
                tool_names,
                description,
            )
        else:
            raise ShapeError(f"{description} is a {type(arrays).__name__}: expected a SampleBatch or a mapping of arrays")
        self.skipped: Counter[str] = Counter()

    def notes(self) -> list[str]:
        """Nothing is skipped before the caller: no note."""
        return []

    def __iter__(self) -> Iterator[SampleBatch]:
        yield self.batch

    def close(self) -> None:
        """Nothing to release."""

    def __enter__(self) -> ArraySource:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


#: The smallest share of a recording's channel samples a job must use for its result to stand
#: (validate compares them, replay sends them): below it the result describes a sliver of the
#: recording (joint stamps on another clock, a tool never announced) and the job fails.
MIN_COVERAGE = 0.5

#: Suffixes of a CSV recording.
CSV_SUFFIXES = (".csv", ".gz")

#: The accepted kinds of recording, in words (for errors and help texts).
ACCEPTED = (
    "a CSV recording (.csv, .csv.gz), or ROS 2 bags (.mcap, .db3 or a bag folder with metadata.yaml, each optionally BAG:CONFIGURATION)"
)


def recording_paths(recording: str | Path | Sequence[str | Path]) -> list[str | Path]:
    """A recording argument as a list of paths: one, or several, each pattern (``'poses/*.csv'``) replaced by its matches.

    Raises:
        RecordingError: A pattern matches no file (:func:`fts_calib.sources.recording_set.expand_patterns`).
    """
    return expand_patterns([recording] if isinstance(recording, (str, Path)) else list(recording))


def open_recording(
    recording: str | Path | Sequence[str | Path],
    joint_names: Sequence[str] | None,
    tool_names: Sequence[str] | None,
    max_abs_channel: float | None = None,
    topics: BagTopics | None = None,
    continuous: Sequence[bool] | np.ndarray | None = None,
    max_gap_s: float = 0.05,
    latency_s: float = 0.0,
) -> RecordingReader | RecordingSet | BagReader:
    """The reader of a recording (see the module docstring).

    Args:
        recording: One or more CSV paths (or patterns), or one or more bags (``PATH`` or ``PATH:CONFIGURATION``).
        joint_names: The robot's joints, in its order; None for the file's.
        tool_names: The tool's configuration names, in order; None to accept any.
        max_abs_channel: Largest plausible channel magnitude, raw units (CSV notes rows beyond it).
        topics: Topic names of a bag (the defaults when None).
        continuous: Which joints are continuous, shape (n_joints,) (a bag's synchronizer).
        max_gap_s: Longest joint gap a bag's synchronizer interpolates across [s].
        latency_s: How late a bag's joint stamps are relative to its channel stamps [s].

    Raises:
        RecordingError: Not one of the accepted kinds (the message lists them), CSV files
            and bags mixed, a pattern that matches nothing, a set of CSV files that do not
            fit together (:class:`~fts_calib.sources.recording_set.RecordingSet`), or the reader's own errors (a
            :class:`~fts_calib.core.exceptions.BagError` for a bag).
    """
    paths = recording_paths(recording)
    if not paths:
        raise RecordingError(Path("."), None, None, f"no recording given: expected {ACCEPTED}")
    parts = [parse_bag_argument(p) for p in paths]
    if all(is_bag(part.path) for part in parts):
        return BagReader(parts, joint_names, tool_names, topics, continuous, max_gap_s, latency_s)
    if any(is_bag(part.path) for part in parts):
        other = next(p.path for p in parts if not is_bag(p.path))
        raise RecordingError(
            other, None, None, f"several recordings are either all CSV files or all ROS 2 bags, and this is not a bag: expected {ACCEPTED}"
        )
    for path in map(Path, paths):
        if path.suffix not in CSV_SUFFIXES and not path.exists():  # a missing CSV is the CSV reader's "file not found"
            raise RecordingError(path, None, None, f"file or folder not found (expected {ACCEPTED})")
        if path.is_dir():
            raise RecordingError(path, None, None, f"a folder without a metadata.yaml is not a ROS 2 bag: expected {ACCEPTED}")
        if path.suffix not in CSV_SUFFIXES:
            raise RecordingError(path, None, None, f"unknown kind of recording '{path.suffix or path.name}': expected {ACCEPTED}")
    from ..robot.orientation import GIMBAL_JOINTS
    from .recording import RecordingReader

    def open_csv(path: Path) -> RecordingReader:
        if joint_names is not None and tuple(joint_names) == GIMBAL_JOINTS:  # no robot: the file gives orientations
            from .orientation_recording import open_orientation_recording

            return open_orientation_recording(path, tool_names, max_abs_channel)
        return RecordingReader(path, joint_names, tool_names, max_abs_channel=max_abs_channel)

    if len(paths) == 1:
        return open_csv(Path(paths[0]))
    return RecordingSet(paths, open_csv)


def orientation_source(reader: RecordingReader | RecordingSet | BagReader, joint_names: Sequence[str] | None) -> str | None:
    """What gives the sensor's orientation in a run without a robot, for the words of a diagnosis.

    Args:
        reader: The reader :func:`open_recording` gave.
        joint_names: The joints it was opened with (the gimbal's in a run without a robot).

    Returns:
        A key of :data:`fts_calib.robot.orientation.ORIENTATION_FORMS` ('quaternion', 'roll-pitch-yaw',
        'tcp') for a CSV, 'pose topic' for bags, or None: a robot's joints.
    """
    from .bag import is_pose_run

    if not is_pose_run(joint_names):
        return None
    if isinstance(reader, BagReader):
        return "pose topic"
    from ..robot.orientation import orientation_form

    return orientation_form(reader.columns)


#: The schemes of a channel device's name.
DEVICE_SCHEMES = ("serial", "netft")
#: The schemes of a live source's name.
LIVE_SCHEMES = ("udp", "ur", *DEVICE_SCHEMES)
#: The accepted names of a source, in words (for errors and help texts).
SOURCES = (
    f"{ACCEPTED}; or udp://HOST:PORT (live datagrams), ur://HOST (a UR arm through RTDE), "
    "serial:///dev/ttyUSB0?baud=115200 (a line of counts per sample) or netft://HOST (an ATI Net F/T box)"
)
_SCHEME = re.compile(r"^([A-Za-z][A-Za-z0-9+.-]*)://")


def open_source(
    text: str | Path | Sequence[str | Path],
    joint_names: Sequence[str] | None = None,
    tool_names: Sequence[str] | None = None,
    *,
    continuous: Sequence[bool] | np.ndarray | None = None,
    max_gap_s: float = 0.05,
    latency_s: float = 0.0,
    max_abs_channel: float | None = None,
    topics: BagTopics | None = None,
    n_channels: int | None = None,
    configuration: str | None = None,
    hold_s: float | None = None,
    listen_any: bool = False,
    udp: str | None = None,
    ur_wrench: bool = False,
    ur_timeout_s: float = TIMEOUT_S,
    end: StreamEnd | None = None,
    on_status: Callable[[FeedStatus], None] | None = None,
    status_interval_s: float = 0.5,
    on_listening: Callable[[tuple[str, int]], None] | None = None,
    joints: str | None = None,
    host_clock: bool = False,
    device_timeout_s: float | None = None,
) -> Source:
    """The source a name gives, as a user types it (see the module docstring).

    Args:
        text: A recording's path, several, a pattern, a bag (``BAG[:CONFIGURATION]``),
            ``udp://HOST:PORT`` or ``ur://HOST``.
        joint_names: The robot's joints, in its order. A recording: None for the file's. A
            live stream: None (or empty) for the strains alone (no joints expected).
        tool_names: The tool's configuration names, in order; None to accept any.
        continuous: Which joints are continuous, shape (n_joints,) (the synchronizer's).
        max_gap_s: Longest joint gap interpolated across [s].
        latency_s: How late the joint stamps are relative to the channel stamps [s].
        max_abs_channel: Largest plausible channel magnitude, raw units (a CSV recording).
        topics: Topic names of a bag (the defaults when None).
        n_channels: Values a strain datagram must have (the sensor's channels); None takes the first's.
        configuration: Live: the tool configuration mounted from the start (tool datagrams may
            change it); None: none until a tool datagram.
        hold_s: Live: how far a stream must pass a strain time before it is placed [s]
            (:class:`~fts_calib.sources.synchronizer.Synchronizer`); ``max_gap_s`` when None.
        listen_any: Let ``udp://`` bind a wildcard host (every interface).
        udp: With ``ur://``: the address of the datagrams that add what RTDE does not give
            (``HOST:PORT`` or ``udp://HOST:PORT``); None for none (then ``ur_wrench``).
        ur_wrench: With ``ur://``: the channels are the built-in sensor's raw wrench.
        ur_timeout_s: With ``ur://``: the longest wait for the controller [s].
        end: Live: what ends the stream besides the sender's ``end`` (:class:`StreamEnd`).
        on_status: Live: called with the counts every ``status_interval_s`` [s].
        status_interval_s: Live: time between two statuses [s].
        on_listening: Live: called with the bound (host, port) when the stream starts.
        joints: With ``serial://`` or ``netft://``: where the joints come from,
            ``udp://HOST:PORT`` (datagrams) or ``ur://HOST`` (RTDE); None for the channels alone.
        host_clock: Live: every stream on the host's monotonic clock (always with a device).
        device_timeout_s: ``netft://``: the longest silence of the box [s] (its default when None).

    Raises:
        ConfigError: A name of an unknown scheme, a live address without a host, with a port
            that is not a number from 0 to 65535, a wildcard host without ``listen_any``,
            ``ur://`` without ``udp`` nor ``ur_wrench`` (the message names the text).
        RecordingError: A recording that cannot be opened (:func:`open_recording`).
        FeedTimeout: ``ur://``: the controller does not answer within ``ur_timeout_s``.
    """
    scheme = _SCHEME.match(text) if isinstance(text, str) else None
    if scheme is None or not isinstance(text, str):
        return open_recording(text, joint_names, tool_names, max_abs_channel, topics, continuous, max_gap_s, latency_s)
    kind = scheme.group(1).lower()
    if kind not in LIVE_SCHEMES:
        raise ConfigError("source", text, SOURCES, message=f"{text}: unknown kind of source '{kind}://': expected {SOURCES}")
    sync = Synchronizer(
        list(joint_names or []),
        continuous if joint_names else None,
        max_gap_s,
        latency_s,
        hold_s,
        configurations=tool_names,
        n_channels=n_channels,
    )
    if configuration is not None:
        sync.add_tool(-math.inf, configuration)
    if kind in DEVICE_SCHEMES:
        return _device_feed(
            text,
            kind,
            sync,
            joints,
            joint_names,
            listen_any,
            ur_timeout_s,
            device_timeout_s,
            end,
            on_status,
            status_interval_s,
            on_listening,
        )
    if kind == "udp":
        host, port = live_address(text)
        receiver = UdpReceiver(host, port, listen_any)
        return LiveFeed(
            receiver,
            sync,
            end=end,
            on_status=on_status,
            status_interval_s=status_interval_s,
            on_listening=on_listening,
            host_clock=host_clock,
        )
    host = _ur_host(text)
    if udp is None and not ur_wrench:
        message = f"{text}: RTDE gives the joints; the strains come as datagrams: give their address (udp=HOST:PORT), or ur_wrench"
        raise ConfigError("udp", None, "the strain datagrams' address", message=message)
    from .ur import RtdePoller, connect_ur

    datagrams = None if udp is None else live_address(udp if "://" in udp else f"udp://{udp}")  # a wrong address before the arm
    clock = time.monotonic if host_clock else None if ur_wrench else time.time  # the strain datagrams' clock: joints put on it
    rtde = RtdePoller(
        connect_ur(host, ur_timeout_s), list(joint_names or []), ur_wrench, clock, timeout_s=ur_timeout_s, where=f"{host}:{RTDE_PORT}"
    )
    listening = None if datagrams is None else UdpReceiver(*datagrams, listen_any)
    described = f"ur://{host}" + ("" if listening is None else f" with udp://{listening.address[0]}:{listening.address[1]}")
    return LiveFeed(
        listening,
        sync,
        rtde,
        end=end,
        on_status=on_status,
        status_interval_s=status_interval_s,
        on_listening=on_listening,
        description=described,
        host_clock=host_clock,
    )


def _device_feed(
    text: str,
    kind: str,
    sync: Synchronizer,
    joints: str | None,
    joint_names: Sequence[str] | None,
    listen_any: bool,
    ur_timeout_s: float,
    device_timeout_s: float | None,
    end: StreamEnd | None,
    on_status: Callable[[FeedStatus], None] | None,
    status_interval_s: float,
    on_listening: Callable[[tuple[str, int]], None] | None,
) -> LiveFeed:
    """The live feed of a channel device (``serial://``, ``netft://``) with the joints of ``joints`` (see :func:`open_source`)."""
    from .devices import ChannelDevice

    device: ChannelDevice
    if kind == "serial":
        from .serial_line import SerialChannels

        device = SerialChannels(text, sync.n_channels)
    else:
        from .netft import TIMEOUT_S as NETFT_TIMEOUT_S
        from .netft import open_netft

        if sync.n_channels not in (None, 6):
            message = f"{text}: a Net F/T box gives 6 channels (its counts Fx..Tz), the sensor has {sync.n_channels}"
            raise ConfigError("source", text, "a 6-channel sensor file (e.g. factory_sensor)", message=message)
        device = open_netft(text, NETFT_TIMEOUT_S if device_timeout_s is None else device_timeout_s)
    named = None if joints is None else _SCHEME.match(joints)
    joint_kind = "udp" if named is None else named.group(1).lower()
    if joints is not None and joint_kind not in ("udp", "ur"):
        message = f"{text}: its joints come as udp://HOST:PORT datagrams or from ur://HOST, not {joints}"
        raise ConfigError("source", joints, "udp://HOST:PORT or ur://HOST", message=message)
    if joints is not None and joint_names and joint_kind == "ur":
        from .ur import RtdePoller, connect_ur

        arm = _ur_host(joints)
        rtde = RtdePoller(
            connect_ur(arm, ur_timeout_s), list(joint_names), False, time.monotonic, timeout_s=ur_timeout_s, where=f"{arm}:{RTDE_PORT}"
        )
        described = f"{text} with {joints}"
        interval = status_interval_s
        return LiveFeed(None, sync, rtde, end=end, on_status=on_status, status_interval_s=interval, description=described, device=device)
    receiver = None
    if joints is not None:
        receiver = UdpReceiver(*live_address(joints if "://" in joints else f"udp://{joints}"), listen_any)
    described = text if receiver is None else f"{text} with udp://{receiver.address[0]}:{receiver.address[1]}"
    return LiveFeed(
        receiver,
        sync,
        end=end,
        on_status=on_status,
        status_interval_s=status_interval_s,
        on_listening=on_listening,
        description=described,
        device=device,
    )


def live_address(text: str) -> tuple[str, int]:
    """The (host, port) of ``udp://HOST:PORT``.

    Raises:
        ConfigError: Not of that form: no host, no port, a port that is not a number from 0
            to 65535, or a path after the port (the message names the text).
    """
    expected = "udp://HOST:PORT, e.g. udp://127.0.0.1:5005 (port 0: any free port)"
    host, port = _host_and_port(text, expected)
    if port is None:
        raise ConfigError("source", text, expected, message=f"{text}: no port: expected {expected}")
    return host, port


def _ur_host(text: str) -> str:
    """The controller's host of ``ur://HOST`` (RTDE's port, when given, must be its own)."""
    expected = f"ur://HOST, the UR controller's address (RTDE: port {RTDE_PORT})"
    host, port = _host_and_port(text, expected)
    if port not in (None, RTDE_PORT):
        raise ConfigError("source", text, expected, message=f"{text}: RTDE listens on port {RTDE_PORT}: expected {expected}")
    return host


def _host_and_port(text: str, expected: str) -> tuple[str, int | None]:
    """The host and the port (None when not given) of a live source's name ``SCHEME://HOST[:PORT]``.

    Raises:
        ConfigError: No host, a port that is not a number from 0 to 65535, or anything after
            the address (the message names the text and says what was ``expected``).
    """
    parts = urlsplit(text)
    if parts.path not in ("", "/") or parts.query or parts.fragment:
        raise ConfigError("source", text, expected, message=f"{text}: nothing may follow the address: expected {expected}")
    if not parts.hostname:
        raise ConfigError("source", text, expected, message=f"{text}: no host: expected {expected}")
    try:
        return parts.hostname, parts.port
    except ValueError:
        given = parts.netloc.rpartition(":")[2]
        message = f"{text}: the port '{given}' is not a number from 0 to 65535: expected {expected}"
        raise ConfigError("source", text, expected, message=message) from None

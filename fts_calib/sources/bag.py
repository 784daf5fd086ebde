"""The robot-log contract of a ROS 2 bag (docs/formats.md): message types, topic names, bag arguments.

Read and written with the ``rosbags`` library (pure Python: no ROS install); bags that do
not embed their message definitions are read with ROS 2 Humble's standard ones. Stamps are
integer nanoseconds; :func:`seconds` turns them into [s], correctly rounded.

Checks of ROS 2 bags before they are read: a bag given twice, and joint and channel stamps on two clocks.

Both refuse a bag with the cause and the way out (see :mod:`fts_calib.sources.bag`): samples
counted twice, or no channel sample that could be placed between two joint readings.

A ROS 2 bag's ``geometry_msgs/msg/PoseStamped`` topic as the sensor's orientation (a run without a robot).

Its quaternion gives ``R_world_sensor`` (or, with a mount rotation, the orientation of the
frame the sensor is mounted on, e.g. a UR's TCP pose in its base frame); its position is not
used. Each message becomes the gimbal's joints ``[yaw, pitch, roll]``
(:mod:`fts_calib.robot.orientation`), which the bag reader's synchronizer interpolates at
the channel times as it would a robot's joints. A quaternion farther than
:data:`~fts_calib.robot.orientation.UNIT_TOLERANCE` from unit norm, or not finite, is ignored
and noted.

ROS 2 bags (MCAP or sqlite3) as a feed: joint states and channels, synchronised into SampleBatch.

Bags are read with the ``rosbags`` library (pure Python: no ROS install). The robot-log
contract (docs/formats.md), topic names being options (:class:`BagTopics`):

- joints: ``sensor_msgs/msg/JointState`` (default ``/joint_states``), stamped by their
  header; positions in [rad], mapped to the robot's joints by name (other names, e.g. a
  gripper's fingers, are ignored; a message without the robot's joints is ignored and noted);
- channels: ``std_msgs/msg/Float64MultiArray`` (default ``/ft_sensor/raw``; its ``data`` are
  the n raw channels, stamped by the bag's log time), or ``geometry_msgs/msg/WrenchStamped``
  (6 channels ``[fx, fy, fz, tx, ty, tz]`` in [N, N·m], header stamps: the ``wrench-6``
  channel layout);
- or, for a run without a robot, the sensor's orientation: ``geometry_msgs/msg/PoseStamped``
  (default ``/ft_sensor/pose``, :mod:`fts_calib.sources.bag`) instead of the joints, stamped
  as they would be;
- the tool configuration: ``std_msgs/msg/String`` (default ``/fts_calib/configuration``), a
  configuration name of the tool file from its log time on; or one bag per configuration
  (``RUN_A.mcap:A``, :func:`parse_bag_argument`), the topic then unused.

The two streams must be on one clock. Before reading, the first :data:`PEEK_MESSAGES` joint
and channel messages are compared with the bag's log time, and a bag is refused with the
cause and the way out (``joint_stamps='log'``, ``--joint-stamps log``) when the joint stamps
do not move while the log time does (a log of simulated time, whose header stamps stay 0),
or when they are more than :data:`~fts_calib.sources.bag.MAX_CLOCK_OFFSET_S` from the channels' clock (a driver
stamping on another clock): no channel sample could then be placed.

The joint and channel streams go through the live path's synchronizer
(:mod:`fts_calib.sources.synchronizer`): joints are interpolated at the channel times (a shared stamp
takes the joint reading as it is), and a channel sample that cannot be placed is dropped
and counted. Messages are read in log-time order and paired every :data:`CHUNK_MESSAGES`
messages, so memory stays bounded whatever the bag's length. Stamps become seconds as
the correctly rounded ``ns / 1e9``: the same stamp gives the same float on both streams, and
a time written with at most nine decimals (a CSV recording's) reads back as the same
float. Several bags are read in the order of their first message, each with its own
synchronizer (a joint stream never reaches into another bag).
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections import Counter
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.exceptions import BagError, ConfigError, FileFormatError, UnknownToolConfiguration
from ..core.files import load_yaml
from .batch import DUPLICATE, UNKNOWN_TOOL, SampleBatch, repeated_rows
from .recording import MAX_NOTES, unlogged_joints_hint
from .recording_set import describe_files
from .synchronizer import Synchronizer

JOINT_STATE = "sensor_msgs/msg/JointState"
FLOAT64_ARRAY = "std_msgs/msg/Float64MultiArray"
WRENCH_STAMPED = "geometry_msgs/msg/WrenchStamped"
STRING = "std_msgs/msg/String"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"

#: Where a joint message's time is read: its header stamp (the contract's default) or its log time.
JOINT_STAMPS = ("header", "log")

#: Suffixes of a bag's storage file (a bag folder holds one or more and a metadata.yaml).
BAG_SUFFIXES = (".mcap", ".db3")


def is_bag(path: str | Path) -> bool:
    """Whether ``path`` is a ROS 2 bag: a ``.mcap`` or ``.db3`` file, or a folder with a metadata.yaml."""
    path = Path(path)
    return path.suffix in BAG_SUFFIXES or (path.is_dir() and (path / "metadata.yaml").is_file())


@dataclass(frozen=True)
class BagTopics:
    """Topic names of a robot log (the defaults are the contract's: docs/formats.md).

    Attributes:
        joints: ``sensor_msgs/msg/JointState`` topic.
        channels: ``std_msgs/msg/Float64MultiArray`` or ``geometry_msgs/msg/WrenchStamped`` topic.
        configuration: ``std_msgs/msg/String`` topic of the tool configuration.
        joint_stamps: The time of a joint (or pose) message: ``header`` (its header stamp) or ``log``
            (the bag's log time: for a log of simulated time whose header stamps stay 0, or
            a driver stamping on another clock).
        pose: ``geometry_msgs/msg/PoseStamped`` topic of the sensor's orientation, read
            instead of ``joints`` when there is no robot (:mod:`fts_calib.robot.orientation`):
            its quaternion gives ``R_world_sensor``, or the TCP's with a mount rotation.
    """

    joints: str = "/joint_states"
    channels: str = "/ft_sensor/raw"
    configuration: str = "/fts_calib/configuration"
    joint_stamps: str = "header"
    pose: str = "/ft_sensor/pose"

    def __post_init__(self):
        if self.joint_stamps not in JOINT_STAMPS:
            raise ConfigError("joint_stamps", self.joint_stamps, f"one of {', '.join(JOINT_STAMPS)}")


@dataclass(frozen=True)
class BagPart:
    """One bag of a run, with the tool configuration it holds when the bag has no configuration topic.

    Attributes:
        path: A storage file (``.mcap``, ``.db3``) or a bag folder.
        configuration: The tool configuration mounted throughout, or None (then the
            configuration topic says).
    """

    path: Path
    configuration: str | None = None


def parse_bag_argument(text: str | Path) -> BagPart:
    """``RUN.mcap`` or ``RUN.mcap:A`` (the bag holds configuration A throughout) as a :class:`BagPart`.

    A name that exists as it is is a path, even with a ':' in it.
    """
    path = Path(text)
    head, sep, name = str(text).rpartition(":")
    if path.exists() or not sep or not head or "/" in name or not name.strip():
        return BagPart(path)
    return BagPart(Path(head), name.strip())


def typestore():
    """The message definitions for bags that do not embed theirs (ROS 2 Humble's standard messages)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


def open_bag(path: Path):
    """An open ``rosbags`` AnyReader of a bag (close it after use).

    Raises:
        BagError: The bag is missing or not a readable ROS 2 bag.
    """
    from rosbags.highlevel import AnyReader, AnyReaderError

    metadata = path / "metadata.yaml"
    if path.is_dir() and metadata.is_file():  # read by rosbags, without limits: checked here first
        try:
            load_yaml(metadata)
        except FileFormatError as exc:
            raise BagError(path, None, f"not a readable ROS 2 bag: {exc}") from None
    try:
        reader = AnyReader([path], default_typestore=typestore())
        reader.open()
    except FileNotFoundError:
        raise BagError(path, None, "bag not found") from None
    except AnyReaderError as exc:
        raise BagError(path, None, f"not a readable ROS 2 bag: {exc}") from None
    except (ValueError, KeyError, TypeError, AttributeError) as exc:  # a damaged file that rosbags does not name
        raise BagError(path, None, f"not a readable ROS 2 bag: {type(exc).__name__}: {exc}") from None
    return reader


def seconds(ns: int) -> float:
    """Integer nanoseconds in [s], correctly rounded (Python divides two ints exactly, then rounds once)."""
    return int(ns) / 1_000_000_000


def stamp_s(stamp) -> float:
    """A ``builtin_interfaces/msg/Time`` in [s]."""
    return seconds(int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec))


def bag_size(path: Path) -> int:
    """Bytes of a bag: its file, or the files of its folder."""
    if path.is_dir():
        return sum(p.stat().st_size for p in path.iterdir() if p.is_file())
    return path.stat().st_size


#: Largest offset between the joints' clock and the channels' clock, in [s]: a latency is milliseconds.
MAX_CLOCK_OFFSET_S = 1.0
#: Joint stamps spanning less than this share of their log times' span do not move.
FROZEN_SHARE = 0.01


def refuse_repeated_parts(parts: Sequence[BagPart]) -> None:
    """Refuse bags given twice (a bag folder and its own storage file, or one path twice): their samples would count twice.

    Raises:
        BagError: Two of ``parts`` hold the same storage file; the message names both.
    """
    owner: dict[str, Path] = {}
    for part in parts:
        path = part.path
        files = [p for p in path.iterdir() if p.suffix in BAG_SUFFIXES] if path.is_dir() else [path]
        for file in files:
            key = os.path.realpath(file)
            if key in owner:
                first = owner[key]
                same = "the same bag" if first == path else f"the same bag as {first} (which holds {file.name})"
                raise BagError(path, None, f"given twice: {same}; its samples would count twice: give each bag once")
            owner[key] = path


def check_clocks(path: Path, topics: BagTopics, joints: list, channels: list, wrench: bool) -> None:
    """Refuse a bag whose joint stamps do not move, or are on another clock than the channels.

    Args:
        path: The bag, for the message.
        topics: The bag's topics and how its joints are stamped (``joint_stamps``).
        joints: The first joint messages' ``(time, log time)`` pairs, in [s].
        channels: The first channel messages' ``(time, log time)`` pairs, in [s].
        wrench: The channels are WrenchStamped (stamped by their header).

    Raises:
        BagError: The joints' times do not move while the log time does, or are more than
            :data:`MAX_CLOCK_OFFSET_S` from the channels' clock; the message gives the way out.
    """
    if len(joints) < 2 or not channels:
        return
    stamp, log = np.array(joints).T
    what = "header stamps" if topics.joint_stamps == "header" else "log times"
    way_out = (
        "read the joints at the bag's log time: --joint-stamps log"
        if topics.joint_stamps == "header"
        else "the channels' header stamps are on another clock than the bag's log time: fix the sensor driver's clock"
    )
    log_span, stamp_span = float(np.ptp(log)), float(np.ptp(stamp))
    if log_span > 0 and stamp_span < FROZEN_SHARE * log_span:
        raise BagError(
            path,
            topics.joints,
            f"the joints' {what} do not move: the first {len(stamp):,} messages span {stamp_span:.3g} s of stamps "
            f"(from {stamp[0]:.3f} s) while their log times span {log_span:.3g} s (a log of simulated time, or a driver "
            f"that does not stamp?), so no channel sample can be placed between two joint readings: {way_out}",
        )
    channel_stamp, channel_log = np.array(channels).T
    offset = float(np.median(stamp - log) - np.median(channel_stamp - channel_log))
    if abs(offset) > MAX_CLOCK_OFFSET_S:
        clock = "their header stamps" if wrench else "the bag's log time"
        raise BagError(
            path,
            topics.joints,
            f"the joints' {what} are {offset:+.3f} s ({offset / 3600:+.2f} h) from the channels' clock ({clock}): "
            f"two clocks, at most {MAX_CLOCK_OFFSET_S:g} s apart for the streams to be paired, so no channel sample "
            f"falls between two joint readings: {way_out}",
        )


#: The gimbal's joints (fts_calib.robot.orientation.GIMBAL_JOINTS, written here: importing it
#: would load pinocchio into the parser of the command line; tests check they agree).
GIMBAL_JOINTS = ("yaw", "pitch", "roll")


def is_pose_run(joint_names) -> bool:
    """Whether a reader's joints are the gimbal's: the run gives orientations (no robot)."""
    return joint_names is not None and tuple(joint_names) == GIMBAL_JOINTS


def pose_joints(message) -> dict[str, float] | str:
    """The gimbal's joints [rad] of a PoseStamped's orientation, by name; or why it cannot be used (a sentence)."""
    from ..robot.orientation import checked_rotation, gimbal_angles

    o = message.pose.orientation
    try:
        R = checked_rotation([o.w, o.x, o.y, o.z], "quat")
    except ValueError as exc:
        return str(exc)
    return dict(zip(GIMBAL_JOINTS, gimbal_angles(R)[0].tolist(), strict=True))


def missing_pose_topic(path: Path, topics: BagTopics, available: dict, listing: str) -> BagError:
    """The error of a bag without the pose topic: the PoseStamped topics it has, and the way to name one."""
    poses = sorted(name for name, info in available.items() if info.msgtype == POSE_STAMPED)
    hint = f"name it with --pose-topic: this bag's are {', '.join(poses)}" if poses else "give --robot and read its joints"
    return BagError(
        path,
        topics.pose,
        f"no such topic: without --robot the sensor's orientation is read from a {POSE_STAMPED} topic ({hint}); the bag has: {listing}",
    )


#: Messages read between two pairings of the streams (about 1 MiB of samples in memory).
CHUNK_MESSAGES = 20_000
#: Joint messages looked at, at the start of a bag, for one that holds every robot joint.
PEEK_MESSAGES = 200


#: Skip reason counted by the bag reader (channel samples; the synchronizer counts the others).
MALFORMED = "malformed message"


class BagReader:
    """Read one or more bags as :class:`SampleBatch` es (see the module docstring).

    The same interface as :class:`fts_calib.sources.recording.RecordingReader`: iterate for
    the batches, then read :attr:`skipped` and :meth:`notes`.

    Args:
        parts: The bags, each a :class:`BagPart` or a path (``RUN.mcap:A`` names its configuration).
        joint_names: The robot's joints, in its order; None for the names of the first joint
            message, in its order; the gimbal's (``fts_calib.robot.orientation.GIMBAL_JOINTS``)
            to read the pose topic instead (a run without a robot).
        tool_names: Tool configuration names, in the tool's order; None to accept any name
            (indices in order of appearance, names in :attr:`tool_names`).
        topics: Topic names.
        continuous: Which joints are continuous (interpolated along the shorter arc), shape
            (n_joints,); None for none.
        max_gap_s: Longest joint gap interpolated across [s].
        latency_s: How late the joint stamps are relative to the channel stamps [s].

    Raises:
        BagError: A bag is missing or unreadable, a topic is missing or of another type (the
            message lists the bag's topics and types), no joint message holds every robot
            joint (the message names the missing ones), a bag has neither a configuration
            topic nor a configuration given, or its joint stamps do not move or are on
            another clock than the channels (the message gives the offset and the way out).
        UnknownToolConfiguration: A configuration given with a bag is not one of ``tool_names``.
        ConfigError: No bag given.

    Attributes:
        skipped: Channel samples skipped so far, by reason.
        rows_read: Channel samples read so far.
        size: Bytes of the bags' files.
        n_channels: Channels per sample (the first channel message's; a message of another
            length is counted and skipped by the synchronizer), or None before it.
    """

    def __init__(
        self,
        parts: Sequence[BagPart | str | Path],
        joint_names: Sequence[str] | None,
        tool_names: Sequence[str] | None,
        topics: BagTopics | None = None,
        continuous: Sequence[bool] | np.ndarray | None = None,
        max_gap_s: float = 0.05,
        latency_s: float = 0.0,
    ):
        self.parts = [p if isinstance(p, BagPart) else parse_bag_argument(p) for p in parts]
        if not self.parts:
            raise ConfigError("recording", "", "at least one bag", message="no bag given")
        self.path = self.parts[0].path
        self.topics = topics or BagTopics()
        self._pose = is_pose_run(joint_names)  # no robot: the orientation topic stands for the joints
        self._joints_topic = self.topics.pose if self._pose else self.topics.joints
        self.tool_codes = {name: k for k, name in enumerate(tool_names or [])}
        self._open_tools = tool_names is None
        self.max_gap_s, self.latency_s = float(max_gap_s), float(latency_s)
        self.skipped: Counter[str] = Counter()
        self.unknown_tools: Counter[str] = Counter()
        self.problems: list[str] = []
        self.unlisted = 0
        self.rows_read = 0
        self.n_channels: int | None = None
        self._messages = 0
        self._ignored_joints = 0
        self._reader = None  # the bag being read
        self._reading = self.path  # and its path
        self._joint_index: dict[tuple[str, ...], np.ndarray | None] = {}
        self.joint_names: list[str] = list(joint_names or [])
        self._previous: np.ndarray | None = None  # the last sample placed (time, joints, channels, configuration)
        refuse_repeated_parts(self.parts)
        starts, self._counts = [], []
        for part in self.parts:
            if part.configuration is not None and not self._open_tools and part.configuration not in self.tool_codes:
                raise UnknownToolConfiguration(part.configuration, self.tool_names)
            reader = open_bag(part.path)
            try:
                self._counts.append(self._check_topics(part, reader))
                if not self.joint_names:
                    self.joint_names = self._first_joint_names(part.path, reader)
                if not self._pose:
                    self._check_joints(part.path, reader)
                self._check_clocks(part.path, reader)
                starts.append(reader.start_time)
            finally:
                reader.close()
        self.parts = [p for _, p in sorted(zip(starts, self.parts, strict=True), key=lambda x: x[0])]
        self._counts = [c for _, c in sorted(zip(starts, self._counts, strict=True), key=lambda x: x[0])]
        self.continuous = np.zeros(len(self.joint_names), dtype=bool) if continuous is None else np.asarray(continuous, dtype=bool)
        self.size = sum(bag_size(p.path) for p in self.parts)
        self._total_messages = max(sum(self._counts), 1)

    @property
    def tool_names(self) -> list[str]:
        """Tool configuration names, by index."""
        return list(self.tool_codes)

    @property
    def description(self) -> str:
        """The bags in words, for messages and provenance: each ``PATH`` or ``PATH:CONFIGURATION``, in reading order."""
        return describe_files([p.path if p.configuration is None else f"{p.path}:{p.configuration}" for p in self.parts])

    @property
    def bytes_read(self) -> int:
        """Bytes of the bags read so far, estimated from the messages read (for progress)."""
        return int(self.size * min(self._messages / self._total_messages, 1.0))

    def close(self) -> None:
        """Close the bag being read, when an iteration stopped before its end (each bag is open only while it is read)."""
        reader, self._reader = self._reader, None
        if reader is not None:
            reader.close()

    def __enter__(self) -> BagReader:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def notes(self) -> list[str]:
        """The problems kept, then how many more were found (when any): for a report."""
        lines = list(self.problems)
        if self._ignored_joints:
            what = "without a unit quaternion" if self._pose else "without every robot joint"
            lines.append(f"{self._ignored_joints:,} message(s) on {self._joints_topic} {what} were ignored")
        if self.unlisted:
            lines.append(f"and {self.unlisted:,} more problem(s) not listed (the counts by reason are complete)")
        return lines

    def unusable_configurations(self) -> list[str]:
        """The tool configurations none of whose samples could be read, in words (a bag's messages have no cells: none)."""
        return []

    def _note(self, text: str) -> None:
        if len(self.problems) < MAX_NOTES:
            self.problems.append(text)
        else:
            self.unlisted += 1

    def _check_topics(self, part: BagPart, reader) -> int:
        """Refuse a bag whose topics are missing or of another type; the number of messages to read."""
        topics = reader.topics
        listing = ", ".join(f"{name} ({info.msgtype})" for name, info in sorted(topics.items())) or "none"
        wanted = [
            (self._joints_topic, (POSE_STAMPED if self._pose else JOINT_STATE,)),
            (self.topics.channels, (FLOAT64_ARRAY, WRENCH_STAMPED)),
        ]
        if part.configuration is None:
            wanted.append((self.topics.configuration, (STRING,)))
        for topic, types in wanted:
            info = topics.get(topic)
            expected = " or ".join(types)
            if info is None and topic == self._joints_topic and self._pose:
                raise missing_pose_topic(part.path, self.topics, topics, listing)
            if info is None:
                hint = ""
                if topic == self.topics.configuration:
                    hint = f"; or name the configuration of the whole bag: {part.path}:NAME"
                raise BagError(part.path, topic, f"no such topic (expected {expected}{hint}); the bag has: {listing}")
            if info.msgtype not in types:
                raise BagError(part.path, topic, f"of type {info.msgtype} but expected {expected}; the bag has: {listing}")
        return sum(topics[t].msgcount for t, _ in wanted)

    def _joint_messages(self, reader, limit: int, topic: str | None = None, log: bool = False):
        """The first ``limit`` messages of ``topic`` (the joints' by default), with their log time [ns] when ``log``."""
        connections = [c for c in reader.connections if c.topic == (topic or self._joints_topic)]
        for count, (connection, log_ns, raw) in enumerate(reader.messages(connections)):
            if count >= limit:
                return
            message = reader.deserialize(raw, connection.msgtype)
            yield (log_ns, message) if log else message

    def _joint_time(self, log_ns: int, message) -> float:
        """A joint message's time [s]: its header stamp, or its log time (``joint_stamps``)."""
        return seconds(log_ns) if self.topics.joint_stamps == "log" else stamp_s(message.header.stamp)

    def _check_clocks(self, path: Path, reader) -> None:
        """Refuse a bag whose joint stamps do not move, or are on another clock than the channels (see the module docstring)."""
        joints = [(self._joint_time(log_ns, m), seconds(log_ns)) for log_ns, m in self._joint_messages(reader, PEEK_MESSAGES, log=True)]
        wrench = reader.topics[self.topics.channels].msgtype == WRENCH_STAMPED
        channels = [
            (stamp_s(m.header.stamp) if wrench else seconds(log_ns), seconds(log_ns))
            for log_ns, m in self._joint_messages(reader, PEEK_MESSAGES, self.topics.channels, log=True)
        ]
        check_clocks(path, dataclasses.replace(self.topics, joints=self._joints_topic), joints, channels, wrench)

    def _first_joint_names(self, path: Path, reader) -> list[str]:
        for message in self._joint_messages(reader, 1):
            return list(message.name)
        raise BagError(path, self._joints_topic, "no joint message: the bag has the topic but no message on it")

    def _check_joints(self, path: Path, reader) -> None:
        """Refuse a bag none of whose first joint messages holds every robot joint."""
        seen: set[str] = set()
        self._first_joint_names(path, reader)  # the topic has a message at all, or this raises
        for message in self._joint_messages(reader, PEEK_MESSAGES):
            if self._index(tuple(message.name)) is not None:
                return
            seen.update(message.name)
        missing = [name for name in self.joint_names if name not in seen]
        raise BagError(
            path,
            self.topics.joints,
            f"no joint message holds the robot's joints {missing}: the messages name {sorted(seen)}; "
            "expected every joint of the robot definition, by name" + unlogged_joints_hint(missing),
        )

    def _index(self, names: tuple[str, ...]) -> np.ndarray | None:
        """Where each robot joint is in a message's names (None when one is missing); cached per name list."""
        if names not in self._joint_index:
            position = {name: k for k, name in enumerate(names)}
            found = [position.get(name) for name in self.joint_names]
            self._joint_index[names] = None if None in found else np.array(found, dtype=int)
        return self._joint_index[names]

    def __iter__(self) -> Iterator[SampleBatch]:
        for part in self.parts:
            yield from self._read(part)

    def _read(self, part: BagPart) -> Iterator[SampleBatch]:
        from rosbags.highlevel import AnyReaderError

        reader, self._reading = open_bag(part.path), part.path
        self._reader = reader
        try:
            sync = Synchronizer(self.joint_names, self.continuous, self.max_gap_s, self.latency_s, n_channels=self.n_channels)
            if part.configuration is not None:
                sync.add_tool(-math.inf, part.configuration)
            wanted = {self._joints_topic, self.topics.channels}
            if part.configuration is None:
                wanted.add(self.topics.configuration)
            connections = [c for c in reader.connections if c.topic in wanted]
            for connection, log_ns, raw in reader.messages(connections):
                self._messages += 1
                try:
                    message = reader.deserialize(raw, connection.msgtype)
                except AnyReaderError as exc:
                    self._malformed(part, connection.topic, log_ns, exc)
                    continue
                if connection.topic == self._joints_topic:
                    self._add_joints(sync, log_ns, message)
                elif connection.topic == self.topics.channels:
                    self._add_channels(sync, connection.msgtype, log_ns, message)
                else:
                    sync.add_tool(seconds(log_ns), str(message.data).strip())
                if self._messages % CHUNK_MESSAGES == 0:
                    yield from self._placed(part, sync, sync.pop())
            yield from self._placed(part, sync, sync.pop(final=True))
        finally:
            if self._reader is reader:
                self.close()
        self.n_channels = sync.n_channels
        self.skipped.update(sync.dropped)

    def _malformed(self, part: BagPart, topic: str, log_ns: int, exc: Exception) -> None:
        if topic == self.topics.channels:
            self.rows_read += 1
            self.skipped[MALFORMED] += 1
        self._note(f"{part.path}, topic '{topic}' at {seconds(log_ns):.9f} s: cannot decode the message ({exc}); skipped")

    def _add_joints(self, sync: Synchronizer, log_ns: int, message) -> None:
        if self._pose:
            joints = pose_joints(message)
            if isinstance(joints, str):
                self._ignored_joints += 1
                self._note(f"{self._reading}, topic '{self._joints_topic}' at {seconds(log_ns):.9f} s: {joints}; ignored")
            else:
                sync.add_joints(self._joint_time(log_ns, message), joints)
            return
        index = self._index(tuple(message.name))
        position = np.asarray(message.position, dtype=float)
        if index is None or len(position) != len(message.name):
            self._ignored_joints += 1
            return
        sync.add_joints(self._joint_time(log_ns, message), dict(zip(self.joint_names, position[index].tolist(), strict=True)))

    def _add_channels(self, sync: Synchronizer, msgtype: str, log_ns: int, message) -> None:
        self.rows_read += 1
        if msgtype == WRENCH_STAMPED:
            f, m = message.wrench.force, message.wrench.torque
            t, values = stamp_s(message.header.stamp), (f.x, f.y, f.z, m.x, m.y, m.z)
        else:
            t, values = seconds(log_ns), tuple(np.asarray(message.data, dtype=float).tolist())
        sync.add_strain(t, values)
        if self.n_channels is None:
            self.n_channels = sync.n_channels

    def _placed(self, part: BagPart, sync: Synchronizer, batch: SampleBatch) -> Iterator[SampleBatch]:
        """The synchronizer's batch with the tool's configuration indices; unknown names counted and skipped."""
        if not len(batch):
            return
        names = sync.configurations  # the synchronizer indexes names in order of announcement
        if self._open_tools:
            for name in names:
                self.tool_codes.setdefault(name, len(self.tool_codes))
        lookup = np.array([self.tool_codes.get(name, -1) for name in names], dtype=np.int64)
        codes = lookup[batch.configuration]
        unknown = codes < 0
        if unknown.any():
            for k in np.unique(batch.configuration[unknown]):
                name = names[k]
                if name not in self.unknown_tools:
                    first = float(batch.time[batch.configuration == k][0])
                    self._note(
                        f"{part.path}, topic '{self.topics.configuration}' at {first:.9f} s: unknown tool configuration '{name}' "
                        f"(known: {', '.join(self.tool_codes)}); its samples are skipped"
                    )
                self.unknown_tools[name] += int(np.sum(batch.configuration == k))
            self.skipped[UNKNOWN_TOOL] += int(unknown.sum())
        keep = ~unknown
        full = np.column_stack((batch.time, batch.joints, batch.channels, codes))
        if self._previous is not None and self._previous.shape != full.shape[1:]:
            self._previous = None  # another channel count: nothing to repeat
        repeated = repeated_rows(full, self._previous) & keep
        self._previous = full[-1]
        if repeated.any():  # a message recorded twice: each sample counts once
            self.skipped[DUPLICATE] += int(repeated.sum())
            if self.skipped[DUPLICATE] == int(repeated.sum()):
                first = float(batch.time[np.argmax(repeated)])
                self._note(f"{part.path}, topic '{self.topics.channels}' at {first:.9f} s: a sample recorded twice; dropped (counted once)")
            keep &= ~repeated
        if keep.any():
            yield SampleBatch(batch.time[keep], batch.joints[keep], batch.channels[keep], codes[keep])

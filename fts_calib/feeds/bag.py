"""ROS 2 bags (MCAP or sqlite3) as a feed: joint states and channels, synchronised into SampleBatch.

Bags are read with the ``rosbags`` library (pure Python: no ROS install). The robot-log
contract of DESIGN.md, topic names being options (:class:`BagTopics`):

- joints: ``sensor_msgs/msg/JointState`` (default ``/joint_states``), stamped by their
  header; positions in [rad], mapped to the robot's joints by name (other names, e.g. a
  gripper's fingers, are ignored; a message without the robot's joints is ignored and noted);
- channels: ``std_msgs/msg/Float64MultiArray`` (default ``/ft_sensor/raw``; its ``data`` are
  the n raw channels, stamped by the bag's log time), or ``geometry_msgs/msg/WrenchStamped``
  (6 channels ``[fx, fy, fz, tx, ty, tz]`` in [N, N·m], header stamps: the ``wrench-6``
  channel layout);
- or, for a run without a robot, the sensor's orientation: ``geometry_msgs/msg/PoseStamped``
  (default ``/ft_sensor/pose``, :mod:`fts_calib.feeds.bag_pose`) instead of the joints, stamped
  as they would be;
- the tool configuration: ``std_msgs/msg/String`` (default ``/fts_calib/configuration``), a
  configuration name of the tool file from its log time on; or one bag per configuration
  (``RUN_A.mcap:A``, :func:`parse_bag_argument`), the topic then unused.

The two streams must be on one clock. Before reading, the first :data:`PEEK_MESSAGES` joint
and channel messages are compared with the bag's log time, and a bag is refused with the
cause and the way out (``joint_stamps='log'``, ``--joint-stamps log``) when the joint stamps
do not move while the log time does (a log of simulated time, whose header stamps stay 0),
or when they are more than :data:`~fts_calib.feeds.bag_checks.MAX_CLOCK_OFFSET_S` from the channels' clock (a driver
stamping on another clock): no channel sample could then be placed.

The joint and channel streams go through the live path's synchronizer
(:mod:`fts_calib.feeds.sync`): joints are interpolated at the channel times (a shared stamp
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
from collections import Counter
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from ..core.exceptions import BagError, ConfigError, UnknownToolConfiguration
from .bag_checks import check_clocks, refuse_repeated_parts
from .bag_log import (
    FLOAT64_ARRAY,
    JOINT_STATE,
    POSE_STAMPED,
    STRING,
    WRENCH_STAMPED,
    BagPart,
    BagTopics,
    bag_size,
    open_bag,
    parse_bag_argument,
    seconds,
    stamp_s,
)
from .bag_pose import is_pose_run, missing_pose_topic, pose_joints
from .batch import DUPLICATE, UNKNOWN_TOOL, SampleBatch, repeated_rows
from .row_notes import MAX_NOTES
from .sync import Synchronizer

#: Messages read between two pairings of the streams (about 1 MiB of samples in memory).
CHUNK_MESSAGES = 20_000
#: Joint messages looked at, at the start of a bag, for one that holds every robot joint.
PEEK_MESSAGES = 200


#: Skip reason counted by the bag reader (channel samples; the synchronizer counts the others).
MALFORMED = "malformed message"


class BagReader:
    """Read one or more bags as :class:`SampleBatch` es (see the module docstring).

    The same interface as :class:`fts_calib.feeds.recording.RecordingReader`: iterate for
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
            "expected every joint of the robot definition, by name",
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

"""Simulated robot logs: a run written as a ROS 2 bag (MCAP or sqlite3), as a robot's logger would.

The bag follows the robot-log contract of :mod:`fts_calib.sources.bag` (docs/formats.md): joint
states with header stamps, the channels as ``std_msgs/msg/Float64MultiArray`` at their log
time or as ``geometry_msgs/msg/WrenchStamped`` with header stamps (6 channels), and the tool
configuration as ``std_msgs/msg/String`` when it changes; or, for a run without a robot, the
sensor's orientation as ``geometry_msgs/msg/PoseStamped`` instead of the joints. Written with the ``rosbags``
library's writer; times in [s] become integer nanoseconds (rounded).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..core.exceptions import ConfigError, ShapeError
from ..sources.bag import FLOAT64_ARRAY, JOINT_STATE, POSE_STAMPED, STRING, WRENCH_STAMPED, BagTopics
from ..sources.source import open_recording

#: Storage plugins of a bag, by name.
STORAGES = ("mcap", "sqlite3")


def _ns(t: float) -> int:
    return int(round(float(t) * 1e9))


class BagWriter:
    """Write the messages of a robot log into a new bag folder (see the module docstring).

    Args:
        path: The bag folder to create (it must not exist); the storage file inside it is
            ``<name>.mcap`` or ``<name>.db3``.
        storage: ``"mcap"`` or ``"sqlite3"``.
        channels_type: ``std_msgs/msg/Float64MultiArray`` or ``geometry_msgs/msg/WrenchStamped``.
        topics: Topic names.
        configuration_topic: Whether the bag has the configuration topic.
        poses: The bag has the pose topic (:meth:`pose`) instead of the joint topic.

    Raises:
        ConfigError: An unknown storage or channel type.
    """

    def __init__(
        self,
        path: str | Path,
        storage: str = "mcap",
        channels_type: str = FLOAT64_ARRAY,
        topics: BagTopics | None = None,
        configuration_topic: bool = True,
        poses: bool = False,
    ):
        from rosbags.rosbag2 import StoragePlugin, Writer
        from rosbags.typesys import Stores, get_typestore

        if storage not in STORAGES:
            raise ConfigError("storage", storage, f"one of {', '.join(STORAGES)}")
        if channels_type not in (FLOAT64_ARRAY, WRENCH_STAMPED):
            raise ConfigError("channels_type", channels_type, f"{FLOAT64_ARRAY} or {WRENCH_STAMPED}")
        self.path = Path(path)
        self.topics = topics or BagTopics()
        self.channels_type = channels_type
        self._store = get_typestore(Stores.ROS2_HUMBLE)
        self._types = self._store.types
        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        self._writer = Writer(self.path, version=9, storage_plugin=plugin)
        self._writer.open()
        add = self._writer.add_connection
        self._joints = (
            add(self.topics.pose, POSE_STAMPED, typestore=self._store)
            if poses
            else add(self.topics.joints, JOINT_STATE, typestore=self._store)
        )
        self._channels = add(self.topics.channels, channels_type, typestore=self._store)
        self._configuration = add(self.topics.configuration, STRING, typestore=self._store) if configuration_topic else None

    def _header(self, ns: int):
        T = self._types
        return T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9), frame_id="")

    def _write(self, connection, ns: int, message) -> None:
        self._writer.write(connection, ns, self._store.serialize_cdr(message, message.__msgtype__))

    def joints(self, t: float, names: Sequence[str], position: Sequence[float], log_t: float | None = None) -> None:
        """A joint state stamped ``t`` [s]: ``position`` [rad] of the joints ``names``; logged at ``log_t`` [s] (``t`` when None)."""
        ns, empty = _ns(t), np.zeros(0)
        message = self._types[JOINT_STATE](
            header=self._header(ns), name=list(names), position=np.array(position, dtype=float), velocity=empty, effort=empty
        )
        self._write(self._joints, ns if log_t is None else _ns(log_t), message)

    def pose(self, t: float, quaternion: Sequence[float], position: Sequence[float] = (0.0, 0.0, 0.0)) -> None:
        """A PoseStamped stamped and logged at ``t`` [s]: orientation ``quaternion`` ``[w, x, y, z]``, ``position`` [m]."""
        ns, T = _ns(t), self._types
        w, x, y, z = (float(v) for v in quaternion)
        pose = T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](*map(float, position)), orientation=T["geometry_msgs/msg/Quaternion"](x, y, z, w)
        )
        self._write(self._joints, ns, T[POSE_STAMPED](header=self._header(ns), pose=pose))

    def channels(self, t: float, values: Sequence[float], log_t: float | None = None) -> None:
        """Raw channels at ``t`` [s]: the log time of a Float64MultiArray, the header stamp of a WrenchStamped (6 values).

        ``log_t`` [s]: the log time of a WrenchStamped (``t`` when None; a Float64MultiArray is logged at ``t``).
        """
        ns, T = _ns(t), self._types
        data = np.array(values, dtype=float)  # a contiguous copy: the serializer needs one
        if self.channels_type == WRENCH_STAMPED:
            if data.shape != (6,):
                raise ShapeError(f"values.shape={data.shape} but expected (6,) for {WRENCH_STAMPED}")
            vector = T["geometry_msgs/msg/Vector3"]
            wrench = T["geometry_msgs/msg/Wrench"](force=vector(*data[:3]), torque=vector(*data[3:]))
            message = T[WRENCH_STAMPED](header=self._header(ns), wrench=wrench)
        else:
            message = T[FLOAT64_ARRAY](layout=T["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0), data=data)
        self._write(self._channels, ns if log_t is None or self.channels_type != WRENCH_STAMPED else _ns(log_t), message)

    def configuration(self, t: float, name: str) -> None:
        """The tool configuration ``name`` mounted from ``t`` [s] on."""
        if self._configuration is None:
            raise ConfigError("configuration_topic", False, "", message="this bag was made without a configuration topic")
        self._write(self._configuration, _ns(t), self._types[STRING](data=name))

    def close(self) -> Path:
        """Finish the bag (its metadata.yaml is written); returns its folder."""
        self._writer.close()
        return self.path

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        self.close()


def recording_to_bag(recording: str | Path, path: str | Path, storage: str = "mcap", channels_type: str = FLOAT64_ARRAY) -> Path:
    """Write a CSV recording as a bag: one joint state and one channel message per row, at its time.

    The tool configuration is announced on the configuration topic whenever it changes
    (and at the first row). Joint names are the recording's columns.

    Args:
        recording: The CSV recording (.csv or .csv.gz).
        path: The bag folder to create.
        storage: ``"mcap"`` or ``"sqlite3"``.
        channels_type: ``std_msgs/msg/Float64MultiArray``, or ``geometry_msgs/msg/WrenchStamped``
            for a recording of 6 channels (a wrench).

    Returns:
        The bag folder.
    """
    with open_recording(recording, None, None) as reader, BagWriter(path, storage, channels_type) as writer:
        current = None
        for batch in reader:
            names, tools = reader.joint_names, reader.tool_names
            for t, joints, channels, code in zip(batch.time, batch.joints, batch.channels, batch.configuration, strict=True):
                if tools[code] != current:
                    current = tools[code]
                    writer.configuration(t, current)
                writer.joints(t, names, joints)
                writer.channels(t, channels)
    return Path(path)

"""The robot-log contract of a ROS 2 bag (DESIGN.md): message types, topic names, bag arguments.

Read and written with the ``rosbags`` library (pure Python: no ROS install); bags that do
not embed their message definitions are read with ROS 2 Humble's standard ones. Stamps are
integer nanoseconds; :func:`seconds` turns them into [s], correctly rounded.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..core.exceptions import BagError, ConfigError, FileFormatError
from ..core.fileio import load_yaml

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
    """Topic names of a robot log (the defaults are DESIGN.md's).

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

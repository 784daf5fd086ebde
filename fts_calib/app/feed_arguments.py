"""Command-line arguments of the feeds: a recording or ROS 2 bags, and a UR arm through RTDE.

Used by :mod:`fts_calib.app.arguments` for ``calibrate``, ``validate``, ``replay`` (the
recording and a bag's topic names) and ``live`` (``--ur``); each destination is a parameter
of the command's ``run``.
"""

from __future__ import annotations

import argparse

from ..feeds.bag_log import JOINT_STAMPS, BagTopics
from ..feeds.rtde import TIMEOUT_S

#: Help text of the recording argument of calibrate, validate and replay.
RECORDING_HELP = (
    "recording CSV (or .csv.gz); several CSVs read as one, in order (e.g. one per static pose: a.csv b.csv, or a quoted "
    "pattern 'poses/*.csv', expanded in natural order); or ROS 2 bags: RUN.mcap, RUN.db3 or a bag folder; "
    "one bag per tool configuration as BAG:CONFIGURATION (e.g. a.mcap:A b.mcap:B)"
)


#: What a feed gives instead of joints when there is no ``--robot`` (fts_calib.robot.orientation).
ORIENTATION_HELP = (
    "CSV columns qw,qx,qy,qz or roll,pitch,yaw or tcp_rx,tcp_ry,tcp_rz; a bag's geometry_msgs/msg/PoseStamped topic; "
    'datagrams with an "R" or "quat" field; gravity -Z of the world'
)


def add_robot_or_orientation(parser: argparse.ArgumentParser, what: str = "the recording", required_for: str = "", note: str = "") -> None:
    """``--robot`` (optional) and ``--mount R P Y``: joints and a robot, or a feed that gives the sensor's orientation.

    Args:
        parser: The command's parser.
        what: What gives the orientation without a robot (for the help text).
        required_for: When the orientation is needed at all (e.g. "with a mounted configuration"), for the help text.
        note: Appended to the help of ``--mount``.
    """
    needed = f" ({required_for})" if required_for else ""
    parser.add_argument(
        "--robot",
        help=f"robot definition: a shipped name (ur5) or a YAML path{needed}; without it {what} gives the sensor's "
        f"orientation ({ORIENTATION_HELP})",
    )
    parser.add_argument(
        "--mount",
        dest="mount_rpy",
        nargs=3,
        type=float,
        metavar=("R", "P", "Y"),
        help=f"without --robot: roll, pitch, yaw in rad from the frame whose orientation {what} gives (e.g. the "
        f"TCP of tcp_rx,tcp_ry,tcp_rz) to the sensor (default: 0 0 0){note}",
    )


def add_recording(parser: argparse.ArgumentParser, pose: bool = False) -> None:
    """The recording argument (a CSV, or ROS 2 bags) and the topic names of a bag (``pose``: the pose topic too)."""
    parser.add_argument("recording", nargs="+", metavar="RECORDING", help=RECORDING_HELP)
    default = BagTopics()
    bag = parser.add_argument_group("ROS 2 bags (topic names; docs/formats.md, ROS 2 bags)")
    bag.add_argument("--joints-topic", default=default.joints, help=f"sensor_msgs/msg/JointState topic (default {default.joints})")
    if pose:
        bag.add_argument(
            "--pose-topic",
            default=default.pose,
            help=f"without --robot: geometry_msgs/msg/PoseStamped topic of the sensor's orientation, read instead of the joints "
            f"(default {default.pose})",
        )
    bag.add_argument(
        "--channels-topic",
        default=default.channels,
        help=f"std_msgs/msg/Float64MultiArray or geometry_msgs/msg/WrenchStamped topic (default {default.channels})",
    )
    bag.add_argument(
        "--configuration-topic",
        default=default.configuration,
        help=f"std_msgs/msg/String topic of the tool configuration (default {default.configuration})",
    )
    bag.add_argument(
        "--joint-stamps",
        choices=JOINT_STAMPS,
        default=default.joint_stamps,
        help="time of a joint message: its header stamp (default), or the bag's log time (a log of simulated time whose "
        "header stamps stay 0, or a joint driver on another clock)",
    )


def add_ur(parser: argparse.ArgumentParser) -> None:
    """--ur HOST and --ur-wrench: a UR arm's joints (and built-in sensor) through RTDE (live)."""
    ur = parser.add_argument_group("UR arms through RTDE (pip install 'fts-calib[ur]')")
    ur.add_argument("--ur", metavar="HOST", help="read the joints of the UR controller at HOST through RTDE instead of joint datagrams")
    ur.add_argument(
        "--ur-wrench",
        action="store_true",
        help="with --ur: the channels are the built-in sensor's raw wrench (needs a wrench-6 --sensor, e.g. factory_sensor)",
    )
    ur.add_argument(
        "--ur-timeout",
        dest="ur_timeout_s",
        type=float,
        default=TIMEOUT_S,
        metavar="SECONDS",
        help=f"with --ur: the longest wait for the controller's handshake, connection and first sample, in s (default {TIMEOUT_S:g}; "
        "then exit 16)",
    )

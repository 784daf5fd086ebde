"""A ROS 2 bag's ``geometry_msgs/msg/PoseStamped`` topic as the sensor's orientation (a run without a robot).

Its quaternion gives ``R_world_sensor`` (or, with a mount rotation, the orientation of the
frame the sensor is mounted on, e.g. a UR's TCP pose in its base frame); its position is not
used. Each message becomes the gimbal's joints ``[yaw, pitch, roll]``
(:mod:`fts_calib.robot.orientation`), which the bag reader's synchronizer interpolates at
the channel times as it would a robot's joints. A quaternion farther than
:data:`~fts_calib.robot.orientation.UNIT_TOLERANCE` from unit norm, or not finite, is ignored
and noted.
"""

from __future__ import annotations

from pathlib import Path

from ..core.exceptions import BagError
from .bag_log import POSE_STAMPED, BagTopics

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

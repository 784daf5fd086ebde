"""The ``replay`` command: send a recording as the live protocol, to test the live path without a robot."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from ..sources.bag import BagTopics
from ..sources.sender import ReplayOptions, replay
from ..sources.source import recording_paths
from .exit_codes import ExitCode, using_udp


def run(
    *,
    recording: str | Path | Sequence[str | Path],
    to: tuple[str, int] = ("127.0.0.1", 5005),
    speed: float = 1.0,
    joint_rate_hz: float | None = None,
    latency_s: float = 0.0,
    loss: float = 0.0,
    reorder: float = 0.0,
    seed: int = 0,
    joints_topic: str = BagTopics.joints,
    channels_topic: str = BagTopics.channels,
    configuration_topic: str = BagTopics.configuration,
    joint_stamps: str = BagTopics.joint_stamps,
) -> int:
    """Send a recording's rows as live datagrams, numbered by ``seq``, and print what was sent (``fts-calib replay``).

    Args:
        recording: Recording (CSV or CSV.gz), or ROS 2 bags (each optionally ``BAG:CONFIGURATION``):
            a bag's channel samples, with the joints synchronised at their times, as rows.
        to: (host, port) to send to.
        speed: Time scale: 1 real time, 10 ten times faster, 0 no pacing.
        joint_rate_hz: Joint messages per second, in [Hz]; one per row when None.
        latency_s: Joint stamps are late by this, in [s].
        loss: Fraction of joint and strain messages dropped, in [0, 1).
        reorder: Fraction of messages delayed by one to five places, in [0, 1).
        seed: Seed of the loss and the reordering.
        joints_topic: A bag's sensor_msgs/msg/JointState topic.
        channels_topic: A bag's std_msgs/msg/Float64MultiArray or geometry_msgs/msg/WrenchStamped topic.
        configuration_topic: A bag's std_msgs/msg/String topic of the tool configuration.
        joint_stamps: A bag's joint times: 'header' (their header stamps) or 'log' (the bag's log time).

    Returns:
        0.
    """
    options = ReplayOptions(speed=speed, joint_rate_hz=joint_rate_hz, latency_s=latency_s, loss=loss, reorder=reorder, seed=seed)
    host, port = to
    paths = recording_paths(recording)
    print(f"replaying {' '.join(map(str, paths))} to udp://{host}:{port} at speed {speed:g}...", flush=True)
    with using_udp(host, port):
        stats = replay(paths, host, port, options, BagTopics(joints_topic, channels_topic, configuration_topic, joint_stamps))
    numbered = stats.sent + stats.dropped  # every message has its seq, the dropped ones too: the receiver counts them as lost
    print(
        f"sent {stats.sent:,} datagrams in {stats.seconds:.1f} s, seq 0 to {numbered - 1:,} "
        f"({stats.dropped:,} dropped and {stats.reordered:,} reordered on purpose)"
    )
    return ExitCode.OK

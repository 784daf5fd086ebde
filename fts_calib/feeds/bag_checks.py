"""Checks of ROS 2 bags before they are read: a bag given twice, and joint and channel stamps on two clocks.

Both refuse a bag with the cause and the way out (see :mod:`fts_calib.feeds.bag`): samples
counted twice, or no channel sample that could be placed between two joint readings.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..core.exceptions import BagError
from .bag_log import BAG_SUFFIXES, BagPart, BagTopics

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

"""The samples of a payload recording: read, one payload checked, bad rows and railed channels refused.

Shared by the payload identification from still poses (:mod:`fts_calib.service.payload`) and
from a continuous motion (:mod:`fts_calib.service.payload_motion`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.exceptions import PayloadError
from ..feeds.batch import SampleBatch
from ..feeds.source import open_recording
from ..model.calibration import Calibration
from ..model.channel_limits import ChannelLimits, detect_limits
from ..model.channels import CALIBRATION_HINT, check_channels
from ..pipeline.checks import SampleChecks
from ..robot.kinematics import Kinematics


@dataclass(frozen=True)
class PayloadSamples:
    """The accepted samples of a payload recording.

    Attributes:
        samples: Rows that passed the checks (configuration 0 for all), in time order.
        rows: Rows read.
        limits: The channels' resolution and rails (declared, or detected in the recording).
        rails: One line per channel whose samples were refused at its rail.
    """

    samples: SampleBatch
    rows: int
    limits: ChannelLimits
    rails: tuple[str, ...]


def read_payload_samples(
    path: str | Path, kin: Kinematics, calibration: Calibration, limits: ChannelLimits | None = None
) -> PayloadSamples:
    """Read a recording of one payload and keep the rows the session's checks accept.

    Args:
        path: Recording (CSV, CSV.gz or a ROS 2 bag) of one payload: one name in its
            configuration column (any name; more than one is refused).
        kin: Kinematics of the robot.
        calibration: The sensor's calibration (its channel layout is checked).
        limits: The channels' declared resolution and rails; what is not declared is detected.

    Raises:
        RecordingError: The recording cannot be read.
        PayloadError: No usable row, or more than one configuration name.
    """
    with open_recording(path, kin.joint_names, None) as reader:
        chunks = list(reader)
        names = list(reader.tool_names)
    if not chunks:
        raise PayloadError(f"{path}: no usable row")
    return check_payload_samples(SampleBatch.concatenate(chunks), names, str(path), kin, calibration, limits)


def check_payload_samples(
    samples: SampleBatch,
    names: list[str],
    where: str,
    kin: Kinematics,
    calibration: Calibration,
    limits: ChannelLimits | None = None,
) -> PayloadSamples:
    """Keep the rows of one payload's samples (a recording's, or a live feed's) that the session's checks accept.

    Args:
        samples: The samples read, in time order; ``configuration`` indexes ``names``.
        names: The tool configuration names the samples may hold (one payload: more than one held is refused).
        where: Where they come from, for the messages (a path, ``udp://HOST:PORT``).
        kin: Kinematics of the robot.
        calibration: The sensor's calibration (its channel layout is checked).
        limits: The channels' declared resolution and rails; what is not declared is detected.

    Raises:
        PayloadError: No sample, or more than one configuration name.
    """
    if not len(samples):
        raise PayloadError(f"{where}: no usable row")
    check_channels(calibration.layout, samples.channels.shape[1], where, CALIBRATION_HINT)
    held = [names[k] for k in np.unique(samples.configuration) if 0 <= k < len(names)]
    if len(held) > 1:  # one fit of one payload would mix their weights
        raise PayloadError(
            f"{where} holds {len(held)} tool configurations ({', '.join(held)}): a payload recording holds one payload; "
            "record each alone (or keep only its rows) and identify them one by one"
        )
    rows = len(samples)
    samples = dataclasses.replace(samples, configuration=np.zeros(rows, dtype=np.int64))
    finite = np.all(np.isfinite(samples.channels), axis=1)
    found = detect_limits(samples.channels[finite], limits)
    checks = SampleChecks(kin, limits=found)
    samples = samples.select(checks.accept(samples))  # a NaN, a railed channel or a row out of order never poisons a window
    rails = () if checks.rails is None else tuple(checks.rails.lines(held or ["payload"]))
    return PayloadSamples(samples, rows, found, rails)

"""The ``monitor`` command: the sensor's health over a recording, from the calibration's parity model."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..core.exceptions import ConfigError
from ..core.outputs import atomic_write_text
from ..core.paths import check_outputs
from ..feeds.bag_log import BagTopics
from ..feeds.source import open_recording, recording_paths
from ..model.calibration import load_calibration
from ..model.channels import check_channels
from ..model.health import ParityModel
from ..service.health import HealthMonitor
from .exit_codes import ExitCode, writing


def run(
    *,
    recording: str | Path | Sequence[str | Path],
    calibration: str | Path,
    json_path: str | Path | None = None,
    false_alarms_per_hour: float = 1e-3,
    joints_topic: str = BagTopics.joints,
    channels_topic: str = BagTopics.channels,
    configuration_topic: str = BagTopics.configuration,
    joint_stamps: str = BagTopics.joint_stamps,
) -> int:
    """Watch a recording's channels with the calibration's parity model (``fts-calib monitor``).

    Args:
        recording: Recording (CSV or CSV.gz) of the sensor in service, or ROS 2 bags.
        calibration: Calibration file with a ``health`` section.
        json_path: Where to write ``{"events": [{"time_s", "kind", "channel", "detail"}, ...],
            "samples": N, "skipped": {...}, "health": "ok" | "fault"}``, atomically; None for none.
        false_alarms_per_hour: False-alarm budget of the tests, per hour of service.
        joints_topic: A bag's sensor_msgs/msg/JointState topic.
        channels_topic: A bag's std_msgs/msg/Float64MultiArray or geometry_msgs/msg/WrenchStamped topic.
        configuration_topic: A bag's std_msgs/msg/String topic of the tool configuration.
        joint_stamps: A bag's joint times: 'header' (their header stamps) or 'log' (the bag's log time).

    Returns:
        0 when no fault was found, 1 when one was.

    Raises:
        ConfigError: The calibration has no health section (a layout with no more channels
            than axes, or a file written before it existed).
    """
    paths = recording_paths(recording)
    check_outputs({"--json": json_path}, {"the calibration": calibration, **{f"recording {k + 1}": p for k, p in enumerate(paths)}})
    cal = load_calibration(calibration)
    if cal.health is None:
        why = (
            "its layout has no more channels than axes: nothing is load-free"
            if cal.layout.n_channels <= 6
            else "it was written before the health section existed: calibrate again"
        )
        raise ConfigError("health", None, "the calibration's parity model", message=f"{calibration} has no health section: {why}")
    parity = ParityModel.from_dict(cal.health)
    monitor: HealthMonitor | None = None
    skipped = 0
    first_time = last_time = None
    topics = BagTopics(joints_topic, channels_topic, configuration_topic, joint_stamps)
    with open_recording(paths, None, None, topics=topics) as reader:
        for chunk in reader:
            check_channels(cal.layout, chunk.channels.shape[1], str(reader.path))
            finite = np.isfinite(chunk.time) & np.all(np.isfinite(chunk.channels), axis=1)
            skipped += int((~finite).sum())
            time, channels = chunk.time[finite], chunk.channels[finite]
            if not len(time):
                continue
            if monitor is None:
                steps = np.diff(time)
                steps = steps[steps > 0]
                rate_hz = 1.0 / float(np.median(steps)) if len(steps) else 1000.0
                monitor = HealthMonitor(parity, rate_hz, false_alarms_per_hour=false_alarms_per_hour)
                first_time = float(time[0])
            monitor.update_batch(time, channels)
            last_time = float(time[-1])
    samples = 0 if monitor is None else monitor.samples
    events = [] if monitor is None else monitor.events
    noise = ", ".join(f"{v:.3g}" for v in np.sqrt(np.diag(parity.covariance)))
    groups = " and ".join("(" + ", ".join(str(k + 1) for k in g) + ")" for g in parity.groups())
    span = 0.0 if first_time is None or last_time is None else last_time - first_time
    print(f"monitor of {' '.join(map(str, paths))}: {samples:,} samples over {span:.1f} s with {calibration}")
    print(f"parity: {parity.n_parity} load-free combinations, noise {noise} (raw units); channels that share a parity line: {groups}")
    if skipped:
        print(f"skipped: {skipped:,} rows with a non-finite value")
    if monitor is not None:
        thresholds = f"gain z^2 > {monitor.gain_threshold:.1f}, jump chi^2 > {monitor.jump_threshold:.1f}"
        print(f"thresholds: {thresholds} ({false_alarms_per_hour:g} false alarms per hour)")
    for event in events:
        print(f"  {event.time_s:10.3f} s  {event.kind:<15} strain_{event.channel}: {event.detail} (reported at {event.detected_s:.3f} s)")
    print(f"health: {'ok, no fault found' if not events else f'{len(events)} fault(s)'}")
    if json_path is not None:
        data = {
            "events": [event.as_dict() for event in events],
            "samples": samples,
            "skipped": {"non-finite": skipped},
            "health": "fault" if events else "ok",
        }
        with writing(json_path):
            written = atomic_write_text(json_path, json.dumps(data, indent=2) + "\n")
        print(f"wrote {written}")
    return ExitCode.CHECK_FAILED if events else ExitCode.OK

"""Re-tare: new offsets D for a calibration, from a short recording or live window.

The frequent use the paper stresses: offsets drift, C does not, so before use the sensor is
held still a moment and D is estimated again (:func:`fts_calib.model.offsets.estimate_offsets`)
with C_bar kept. With nothing mounted, the known load is zero; with a known tool
configuration on, it is that configuration's weight at the orientation the kinematics give
(paper eqs 17-18), and only the quasi-static samples count. The calibration keeps its
previous offsets, and when and why they were replaced, in ``offset_history``; the result
also says how far the offsets drifted since the calibration run (against the offsets it
ended with, the first of the history) and over how long (from the calibration's time).
"""

from __future__ import annotations

import dataclasses
import datetime
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core import validation
from ..core.exceptions import ConfigError, InsufficientExcitation
from ..feeds.batch import SampleBatch
from ..feeds.protocol import Strain
from ..feeds.source import open_recording
from ..feeds.sync import Synchronizer
from ..feeds.udp import LiveStats, UdpReceiver, feed_datagram
from ..model.calibration import Calibration
from ..model.channels import CALIBRATION_HINT, check_channels
from ..model.offsets import OffsetEstimate, estimate_offsets
from ..pipeline.qsfilter import QuasiStaticFilter
from ..pipeline.settings import PipelineConfig
from ..pipeline.still import quasi_static
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool


@dataclass(frozen=True)
class TareResult:
    """A re-tare.

    Attributes:
        calibration: The calibration with the new offsets (the old ones in its history).
        estimate: The offsets and their standard errors.
        previous: The offsets before, [N, N, N, N m, N m, N m]. Shape (6,).
        samples_seen: Samples read.
        since_calibration: The new offsets minus those at the end of the calibration run,
            [N, N, N, N m, N m, N m]. Shape (6,).
        elapsed_s: Time since the calibration run [s] (from its provenance time), or None
            when the file does not say.
    """

    calibration: Calibration
    estimate: OffsetEstimate
    previous: np.ndarray
    samples_seen: int
    since_calibration: np.ndarray = field(default_factory=lambda: np.zeros(6))
    elapsed_s: float | None = None


def _known_load(
    kin: Kinematics | None,
    tool: Tool | None,
    configuration: str | None,
    settings: PipelineConfig,
    samples: SampleBatch,
) -> tuple[np.ndarray, np.ndarray]:
    """The strains to use and the load on the sensor for each (zero with nothing mounted)."""
    if tool is None:
        return samples.channels, np.zeros((len(samples), 6))
    if configuration is None:
        message = f"tool '{tool.name}' is mounted: give its configuration, one of {tool.names}"
        raise ConfigError("configuration", None, f"one of {tool.names}", message=message)
    config_index = tool.names.index(tool.configuration(configuration).name)  # UnknownToolConfiguration lists the names
    if kin is None:
        message = f"tool '{tool.name}' is mounted: its load depends on the orientation, so give the kinematics"
        raise ConfigError("kin", None, "the robot's kinematics", message=message)
    mounted = dataclasses.replace(samples, configuration=np.full(len(samples), config_index))
    still = quasi_static(QuasiStaticFilter(settings.filter, kin.continuous), kin, tool, mounted, final=True)
    return still.samples.channels, still.w_sensor if still.w_sensor is not None else np.zeros((0, 6))


def _apply(calibration: Calibration, strain: np.ndarray, load: np.ndarray, reason: str, seen: int) -> TareResult:
    if not len(strain):
        raise InsufficientExcitation(0, 1, "no still sample to re-tare from: hold the arm still while recording")
    estimate = estimate_offsets(calibration.C_bar, strain, load, calibration.layout, calibration.model)
    what = f"{reason} ({estimate.samples_used:,} samples)"
    history = calibration.offset_history
    at_calibration = np.asarray(history[0]["D"], dtype=float) if history else calibration.D
    elapsed = None
    stamp = calibration.provenance.get("time")
    if isinstance(stamp, str):
        try:
            then = datetime.datetime.fromisoformat(stamp.replace("Z", "+00:00"))
            if then.tzinfo is None:
                then = then.replace(tzinfo=datetime.timezone.utc)  # a time without a zone: UTC, as fts-calib writes it
            elapsed = (datetime.datetime.now(datetime.timezone.utc) - then).total_seconds()
        except ValueError:
            elapsed = None  # a hand-written time: the drift is still reported, without its rate
    updated = calibration.with_offsets(estimate.D, what)
    return TareResult(updated, estimate, calibration.D.copy(), seen, estimate.D - at_calibration, elapsed)


def _what(tool: Tool | None, configuration: str | None) -> str:
    return "nothing mounted" if tool is None else f"'{tool.name}' configuration {configuration} mounted"


def tare_recording(
    calibration: Calibration,
    path: str | Path,
    kin: Kinematics | None = None,
    tool: Tool | None = None,
    configuration: str | None = None,
    settings: PipelineConfig | None = None,
) -> TareResult:
    """Re-tare from a recording (see the module docstring).

    Args:
        calibration: The calibration to update.
        path: Recording (CSV, or a ROS 2 bag: :mod:`fts_calib.feeds.source`) with the sensor still.
        kin: Kinematics (needed with a tool; with nothing mounted the joints are not used).
        tool: The mounted tool, or None for nothing mounted.
        configuration: The mounted configuration of ``tool``.
        settings: Pipeline settings (filter thresholds).

    Raises:
        RecordingError: The recording cannot be read.
        InsufficientExcitation: No usable sample.
    """
    settings = settings or PipelineConfig()
    joint_names = None if kin is None else kin.joint_names
    with open_recording(path, joint_names, None) as reader:
        chunks = list(reader)
    seen = reader.rows_read
    if not chunks:
        raise InsufficientExcitation(0, 1, f"{path} has no usable row")
    samples = SampleBatch.concatenate(chunks)
    check_channels(calibration.layout, samples.channels.shape[1], str(path), CALIBRATION_HINT)
    finite = np.all(np.isfinite(samples.channels), axis=1) & (np.all(np.isfinite(samples.joints), axis=1) if kin is not None else True)
    strain, load = _known_load(kin, tool, configuration, settings, samples.select(finite))
    return _apply(calibration, strain, load, f"re-tare from {Path(path).name}, {_what(tool, configuration)}", seen)


def tare_live(
    calibration: Calibration,
    host: str,
    port: int,
    seconds: float,
    kin: Kinematics | None = None,
    tool: Tool | None = None,
    configuration: str | None = None,
    settings: PipelineConfig | None = None,
    on_listening: Callable[[tuple[str, int]], None] | None = None,
) -> TareResult:
    """Re-tare from a live window of ``seconds`` [s] (> 0) on the UDP protocol (see :mod:`fts_calib.pipeline.live`).

    ``on_listening`` is called with the bound (host, port) once the socket listens (port 0
    picks a free one), before the window starts.
    """
    validation.positive("seconds", seconds, "s")
    settings = settings or PipelineConfig()
    receiver = UdpReceiver(host, port)
    host, port = receiver.address[:2]
    sync = None if kin is None else Synchronizer(kin.joint_names, kin.continuous, settings.live.max_gap_s, settings.live.latency_s)
    stats = LiveStats()
    strains: list[tuple[float, ...]] = []
    try:
        if on_listening is not None:
            on_listening((host, port))
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            for data in receiver.drain():
                message = feed_datagram(data, sync, stats)
                if isinstance(message, Strain):
                    strains.append(message.strain)
            time.sleep(0.005)
    finally:
        receiver.close()
    reason = f"re-tare from a live window of {seconds:g} s on udp://{host}:{port}, {_what(tool, configuration)}"
    if not strains:
        heard = f"{stats.received:,} datagrams, none of them strain" if stats.received else "no datagram at all"
        raise InsufficientExcitation(0, 1, f"{heard} on udp://{host}:{port} in {seconds:g} s: is the sender running, to this port?")
    if sync is None:
        s = np.array(strains, dtype=float).reshape(len(strains), -1)
        return _apply(calibration, s, np.zeros((len(s), 6)), reason, len(s))
    strain, load = _known_load(kin, tool, configuration, settings, sync.pop(final=True))
    return _apply(calibration, strain, load, reason, len(strains))

"""Re-tare: new offsets D for a calibration, from a short recording or live window.

The frequent use the paper stresses: offsets drift, C does not, so before use the sensor is
held still a moment and D is estimated again (:func:`fts_calib.model.estimator.estimate_offsets`)
with C_bar kept. With nothing mounted, the known load is zero; with a known tool
configuration on, it is that configuration's weight at the orientation the kinematics give
(paper eqs 17-18), and only the quasi-static samples count. The calibration keeps its
previous offsets, and when and why they were replaced, in ``offset_history``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.exceptions import InsufficientExcitation
from ..feeds.protocol import Joints, ProtocolError, Strain, ToolChange, decode
from ..feeds.recording import RecordingReader
from ..model.calibration import Calibration
from ..model.estimator import OffsetEstimate, estimate_offsets
from ..pipeline.qsfilter import QuasiStaticFilter
from ..pipeline.settings import PipelineConfig
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
    """

    calibration: Calibration
    estimate: OffsetEstimate
    previous: np.ndarray
    samples_seen: int


def _known_load(
    kin: Kinematics | None,
    tool: Tool | None,
    configuration: str | None,
    config: PipelineConfig,
    time_s: np.ndarray,
    readings: np.ndarray | None,
    strain: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The strains to use and the load on the sensor for each (zero with nothing mounted)."""
    if tool is None:
        return strain, np.zeros((len(strain), 6))
    if configuration is None:
        raise ValueError(f"tool '{tool.name}' is mounted: give its configuration, one of {tool.names}")
    config_index = tool.names.index(configuration)
    if kin is None:
        raise ValueError(f"tool '{tool.name}' is mounted: its load depends on the orientation, so give the kinematics")
    filt = QuasiStaticFilter(config.filter, kin, tool)
    decided = filt.process(time_s, readings, strain, np.full(len(time_s), config_index), final=True)
    weight = tool.configurations[config_index].static_wrench(decided.g_sensor) if len(decided.g_sensor) else np.zeros((0, 6))
    return decided.strain[decided.keep], weight


def _apply(calibration: Calibration, strain: np.ndarray, load: np.ndarray, reason: str, seen: int) -> TareResult:
    if not len(strain):
        raise InsufficientExcitation(0, 1, "no still sample to re-tare from: hold the arm still while recording")
    estimate = estimate_offsets(calibration.C_bar, strain, load)
    what = f"{reason} ({estimate.samples_used:,} samples)"
    return TareResult(calibration.with_offsets(estimate.D, what), estimate, calibration.D.copy(), seen)


def _what(tool: Tool | None, configuration: str | None) -> str:
    return "nothing mounted" if tool is None else f"'{tool.name}' configuration {configuration} mounted"


def tare_recording(
    calibration: Calibration,
    path: str | Path,
    kin: Kinematics | None = None,
    tool: Tool | None = None,
    configuration: str | None = None,
    config: PipelineConfig | None = None,
) -> TareResult:
    """Re-tare from a recording (see the module docstring).

    Args:
        calibration: The calibration to update.
        path: Recording with the sensor still.
        kin: Kinematics (needed with a tool; with nothing mounted the joints are not used).
        tool: The mounted tool, or None for nothing mounted.
        configuration: The mounted configuration of ``tool``.
        config: Pipeline settings (filter thresholds).

    Raises:
        RecordingError: The recording cannot be read.
        InsufficientExcitation: No usable sample.
    """
    config = config or PipelineConfig()
    joint_names = None if kin is None else kin.joint_names
    with RecordingReader(path, joint_names, None) as reader:
        chunks = list(reader)
    seen = reader.rows_read
    if not chunks:
        raise InsufficientExcitation(0, 1, f"{path} has no usable row")
    t = np.concatenate([c.time for c in chunks])
    q = np.concatenate([c.readings for c in chunks]) if kin is not None else None
    s = np.concatenate([c.strain for c in chunks])
    finite = np.all(np.isfinite(s), axis=1) & (np.all(np.isfinite(q), axis=1) if q is not None else True)
    strain, load = _known_load(kin, tool, configuration, config, t[finite], None if q is None else q[finite], s[finite])
    return _apply(calibration, strain, load, f"re-tare from {Path(path).name}, {_what(tool, configuration)}", seen)


def tare_live(
    calibration: Calibration,
    host: str,
    port: int,
    seconds: float,
    kin: Kinematics | None = None,
    tool: Tool | None = None,
    configuration: str | None = None,
    config: PipelineConfig | None = None,
    on_listening: Callable[[tuple[str, int]], None] | None = None,
) -> TareResult:
    """Re-tare from a live window of ``seconds`` [s] on the UDP protocol (see :mod:`fts_calib.pipeline.live`).

    ``on_listening`` is called with the bound (host, port) once the socket listens (port 0
    picks a free one), before the window starts.
    """
    from ..feeds.sync import Synchronizer
    from ..pipeline.live import UdpReceiver

    config = config or PipelineConfig()
    receiver = UdpReceiver(host, port)
    host, port = receiver.address[:2]
    sync = (
        None
        if kin is None
        else Synchronizer(kin.joint_names, [j.kind == "continuous" for j in kin.joints], config.live.max_gap_s, config.live.latency_s)
    )
    strains: list[tuple[float, tuple]] = []
    try:
        if on_listening is not None:
            on_listening((host, port))
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            for data in receiver.drain():
                try:
                    message = decode(data)
                except ProtocolError:
                    continue
                if isinstance(message, Strain):
                    strains.append((message.t, message.strain))
                    if sync is not None:
                        sync.add_strain(message.t, message.strain)
                elif isinstance(message, Joints) and sync is not None:
                    sync.add_joints(message.t, message.q)
                elif isinstance(message, ToolChange) and sync is not None:
                    sync.add_tool(message.t, message.name)
            time.sleep(0.005)
    finally:
        receiver.close()
    reason = f"re-tare from a live window of {seconds:g} s on udp://{host}:{port}, {_what(tool, configuration)}"
    if sync is None:
        s = np.array([v for _, v in strains], dtype=float).reshape(-1, 8)
        return _apply(calibration, s, np.zeros((len(s), 6)), reason, len(s))
    paired = sync.pop(final=True)
    strain, load = _known_load(kin, tool, configuration, config, paired.time, paired.readings, paired.strain)
    return _apply(calibration, strain, load, reason, len(strains))

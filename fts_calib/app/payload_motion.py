"""``payload --motion``: identify mass, centre of mass and inertia from a continuous motion and write the tool file."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

from ..model.calibration import Calibration
from ..pipeline.live import format_stats
from ..pipeline.settings import PipelineConfig
from ..robot.kinematics import Kinematics
from ..robot.tool import save_tool
from ..service.payload_live import MotionProgress, collect_motion, identify_live_motion
from ..service.payload_motion import NAMES
from ..service.payload_motion_recording import RecordedMotionPayload, identify_payload_from_motion
from .exit_codes import ExitCode, using_udp, writing


def format_motion_payload(found: RecordedMotionPayload) -> str:
    """The estimate with its standard errors, with units."""
    est = found.estimate
    latency = f"{1e3 * est.latency_s:.3f}" + ("" if not math.isfinite(est.stderr_latency_s) else f" ± {1e3 * est.stderr_latency_s:.1g}")
    lines = [
        f"payload from {est.samples:,} samples of motion ({found.duration_s:.1f} s; {found.rows:,} rows read), joints {latency} ms late:",
        f"  mass {est.mass:.4f} ± {est.stderr_mass:.1g} kg",
        "  centre of mass in the sensor frame "
        + ", ".join(f"{a} {v:+.5f} ± {e:.1g}" for a, v, e in zip("xyz", est.com, est.stderr_com, strict=True))
        + " m",
        "  inertia about the centre of mass "
        + ", ".join(
            f"{name} {est.inertia_com['xyz'.index(name[1]), 'xyz'.index(name[2])]:+.6f} ± {e:.1g}"
            for name, e in zip(NAMES[4:], est.stderr[4:], strict=True)
        )
        + " kg·m²",
        "  offsets "
        + ", ".join(f"{v:+.4f}" for v in est.offsets)
        + " [N, N, N, N·m, N·m, N·m] at the middle of the motion, drifting "
        + ", ".join(f"{v:+.2g}" for v in est.offset_rate)
        + " per s",
        "  residual RMS " + ", ".join(f"{v:.2g}" for v in est.residual_rms) + " [N, N·m]",
    ]
    if est.constrained:
        lines.append("  the least-squares inertia was not physical: the closest physical body is given (log-Cholesky fit)")
    return "\n".join(lines)


def motion_payload(
    recording: str | Path, kin: Kinematics, calibration: Calibration, settings: PipelineConfig, output: str | Path, name: str
) -> int:
    """Identify the payload from ``recording`` (a continuous motion), print it and write it as a tool file with its inertia.

    Args:
        recording: Recording of the payload moving (e.g. turned by the wrist joints, :mod:`fts_calib.planning.payload_excitation`).
        kin: Kinematics of the robot.
        calibration: The sensor's calibration.
        settings: Pipeline settings: the joint-rate window (``filter.derivative_window_s``) and the
            starting latency (``live.latency_s``).
        output: Tool file to write.
        name: Name of the payload in the tool file.

    Returns:
        0.
    """
    found = identify_payload_from_motion(recording, kin, calibration, settings.filter.derivative_window_s, settings.live.latency_s)
    return _write(found, str(recording), kin, output, name)


def live_motion_payload(
    listen: tuple[str, int],
    seconds: float | None,
    idle_timeout_s: float,
    kin: Kinematics,
    calibration: Calibration,
    settings: PipelineConfig,
    output: str | Path,
    name: str,
) -> int:
    """Collect a continuous motion from the live feeds, identify the payload, print it and write its tool file.

    Args:
        listen: (host, port) to bind (port 0: a free one, printed).
        seconds: End after this much motion [s]; None: at the sender's ``end`` or Ctrl-C.
        idle_timeout_s: The longest wait for a datagram [s]: none at all is a timeout.
        kin: Kinematics of the robot (the gimbal's for a feed of the sensor's orientation).
        calibration: The sensor's calibration.
        settings: Pipeline settings: the synchronizer's (``live``) and the joint-rate window.
        output: Tool file to write.
        name: Name of the payload in the tool file.

    Returns:
        0.

    Raises:
        FeedTimeout: No datagram within ``idle_timeout_s``.
        PayloadError: Nothing paired, or a motion that does not determine the payload.
    """
    host, port = listen
    until = "the sender's end" + (f", {seconds:g} s of motion" if seconds is not None else "") + " or Ctrl-C"

    def listening(address: tuple[str, int]) -> None:  # the bound port, also when --listen gave port 0
        print(
            f"listening on udp://{address[0]}:{address[1]} until {until} (at most {idle_timeout_s:g} s without data): move the payload...",
            flush=True,
        )

    shown = [0]

    def show(progress: MotionProgress) -> None:  # one status line, rewritten
        line = progress.line()[:240]
        sys.stderr.write("\r" + line.ljust(shown[0]))
        sys.stderr.flush()
        shown[0] = len(line)

    with using_udp(host, port):
        motion = collect_motion(host, port, kin, settings, calibration.layout.n_channels, seconds, idle_timeout_s, listening, show)
    sys.stderr.write("\n")
    print(format_stats(motion.stats, motion.sync))
    found = identify_live_motion(motion, kin, calibration, settings)
    return _write(found, motion.address, kin, output, name)


def _write(found: RecordedMotionPayload, source: str, kin: Kinematics, output: str | Path, name: str) -> int:
    """Print the payload and write its tool file through the output guard."""
    print(format_motion_payload(found))
    for line in found.rails:
        print(f"  refused: {line}")
    est = found.estimate
    header = (
        f"payload identified by fts-calib from {source} ({est.samples} samples of motion, {found.duration_s:.1f} s)\n"
        f"mass {est.mass:.6g} ± {est.stderr_mass:.2g} kg; com ± {', '.join(f'{e:.2g}' for e in est.stderr_com)} m; "
        f"inertia ± {', '.join(f'{e:.2g}' for e in est.stderr[4:])} kg·m² ({', '.join(NAMES[4:])})"
    )
    gravity = float(np.linalg.norm(kin.g_world()))
    with writing(output):
        path = save_tool(est.tool(name, gravity), output, header)
    print(f"wrote {path}")
    return ExitCode.OK

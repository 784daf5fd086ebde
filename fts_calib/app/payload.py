"""``payload --motion``: identify mass, centre of mass and inertia from a continuous motion and write the tool file.

The ``payload`` command: identify an unknown payload (mass, centre of mass, offsets) and write its tool file.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..core.exceptions import ConfigError
from ..core.files import check_outputs
from ..filters.settings import PipelineConfig
from ..model.calibration import Calibration, load_calibration
from ..payload.moving import NAMES
from ..payload.samples import (
    IDLE_TIMEOUT_S,
    MotionProgress,
    RecordedMotionPayload,
    collect_motion,
    identify_live_motion,
    identify_payload_from_motion,
)
from ..payload.still import MIN_SPREAD_DEG, PayloadEstimate, identify_payload_from_recording
from ..robot.kinematics import Kinematics
from ..robot.tool import save_tool
from ..session.calibration_run import format_stats
from .exit_codes import ExitCode, using_udp, writing
from .setup import load_robot_or_orientation, load_settings


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
        recording: Recording of the payload moving (e.g. turned by the wrist joints, :mod:`fts_calib.payload.inertia_motion`).
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


def format_payload(estimate: PayloadEstimate, rows: int) -> str:
    """The estimate with its standard errors, with units; ``rows`` samples were read."""
    lines = [
        f"payload from {estimate.samples:,} still samples ({rows - estimate.samples:,} moving or unsettled skipped) in "
        f"{len(estimate.poses)} orientations (gravity spread {estimate.spread_deg[0]:.1f}° and {estimate.spread_deg[1]:.1f}° RMS "
        f"about two axes; condition number {estimate.condition:.3g}):",
        f"  mass {estimate.mass:.4f} ± {estimate.stderr_mass:.1g} kg",
        "  centre of mass in the sensor frame "
        + ", ".join(f"{a} {v:+.5f} ± {e:.1g}" for a, v, e in zip("xyz", estimate.com, estimate.stderr_com, strict=True))
        + " m",
        "  offsets " + ", ".join(f"{v:+.4f}" for v in estimate.offsets) + " [N, N, N, N·m, N·m, N·m] (add to D to re-tare)",
    ]
    # the two are estimated together: both arrays or both None
    if estimate.mount_rotation is not None and estimate.stderr_mount_rotation is not None:
        lines.append(
            "  mount rotation "
            + ", ".join(
                f"{np.degrees(v):+.3f} ± {np.degrees(e):.1g}"
                for v, e in zip(estimate.mount_rotation, estimate.stderr_mount_rotation, strict=True)
            )
            + " deg"
        )
    lines.append("  residual RMS " + ", ".join(f"{v:.2g}" for v in estimate.residual_rms) + " [N, N·m]")
    return "\n".join(lines)


def run(
    *,
    recording: str | Path | None = None,
    calibration: str | Path,
    robot: str | Path | None = None,
    output: str | Path,
    name: str = "payload",
    mount: bool = False,
    min_spread_deg: float = MIN_SPREAD_DEG,
    pipeline: str | Path = "pipeline",
    mount_rpy: Sequence[float] | None = None,
    motion: bool = False,
    listen: tuple[str, int] | None = None,
    seconds: float | None = None,
    idle_timeout_s: float = IDLE_TIMEOUT_S,
) -> int:
    """Identify a payload held still in several orientations and write it as a tool file (``fts-calib payload``).

    With ``motion``, from a continuous motion instead: mass, centre of mass and inertia
    (:func:`fts_calib.app.payload.motion_payload`), from a recording or, with ``listen``,
    from the live feeds (:func:`fts_calib.app.payload.live_motion_payload`).

    Args:
        recording: Recording of the payload still in orientations that tilt gravity about two axes
            (with ``motion``: moving); None with ``listen``.
        calibration: The sensor's calibration file.
        robot: Robot definition: a shipped name (e.g. 'ur5') or a YAML path; None for a
            recording that gives the sensor's orientation (:mod:`fts_calib.robot.orientation`).
        output: Tool file to write (for gravity compensation).
        name: Name of the payload in the tool file.
        mount: Also estimate a small rotation of the sensor mount (``--estimate-mount``).
        min_spread_deg: Smallest RMS spread of the gravity directions along each of two axes, in [deg].
        pipeline: Pipeline settings (filter thresholds).
        mount_rpy: Without ``robot``: roll, pitch, yaw [rad] from the frame the recording's
            orientation gives to the sensor; None for none (``--mount R P Y``).
        motion: The recording is a continuous motion: identify the inertia too.
        listen: With ``motion``: (host, port) to collect the motion from the live feeds instead of a recording.
        seconds: With ``listen``: end after this much motion [s]; None at the sender's ``end`` or Ctrl-C.
        idle_timeout_s: With ``listen``: the longest wait for a datagram [s] (none at all: a timeout).

    Returns:
        0.

    Raises:
        ConfigError: ``output`` is one of the inputs (the recording, the calibration), ``mount_rpy`` with a robot,
            ``mount`` (``--estimate-mount``) with ``motion``, ``listen`` without ``motion`` or with a recording,
            neither a recording nor ``listen``, or ``seconds`` without ``listen``.
        FeedTimeout: With ``listen``: no datagram within ``idle_timeout_s``.
        OSError: ``output`` cannot be written (a folder); checked before any work.
    """
    _check_source(recording, motion, listen, seconds)
    inputs = {"the recording": recording, "the calibration": calibration, "the robot file": robot, "the pipeline file": pipeline}
    check_outputs({"-o": output}, inputs)
    kin = load_robot_or_orientation(robot, mount_rpy)
    settings = load_settings(pipeline)
    if motion:
        if mount:
            message = "--estimate-mount is for still poses: leave it out with --motion"
            raise ConfigError("--estimate-mount", True, "not with --motion", message=message)
        if listen is not None:
            return live_motion_payload(listen, seconds, idle_timeout_s, kin, load_calibration(calibration), settings, output, name)
        assert recording is not None  # _check_source
        return motion_payload(recording, kin, load_calibration(calibration), settings, output, name)
    assert recording is not None  # _check_source
    found = identify_payload_from_recording(recording, kin, load_calibration(calibration), settings.filter, mount, min_spread_deg)
    estimate = found.estimate
    print(format_payload(estimate, found.rows))
    for line in found.rails:
        print(f"  refused: {line}")
    header = (
        f"payload identified by fts-calib from {recording} ({estimate.samples} samples, {len(estimate.poses)} "
        f"orientations)\nmass {estimate.mass:.6g} ± {estimate.stderr_mass:.2g} kg; com ± "
        f"{', '.join(f'{e:.2g}' for e in estimate.stderr_com)} m"
    )
    gravity = float(np.linalg.norm(kin.g_world()))  # the robot model's: the one the estimate used
    with writing(output):
        path = save_tool(estimate.tool(name, gravity), output, header)
    print(f"wrote {path}")
    return ExitCode.OK


def _check_source(recording: str | Path | None, motion: bool, listen: tuple[str, int] | None, seconds: float | None) -> None:
    """One source: a recording, or ``--listen`` with ``--motion``; ``--seconds`` only with ``--listen``."""
    if listen is not None and not motion:
        message = "--listen collects a continuous motion: add --motion (still poses are identified from a recording)"
        raise ConfigError("--listen", f"{listen[0]}:{listen[1]}", "with --motion", message=message)
    if listen is not None and recording is not None:
        message = f"give a recording or --listen HOST:PORT, not both (got {recording} and --listen {listen[0]}:{listen[1]})"
        raise ConfigError("recording", str(recording), "a recording or --listen", message=message)
    if listen is None and recording is None:
        message = "give a recording, or --motion --listen HOST:PORT to identify the payload from a live motion"
        raise ConfigError("recording", None, "a recording or --listen", message=message)
    if seconds is not None and listen is None:
        message = "--seconds is the length of a live motion: it goes with --listen (a recording is used whole)"
        raise ConfigError("--seconds", seconds, "with --listen", message=message)

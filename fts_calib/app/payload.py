"""The ``payload`` command: identify an unknown payload (mass, centre of mass, offsets) and write its tool file."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..core.exceptions import ConfigError
from ..core.paths import check_outputs
from ..model.calibration import load_calibration
from ..robot.tool import save_tool
from ..service.payload import MIN_SPREAD_DEG, PayloadEstimate, identify_payload_from_recording
from ..service.payload_live import IDLE_TIMEOUT_S
from .exit_codes import ExitCode, writing
from .payload_motion import live_motion_payload, motion_payload
from .setup import load_robot_or_orientation, load_settings


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
    (:func:`fts_calib.app.payload_motion.motion_payload`), from a recording or, with ``listen``,
    from the live feeds (:func:`fts_calib.app.payload_motion.live_motion_payload`).

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

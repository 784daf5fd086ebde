"""``payload --motion``: identify mass, centre of mass and inertia from a continuous motion and write the tool file."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..model.calibration import Calibration
from ..pipeline.settings import PipelineConfig
from ..robot.kinematics import Kinematics
from ..robot.tool import save_tool
from ..service.payload_motion import NAMES
from ..service.payload_motion_recording import RecordedMotionPayload, identify_payload_from_motion
from .exit_codes import ExitCode, writing


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
    print(format_motion_payload(found))
    for line in found.rails:
        print(f"  refused: {line}")
    est = found.estimate
    header = (
        f"payload identified by fts-calib from {recording} ({est.samples} samples of motion, {found.duration_s:.1f} s)\n"
        f"mass {est.mass:.6g} ± {est.stderr_mass:.2g} kg; com ± {', '.join(f'{e:.2g}' for e in est.stderr_com)} m; "
        f"inertia ± {', '.join(f'{e:.2g}' for e in est.stderr[4:])} kg·m² ({', '.join(NAMES[4:])})"
    )
    gravity = float(np.linalg.norm(kin.g_world()))
    with writing(output):
        path = save_tool(est.tool(name, gravity), output, header)
    print(f"wrote {path}")
    return ExitCode.OK

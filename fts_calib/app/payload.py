"""The ``payload`` command: identify an unknown payload from a source and write its tool file.

One SOURCE, a recording or ``udp://HOST:PORT`` (a live feed, with its progress shown), or a
channel device (``serial://...``, ``netft://HOST``) with the joints' source (``udp://HOST:PORT``
or ``ur://HOST``), read live as ``calibrate`` reads them; still
poses or a continuous motion decided from the data (``--motion auto``, the line that says it
printed first) or forced (``--motion still``, ``--motion moving``); one estimate printed with its
standard errors and written (:func:`fts_calib.payload.identify.identify_payload`,
:func:`fts_calib.payload.estimate.save_payload`). The spellings of the release before keep
working, warned about: a bare ``--motion`` (now ``--motion moving``) and ``--listen HOST:PORT``
(now the SOURCE ``udp://HOST:PORT``, :mod:`fts_calib.core.deprecation`).
"""

from __future__ import annotations

import contextlib
import math
import sys
import warnings
from pathlib import Path

import numpy as np

from ..core.deprecation import REMOVED_IN
from ..core.exceptions import ConfigError, ResultRefused
from ..core.files import check_outputs
from ..filters.settings import PipelineConfig
from ..model.calibration import Calibration, load_calibration
from ..payload.estimate import MOVING, NAMES, STILL, PayloadEstimate, save_payload
from ..payload.identify import AUTO, MOTIONS, identify_payload
from ..payload.samples import IDLE_TIMEOUT_S, MotionProgress, collect_motion
from ..payload.still import MIN_SPREAD_DEG
from ..robot.kinematics import Kinematics
from ..session.calibration_run import StatusLine, format_stats
from ..sources.source import live_address
from .exit_codes import ExitCode, using_udp, writing
from .setup import Setup, SourceOptions, channel_device


def format_motion_payload(estimate: PayloadEstimate) -> str:
    """A payload identified from a motion, with its standard errors and units."""
    est = estimate
    latency_s = 0.0 if est.latency_s is None else est.latency_s
    latency = f"{1e3 * latency_s:.3f}" + ("" if not math.isfinite(est.stderr_latency_s) else f" ± {1e3 * est.stderr_latency_s:.1g}")
    inertia = np.zeros((3, 3)) if est.inertia_com is None else est.inertia_com
    lines = [
        f"payload from {est.samples:,} samples of motion ({est.duration_s:.1f} s; {est.rows:,} rows read), joints {latency} ms late:",
        f"  mass {est.mass:.4f} ± {est.stderr_mass:.1g} kg",
        "  centre of mass in the sensor frame "
        + ", ".join(f"{a} {v:+.5f} ± {e:.1g}" for a, v, e in zip("xyz", est.com, est.stderr_com, strict=True))
        + " m",
        "  inertia about the centre of mass "
        + ", ".join(
            f"{name} {inertia['xyz'.index(name[1]), 'xyz'.index(name[2])]:+.6f} ± {e:.1g}"
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
    if est.left_out:
        lines.append(f"  {est.left_out}")
    return "\n".join(lines)


def format_payload(estimate: PayloadEstimate) -> str:
    """A payload identified from still poses, with its standard errors and units."""
    lines = [
        f"payload from {estimate.samples:,} still samples ({estimate.rows - estimate.samples:,} moving or unsettled skipped) in "
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


def live_payload(
    address: tuple[str, int],
    seconds: float | None,
    idle_timeout_s: float,
    kin: Kinematics,
    calibration: Calibration,
    settings: PipelineConfig,
    motion: str,
    mount: bool,
    min_spread_deg: float,
    device: tuple[str, str] | None = None,
) -> PayloadEstimate:
    """Collect the live feed on ``address`` (its progress shown, its counts printed), then identify the payload.

    Args:
        address: (host, port) to bind (port 0: a free one, printed); with ``device`` and ``ur://``
            joints, unused.
        seconds: End after this much motion [s]; None: at the sender's ``end`` or Ctrl-C.
        idle_timeout_s: The longest wait for a datagram [s]: none at all is a timeout.
        kin: Kinematics of the robot (the gimbal's for a feed of the sensor's orientation).
        calibration: The sensor's calibration.
        settings: Pipeline settings: the synchronizer's (``live``) and the filter chain's.
        motion: ``auto``, ``still`` or ``moving``.
        mount: Also estimate a small mount rotation (still poses).
        min_spread_deg: Smallest RMS spread of the gravity directions about each of two axes [deg].
        device: A channel device and the joints' source (``serial://...``, ``udp://HOST:PORT``),
            or None for the datagrams of ``address`` alone.

    Raises:
        FeedTimeout: No datagram within ``idle_timeout_s`` (a box or controller that never answers).
        DeviceLost: A serial device that cannot be opened.
        PayloadError: Nothing paired, or data that do not determine the payload.
    """
    host, port = address
    until = "the sender's end" + (f", {seconds:g} s of motion" if seconds is not None else "") + " or Ctrl-C"

    def listening(bound: tuple[str, int]) -> None:  # the bound port, also when the address gave port 0
        print(
            f"listening on udp://{bound[0]}:{bound[1]} until {until} (at most {idle_timeout_s:g} s without data): move the payload...",
            flush=True,
        )

    status = StatusLine(sys.stderr)  # rewritten on a terminal, a line every few seconds in a file

    def show(progress: MotionProgress) -> None:
        status.show(progress.line())

    udp = device is None or device[1].lower().startswith("udp")
    if device is not None:
        print(f"reading the channels of {device[0]} with the joints of {device[1]}", flush=True)
    with using_udp(host, port) if udp else contextlib.nullcontext():
        collected = collect_motion(
            host, port, kin, settings, calibration.layout.n_channels, seconds, idle_timeout_s, listening, show, device=device
        )
    status.close()
    print(format_stats(collected.stats, collected.sync))
    return identify_payload(collected, kin, calibration, motion, settings=settings, mount=mount, min_spread_deg=min_spread_deg)


def run(
    setup: Setup,
    source: SourceOptions,
    *,
    calibration: str | Path,
    output: str | Path,
    name: str = "payload",
    estimate_mount: bool = False,
    min_spread_deg: float = MIN_SPREAD_DEG,
    motion: str | bool = AUTO,
) -> int:
    """Identify a payload from a source and write it as a tool file (``fts-calib payload``).

    Args:
        setup: The robot (``robot_file``; None for a recording that gives the sensor's
            orientation, with ``mount_rpy`` [rad], :mod:`fts_calib.robot.orientation`) and the
            pipeline settings (filter thresholds).
        source: One SOURCE: a recording of the payload, still in orientations that tilt gravity
            about two axes or moving; or ``udp://HOST:PORT``, the live feed, read for
            ``window_s`` [s] of motion (None: to the sender's ``end`` or Ctrl-C) with at most
            ``idle_timeout_s`` [s] without a datagram (None: :data:`IDLE_TIMEOUT_S`).
        calibration: The sensor's calibration file.
        output: Tool file to write (for gravity compensation).
        name: Name of the payload in the tool file.
        estimate_mount: Also estimate a small rotation of the sensor mount (``--estimate-mount``; still poses).
        min_spread_deg: Smallest RMS spread of the gravity directions along each of two axes, in [deg].
        motion: ``auto`` (decided from the data, and said), ``still`` or ``moving``; True (a bare
            ``--motion``, the release before's flag) is ``moving``, warned about.

    Returns:
        0.

    Raises:
        ConfigError: No source or more than one, ``output`` one of the inputs (the recording, the
            calibration), ``mount_rpy`` with a robot, ``estimate_mount`` with a motion, an
            unknown ``motion``, or ``window_s`` with a recording.
        FeedTimeout: A live source: no datagram within ``idle_timeout_s``.
        OSError: ``output`` cannot be written (a folder); checked before any work.
    """
    kind = _motion(motion)
    address, device = _live_source(source)
    if estimate_mount and kind == MOVING:
        message = "--estimate-mount is for still poses: leave it out with --motion moving"
        raise ConfigError("--estimate-mount", True, "not with --motion moving", message=message)
    live = address is not None or device is not None
    recording = None if live else source.given[0]
    check_outputs({"-o": output}, {"the recording": recording, "the calibration": calibration, **setup.inputs()})
    kin = setup.kinematics
    settings = setup.settings
    cal = load_calibration(calibration)
    if live:
        idle_timeout_s = IDLE_TIMEOUT_S if source.idle_timeout_s is None else source.idle_timeout_s
        estimate = live_payload(
            address or ("", 0), source.window_s, idle_timeout_s, kin, cal, settings, kind, estimate_mount, min_spread_deg, device=device
        )
    else:
        assert recording is not None  # _live_source
        estimate = identify_payload(recording, kin, cal, kind, settings=settings, mount=estimate_mount, min_spread_deg=min_spread_deg)
    if estimate.decided:
        print(estimate.decided)
    print(format_payload(estimate) if estimate.motion == STILL else format_motion_payload(estimate))
    for line in estimate.rails:
        print(f"  refused: {line}")
    check_weight(estimate, cal, setup.sensor.full_scale)
    with writing(output):
        path = save_payload(estimate, output, name)
    print(f"wrote {path}")
    return ExitCode.OK


def check_weight(estimate: PayloadEstimate, calibration: Calibration, sensor_full_scale: np.ndarray) -> None:
    """Refuse a payload heavier than the sensor's force full scale: the sensor carried it, so its weight is within its range.

    Args:
        estimate: The payload identified (its mass [kg], the gravity it used [m/s^2]).
        calibration: The calibration used: its accuracy budget's full scale when recorded.
        sensor_full_scale: The sensor file's full scale [N, N, N, N m, N m, N m], shape (6,): when
            the calibration records none.

    Raises:
        ResultRefused: The payload's weight exceeds the largest force full scale; nothing is written.
    """
    recorded = _recorded_full_scale(calibration)
    full_scale = recorded if recorded is not None else np.asarray(sensor_full_scale, dtype=float)
    force = float(np.max(full_scale[:3]))
    weight = abs(estimate.mass) * estimate.gravity
    if weight > force:
        whose = "the calibration's accuracy budget" if recorded is not None else "the sensor file's"
        raise ResultRefused(
            f"refused (nothing written): the payload identified weighs {weight:,.0f} N ({estimate.mass:,.4g} kg), "
            f"{weight / force:.3g} times the sensor's force full scale of {force:g} N ({whose}): the sensor carried it, so its weight "
            "lies within its range; are the recording's channels in another unit or scale than the calibration's, or is the "
            "calibration another sensor's?"
        )


def _recorded_full_scale(calibration: Calibration) -> np.ndarray | None:
    """The full scale in the calibration's quality (its accuracy budget), shape (6,); None when it records none."""
    budget = calibration.quality.budget if calibration.quality is not None else None
    values = budget.get("full_scale") if isinstance(budget, dict) else None
    if not isinstance(values, dict) or len(values) != 6:
        return None
    try:
        out = np.array([float(v) for v in values.values()])
    except (TypeError, ValueError):
        return None
    return out if np.all(np.isfinite(out) & (out > 0)) else None


def _motion(motion: str | bool) -> str:
    """``auto``, ``still`` or ``moving``; the release before's True (a bare ``--motion``) and False, warned about."""
    if isinstance(motion, bool):
        new = MOVING if motion else STILL
        warnings.warn(
            f"--motion without a value is now --motion {new} (motion={motion} is motion='{new}'); "
            f"the old spelling goes in fts-calib {REMOVED_IN}",
            DeprecationWarning,
            stacklevel=3,
        )
        return new
    if motion not in MOTIONS:
        raise ConfigError("--motion", motion, " or ".join(MOTIONS))
    return motion


def _live_source(source: SourceOptions) -> tuple[tuple[str, int] | None, tuple[str, str] | None]:
    """The live feed's (host, port) and the channel device with its joints' source, the options checked before any wait.

    The address is None for a recording or ``ur://`` joints; the device None without one.

    Raises:
        ConfigError: No source, more than one (a device takes the joints' source too), two devices, a device without
            the joints' source, ``--seconds`` with a recording.
    """
    given = source.given
    device = channel_device(source.live, "payload", joints=True)
    if device is not None:
        joints = source.live.get("udp") or source.live["ur"]  # channel_device: one of them is given
        if len(given) != 2:
            message = f"{' '.join(map(str, given))}: the channels of {device} and the joints' source, nothing more"
            raise ConfigError("source", [str(name) for name in given], "a channel device and the joints' source", message=message)
        return (live_address(joints) if joints.lower().startswith("udp") else None), (device, joints)
    if len(given) != 1:
        message = (
            "give a recording of the payload, or a live feed udp://HOST:PORT"
            if not given
            else f"one source of the payload, not {len(given)} ({', '.join(map(str, given))})"
        )
        raise ConfigError("source", [str(name) for name in given], "a recording or udp://HOST:PORT", message=message)
    live = source.live.get("udp")
    if live is None and source.window_s is not None:
        message = f"--seconds is the length of a live motion, read from a udp://HOST:PORT source ({given[0]} is used whole)"
        raise ConfigError("--seconds", source.window_s, "with a live source", message=message)
    return (None if live is None else live_address(live)), None

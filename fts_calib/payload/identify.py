"""The one entry point of payload identification: a source in, still poses or a motion decided, one estimate out.

:func:`identify_payload` takes what a user holds: a recording's path (CSV, CSV.gz, ROS 2 bags),
``udp://HOST:PORT`` (the live protocol, collected until the sender's end, ``seconds`` or Ctrl-C),
arrays (a :class:`~fts_calib.sources.batch.SampleBatch` or a mapping of them) or any
:class:`~fts_calib.sources.source.Source`, with the kinematics and the sensor's calibration. Its
samples go through the filter chain (:mod:`fts_calib.payload.samples`), and then

- still poses (``motion="still"``): the samples the quasi-static rules keep, their calibrated
  wrench and gravity in the sensor frame (:func:`fts_calib.payload.still.fit_payload_still`):
  mass, centre of mass and offsets (and a small rotation of the sensor mount with ``mount``);
- a continuous motion (``motion="moving"``): every checked sample, the sensor's motion from the
  joints (:func:`fts_calib.payload.moving.fit_motion_samples`): the inertia too, physically
  consistent, and the joint stream's latency;
- ``motion="auto"`` (the default) decides from the data (:func:`decide_motion`): still poses
  when the still samples see gravity from directions enough to determine the payload (their RMS
  spread at least ``min_spread_deg`` about two axes), or when most samples are still; a
  continuous motion otherwise. The estimate says which it decided and why
  (:attr:`~fts_calib.payload.estimate.PayloadEstimate.decided`).

One estimate comes out either way (:class:`~fts_calib.payload.estimate.PayloadEstimate`, written
as a tool file by :func:`~fts_calib.payload.estimate.save_payload`).

The array form of the release before, ``identify_payload(w_measured, g_sensor, mount=False,
min_spread_deg=3.0)`` (calibrated wrenches of still samples [N, N m], shape (N, 6), and gravity in
the sensor frame at each [m/s^2], shape (N, 3)), works as it did: it is
:func:`fts_calib.payload.still.fit_payload_still`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from ..core.exceptions import ConfigError, PayloadError, ShapeError
from ..filters.quasi_static import sample_period
from ..filters.settings import PipelineConfig
from ..model.calibration import Calibration
from ..model.channel_limits import ChannelLimits
from ..robot.kinematics import Kinematics
from .estimate import MOVING, STILL, PayloadEstimate
from .moving import fit_motion_samples
from .samples import IDLE_TIMEOUT_S, MotionProgress, PayloadSamples, PayloadSource, payload_samples, source_samples
from .still import MIN_SPREAD_DEG, STILL_UNKNOWNS, fit_payload_still, orientation_spread

#: ``motion``: decide from the data, still poses, or a continuous motion.
AUTO = "auto"
MOTIONS = (AUTO, STILL, MOVING)
#: Below this share of still samples, whose orientations cannot determine the payload, the data are a motion.
MIN_STILL_SHARE = 0.5


def decide_motion(read: PayloadSamples, min_spread_deg: float = MIN_SPREAD_DEG) -> tuple[str, str]:
    """Still poses or a continuous motion, from the data, and why in words (see the module docstring).

    Args:
        read: The payload's samples through the filter chain (:func:`fts_calib.payload.samples.payload_samples`).
        min_spread_deg: Smallest RMS spread of the still samples' gravity directions about each of two axes [deg].

    Returns:
        ``(STILL or MOVING, the reason)``.
    """
    still = read.still
    kept, seen = int(np.count_nonzero(still.keep)), len(read.checked)
    counted = f"{kept:,} of {seen:,} samples still"
    if kept >= 2:
        spread, _ = orientation_spread(still.g_sensor)
        if spread[1] >= min_spread_deg:
            return STILL, (
                f"decided from the data: still poses ({counted}, their gravity spread {spread[0]:.1f}° and {spread[1]:.1f}° "
                "RMS about two axes; --motion moving forces a motion)"
            )
    share = kept / seen if seen else 0.0
    if share >= MIN_STILL_SHARE:
        return STILL, f"decided from the data: still poses ({counted}, {100 * share:.0f} %; --motion moving forces a motion)"
    return MOVING, (
        f"decided from the data: a continuous motion (only {counted}, {100 * share:.1f} %, and their orientations do not "
        "determine the payload; --motion still forces still poses)"
    )


def identify_payload(
    source: PayloadSource | np.ndarray,
    kin: Kinematics | np.ndarray | None = None,
    calibration: Calibration | bool | None = None,
    motion: str | float = AUTO,
    *,
    mount: bool = False,
    min_spread_deg: float = MIN_SPREAD_DEG,
    settings: PipelineConfig | None = None,
    limits: ChannelLimits | None = None,
    latency_s: float | None = None,
    seconds: float | None = None,
    idle_timeout_s: float = IDLE_TIMEOUT_S,
    on_listening: Callable[[tuple[str, int]], None] | None = None,
    on_progress: Callable[[MotionProgress], None] | None = None,
) -> PayloadEstimate:
    """Identify an unknown payload from a source: still poses or a continuous motion (see the module docstring).

    The array form of the release before, ``identify_payload(w_measured, g_sensor, mount, min_spread_deg)``
    (calibrated wrenches of still samples [N, N m], shape (N, 6), and gravity in the sensor frame
    [m/s^2], shape (N, 3)), is :func:`fts_calib.payload.still.fit_payload_still`.

    Args:
        source: A recording's path (or several, a pattern, ``BAG[:CONFIGURATION]``),
            ``udp://HOST:PORT``, a :class:`~fts_calib.sources.batch.SampleBatch` or a mapping of
            arrays (``time`` [s], ``joints`` [rad], ``channels``, ``configuration``), or any
            :class:`~fts_calib.sources.source.Source`; one payload (one configuration name).
        kin: Kinematics of the robot (the gimbal's for a recording of the sensor's orientation).
        calibration: The sensor's calibration.
        motion: ``auto`` (decide from the data), ``still`` or ``moving``.
        mount: Also estimate a small rotation of the sensor mount (still poses only).
        min_spread_deg: Smallest RMS spread of the gravity directions along each of two axes [deg].
        settings: Pipeline settings: the filter chain's (checks, quasi-static thresholds, the
            joint-rate window) and a live feed's synchronizer; the defaults when None.
        limits: The channels' declared resolution and rails; what is not declared is detected.
        latency_s: A motion: how late the joint readings are [s], where the latency's fit starts;
            None: ``settings.live.latency_s`` (0 for a live feed: its synchronizer applied it).
        seconds: ``udp://``: end after this much motion [s] by the feed's clock; None at the sender's end or Ctrl-C.
        idle_timeout_s: ``udp://``: the longest wait for a datagram [s] (none at all: :class:`FeedTimeout`).
        on_listening: ``udp://``: called with the bound (host, port).
        on_progress: ``udp://``: called with the progress every half second.

    Returns:
        The payload, with where it came from and, for ``auto``, what was decided and why.

    Raises:
        ConfigError: An unknown ``motion``, no kinematics or calibration, or ``mount`` with a motion.
        ShapeError: One array as the source (its samples are a mapping of arrays or a SampleBatch).
        RecordingError: A recording that cannot be read.
        PayloadError: No usable sample, two payloads, or data that do not determine the
            payload (the message names what is missing).
        FeedTimeout: ``udp://``: nothing within ``idle_timeout_s``.
    """
    if kin is None:
        raise ConfigError("kin", None, "the robot's kinematics (fts_calib.Kinematics)")
    if not isinstance(kin, Kinematics):  # the array form: (w_measured, g_sensor[, mount[, min_spread_deg]])
        if calibration is not None:
            mount = bool(calibration)
        if motion != AUTO:
            min_spread_deg = float(motion)
        return fit_payload_still(source, kin, mount, min_spread_deg)
    motion = str(motion)
    if isinstance(source, np.ndarray):
        message = "source is one array: give a recording, udp://HOST:PORT, or the samples (time, joints, channels, configuration)"
        raise ShapeError(f"{source.shape=}: {message}")
    if motion not in MOTIONS:
        raise ConfigError("motion", motion, " or ".join(MOTIONS))
    if not isinstance(calibration, Calibration):
        raise ConfigError("calibration", calibration, "the sensor's calibration (fts_calib.load_calibration)")
    if mount and motion == MOVING:
        raise ConfigError("mount", True, "still poses", message="a mount rotation is estimated from still poses, not from a motion")
    settings = settings or PipelineConfig()
    n_channels = calibration.layout.n_channels
    samples, names, where, live = source_samples(source, kin, settings, n_channels, seconds, idle_timeout_s, on_listening, on_progress)
    read = payload_samples(samples, names, where, kin, calibration, settings, limits)
    kind, why = decide_motion(read, min_spread_deg) if motion == AUTO else (motion, "")
    if mount and kind == MOVING:
        message = f"a mount rotation is estimated from still poses, but {why}: leave out the mount, or force still poses"
        raise ConfigError("mount", True, "still poses", message=message)
    try:
        if kind == STILL:
            still = read.still
            estimate = fit_payload_still(calibration.wrench(still.samples.channels), still.g_sensor, mount, min_spread_deg)
        else:
            start = (0.0 if live else settings.live.latency_s) if latency_s is None else latency_s
            estimate = fit_motion_samples(read.checked, kin, calibration, read.derivative_window_s, start, where=where)
    except PayloadError as exc:
        raise _too_few_still(exc, read, settings, kind, motion == AUTO) from None
    gravity = float(np.linalg.norm(kin.g_world()))  # the robot model's: the one the estimate used
    return _with_source(estimate, gravity, read, why)


def _too_few_still(exc: PayloadError, read: PayloadSamples, settings: PipelineConfig, kind: str, auto: bool) -> PayloadError:
    """``exc``, with the rate and the filter's windows named when too few samples were still for a still fit.

    A stop shorter than the still rules' span at the recording's rate (1.0 s at 10 Hz:
    :meth:`fts_calib.filters.settings.FilterConfig.windows`) has no still sample; the message then says so,
    whichever fit failed for want of samples (a continuous motion decided for want of still ones, at a
    rate where a window holds its minimum of samples rather than its duration).
    """
    kept = int(np.count_nonzero(read.still.keep))
    if (kind != STILL and not auto) or kept >= STILL_UNKNOWNS or (read.still.still is None and not len(read.checked)):
        return exc
    period = sample_period(read.checked.time)
    if kind != STILL and not settings.filter.low_rate_text(period):
        return exc  # a motion decided at a rate where the windows are their durations: the motion's own refusal says it
    windows = settings.filter.windows(period)
    moving = "" if kind == STILL else f"; as a continuous motion: {exc}"
    return PayloadError(
        f"{read.where}: {kept:,} of {len(read.checked):,} samples still, too few for a still fit of the payload's "
        f"{STILL_UNKNOWNS} unknowns: {windows.text()}; hold each pose that long, or record at a higher rate{moving}"
    )


def _with_source(estimate: PayloadEstimate, gravity: float, read: PayloadSamples, decided: str) -> PayloadEstimate:
    """The estimate with where it came from (the samples read, the railed channels) and what was decided."""
    return dataclasses.replace(estimate, gravity=gravity, source=read.where, rows=read.rows, rails=read.rails, decided=decided)

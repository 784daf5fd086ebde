"""The samples of a payload recording: read, one payload checked, bad rows and railed channels refused.

Shared by the payload identification from still poses (:mod:`fts_calib.payload.still`) and
from a continuous motion (:mod:`fts_calib.payload.moving`).

Payload from a recorded continuous motion: the sensor's motion from the joint readings, the latency estimated.

The recording's rows (:func:`fts_calib.payload.samples.read_payload_samples`: one
payload, bad rows and railed channels refused) give the calibrated wrench; the joint readings,
aligned by the stream latency, give the sensor frame's motion (joint rates by
:func:`fts_calib.filters.joint_rates.joint_rates`, then :meth:`Kinematics.sensor_motion`), and
:func:`fts_calib.payload.moving.fit_payload_motion` the payload. The latency starts at
the pipeline's ``live.latency_s`` and is then estimated from the residuals of the payload just
identified (:func:`fts_calib.filters.latency.latency_regression` on the fit's residuals, with the
offsets' drift left out), the joints re-aligned and the payload fitted again, until the
latency moves by less than 20 us. Samples within half a derivative window of the recording's ends, or of a
sample missing (a row refused, a datagram lost), are left out (their rates come from a cut or uneven window).
Times in [s].

Payload from a live continuous motion: the joint and strain datagrams collected, then identified as a recording.

The live protocol over UDP (:mod:`fts_calib.sources.udp`), read by the one live loop
(:class:`fts_calib.sources.live_feed.LiveFeed`): joint readings (or the sensor's orientation,
without a robot) and strains, paired by the synchronizer as ``live`` pairs them
(:class:`fts_calib.sources.synchronizer.Synchronizer`: joints interpolated at the strain times,
the pipeline's ``live.latency_s`` taken off their stamps, no interpolation across a gap longer
than ``live.max_gap_s``). Collection ends where every live stream ends: on the sender's
``end`` message, after ``seconds`` of motion (by the feed's own time stamps), on Ctrl-C or
SIGTERM, or when the feed falls silent for ``idle_timeout_s`` after it had started; a feed
that sends nothing at all within ``idle_timeout_s`` is a :class:`FeedTimeout`. Malformed,
oversized and duplicated datagrams are counted and skipped (:func:`fts_calib.sources.udp.feed_datagram`).
The samples then go through the checks and the identification of a recording
(:func:`fts_calib.payload.samples.check_payload_samples`,
:func:`fts_calib.payload.samples.identify_payload_from_samples`), the
remaining latency estimated from them. Times in [s].

A tool message names the payload, as a recording's configuration column does; the samples
before any are the payload's too (a sender need not announce it), and two names are refused
as in a recording. The progress shows the seconds of motion so far and how far the sensor
has turned about each of its axes (from its orientation, 50 times a second of the feed): the
inertia about an axis the sensor has not turned about is not determined.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core import arrays as validation
from ..core.exceptions import PayloadError
from ..filters.joint_rates import joint_rates, smoothed_like_acceleration
from ..filters.latency import latency_regression, latency_sums, wrench_rate
from ..filters.quasi_static import PERIOD_SAMPLES, sample_period
from ..filters.sample_checks import SampleChecks
from ..filters.settings import PipelineConfig
from ..model.calibration import Calibration
from ..model.channel_limits import ChannelLimits, detect_limits
from ..model.channels import CALIBRATION_HINT, check_channels
from ..robot import inertial
from ..robot.kinematics import Kinematics
from ..sources.batch import SampleBatch
from ..sources.live_feed import LiveFeed, StreamEnd
from ..sources.source import open_recording
from ..sources.synchronizer import Synchronizer
from ..sources.udp import LiveStats, UdpReceiver
from .moving import MotionPayloadEstimate, fit_payload_regressor


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


_LATENCY_TOLERANCE_S = 2e-5  # [s] a latency step below this ends the alternation (the estimate's own error: tests/test_latency.py)
_ROUNDS = 5  # fits at most


@dataclass(frozen=True)
class RecordedMotionPayload:
    """A payload identified from a recorded motion.

    Attributes:
        estimate: The payload, offsets and latency with their standard errors.
        rows: Rows read from the recording.
        duration_s: Time spanned by the samples used [s].
        rails: One line per channel whose samples were refused at its rail.
    """

    estimate: MotionPayloadEstimate
    rows: int
    duration_s: float
    rails: tuple[str, ...] = ()


def aligned_joints(time: np.ndarray, joints: np.ndarray, latency_s: float, continuous: np.ndarray) -> np.ndarray:
    """The joints at each sample's time when the readings are ``latency_s`` late: read at ``t + latency_s``.

    Args:
        time: Sample times [s], non-decreasing. Shape (N,).
        joints: Joint readings [rad]. Shape (N, n_joints).
        latency_s: How late the readings are [s] (the row of time t holds the joints of t - latency_s).
        continuous: Which joints are continuous (unwrapped before interpolating). Shape (n_joints,).

    Returns:
        Shape (N, n_joints); rows whose ``t + latency_s`` is outside the recording take its end value.
    """
    joints = np.array(joints, dtype=float)
    if np.any(continuous) and len(joints) > 1:
        joints[:, continuous] = np.unwrap(joints[:, continuous], axis=0)
    if latency_s == 0.0:
        return joints
    return np.stack([np.interp(time + latency_s, time, joints[:, k]) for k in range(joints.shape[1])], axis=1)


def _regressor(time, g, omega, alpha, a, window_s: float, dt: float) -> np.ndarray:
    """The regressor seen through the joint-rate window: its terms in gravity and speed smoothed, (N, 6, 10).

    The regressor is linear in the accelerations: ``Y(g, omega, alpha, a) = Y(g, omega, 0, 0) +
    Y(0, 0, alpha, a)``. The accelerations from the joint-rate estimates are already smoothed
    by the window's kernel, and the measured wrench is smoothed by it
    (:func:`fts_calib.filters.joint_rates.smoothed_like_acceleration`); the terms in gravity and speed are smoothed here, so that
    every term of the model sees the same smoothing (in the simulation this takes the inertia's
    bias from about 1 % to 0.2 %).
    """
    zero = np.zeros_like(g)
    rest = inertial.body_regressor(g, omega, zero, zero)
    smoothed, _ = smoothed_like_acceleration(time, rest.reshape(len(time), -1), window_s, dt)
    return smoothed.reshape(rest.shape) + inertial.body_regressor(zero, zero, alpha, a)


def _latency_left(
    time: np.ndarray, measured: np.ndarray, regressor: np.ndarray, estimate: MotionPayloadEstimate, block_samples: int
) -> tuple[float, float]:
    """How much later the joints still are than the fit assumed, from its residuals.

    The regression of :mod:`fts_calib.filters.latency` (``W_meas - W_pred ~ tau dW_pred/dt``,
    each axis weighted by its residual spread) on the fit's own residuals, which leave out the
    offsets' drift (``estimate_latency`` takes constant offsets: a sensor warming up moved its
    estimate by 0.15 ms); its standard error from the spread of the estimates of blocks of
    ``block_samples``.

    Args:
        time: Sample times [s]. Shape (N,).
        measured: Measured wrenches [N, N m]. Shape (N, 6).
        regressor: The fit's regressor. Shape (N, 6, 10).
        estimate: The fit.
        block_samples: Samples per block.

    Returns:
        ``(latency step [s], its standard error [s])`` (0 and inf when the motion shows none).
    """
    predicted = regressor @ estimate.parameters
    middle = (time[0] + time[-1]) / 2
    residual = measured - predicted - estimate.offsets - np.outer(time - middle, estimate.offset_rate)
    rate = wrench_rate(time, predicted)
    ok = np.all(np.isfinite(rate), axis=1)  # repeated time stamps: no slope there
    rs, ss = latency_sums(residual[ok], rate[ok], 1.0 / np.maximum(estimate.residual_rms, 1e-15) ** 2)
    blocks = max(len(ss) // max(block_samples, 1), 1)
    step = latency_regression(rs, ss, np.linspace(0, len(ss), blocks + 1).astype(int)[:-1])
    return (0.0, math.inf) if step is None else (step.latency_s, step.stderr_s)


def identify_payload_from_motion(
    path: str | Path,
    kin: Kinematics,
    calibration: Calibration,
    window_s: float = 0.05,
    latency_s: float = 0.0,
    fit_latency: bool = True,
    limits: ChannelLimits | None = None,
) -> RecordedMotionPayload:
    """Identify mass, centre of mass, inertia and offsets from a recording of a continuous motion (module docstring).

    Args:
        path: Recording (CSV, CSV.gz or a ROS 2 bag) of one payload moving.
        kin: Kinematics of the robot (its model's gravity is used).
        calibration: The sensor's calibration.
        window_s: Window of the joint-rate estimates [s] (the filter's ``derivative_window_s``).
        latency_s: How late the joint readings are [s] (the pipeline's ``live.latency_s``): the start.
        fit_latency: Estimate the remaining latency from the recording (else ``latency_s`` is used as is).
        limits: The channels' declared resolution and rails; what is not declared is detected.

    Raises:
        RecordingError: The recording cannot be read.
        PayloadError: No usable row, more than one configuration, or a motion that does not
            determine the payload (the message names what is missing).
    """
    return identify_payload_from_samples(
        read_payload_samples(path, kin, calibration, limits), str(path), kin, calibration, window_s, latency_s, fit_latency
    )


def identify_payload_from_samples(
    read: PayloadSamples,
    where: str,
    kin: Kinematics,
    calibration: Calibration,
    window_s: float = 0.05,
    latency_s: float = 0.0,
    fit_latency: bool = True,
) -> RecordedMotionPayload:
    """Identify mass, centre of mass, inertia and offsets from the samples of a continuous motion (module docstring).

    The arrays' form of :func:`identify_payload_from_motion`: the samples of a recording, or
    of a live feed (:mod:`fts_calib.payload.samples`), checked by
    :func:`fts_calib.payload.samples.check_payload_samples`.

    Args:
        read: The accepted samples (time [s], joints [rad], channels), in time order.
        where: Where they come from, for the messages (a path, ``udp://HOST:PORT``).
        kin: Kinematics of the robot (its model's gravity is used).
        calibration: The sensor's calibration.
        window_s: Window of the joint-rate estimates [s].
        latency_s: How late the joint readings still are [s]: the start.
        fit_latency: Estimate the remaining latency (else ``latency_s`` is used as is).

    Raises:
        PayloadError: Too few samples, or a motion that does not determine the payload.
    """
    samples = read.samples
    if len(samples) < 3:
        raise PayloadError(f"{where}: {len(samples)} usable rows, too few for a motion")
    time = samples.time
    dt = sample_period(time) if len(time) > PERIOD_SAMPLES else float(np.median(np.diff(time)))
    wrench, smooth = smoothed_like_acceleration(time, calibration.wrench(samples.channels), window_s, dt)
    g_world = kin.g_world()
    middle = len(time) // 2
    block = max(int(round(8 * window_s / dt)), 40)  # samples per block of the standard errors: eight joint-rate windows
    lag, stderr_lag = float(latency_s), math.inf
    final = not fit_latency
    for round_ in range(_ROUNDS):
        joints = aligned_joints(time, samples.joints, lag, kin.continuous)
        rates = joint_rates(time, joints, window_s, dt, kin.continuous, order=2)
        motion = kin.sensor_motion(joints, rates.velocity, rates.acceleration)
        R = motion.R_world_sensor
        g = np.einsum("nji,j->ni", R, g_world)
        keep = smooth.copy()
        keep &= (time + lag >= time[0]) & (time + lag <= time[-1])
        axes = {name: R[middle].T @ kin.joint_axis_world(joints[middle], name) for name in kin.joint_names}
        regressor = _regressor(time, g, motion.omega, motion.alpha, motion.a, window_s, dt)
        estimate = fit_payload_regressor(wrench[keep], regressor[keep], axes, where, final, block, time[keep])
        if final:
            break
        step, stderr_lag = _latency_left(time[keep], wrench[keep], regressor[keep], estimate, block)
        lag += step
        # the last fit is the one checked: with the joints aligned (what is left is below the tolerance)
        final = abs(step) < _LATENCY_TOLERANCE_S or round_ == _ROUNDS - 2
    estimate = dataclasses.replace(estimate, latency_s=lag, stderr_latency_s=stderr_lag)
    used = time[keep]
    return RecordedMotionPayload(estimate, read.rows, float(used[-1] - used[0]) if len(used) else 0.0, read.rails)


#: Idle timeout of a live payload motion [s]: the longest wait for the first datagram, and for the next.
IDLE_TIMEOUT_S = 10.0
_PLACEHOLDER = "payload"  # the configuration of the samples before any tool message
_PROGRESS_S = 0.5  # [s] how often the progress is shown
_TURN_STEP_S = 0.02  # [s] of the feed between the orientations that measure the turning
#: An axis turned less than this fraction of the most turned one is shown as not yet turned about.
LITTLE_TURN = 0.1


@dataclass
class MotionProgress:
    """What a live payload motion has collected so far.

    Attributes:
        seconds: Time spanned by the paired samples [s] (the feed's clock).
        samples: Paired samples.
        turned_rad: How far the sensor turned about each of its axes x, y, z [rad] (sum of
            the absolute increments). Shape (3,).
        stats: The datagram counts.
    """

    seconds: float = 0.0
    samples: int = 0
    turned_rad: np.ndarray = field(default_factory=lambda: np.zeros(3))
    stats: LiveStats = field(default_factory=LiveStats)

    def line(self) -> str:
        """One status line: seconds, samples, turning about each axis, bad and lost datagrams, what is not yet turned about."""
        if not self.samples:
            return f"waiting for the motion: {self.stats.received:,} datagrams, no strain sample paired with the joints yet"
        turned = " ".join(f"{a} {v:.1f}" for a, v in zip("xyz", self.turned_rad, strict=True))
        text = f"motion {self.seconds:6.1f} s | {self.samples:,} samples | turned about the sensor's {turned} rad"
        bad = self.stats.malformed + self.stats.oversized
        if bad:
            text += f" | bad datagrams {bad}"
        if self.stats.gaps:
            text += f" | lost datagrams {self.stats.gaps}"
        little = [a for a, v in zip("xyz", self.turned_rad, strict=True) if v < LITTLE_TURN * max(float(np.max(self.turned_rad)), 1e-9)]
        if little:
            text += f" | not yet turned about {', '.join(little)} (its inertia is not seen)"
        return text


@dataclass(frozen=True)
class LiveMotion:
    """The samples of a live payload motion.

    Attributes:
        samples: The paired samples, in time order; ``configuration`` indexes ``names``.
        names: The configuration names (the placeholder first, then those the sender announced).
        stats: The datagram counts.
        sync: The synchronizer (its ``dropped``: strain samples it could not pair, by reason).
        address: Where it listened: ``udp://HOST:PORT``.
    """

    samples: SampleBatch
    names: list[str]
    stats: LiveStats
    sync: Synchronizer
    address: str


class _Turning:
    """How far the sensor turned about its axes, from its orientation every ``_TURN_STEP_S`` of the feed."""

    def __init__(self, kin: Kinematics):
        self.kin = kin
        self.total = np.zeros(3)
        self._last_t = -math.inf
        self._last_R: np.ndarray | None = None

    def add(self, batch: SampleBatch) -> None:
        if not len(batch):
            return
        picks, t = [], self._last_t
        for k, tk in enumerate(batch.time):
            if tk >= t + _TURN_STEP_S:
                picks.append(k)
                t = float(tk)
        if not picks:
            return
        self._last_t = t
        R = self.kin.R_world_sensor(batch.joints[picks])
        if self._last_R is not None:
            R = np.concatenate([self._last_R[None], R])
        self._last_R = R[-1]
        step = np.einsum("nji,njk->nik", R[:-1], R[1:])  # R_k^T R_k+1: the turn in the sensor frame
        vee = np.stack([step[:, 2, 1] - step[:, 1, 2], step[:, 0, 2] - step[:, 2, 0], step[:, 1, 0] - step[:, 0, 1]], axis=1) / 2
        self.total += np.sum(np.abs(vee), axis=0)  # small steps: sin(angle) ~ angle


def collect_motion(
    host: str,
    port: int,
    kin: Kinematics,
    settings: PipelineConfig,
    n_channels: int | None = None,
    seconds: float | None = None,
    idle_timeout_s: float = IDLE_TIMEOUT_S,
    on_listening: Callable[[tuple[str, int]], None] | None = None,
    on_progress: Callable[[MotionProgress], None] | None = None,
) -> LiveMotion:
    """Collect a continuous motion from the live feeds (see the module docstring).

    Args:
        host: Address to bind (loopback by default: :class:`fts_calib.sources.udp.UdpReceiver`).
        port: UDP port; 0 picks a free one (given to ``on_listening``).
        kin: Kinematics of the robot (the joints expected; the gimbal's for an orientation feed).
        settings: Pipeline settings: the synchronizer's ``live.latency_s`` and ``live.max_gap_s``.
        n_channels: Values a strain message must have; None takes the first message's.
        seconds: End after this much motion [s] (> 0) by the feed's time stamps; None for no limit.
        idle_timeout_s: The longest wait for a datagram [s] (> 0).
        on_listening: Called with the bound (host, port) once the socket listens.
        on_progress: Called with the progress every half second of collection and at its end.

    Raises:
        FeedTimeout: No datagram at all within ``idle_timeout_s``.
        ConfigError: A wildcard ``host``, or a ``seconds`` or ``idle_timeout_s`` that is not positive.
    """
    if seconds is not None:
        validation.positive("seconds", seconds, "s")
    validation.positive("idle_timeout_s", idle_timeout_s, "s")
    sync = Synchronizer(kin.joint_names, kin.continuous, settings.live.max_gap_s, settings.live.latency_s, n_channels=n_channels)
    sync.add_tool(-math.inf, _PLACEHOLDER)
    progress, turning, batches = MotionProgress(), _Turning(kin), []
    end = StreamEnd(idle_timeout_s=idle_timeout_s, first_timeout_s=idle_timeout_s, stream_s=seconds)
    show = None if on_progress is None else (lambda _counts: on_progress(progress))
    feed = LiveFeed(UdpReceiver(host, port), sync, end=end, on_status=show, status_interval_s=_PROGRESS_S, on_listening=on_listening)
    progress.stats = feed.stats
    with feed:
        for batch in feed:
            batches.append(batch)
            turning.add(batch)
            progress.samples, progress.seconds, progress.turned_rad = feed.samples, feed.stream_s, turning.total
    if on_progress is not None:
        on_progress(progress)
    samples = SampleBatch.concatenate(batches) if batches else SampleBatch.empty(len(kin.joint_names), n_channels or 8)
    return LiveMotion(samples, list(sync.configurations), feed.stats, sync, feed.description)


def identify_live_motion(
    motion: LiveMotion,
    kin: Kinematics,
    calibration: Calibration,
    settings: PipelineConfig,
    limits: ChannelLimits | None = None,
) -> RecordedMotionPayload:
    """Identify the payload from a collected live motion, as from a recording.

    Args:
        motion: The collected samples (:func:`collect_motion`).
        kin: Kinematics of the robot.
        calibration: The sensor's calibration.
        settings: Pipeline settings: the joint-rate window (``filter.derivative_window_s``); the
            synchronizer already took ``live.latency_s`` off, so the remaining latency starts at 0.
        limits: The channels' declared resolution and rails; what is not declared is detected.

    Raises:
        PayloadError: No paired sample (the message says what the feed sent and why nothing
            paired), two payloads announced, or a motion that does not determine the payload.
    """
    if not len(motion.samples):
        stats = motion.stats
        why = "; ".join(f"{reason}: {count:,}" for reason, count in motion.sync.dropped.items() if count)
        raise PayloadError(
            f"no strain sample on {motion.address} could be paired with the joints ({stats.received:,} datagrams: "
            f"{stats.joints:,} joints, {stats.strain:,} strain, {stats.malformed + stats.oversized:,} malformed or oversized"
            + (f"; unpaired: {why}" if why else "")
            + "): the sender must send both the joints (or the orientation) and the strains, on one clock"
        )
    names = list(motion.names)
    announced = [name for name in names[1:] if name != _PLACEHOLDER]
    samples = motion.samples
    if len(announced) == 1:  # the samples before the sender's announcement are that payload's
        codes = np.where(samples.configuration == 0, names.index(announced[0]), samples.configuration)
        samples = dataclasses.replace(samples, configuration=codes)
    read = check_payload_samples(samples, names, motion.address, kin, calibration, limits)
    return identify_payload_from_samples(read, motion.address, kin, calibration, settings.filter.derivative_window_s, 0.0)

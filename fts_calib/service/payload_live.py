"""Payload from a live continuous motion: the joint and strain datagrams collected, then identified as a recording.

The live protocol over UDP (:mod:`fts_calib.feeds.udp`, :mod:`fts_calib.feeds.protocol`):
joint readings (or the sensor's orientation, without a robot) and strains, paired by the
synchronizer as ``live`` pairs them (:class:`fts_calib.feeds.sync.Synchronizer`: joints
interpolated at the strain times, the pipeline's ``live.latency_s`` taken off their stamps,
no interpolation across a gap longer than ``live.max_gap_s``). Collection ends on the
sender's ``end`` message, after ``seconds`` of motion (by the feed's own time stamps), on
Ctrl-C, or when the feed falls silent for ``idle_timeout_s`` after it had started; a feed
that sends nothing at all within ``idle_timeout_s`` is a :class:`FeedTimeout`. Malformed,
oversized and duplicated datagrams are counted and skipped (:func:`fts_calib.feeds.udp.feed_datagram`).
The samples then go through the checks and the identification of a recording
(:func:`fts_calib.service.payload_recording.check_payload_samples`,
:func:`fts_calib.service.payload_motion_recording.identify_payload_from_samples`), the
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
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..core import validation
from ..core.exceptions import FeedTimeout, PayloadError
from ..feeds.batch import SampleBatch
from ..feeds.sync import Synchronizer
from ..feeds.udp import LiveStats, UdpReceiver, feed_datagram
from ..model.calibration import Calibration
from ..model.channel_limits import ChannelLimits
from ..pipeline.settings import PipelineConfig
from ..robot.kinematics import Kinematics
from .payload_motion_recording import RecordedMotionPayload, identify_payload_from_samples
from .payload_recording import check_payload_samples

#: Idle timeout of a live payload motion [s]: the longest wait for the first datagram, and for the next.
IDLE_TIMEOUT_S = 10.0
_PLACEHOLDER = "payload"  # the configuration of the samples before any tool message
_FEED_S = 0.02  # [s] how often the synchronizer places samples
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
        host: Address to bind (loopback by default: :class:`fts_calib.feeds.udp.UdpReceiver`).
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
    receiver = UdpReceiver(host, port)
    host, port = receiver.address[:2]
    address = f"udp://{host}:{port}"
    sync = Synchronizer(kin.joint_names, kin.continuous, settings.live.max_gap_s, settings.live.latency_s, n_channels=n_channels)
    sync.add_tool(-math.inf, _PLACEHOLDER)
    progress, turning, batches = MotionProgress(), _Turning(kin), []

    def place(final: bool = False) -> None:
        batch = sync.pop(final=final)
        if len(batch):
            batches.append(batch)
            turning.add(batch)
            progress.samples += len(batch)
            progress.seconds = float(batch.time[-1] - batches[0].time[0])
            progress.turned_rad = turning.total

    stats = progress.stats
    start, cpu0 = time.monotonic(), time.process_time()
    try:
        if on_listening is not None:
            on_listening((host, port))
        last_data = last_feed = last_shown = time.monotonic()
        while not stats.ended and (seconds is None or progress.seconds < seconds):
            datagrams = receiver.drain_from()
            now = time.monotonic()
            for data, sender in datagrams:
                feed_datagram(data, sync, stats, sender)
                if stats.ended:
                    break
            if datagrams:
                last_data = now
            else:
                time.sleep(0.005)
            if now - last_feed >= _FEED_S:
                place()
                last_feed = now
            if on_progress is not None and now - last_shown >= _PROGRESS_S:
                on_progress(progress)
                last_shown = now
            if now - last_data >= idle_timeout_s:
                if not stats.received:
                    hint = (
                        "check that the sender runs and sends to this host and port (its address, not 127.0.0.1, when it runs "
                        "on another machine: then --listen this host's address), and that no firewall drops UDP"
                    )
                    raise FeedTimeout(f"the first datagram on {address}", idle_timeout_s, hint)
                break  # the feed fell silent: what was collected is identified
    except KeyboardInterrupt:
        pass  # Ctrl-C ends the motion: what was collected is identified
    finally:
        receiver.close()
    for data, sender in receiver.drain_from():  # whatever arrived with the end
        feed_datagram(data, sync, stats, sender)
    place(final=True)
    if on_progress is not None:
        on_progress(progress)
    samples = SampleBatch.concatenate(batches) if batches else SampleBatch.empty(len(kin.joint_names), n_channels or 8)
    stats.wall_s, stats.cpu_s = time.monotonic() - start, time.process_time() - cpu0
    return LiveMotion(samples, list(sync.configurations), stats, sync, address)


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

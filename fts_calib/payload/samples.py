"""A payload's samples: read from any source, one payload checked, through the filter chain.

:func:`source_samples` reads every sample a source gives (a payload is identified once its
source has ended): a recording (CSV, CSV.gz, ROS 2 bags: :func:`fts_calib.sources.source.open_recording`),
arrays (:class:`fts_calib.sources.source.ArraySource`), any :class:`fts_calib.sources.source.Source`,
or the live feed of ``udp://HOST:PORT``, collected by :func:`collect_motion`. :func:`payload_samples`
then checks that they hold one payload and runs them through the filter chain of every job
(:func:`fts_calib.filters.chain.filter_chain`, quasi-static, no tool: the payload is unknown):
the checks refuse and count bad samples and those with a channel at its rail (declared, or
detected in the samples), and the quasi-static rules (1-3) say which samples are still, with
gravity in the sensor frame at each. Still poses are identified from the still ones, a
continuous motion from every checked one (:mod:`fts_calib.payload.identify`).

A live feed: the live protocol over UDP (:mod:`fts_calib.sources.udp`), read by the one live loop
(:class:`fts_calib.sources.live_feed.LiveFeed`): joint readings (or the sensor's orientation,
without a robot) and strains, paired by the synchronizer as ``live`` pairs them
(:class:`fts_calib.sources.synchronizer.Synchronizer`: joints interpolated at the strain times,
the pipeline's ``live.latency_s`` taken off their stamps, no interpolation across a gap longer
than ``live.max_gap_s``). Collection ends where every live stream ends: on the sender's
``end`` message, after ``seconds`` of motion (by the feed's own time stamps), on Ctrl-C or
SIGTERM, or when the feed falls silent for ``idle_timeout_s`` after it had started; a feed
that sends nothing at all within ``idle_timeout_s`` is a :class:`FeedTimeout`. Malformed,
oversized and duplicated datagrams are counted and skipped (:func:`fts_calib.sources.udp.feed_datagram`).

A tool message names the payload, as a recording's configuration column does; the samples
before any are the payload's too (a sender need not announce it), and two names are refused
as in a recording. The progress shows the seconds of motion so far and how far the sensor
has turned about each of its axes (from its orientation, 50 times a second of the feed): the
inertia about an axis the sensor has not turned about is not determined. Times in [s].
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeAlias

import numpy as np

from ..core import arrays as validation
from ..core.exceptions import PayloadError
from ..filters.chain import filter_chain
from ..filters.quasi_static import StillSamples, sample_period
from ..filters.settings import QUASI_STATIC, PipelineConfig
from ..model.calibration import Calibration
from ..model.channel_limits import ChannelLimits, detect_limits
from ..model.channels import CALIBRATION_HINT, check_channels
from ..robot.kinematics import Kinematics
from ..sources.batch import SampleBatch
from ..sources.live_feed import LiveFeed, StreamEnd
from ..sources.source import ArraySource, Source, live_address, open_recording, open_source
from ..sources.synchronizer import Synchronizer
from ..sources.udp import LiveStats, UdpReceiver

#: What a payload may be identified from: a recording's path (or several, a pattern, bags),
#: ``udp://HOST:PORT``, arrays (a :class:`SampleBatch` or a mapping of them), any :class:`Source`,
#: or a live motion collected already (:class:`LiveMotion`).
PayloadSource: TypeAlias = "str | Path | Sequence[str | Path] | SampleBatch | Mapping | Source | LiveMotion"


@dataclass(frozen=True)
class PayloadSamples:
    """A payload's samples through the filter chain.

    Attributes:
        checked: The samples that passed the checks (configuration 0 for all), in time order.
        still: The quasi-static rules' decisions over them: ``still.samples`` the still ones,
            ``still.g_sensor`` gravity in the sensor frame at each [m/s^2].
        rows: Samples read from the source.
        limits: The channels' resolution and rails (declared, or detected in the samples).
        rails: One line per channel whose samples were refused at its rail.
        where: Where they come from, for the messages (a path, ``udp://HOST:PORT``).
        derivative_window_s: The chain's joint-rate window for a motion at the samples' period [s] (the filter's duration,
            at least 3 samples: :meth:`fts_calib.filters.chain.FilterChain.motion_window`).
    """

    checked: SampleBatch
    still: StillSamples
    rows: int
    limits: ChannelLimits
    rails: tuple[str, ...]
    where: str
    derivative_window_s: float


def payload_samples(
    samples: SampleBatch,
    names: Sequence[str],
    where: str,
    kin: Kinematics,
    calibration: Calibration,
    settings: PipelineConfig | None = None,
    limits: ChannelLimits | None = None,
) -> PayloadSamples:
    """One payload's samples (a recording's, arrays, a live feed's) through the filter chain (see the module docstring).

    Args:
        samples: The samples read, in time order; ``configuration`` indexes ``names``.
        names: The tool configuration names the samples may hold (one payload: more than one held is refused).
        where: Where they come from, for the messages (a path, ``udp://HOST:PORT``).
        kin: Kinematics of the robot.
        calibration: The sensor's calibration (its channel layout is checked).
        settings: Pipeline settings (the checks' and the quasi-static filter's); the defaults when None.
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
    settings = (settings or PipelineConfig()).with_limits(found)
    chain = filter_chain(settings, kin, QUASI_STATIC, calibration.layout)
    # a NaN, a railed channel or a row out of order never poisons a window; the payload is unknown: no tool
    step = chain.samples(samples, None, final=True)
    rails = () if chain.checks.rails is None else tuple(chain.checks.rails.lines(held or ["payload"]))
    window = chain.motion_window(sample_period(step.checked.time))
    return PayloadSamples(step.checked, step.still, rows, found, rails, where, window)


def read_payload(
    source: PayloadSource,
    kin: Kinematics,
    calibration: Calibration,
    settings: PipelineConfig | None = None,
    limits: ChannelLimits | None = None,
) -> PayloadSamples:
    """A recording's (or arrays', a source's) samples of one payload through the filter chain (:func:`payload_samples`).

    Raises:
        RecordingError: The recording cannot be read.
        PayloadError: No usable row, or more than one configuration name.
    """
    samples, names, where, _ = source_samples(source, kin, settings or PipelineConfig(), calibration.layout.n_channels)
    return payload_samples(samples, names, where, kin, calibration, settings, limits)


def source_samples(
    source: PayloadSource,
    kin: Kinematics,
    settings: PipelineConfig,
    n_channels: int | None = None,
    seconds: float | None = None,
    idle_timeout_s: float | None = None,
    on_listening: Callable[[tuple[str, int]], None] | None = None,
    on_progress: Callable[[MotionProgress], None] | None = None,
) -> tuple[SampleBatch, list[str], str, bool]:
    """Every sample a source gives (see the module docstring).

    Args:
        source: A recording's path (several, a pattern, bags), ``udp://HOST:PORT``, a
            :class:`SampleBatch` or a mapping of arrays (:class:`ArraySource`), a :class:`Source`,
            or a collected :class:`LiveMotion`.
        kin: Kinematics of the robot (the joints expected, in its order).
        settings: Pipeline settings (a live feed's synchronizer: ``live``).
        n_channels: Values a strain datagram must have; None takes the first's.
        seconds: A live feed: end after this much motion [s]; None for the sender's end or Ctrl-C.
        idle_timeout_s: A live feed: the longest wait for a datagram [s]; :data:`IDLE_TIMEOUT_S` when None.
        on_listening: A live feed: called with the bound (host, port).
        on_progress: A live feed: called with the progress (:class:`MotionProgress`).

    Returns:
        ``(samples, configuration names, where, live)``; ``live``: a live feed's synchronizer
        already took ``live.latency_s`` off the joints.

    Raises:
        RecordingError: A recording that cannot be read.
        PayloadError: A recording with no usable row; a live feed of which nothing paired.
        FeedTimeout: A live feed that sent nothing within ``idle_timeout_s``.
    """
    if isinstance(source, LiveMotion):  # collected already (:func:`collect_motion`)
        return source.batch(), list(source.names), source.address, True
    if isinstance(source, str) and source.lower().startswith("udp://"):
        host, port = live_address(source)
        timeout = IDLE_TIMEOUT_S if idle_timeout_s is None else idle_timeout_s
        motion = collect_motion(host, port, kin, settings, n_channels, seconds, timeout, on_listening, on_progress)
        return motion.batch(), list(motion.names), motion.address, True
    reader: Source
    if isinstance(source, SampleBatch | Mapping):
        reader = ArraySource(source, kin.joint_names)
    elif isinstance(source, str) and "://" in source:  # another live scheme: as open_source names it (or refuses it)
        live = settings.live
        reader = open_source(source, kin.joint_names, None, continuous=kin.continuous, max_gap_s=live.max_gap_s,
                             latency_s=live.latency_s, n_channels=n_channels, end=StreamEnd(stream_s=seconds),
                             on_listening=on_listening)  # fmt: skip
    elif isinstance(source, str | Path | Sequence):
        reader = open_recording(source, kin.joint_names, None)
    else:
        reader = source
    where = str(source) if isinstance(source, str | Path) else reader.description
    with reader:
        chunks = list(reader)
        names = list(reader.tool_names)
    if not chunks:
        raise PayloadError(f"{where}: no usable row")
    return SampleBatch.concatenate(chunks), names, where, isinstance(reader, LiveFeed)


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

    def batch(self) -> SampleBatch:
        """The samples, those before the sender announced the payload taken as its (see the module docstring).

        Raises:
            PayloadError: No paired sample (the message says what the feed sent and why nothing paired).
        """
        if not len(self.samples):
            stats = self.stats
            why = "; ".join(f"{reason}: {count:,}" for reason, count in self.sync.dropped.items() if count)
            raise PayloadError(
                f"no strain sample on {self.address} could be paired with the joints ({stats.received:,} datagrams: "
                f"{stats.joints:,} joints, {stats.strain:,} strain, {stats.malformed + stats.oversized:,} malformed or oversized"
                + (f"; unpaired: {why}" if why else "")
                + "): the sender must send both the joints (or the orientation) and the strains, on one clock"
            )
        announced = [name for name in self.names[1:] if name != _PLACEHOLDER]
        if len(announced) != 1:
            return self.samples
        codes = np.where(self.samples.configuration == 0, self.names.index(announced[0]), self.samples.configuration)
        return dataclasses.replace(self.samples, configuration=codes)

    def source(self) -> ArraySource:
        """The collected samples as a :class:`Source` (:meth:`batch`): what a payload is identified from."""
        return ArraySource(self.batch(), tool_names=self.names, description=self.address)


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
    device: tuple[str, str] | None = None,
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
        device: A channel device and the joints' source, ``("serial://...", "udp://HOST:PORT")``
            or ``("netft://HOST", "ur://HOST")``, opened as every command opens them
            (:func:`fts_calib.sources.source.open_source`, every stream on the host's clock);
            None for the datagrams of ``host``:``port`` (then unused).

    Raises:
        FeedTimeout: No datagram at all within ``idle_timeout_s`` (a box or controller that never answers).
        ConfigError: A wildcard ``host``, or a ``seconds`` or ``idle_timeout_s`` that is not positive.
        DeviceLost: A serial device that cannot be opened.
    """
    if seconds is not None:
        validation.positive("seconds", seconds, "s")
    validation.positive("idle_timeout_s", idle_timeout_s, "s")
    progress, turning, batches = MotionProgress(), _Turning(kin), []
    end = StreamEnd(idle_timeout_s=idle_timeout_s, first_timeout_s=idle_timeout_s, stream_s=seconds)
    show = None if on_progress is None else (lambda _counts: on_progress(progress))
    if device is None:
        sync = Synchronizer(kin.joint_names, kin.continuous, settings.live.max_gap_s, settings.live.latency_s, n_channels=n_channels)
        sync.add_tool(-math.inf, _PLACEHOLDER)
        feed = LiveFeed(UdpReceiver(host, port), sync, end=end, on_status=show, status_interval_s=_PROGRESS_S, on_listening=on_listening)
    else:
        opened = open_source(
            device[0],
            kin.joint_names,
            None,
            continuous=kin.continuous,
            max_gap_s=settings.live.max_gap_s,
            latency_s=settings.live.latency_s,
            n_channels=n_channels,
            configuration=_PLACEHOLDER,
            end=end,
            on_status=show,
            status_interval_s=_PROGRESS_S,
            on_listening=on_listening,
            joints=device[1],
            host_clock=True,
        )
        assert isinstance(opened, LiveFeed)  # a device's name always opens a live feed
        feed, sync = opened, opened.sync
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

"""The offsets part of ``fts-calib monitor``: a known payload's wrench against the measured one (:mod:`fts_calib.monitor.offset_watch`).

The ``monitor`` command: the sensor's health over a recording, from the calibration's parity model.

It also counts the samples whose measured wrench (``C strain + D``, the calibration's D) lies
outside the load region the calibration was fitted on (:mod:`fts_calib.model.region`): loads
of the service the calibration was not determined on.
"""

from __future__ import annotations

import contextlib
import json
import math
import sys
from pathlib import Path

import numpy as np

from ..core.exceptions import ConfigError, FeedTimeout, FtsCalibError, ProtocolError, RecordingError, ResultRefused
from ..core.files import atomic_write_text, check_outputs
from ..filters.clock import check_sample_clock
from ..model.calibration import Calibration, load_calibration, save_calibration
from ..model.channels import WRENCH_AXES, WRENCH_UNITS, check_channels
from ..model.parity import ParityModel
from ..monitor.health import HealthMonitor
from ..monitor.offset_watch import RATE_SIGMAS, OffsetWatch
from ..robot.tool import tool_load
from ..service.reader import WrenchReader
from ..session.calibration_run import StatusLine
from ..sources.batch import SampleBatch
from ..sources.live_feed import FeedStatus, LiveFeed, StreamEnd
from ..sources.recording_set import describe_files
from ..sources.source import live_address, open_recording, open_source
from .exit_codes import ExitCode, using_udp, writing
from .setup import OutputOptions, Setup, SourceOptions, channel_device

#: Windows without contact before an automatic re-tare is trusted (since the last re-tare): at most one re-tare a second
#: of still windows (0.1 s each), and still windows off the tracked offset beyond this many (and beyond those that agree)
#: refuse the load assumed.
MIN_UPDATES = 10
#: Angle the payload's force must turn through, in the sensor frame, over the windows without contact since the last
#: re-tare before a re-tare is written [rad] (11.5 deg): at one orientation a payload other than the one named cannot be
#: told from an offset (the windows at a second one disagree: refused).
MIN_TILT_RAD = 0.2
#: Largest offset error tolerated before a re-tare, in % of full scale (--tare-threshold).
MAX_TARE_THRESHOLD = 100.0
#: Largest false-alarm budget, per hour of service (--false-alarms): beyond it the thresholds are not a test.
MAX_FALSE_ALARMS = 100.0
#: Samples whose median time step sizes the windows (0.1 s), whatever batches they arrive in.
SIZING_SAMPLES = 20


class OffsetFeed:
    """Feeds an :class:`OffsetWatch` from a recording's batches and re-tares when asked.

    Args:
        calibration: The calibration in use (its C and D turn channels into wrenches).
        path: Its file (re-tares are written there, atomically, with the old offsets in its history).
        parity: Its parity model (the channels' noise, for the wrench noise).
        setup: The robot's kinematics, the payload's tool file, its configuration (None: each
            sample's, the recording's tool column) and the sensor's full scale.
        auto_tare: Re-tare when the offset error exceeds ``threshold_percent``.
        threshold_percent: Offset error tolerated, in % of full scale.
    """

    def __init__(self, calibration: Calibration, path, parity: ParityModel, setup: Setup, auto_tare: bool, threshold_percent: float):
        kin, tool, configuration, full_scale = setup.kinematics, setup.tool, setup.configuration, setup.sensor.full_scale
        if configuration is not None and configuration not in tool.names:
            raise ConfigError("configuration", configuration, f"one of the tool's: {', '.join(tool.names)}")
        self.calibration, self.path, self.kin, self.tool = calibration, Path(path), kin, tool
        self.index = None if configuration is None else tool.names.index(configuration)
        self.full_scale = np.asarray(full_scale, dtype=float)
        self.threshold = self.full_scale * threshold_percent / 100.0
        self.auto_tare = auto_tare
        noise = np.sqrt(np.diag(calibration.C @ np.diag(parity.channel_noise**2) @ calibration.C.T))
        allowance = np.zeros(6)
        if tool.tolerance is not None:  # what a payload known to a tolerance adds to the residual
            heaviest = max(c.mass for c in tool.configurations)
            farthest = max(float(np.linalg.norm(c.p_sensor_com)) for c in tool.configurations)
            mass, com = tool.tolerance.total_mass, tool.tolerance.total_com  # a configuration's: common and own
            allowance[:3] = tool.gravity * mass
            allowance[3:] = tool.gravity * (heaviest * com + mass * farthest)
        self._noise, self._allowance = noise, allowance
        self.watch = OffsetWatch(noise, allowance)  # replaced by one with 0.1 s windows once the rate is known
        self._sized = False
        self._waiting: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
        self.tares: list[float] = []
        self.held = ""  # why a re-tare due was not written (the payload seen at one orientation), or ''
        self.last_time = math.nan
        self._what = f"'{tool.name}' " + (
            f"configuration {configuration}" if configuration is not None else "as the recording's tool column names it"
        )
        self._since = (0, 0)  # the watch's updates and steady windows at the last re-tare

    def add(self, time: np.ndarray, joints: np.ndarray, channels: np.ndarray, configuration: np.ndarray) -> None:
        """Add a batch: times [s] (N,), joints [rad] (N, n_joints), raw channels (N, n), configuration indices (N,) (-1: unknown).

        The windows, the updates and the re-tares do not depend on how a feed is cut into
        batches: the window length comes from the first :data:`SIZING_SAMPLES` samples (held
        until they have all arrived), and a re-tare is judged after each window.
        """
        codes = np.full(len(time), self.index) if self.index is not None else np.asarray(configuration)
        if not self._sized:
            self._waiting.append((np.asarray(time, dtype=float), np.asarray(joints), np.asarray(channels), codes))
            if sum(len(w[0]) for w in self._waiting) < SIZING_SAMPLES:
                return
            self._size_and_judge()
            return
        self._judge(time, joints, channels, codes)

    def finish(self) -> None:
        """End of the feed: a feed shorter than :data:`SIZING_SAMPLES` samples is sized from what arrived and judged."""
        if not self._sized and self._waiting:
            self._size_and_judge()

    def _size_and_judge(self) -> None:
        time, joints, channels, codes = (np.concatenate([w[k] for w in self._waiting]) for k in range(4))
        self._waiting = []
        steps = np.diff(time[:SIZING_SAMPLES])
        steps = steps[steps > 0]
        block = max(10, int(round(0.1 / float(np.median(steps))))) if len(steps) else 100  # windows of 0.1 s
        self.watch, self._sized = OffsetWatch(self._noise, self._allowance, block=block), True
        self._judge(time, joints, channels, codes)

    def _judge(self, time: np.ndarray, joints: np.ndarray, channels: np.ndarray, codes: np.ndarray) -> None:
        known = codes >= 0
        if not known.any():
            return
        time, joints, channels = time[known], joints[known], channels[known]
        payload = tool_load(self.kin, self.tool, joints, codes[known]).static
        wrench = self.calibration.wrench(channels, region_check=False)  # monitor counts the region itself
        start = 0
        while start < len(time):
            # with --auto-tare, up to the end of the next window: a re-tare is judged after each one
            stop = min(len(time), start + self.watch.block - self.watch.pending) if self.auto_tare else len(time)
            self.watch.update_batch(time[start:stop], wrench[start:stop], payload[start:stop], joints[start:stop])
            self.last_time, start = float(time[stop - 1]), stop
            if self.auto_tare and self.watch.pending == 0 and self._due():
                self._retare()
                wrench[start:] = self.calibration.wrench(channels[start:], region_check=False)

    def _due(self) -> bool:
        """Whether a re-tare is due and trusted now (after a window); refuses a load that does not fit.

        Raises:
            ResultRefused: More still windows since the last re-tare disagree with the tracked
                offset than agree, and at least :data:`MIN_UPDATES` of them: the payload named
                is not the one on the sensor (or something rests on it); nothing is written.
        """
        w = self.watch
        updates, steady = w.updates - self._since[0], w.steady - self._since[1]
        if steady >= MIN_UPDATES and steady > updates:
            worst = int(np.argmax(w.steady_worst / self.full_scale))
            raise ResultRefused(
                f"refused to re-tare ({self.path} untouched{', after ' + str(len(self.tares)) + ' re-tare(s)' if self.tares else ''}): "
                f"the load does not fit {self._what} mounted: {steady:,} still windows (no joint moving, noise-level scatter) "
                f"disagree with the offset tracked at the other {updates:,}, by up to {w.steady_worst[worst]:.3g} {WRENCH_UNITS[worst]} "
                f"on {WRENCH_AXES[worst]} ({100 * w.steady_worst[worst] / self.full_scale[worst]:.3g} % FS) by {self.last_time:.1f} s: "
                "is another configuration mounted (--configuration), or does something rest on the tool?"
            )
        if updates < MIN_UPDATES or not np.any(np.abs(w.offset) > self.threshold):  # never on the first windows' estimate
            return False
        if w.tilt_rad < MIN_TILT_RAD:
            self.held = (
                f"a re-tare is due but held: the {updates:,} windows without contact since the "
                f"{'last re-tare' if self.tares else 'start'} saw the payload turn by {math.degrees(w.tilt_rad):.1f} deg, "
                f"at least {math.degrees(MIN_TILT_RAD):.1f} deg is needed to tell an offset from a payload other than the one named"
            )
            return False
        self.held = ""
        return True

    def _retare(self) -> None:
        self.calibration = self.watch.retare(
            self.calibration, f"re-tared by monitor at {self.last_time:.3f} s: offset drift without contact"
        )
        with writing(self.path):
            save_calibration(self.calibration, self.path)
        self.tares.append(self.last_time)
        self._since = (self.watch.updates, self.watch.steady)

    def lines(self) -> list[str]:
        """The offset state in words: error, rate, windows, forecast, re-tares."""
        w = self.watch
        error = ", ".join(f"{a} {v:+.4g} {u}" for a, v, u in zip(WRENCH_AXES, w.offset, WRENCH_UNITS, strict=True))
        rate = ", ".join(f"{a} {60 * v:+.3g} {u}/min" for a, v, u in zip(WRENCH_AXES, w.rate, WRENCH_UNITS, strict=True))
        forecast = w.forecast_s(self.threshold)
        threshold = f"{100 * self.threshold[0] / self.full_scale[0]:g} % of full scale"
        exceeds = f"the offset error exceeds {threshold} " + ("never at this rate" if math.isinf(forecast) else f"in {forecast:.1f} s")
        if math.isinf(forecast) and not np.any(w.drifting()):  # a rate at the noise level: nothing to extrapolate
            exceeds = f"the offset error stays within {threshold}: no axis drifts beyond its rate's noise ({RATE_SIGMAS:g}σ)"
        out = [
            f"offset error (measured - payload, windows without contact): {error}",
            f"offset drift: {rate}; {w.updates:,} windows without contact, {w.contacts:,} refused (contact or motion)",
            exceeds,
        ]
        if self.tares:
            last = self.tares[-10:]
            which = "at" if len(last) == len(self.tares) else f"the last {len(last)} at"
            out.append(f"re-tared {len(self.tares)} time(s) ({which} {', '.join(f'{t:.1f}' for t in last)} s); wrote {self.path}")
        if self.held:
            out.append(self.held)
        return out

    def status(self) -> str:
        """The offset state for a status line: the largest error in % FS, contact or not, the re-tares."""
        worst = float(np.max(np.abs(self.watch.offset) / self.full_scale)) * 100
        state = "contact" if self.watch.in_contact else "free"
        return f"offset error {worst:.4f} % FS ({state}, {self.watch.updates:,} windows), {len(self.tares)} re-tare(s)"

    def as_dict(self) -> dict:
        """The offset state for ``--json``."""
        return {
            "error": self.watch.offset.tolist(),
            "rate_per_s": self.watch.rate.tolist(),
            "windows_without_contact": self.watch.updates,
            "windows_refused": self.watch.contacts,
            "exceeds_threshold_in_s": self.watch.forecast_s(self.threshold),
            "tares_s": self.tares,
        }


def run(
    setup: Setup,
    source: SourceOptions,
    outputs: OutputOptions | None = None,
    *,
    calibration: str | Path,
    false_alarms_per_hour: float = 1e-3,
    auto_tare: bool = False,
    tare_threshold_percent: float = 0.05,
) -> int:
    """Watch a recording's or a live feed's channels with the calibration's parity model (``fts-calib monitor``).

    Args:
        setup: With a robot: the payload's wrench from the joints, and the offset tracked
            where nothing touches the payload (:mod:`fts_calib.monitor.offset_watch`): the
            payload's tool file (None: the one the calibration records, :meth:`Setup.recorded`;
            refused when it records none), its configuration (None: each
            sample's, the recording's tool column) and the sensor's full scale.
        source: The recording (CSV or CSV.gz) of the sensor in service, or ROS 2 bags; or a
            live feed ``udp://HOST:PORT`` (its strain datagrams, :mod:`fts_calib.sources.udp`),
            watched until an 'end' datagram, Ctrl-C, SIGTERM or ``idle_timeout_s``
            (:mod:`fts_calib.sources.live_feed`); ``rate_hz``: the sample rate, measured from
            the time stamps when None (and said).
        outputs: ``json_path``: where to write ``{"events": [{"time_s", "kind", "channel",
            "detail"}, ...], "samples": N, "skipped": N, "health": "ok" | "fault", "region":
            {"outside": k, "samples": N} or null}`` (``region`` null for a calibration that
            records none), atomically; ``quiet``: no status line (live).
        calibration: Calibration file with a ``health`` section.
        false_alarms_per_hour: False-alarm budget of the tests, per hour of service.
        auto_tare: Re-tare when the offset error exceeds ``tare_threshold_percent`` (written
            into the calibration file, the old offsets in its tare history).
        tare_threshold_percent: Offset error tolerated, in % of full scale.

    Returns:
        0 when no fault was found, 1 when one was.

    Raises:
        ConfigError: No source, or a live one with recordings; the calibration has no health
            section (a layout with no more channels than axes, or a file written before it existed).
    """
    outputs = outputs or OutputOptions()
    check_settings(false_alarms_per_hour, tare_threshold_percent)
    live = source.live.get("udp")
    device = channel_device(source.live, "monitor", joints=setup.robot_file is not None)
    if not source.given:
        raise ConfigError("source", [], "a recording, or a live feed udp://HOST:PORT (one of them)")
    paths = source.paths() if live is None and device is None else []
    json_path = outputs.json_path
    check_outputs({"--json": json_path}, {"the calibration": calibration, **{f"recording {k + 1}": p for k, p in enumerate(paths)}})
    cal = load_calibration(calibration)
    if cal.health is None:
        why = (
            "its layout has no more channels than axes: nothing is load-free"
            if cal.layout.n_channels <= 6
            else "it was written before the health section existed: calibrate again"
        )
        raise ConfigError("health", None, "the calibration's parity model", message=f"{calibration} has no health section: {why}")
    parity = ParityModel.from_dict(cal.health)
    region = RegionCount(cal)
    offsets = None
    if setup.robot_file is not None:
        setup = setup.recorded(cal.provenance, calibration, robot=False)  # the payload: the calibration's tool, unless given
        offsets = OffsetFeed(cal, calibration, parity, setup, auto_tare, tare_threshold_percent)
    elif auto_tare:
        raise ConfigError("auto_tare", True, "--robot and --tool: the payload's wrench needs the joints")
    watch = HealthWatch(parity, false_alarms_per_hour, region, offsets, source.rate_hz)
    if device is not None:
        _listen(device, source, watch, outputs.quiet, joints=live)
    elif live is not None:
        _listen(live, source, watch, outputs.quiet)
    else:
        names = (offsets.kin.joint_names, offsets.tool.names) if offsets is not None else (None, None)
        with open_recording(paths, *names) as reader:
            watch.description = describe_files(paths)
            watch.path = Path(paths[0])
            for chunk in reader:
                check_channels(cal.layout, chunk.channels.shape[1], str(reader.path))
                finite = np.isfinite(chunk.time) & np.all(np.isfinite(chunk.channels), axis=1)
                watch.skip(int((~finite).sum()), "non-finite time or channel")
                watch.add(chunk.select(finite))
            for reason, count in reader.skipped.items():
                watch.skip(count, reason)
            watch.notes = reader.notes()
    return _report(watch, calibration, json_path)


def check_settings(false_alarms_per_hour: float, tare_threshold_percent: float) -> None:
    """Refuse a false-alarm budget or a re-tare threshold ``monitor`` cannot use, naming the option.

    Args:
        false_alarms_per_hour: ``--false-alarms``, per hour of service: finite, in (0, :data:`MAX_FALSE_ALARMS`].
        tare_threshold_percent: ``--tare-threshold``, in % of full scale: finite, in (0, :data:`MAX_TARE_THRESHOLD`].

    Raises:
        ConfigError: Either is outside its range (or not a number).
    """
    if not (math.isfinite(false_alarms_per_hour) and 0 < false_alarms_per_hour <= MAX_FALSE_ALARMS):
        raise ConfigError(
            "--false-alarms",
            false_alarms_per_hour,
            f"a finite budget of false alarms per hour of service above 0 and at most {MAX_FALSE_ALARMS:g} (default 1e-3)",
        )
    if not (math.isfinite(tare_threshold_percent) and 0 < tare_threshold_percent <= MAX_TARE_THRESHOLD):
        raise ConfigError(
            "--tare-threshold",
            tare_threshold_percent,
            f"a finite offset error in % of full scale above 0 and at most {MAX_TARE_THRESHOLD:g} (default 0.05): at 0 or below "
            "every window would re-tare",
        )


class HealthWatch:
    """What ``monitor`` watches a feed with: the health monitor, the load region count, the offsets, and what was seen.

    The health monitor's windows need the sample rate: given, or measured from the median step of
    the first :data:`SIZING_SAMPLES` samples' time stamps (held until they have all arrived).

    Args:
        parity: The calibration's parity model.
        false_alarms_per_hour: False-alarm budget of the tests, per hour of service.
        region: The load region count.
        offsets: The offsets watched (a payload and its robot), or None.
        rate_hz: The sample rate [Hz]; None: measured from the time stamps.

    Attributes:
        monitor: The health monitor, None before the rate is known.
        rate_found: How the rate was found, in words ('' when given).
        description: The source in words.
        skipped: Samples skipped before the monitor (non-finite, unpaired, malformed datagrams).
        reasons: Those samples by reason.
        notes: The first problems of a recording, with file and line.
        lost: Datagrams lost on the way (gaps in their ``seq`` numbers; live only).
        path: The (first) recording, for an error; None for a live feed.
    """

    def __init__(
        self, parity: ParityModel, false_alarms_per_hour: float, region: RegionCount, offsets: OffsetFeed | None, rate_hz: float | None
    ):
        self.parity, self.false_alarms_per_hour, self.region, self.offsets = parity, false_alarms_per_hour, region, offsets
        self.monitor: HealthMonitor | None = (
            None if rate_hz is None else HealthMonitor(parity, rate_hz, false_alarms_per_hour=false_alarms_per_hour)
        )
        self.rate_found = ""
        self.description = ""
        self.skipped = 0
        self.reasons: dict[str, int] = {}
        self.notes: list[str] = []
        self.lost = 0
        self.received = 0
        self.waited_s = 0.0
        self.path: Path | None = None
        self.first_time = self.last_time = math.nan
        self._waiting: list[SampleBatch] = []

    @property
    def span_s(self) -> float:
        """Time between the first and the last sample watched [s] (0 before two)."""
        return 0.0 if math.isnan(self.first_time) else self.last_time - self.first_time

    def skip(self, count: int, reason: str) -> None:
        """Count ``count`` samples skipped for ``reason`` (in words)."""
        if count:
            self.skipped += count
            self.reasons[reason] = self.reasons.get(reason, 0) + count

    def add(self, batch: SampleBatch) -> None:
        """Watch a batch of samples (finite, in time order)."""
        if not len(batch):
            return
        if self.offsets is not None:
            self.offsets.add(batch.time, batch.joints, batch.channels, batch.configuration)
        if self.monitor is None:
            self._waiting.append(batch)
            if sum(len(b) for b in self._waiting) < SIZING_SAMPLES:
                return
            self._start()
            return
        self._watch(batch)

    def finish(self) -> None:
        """End of the feed: a feed shorter than :data:`SIZING_SAMPLES` samples is sized from what arrived."""
        if self.monitor is None and self._waiting:
            self._start()
        if self.offsets is not None:
            self.offsets.finish()

    def _start(self) -> None:
        held = SampleBatch.concatenate(self._waiting)
        self._waiting = []
        steps = np.diff(held.time)
        steps = steps[steps > 0]
        if self.path is not None and len(held) >= SIZING_SAMPLES:  # a recording's clock the rate is measured from: in s, ticking
            check_sample_clock(self.path, held.time, "the health monitor's thresholds and the offsets' windows of 0.1 s need it")
        rate_hz = 1.0 / float(np.median(steps)) if len(steps) else DEFAULT_RATE_HZ
        self.rate_found = f"{rate_hz:.4g} Hz, measured from the time stamps" if len(steps) else f"{rate_hz:g} Hz (no two time stamps apart)"
        self.monitor = HealthMonitor(self.parity, rate_hz, false_alarms_per_hour=self.false_alarms_per_hour)
        self._watch(held)

    def _watch(self, batch: SampleBatch) -> None:
        if self.monitor is None:
            return
        self.monitor.update_batch(batch.time, batch.channels)
        self.region.add(batch.channels)
        if math.isnan(self.first_time):
            self.first_time = float(batch.time[0])
        self.last_time = float(batch.time[-1])


#: The sample rate taken when no two time stamps are apart (a feed of one sample) [Hz].
DEFAULT_RATE_HZ = 1000.0


class RegionCount:
    """Counts the samples whose measured wrench lies outside the calibration's load region.

    The wrench is the calibration's own (``C strain + D``, its D at the start: an offset that
    drifts by a small fraction of the region's 1 % FS margin changes nothing).

    Args:
        calibration: The calibration; one without a region counts nothing.

    Attributes:
        outside: Samples outside the region so far.
        samples: Samples counted so far.
    """

    def __init__(self, calibration: Calibration):
        self.region = calibration.region
        self.reader = WrenchReader(calibration)
        self.outside = 0
        self.samples = 0

    def add(self, channels) -> None:
        """Count samples: raw channels, shape (N, n)."""
        if self.region is not None and len(channels):
            self.outside += int(np.count_nonzero(~self.region.contains(self.reader.wrench_batch(channels))))
            self.samples += len(channels)

    def add_one(self, channels) -> None:
        """Count one sample: raw channels, shape (n,) (the reader's one-sample path: no array per call)."""
        if self.region is not None:
            self.outside += self.reader.outside_region(self.reader.wrench(channels))
            self.samples += 1

    def line(self) -> str:
        """What the summary prints, e.g. '12 of 4,035 samples (0.297 %) outside the calibrated load region (...)'."""
        if self.region is None:
            return "load region: the calibration records none (typed in by hand, or written before regions were recorded)"
        share = 100.0 * self.outside / self.samples if self.samples else 0.0
        return (
            f"{self.outside:,} of {self.samples:,} samples ({share:.3g} %) outside the calibrated load region "
            f"({self.region.describe()}; measured wrench)"
        )

    def as_dict(self) -> dict | None:
        """``{"outside": k, "samples": N}`` for ``--json``; None without a region."""
        return None if self.region is None else {"outside": self.outside, "samples": self.samples}


def _report(watch: HealthWatch, calibration: str | Path, json_path: str | Path | None) -> int:
    """Print what the monitor found, write the JSON; the exit status (1 on a fault)."""
    watch.finish()
    monitor, parity, region, offsets = watch.monitor, watch.parity, watch.region, watch.offsets
    samples = 0 if monitor is None else monitor.samples
    if not samples:
        _nothing_watched(watch)
    events = [] if monitor is None else monitor.events
    noise = ", ".join(f"{v:.3g}" for v in np.sqrt(np.diag(parity.covariance)))
    groups = " and ".join("(" + ", ".join(str(k + 1) for k in g) + ")" for g in parity.groups())
    print(f"monitor of {watch.description}: {samples:,} samples over {watch.span_s:.1f} s with {calibration}")
    print(f"parity: {parity.n_parity} load-free combinations, noise {noise} (raw units); channels that share a parity line: {groups}")
    if watch.skipped:
        print(f"skipped: {watch.skipped:,} samples ({_reasons(watch)})")
        for note in watch.notes[:3]:
            print(f"  {note}")
    if watch.path is None and watch.received:
        lost = (
            f"{watch.lost:,} lost on the way (gaps in their seq numbers), not watched" if watch.lost else "none lost (by their seq numbers)"
        )
        print(f"datagrams: {watch.received:,} received, {lost}")
    if monitor is not None:
        thresholds = f"gain z^2 > {monitor.gain_threshold:.1f}, jump chi^2 > {monitor.jump_threshold:.1f}"
        print(f"thresholds: {thresholds} ({watch.false_alarms_per_hour:g} false alarms per hour)")
        print("\n".join(f"frozen: {line}" for line in monitor.freeze_words))
    if watch.rate_found:
        print(f"sample rate: {watch.rate_found} (--rate gives it)")
    for event in events:
        print(f"  {event.time_s:10.3f} s  {event.kind:<15} strain_{event.channel}: {event.detail} (reported at {event.detected_s:.3f} s)")
    print(f"health: {'ok, no fault found' if not events else f'{len(events)} fault(s)'}")
    print(region.line())
    for line in [] if offsets is None else offsets.lines():
        print(line)
    if json_path is not None:
        data = {
            "events": [event.as_dict() for event in events],
            "samples": samples,
            "skipped": watch.skipped,
            "skipped_by_reason": watch.reasons,
            "lost": watch.lost,
            "health": "fault" if events else "ok",
            "region": region.as_dict(),
            **({} if offsets is None else {"offset": offsets.as_dict()}),
        }
        with writing(json_path):
            written = atomic_write_text(json_path, json.dumps(data, indent=2) + "\n")
        print(f"wrote {written}")
    return ExitCode.CHECK_FAILED if events else ExitCode.OK


def _listen(name: str, source: SourceOptions, watch: HealthWatch, quiet: bool, joints: str | None = None) -> None:
    """Watch the live feed ``name`` (``udp://HOST:PORT``): its strain datagrams, or with the offsets the samples paired with the joints.

    ``name`` may be a channel device (``serial://``, ``netft://``): its samples are the strains,
    and ``joints`` (``udp://HOST:PORT``) the joint datagrams the offsets need.

    The one live loop reads the feed (:func:`fts_calib.sources.source.open_source`: until an
    'end' datagram, Ctrl-C, SIGTERM or the idle timeout). Datagrams are decoded by the bounded
    protocol parser (a malformed one is counted, never fatal); a strain sample of another number
    of channels, or not after the last one, is skipped (the strains alone, placed on arrival).
    The status line (standard error, once a second) shows the samples, the health and the
    largest statistics of the last block. With the offsets (a payload and its robot), the strains
    are paired with the joint datagrams by the synchronizer first, and the offset state shows too.
    """
    udp = name if joints is None else joints
    host, port = live_address(udp) if udp.startswith("udp") else ("", 0)
    offsets, n = watch.offsets, watch.parity.n_channels
    if not udp.startswith("udp"):
        watch.description = name

    def listening(bound: tuple[str, int]) -> None:
        watch.description = f"udp://{bound[0]}:{bound[1]}"
        print(f"listening on udp://{bound[0]}:{bound[1]}; Ctrl-C or an 'end' datagram stops", flush=True)

    status = StatusLine(sys.stderr)  # rewritten on a terminal, a line every few seconds in a file

    def show(counts: FeedStatus) -> None:
        monitor = watch.monitor
        if monitor is None:
            state = f"{sum(len(b) for b in watch._waiting):,} samples, measuring the sample rate"
        else:
            gain, jump = monitor.last_statistics
            faults = ", ".join(f"{e.kind} strain_{e.channel}" for e in monitor.events) or "none"
            state = f"{monitor.samples:,} samples, health {monitor.state} (faults: {faults}; gain z^2 {gain:.1f}, jump {jump:.1f})"
        offset = "" if offsets is None else f"; {offsets.status()}"
        status.show(f"{state}; malformed {counts.malformed:,}{offset}")

    named = (offsets.kin.joint_names, offsets.tool.names) if offsets is not None else ([], None)
    with using_udp(host, port) if host else contextlib.nullcontext():
        feed = open_source(
            name,
            *named,
            continuous=None if offsets is None else offsets.kin.continuous,
            n_channels=n,
            hold_s=None if offsets is not None else 0.0,  # the strains alone: each placed on arrival
            listen_any=source.listen_any,
            end=StreamEnd(idle_timeout_s=source.idle_timeout_s),
            on_status=None if quiet else show,
            status_interval_s=1.0,
            on_listening=listening,
            joints=joints,
        )
    if not isinstance(feed, LiveFeed):  # open_source opens a live feed for a live name: never
        raise FtsCalibError(f"internal error: {name} did not open a live feed")
    with feed:
        for batch in feed:
            watch.add(batch)
    status.close()
    watch.description = watch.description or f"udp://{host}:{port}"
    for reason, count in feed.sync.dropped.items():
        watch.skip(count, reason)
    watch.skip(feed.stats.malformed, "malformed datagram" + (f": {feed.stats.first_malformed}" if feed.stats.first_malformed else ""))
    watch.skip(feed.stats.oversized, "oversized datagram")
    watch.lost = feed.stats.gaps
    watch.received, watch.waited_s = feed.stats.received, feed.stats.wall_s


def _reasons(watch: HealthWatch) -> str:
    """The samples skipped by reason, in words: 'malformed line 1, non-finite time or channel 3'."""
    return ", ".join(f"{reason}: {count:,}" for reason, count in sorted(watch.reasons.items(), key=lambda item: -item[1]))


def _nothing_watched(watch: HealthWatch) -> None:
    """No sample reached the health monitor: say why, as an error (a health verdict over nothing is none).

    Raises:
        RecordingError: From a recording (every row skipped, or none).
        ProtocolError: From a live feed whose datagrams were all unusable (another number of channels, malformed).
        FeedTimeout: From a live feed to which no datagram came.
    """
    n = watch.parity.n_channels
    if watch.path is not None:
        why = f"all {watch.skipped:,} rows were skipped ({_reasons(watch)})" if watch.skipped else "it has no data row"
        first = f"; the first: {watch.notes[0]}" if watch.notes else ""
        raise RecordingError(watch.path, None, None, f"no sample to watch: {why}{first}; a health verdict needs {n} finite channels")
    if not watch.received:
        raise FeedTimeout(f"a datagram on {watch.description}", watch.waited_s, "is the sender sending to this address?")
    why = f"all {watch.skipped:,} skipped ({_reasons(watch)})" if watch.skipped else "none of them a strain sample"
    raise ProtocolError(
        "malformed",
        f"no strain sample of {n} channels to watch on {watch.description}: {watch.received:,} datagrams received, {why}; "
        f"the calibration has {n} channels: is the sender's sensor the calibration's?",
    )

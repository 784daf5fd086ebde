"""The offsets part of ``fts-calib monitor``: a known payload's wrench against the measured one (:mod:`fts_calib.monitor.offset_watch`).

The ``monitor`` command: the sensor's health over a recording, from the calibration's parity model.

It also counts the samples whose measured wrench (``C strain + D``, the calibration's D) lies
outside the load region the calibration was fitted on (:mod:`fts_calib.model.region`): loads
of the service the calibration was not determined on.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np

from ..core.exceptions import ConfigError, FtsCalibError
from ..core.files import atomic_write_text, check_outputs
from ..model.calibration import Calibration, load_calibration, save_calibration
from ..model.channels import WRENCH_AXES, WRENCH_UNITS, check_channels
from ..model.parity import ParityModel
from ..monitor.health import HealthMonitor
from ..monitor.offset_watch import OffsetWatch
from ..robot.tool import tool_load
from ..service.reader import WrenchReader
from ..sources.batch import SampleBatch
from ..sources.live_feed import FeedStatus, LiveFeed, StreamEnd
from ..sources.recording_set import describe_files
from ..sources.source import live_address, open_recording, open_source
from .exit_codes import ExitCode, using_udp, writing
from .setup import OutputOptions, Setup, SourceOptions

#: Windows without contact before an automatic re-tare is trusted.
MIN_UPDATES = 10
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
        self.last_time = math.nan

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
            learnt = self.watch.updates >= MIN_UPDATES  # never re-tare on the first windows' estimate
            if self.auto_tare and learnt and self.watch.pending == 0 and np.any(np.abs(self.watch.offset) > self.threshold):
                self._retare()
                wrench[start:] = self.calibration.wrench(channels[start:], region_check=False)

    def _retare(self) -> None:
        self.calibration = self.watch.retare(
            self.calibration, f"re-tared by monitor at {self.last_time:.3f} s: offset drift without contact"
        )
        with writing(self.path):
            save_calibration(self.calibration, self.path)
        self.tares.append(self.last_time)

    def lines(self) -> list[str]:
        """The offset state in words: error, rate, windows, forecast, re-tares."""
        w = self.watch
        error = ", ".join(f"{a} {v:+.4g} {u}" for a, v, u in zip(WRENCH_AXES, w.offset, WRENCH_UNITS, strict=True))
        rate = ", ".join(f"{a} {60 * v:+.3g} {u}/min" for a, v, u in zip(WRENCH_AXES, w.rate, WRENCH_UNITS, strict=True))
        forecast = w.forecast_s(self.threshold)
        when = "never at this rate" if math.isinf(forecast) else f"in {forecast:.1f} s"
        out = [
            f"offset error (measured - payload, windows without contact): {error}",
            f"offset drift: {rate}; {w.updates:,} windows without contact, {w.contacts:,} refused (contact or motion)",
            f"the offset error exceeds {100 * self.threshold[0] / self.full_scale[0]:g} % of full scale {when}",
        ]
        if self.tares:
            out.append(f"re-tared {len(self.tares)} time(s) (at {', '.join(f'{t:.1f}' for t in self.tares)} s); wrote {self.path}")
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
            payload's tool file (``paper_tool`` when None), its configuration (None: each
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
    live = source.live.get("udp")
    if not source.given:
        raise ConfigError("source", [], "a recording, or a live feed udp://HOST:PORT (one of them)")
    paths = source.paths() if live is None else []
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
        offsets = OffsetFeed(cal, calibration, parity, setup, auto_tare, tare_threshold_percent)
    elif auto_tare:
        raise ConfigError("auto_tare", True, "--robot and --tool: the payload's wrench needs the joints")
    watch = HealthWatch(parity, false_alarms_per_hour, region, offsets, source.rate_hz)
    if live is not None:
        _listen(live, source, watch, outputs.quiet)
    else:
        names = (offsets.kin.joint_names, offsets.tool.names) if offsets is not None else (None, None)
        with open_recording(paths, *names) as reader:
            watch.description = describe_files(paths)
            for chunk in reader:
                check_channels(cal.layout, chunk.channels.shape[1], str(reader.path))
                finite = np.isfinite(chunk.time) & np.all(np.isfinite(chunk.channels), axis=1)
                watch.skipped += int((~finite).sum())
                watch.add(chunk.select(finite))
    return _report(watch, calibration, json_path)


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
        self.first_time = self.last_time = math.nan
        self._waiting: list[SampleBatch] = []

    @property
    def span_s(self) -> float:
        """Time between the first and the last sample watched [s] (0 before two)."""
        return 0.0 if math.isnan(self.first_time) else self.last_time - self.first_time

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
    events = [] if monitor is None else monitor.events
    noise = ", ".join(f"{v:.3g}" for v in np.sqrt(np.diag(parity.covariance)))
    groups = " and ".join("(" + ", ".join(str(k + 1) for k in g) + ")" for g in parity.groups())
    print(f"monitor of {watch.description}: {samples:,} samples over {watch.span_s:.1f} s with {calibration}")
    print(f"parity: {parity.n_parity} load-free combinations, noise {noise} (raw units); channels that share a parity line: {groups}")
    if watch.skipped:
        print(f"skipped: {watch.skipped:,} samples (non-finite, of another number of channels, or back in time)")
    if monitor is not None:
        thresholds = f"gain z^2 > {monitor.gain_threshold:.1f}, jump chi^2 > {monitor.jump_threshold:.1f}"
        print(f"thresholds: {thresholds} ({watch.false_alarms_per_hour:g} false alarms per hour)")
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
            "health": "fault" if events else "ok",
            "region": region.as_dict(),
            **({} if offsets is None else {"offset": offsets.as_dict()}),
        }
        with writing(json_path):
            written = atomic_write_text(json_path, json.dumps(data, indent=2) + "\n")
        print(f"wrote {written}")
    return ExitCode.CHECK_FAILED if events else ExitCode.OK


def _listen(name: str, source: SourceOptions, watch: HealthWatch, quiet: bool) -> None:
    """Watch the live feed ``name`` (``udp://HOST:PORT``): its strain datagrams, or with the offsets the samples paired with the joints.

    The one live loop reads the feed (:func:`fts_calib.sources.source.open_source`: until an
    'end' datagram, Ctrl-C, SIGTERM or the idle timeout). Datagrams are decoded by the bounded
    protocol parser (a malformed one is counted, never fatal); a strain sample of another number
    of channels, or not after the last one, is skipped (the strains alone, placed on arrival).
    The status line (standard error, once a second) shows the samples, the health and the
    largest statistics of the last block. With the offsets (a payload and its robot), the strains
    are paired with the joint datagrams by the synchronizer first, and the offset state shows too.
    """
    host, port = live_address(name)
    offsets, n = watch.offsets, watch.parity.n_channels

    def listening(bound: tuple[str, int]) -> None:
        print(f"listening on udp://{bound[0]}:{bound[1]}; Ctrl-C or an 'end' datagram stops", flush=True)

    def show(counts: FeedStatus) -> None:
        monitor = watch.monitor
        if monitor is None:
            state = f"{sum(len(b) for b in watch._waiting):,} samples, measuring the sample rate"
        else:
            gain, jump = monitor.last_statistics
            faults = ", ".join(f"{e.kind} strain_{e.channel}" for e in monitor.events) or "none"
            state = f"{monitor.samples:,} samples, health {monitor.state} (faults: {faults}; gain z^2 {gain:.1f}, jump {jump:.1f})"
        offset = "" if offsets is None else f"; {offsets.status()}"
        print(f"\r{state}; malformed {counts.malformed:,}{offset}", end="", file=sys.stderr, flush=True)

    joints = (offsets.kin.joint_names, offsets.tool.names) if offsets is not None else ([], None)
    with using_udp(host, port):
        feed = open_source(
            name,
            *joints,
            continuous=None if offsets is None else offsets.kin.continuous,
            n_channels=n,
            hold_s=None if offsets is not None else 0.0,  # the strains alone: each placed on arrival
            listen_any=source.listen_any,
            end=StreamEnd(idle_timeout_s=source.idle_timeout_s),
            on_status=None if quiet else show,
            status_interval_s=1.0,
            on_listening=listening,
        )
    if not isinstance(feed, LiveFeed):  # open_source opens a live feed for a live name: never
        raise FtsCalibError(f"internal error: {name} did not open a live feed")
    with feed:
        for batch in feed:
            watch.add(batch)
    if not quiet:
        print(file=sys.stderr)
    watch.description = f"udp://{host}:{port}"
    watch.skipped += sum(feed.sync.dropped.values()) + feed.stats.malformed + feed.stats.oversized

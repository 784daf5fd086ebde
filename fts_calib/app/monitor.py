"""The ``monitor`` command: the sensor's health over a recording, from the calibration's parity model.

It also counts the samples whose measured wrench (``C strain + D``, the calibration's D) lies
outside the load region the calibration was fitted on (:mod:`fts_calib.model.region`): loads
of the service the calibration was not determined on.
"""

from __future__ import annotations

import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..core.exceptions import ConfigError
from ..core.outputs import atomic_write_text
from ..core.paths import check_outputs
from ..feeds.protocol import Strain
from ..feeds.recording_set import describe_files
from ..feeds.source import open_recording, recording_paths
from ..feeds.sync import Synchronizer
from ..feeds.udp import LiveStats, UdpReceiver, feed_datagram
from ..model.calibration import Calibration, load_calibration
from ..model.channels import check_channels
from ..model.health import ParityModel
from ..service.health import HealthMonitor
from ..service.reader import WrenchReader
from .exit_codes import ExitCode, using_udp, writing
from .monitor_offsets import OffsetFeed
from .setup import load_sensor, load_setup


def run(
    *,
    recording: str | Path | Sequence[str | Path],
    calibration: str | Path,
    json_path: str | Path | None = None,
    false_alarms_per_hour: float = 1e-3,
    listen: tuple[str, int] | None = None,
    listen_any: bool = False,
    rate_hz: float = 1000.0,
    idle_timeout_s: float | None = None,
    quiet: bool = False,
    robot: str | Path | None = None,
    tool: str | Path = "paper_tool",
    configuration: str | None = None,
    sensor: str | Path = "sensor",
    auto_tare: bool = False,
    tare_threshold_percent: float = 0.05,
) -> int:
    """Watch a recording's channels with the calibration's parity model (``fts-calib monitor``).

    Args:
        recording: Recording (CSV or CSV.gz) of the sensor in service, or ROS 2 bags.
        calibration: Calibration file with a ``health`` section.
        json_path: Where to write ``{"events": [{"time_s", "kind", "channel", "detail"}, ...],
            "samples": N, "skipped": N, "health": "ok" | "fault", "region": {"outside": k,
            "samples": N} or null}`` (``region`` null for a calibration that records none),
            atomically; None for none.
        false_alarms_per_hour: False-alarm budget of the tests, per hour of service.
        listen: ``(host, port)`` of the live UDP feed to watch instead of a recording (its
            strain datagrams, :mod:`fts_calib.feeds.protocol`), until an 'end' datagram, Ctrl-C
            or ``idle_timeout_s``; None: a recording.
        listen_any: Bind every interface (see :func:`fts_calib.feeds.udp.listen_host`).
        rate_hz: Sample rate of the live feed [Hz] (a recording's is measured).
        idle_timeout_s: Stop listening after this many seconds without a datagram; None: never.
        quiet: No status line (live).
        robot: Robot definition: with it, the payload's wrench from the joints, and the offset
            tracked where nothing touches the payload (:mod:`fts_calib.service.offset_watch`).
        tool: The payload's tool file (with ``robot``).
        configuration: The payload's configuration; None: each sample's (the recording's tool column).
        sensor: Sensor configuration: its full scale (with ``robot``).
        auto_tare: Re-tare when the offset error exceeds ``tare_threshold_percent`` (written
            into the calibration file, the old offsets in its tare history).
        tare_threshold_percent: Offset error tolerated, in % of full scale.

    Returns:
        0 when no fault was found, 1 when one was.

    Raises:
        ConfigError: The calibration has no health section (a layout with no more channels
            than axes, or a file written before it existed).
    """
    if (listen is None) == (not recording):
        raise ConfigError(
            "recording", [str(p) for p in recording_paths(recording)] if recording else [], "a recording, or --listen (one of them)"
        )
    paths = recording_paths(recording) if recording else []
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
    if robot is not None:
        kin, payload, _ = load_setup(robot, tool)
        full_scale = load_sensor(sensor).full_scale
        offsets = OffsetFeed(cal, calibration, parity, kin, payload, configuration, full_scale, auto_tare, tare_threshold_percent)
    elif auto_tare:
        raise ConfigError("auto_tare", True, "--robot and --tool: the payload's wrench needs the joints")
    if listen is not None:
        live, span, skipped = _listen(parity, listen, listen_any, rate_hz, false_alarms_per_hour, idle_timeout_s, quiet, region, offsets)
        source = f"udp://{listen[0]}:{listen[1]}"
        return _report(live, parity, source, calibration, span, skipped, false_alarms_per_hour, json_path, region, offsets)
    monitor: HealthMonitor | None = None
    skipped = 0
    first_time = last_time = None
    names = (kin.joint_names, payload.names) if offsets is not None else (None, None)
    with open_recording(paths, *names) as reader:
        for chunk in reader:
            check_channels(cal.layout, chunk.channels.shape[1], str(reader.path))
            finite = np.isfinite(chunk.time) & np.all(np.isfinite(chunk.channels), axis=1)
            skipped += int((~finite).sum())
            time, channels = chunk.time[finite], chunk.channels[finite]
            if offsets is not None and len(time):
                offsets.add(time, chunk.joints[finite], channels, chunk.configuration[finite])
            if not len(time):
                continue
            if monitor is None:
                steps = np.diff(time)
                steps = steps[steps > 0]
                rate_hz = 1.0 / float(np.median(steps)) if len(steps) else 1000.0
                monitor = HealthMonitor(parity, rate_hz, false_alarms_per_hour=false_alarms_per_hour)
                first_time = float(time[0])
            monitor.update_batch(time, channels)
            region.add(channels)
            last_time = float(time[-1])
    span = 0.0 if first_time is None or last_time is None else last_time - first_time
    return _report(monitor, parity, describe_files(paths), calibration, span, skipped, false_alarms_per_hour, json_path, region, offsets)


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


def _report(
    monitor: HealthMonitor | None,
    parity: ParityModel,
    source: str,
    calibration: str | Path,
    span: float,
    skipped: int,
    false_alarms_per_hour: float,
    json_path: str | Path | None,
    region: RegionCount,
    offsets: OffsetFeed | None = None,
) -> int:
    """Print what the monitor found, write the JSON; the exit status (1 on a fault)."""
    if offsets is not None:
        offsets.finish()
    samples = 0 if monitor is None else monitor.samples
    events = [] if monitor is None else monitor.events
    noise = ", ".join(f"{v:.3g}" for v in np.sqrt(np.diag(parity.covariance)))
    groups = " and ".join("(" + ", ".join(str(k + 1) for k in g) + ")" for g in parity.groups())
    print(f"monitor of {source}: {samples:,} samples over {span:.1f} s with {calibration}")
    print(f"parity: {parity.n_parity} load-free combinations, noise {noise} (raw units); channels that share a parity line: {groups}")
    if skipped:
        print(f"skipped: {skipped:,} samples (non-finite, of another number of channels, or back in time)")
    if monitor is not None:
        thresholds = f"gain z^2 > {monitor.gain_threshold:.1f}, jump chi^2 > {monitor.jump_threshold:.1f}"
        print(f"thresholds: {thresholds} ({false_alarms_per_hour:g} false alarms per hour)")
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
            "skipped": skipped,
            "health": "fault" if events else "ok",
            "region": region.as_dict(),
            **({} if offsets is None else {"offset": offsets.as_dict()}),
        }
        with writing(json_path):
            written = atomic_write_text(json_path, json.dumps(data, indent=2) + "\n")
        print(f"wrote {written}")
    return ExitCode.CHECK_FAILED if events else ExitCode.OK


def _listen(
    parity: ParityModel,
    address: tuple[str, int],
    listen_any: bool,
    rate_hz: float,
    false_alarms_per_hour: float,
    idle_timeout_s: float | None,
    quiet: bool,
    region: RegionCount,
    offsets: OffsetFeed | None = None,
) -> tuple[HealthMonitor, float, int]:
    """Watch the live feed's strain datagrams; returns the monitor, the time span [s] and the samples skipped.

    Datagrams are decoded by the bounded protocol parser (a malformed one is counted, never
    fatal); a strain sample of another number of channels, or not after the last one, is skipped.
    The status line (standard error, once a second) shows the samples, the health and the
    largest statistics of the last block. With ``offsets`` (a payload and its robot), the
    strains are paired with the joint datagrams by the synchronizer first, and the offset
    state shows too.
    """
    host, port = address
    monitor = HealthMonitor(parity, rate_hz, false_alarms_per_hour=false_alarms_per_hour)
    stats = LiveStats()
    with using_udp(host, port):
        receiver = UdpReceiver(host, port, listen_any)
    print(f"listening on udp://{receiver.address[0]}:{receiver.address[1]}; Ctrl-C or an 'end' datagram stops", flush=True)
    n, skipped = parity.n_channels, 0
    first = last = None
    sync = None
    if offsets is not None:
        sync = Synchronizer(offsets.kin.joint_names, offsets.kin.continuous, configurations=offsets.tool.names, n_channels=n)
    quiet_since = status_at = time.monotonic()
    try:
        while not stats.ended:
            datagrams = receiver.drain_from()
            now = time.monotonic()
            if not datagrams:
                if idle_timeout_s is not None and now - quiet_since > idle_timeout_s:
                    break
                time.sleep(0.002)  # the receiver's thread queues what arrives meanwhile
                continue
            quiet_since = now
            if sync is not None:
                for data, sender in datagrams:
                    feed_datagram(data, sync, stats, sender)
                first, last = _paired(sync.pop(final=stats.ended), monitor, region, offsets, first, last)
                datagrams = []
            for data, sender in datagrams:
                message = feed_datagram(data, None, stats, sender)
                if not isinstance(message, Strain):
                    continue
                if len(message.strain) != n or (last is not None and message.t <= last):
                    skipped += 1
                    continue
                monitor.update(message.t, message.strain)
                region.add_one(message.strain)
                first = message.t if first is None else first
                last = message.t
            if not quiet and now - status_at >= 1.0:
                status_at = now
                gain, jump = monitor.last_statistics
                faults = ", ".join(f"{e.kind} strain_{e.channel}" for e in monitor.events) or "none"
                offset = "" if offsets is None else f"; {offsets.status()}"
                print(
                    f"\r{monitor.samples:,} samples, health {monitor.state} (faults: {faults}; gain z^2 {gain:.1f}, jump {jump:.1f}); "
                    f"malformed {stats.malformed:,}{offset}",
                    end="",
                    file=sys.stderr,
                    flush=True,
                )
    except KeyboardInterrupt:
        pass
    finally:
        receiver.close()
    if sync is not None:
        first, last = _paired(sync.pop(final=True), monitor, region, offsets, first, last)
        skipped += sum(sync.dropped.values())
    if not quiet:
        print(file=sys.stderr)
    skipped += stats.malformed + stats.oversized
    return monitor, 0.0 if first is None or last is None else last - first, skipped


def _paired(
    batch, monitor: HealthMonitor, region: RegionCount, offsets: OffsetFeed | None, first, last
) -> tuple[float | None, float | None]:
    """Feed the synchronizer's paired samples to the monitor, the region count and the offsets; the first and last times so far."""
    if not len(batch):
        return first, last
    monitor.update_batch(batch.time, batch.channels)
    region.add(batch.channels)
    if offsets is not None:
        offsets.add(batch.time, batch.joints, batch.channels, batch.configuration)
    return (float(batch.time[0]) if first is None else first), float(batch.time[-1])

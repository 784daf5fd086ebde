"""``fts-calib record``: joints and raw channels on one clock, into a recording.

The joints come from a UR controller (``ur://HOST``, RTDE) or the joint datagrams
(``udp://HOST:PORT``); the channels from a serial line (``serial://...``), an ATI Net F/T box
(``netft://HOST``) or the strain datagrams (``udp://HOST:PORT``, the same address as the
joints). Every stream is stamped on arrival with the host's monotonic clock
(:mod:`fts_calib.sources.devices`: a stream with its own stamps is mapped onto it), paired by
the live loop's synchronizer (:class:`~fts_calib.sources.live_feed.LiveFeed`) and written in
the recording format (:class:`~fts_calib.sources.writer.RecordingWriter`, atomically). Beside
the recording, ``FILE.streams.yaml`` gives each stream's samples, rate [Hz], interval jitter [s],
latency [s] and clock offset [s], and what was skipped.

The run ends on the sender's ``end``, ``--seconds``, ``--idle-timeout``, a device that stops
(the cable pulled), or Ctrl-C / SIGTERM: in every case the recording is whole and readable.
"""

from __future__ import annotations

import contextlib
import sys
import time
from collections import Counter
from pathlib import Path
from typing import Any

from ..core.exceptions import ConfigError, FtsCalibError
from ..core.files import atomic_write_text, check_outputs, dump_yaml
from ..sources.batch import SampleBatch
from ..sources.live_feed import FeedStatus, LiveFeed, StreamEnd
from ..sources.source import DEVICE_SCHEMES, live_address, open_source
from ..sources.writer import RecordingWriter
from .exit_codes import ExitCode, using_udp, writing
from .setup import OutputOptions, Setup, SourceOptions

#: What the sources of ``record`` may be, in words.
EXPECTED = (
    "the joints (ur://HOST, or udp://HOST:PORT datagrams) and the channels (serial://DEVICE?baud=..., netft://HOST, "
    "or the strain datagrams of the same udp://HOST:PORT)"
)


def streams_path(output: str | Path) -> Path:
    """The YAML of the streams' figures beside a recording: ``run.csv`` -> ``run.streams.yaml``."""
    path = Path(output)
    name = path.name
    for suffix in (".csv.gz", ".csv"):
        if name.endswith(suffix):
            return path.with_name(name[: -len(suffix)] + ".streams.yaml")
    return path.with_name(name + ".streams.yaml")


def _sources(given: list[str]) -> tuple[str, str | None]:
    """The channels' source and the joints' (None: the channels' own, ``udp://``).

    Raises:
        ConfigError: Not one channel source and at most one joint source (the message says what is expected).
    """
    kinds: dict[str, str] = {}
    for name in given:
        kind = name.split("://", 1)[0].lower() if "://" in name else ""
        kind = "device" if kind in DEVICE_SCHEMES else kind
        if kind not in ("udp", "ur", "device") or kind in kinds:
            raise ConfigError("source", given, EXPECTED, message=f"{' '.join(given) or 'no source'}: expected {EXPECTED}")
        kinds[kind] = name
    if "device" in kinds:
        joints = kinds.get("ur") or kinds.get("udp")
        if joints is None or len(kinds) > 2:
            raise ConfigError("source", given, EXPECTED, message=f"{' '.join(given)}: expected {EXPECTED}")
        return kinds["device"], joints
    if "udp" in kinds:
        return kinds["udp"], kinds.get("ur")
    raise ConfigError("source", given, EXPECTED, message=f"{' '.join(given) or 'no source'}: no channels: expected {EXPECTED}")


class Progress:
    """Samples written per configuration, and the status line."""

    def __init__(self, names: list[str]):
        self.names = names
        self.samples: Counter[str] = Counter()
        self.span: dict[str, list[float]] = {}

    def add(self, batch: SampleBatch) -> list[str]:
        """Count a batch; its configuration name per sample."""
        tools = [self.names[k] if 0 <= k < len(self.names) else "" for k in batch.configuration.tolist()]
        for name, t in zip(tools, batch.time.tolist(), strict=True):
            self.samples[name] += 1
            first_last = self.span.setdefault(name, [t, t])
            first_last[1] = t
        return tools

    def line(self, status: FeedStatus | None = None) -> str:
        """Per configuration: samples and seconds; with the status, the streams' rates."""
        parts = [f"{name or '?'}: {n:,} samples ({self.span[name][1] - self.span[name][0]:.1f} s)" for name, n in self.samples.items()]
        text = "; ".join(parts) or "no sample yet"
        if status is not None:
            text += f" | channels {status.strain_hz:.0f} Hz, joints {status.joints_hz:.0f} Hz, lost {status.lost:,}"
        return text


def run(setup: Setup, source: SourceOptions, outputs: OutputOptions) -> int:
    """Record joints and channels on one clock (``fts-calib record``; see the module docstring).

    Args:
        setup: The robot (its joint names; required) and ``configuration``, the tool
            configuration mounted (tool datagrams may change it).
        source: The SOURCE texts (channels and joints), ``window_s`` (stop after so many
            seconds [s]), ``idle_timeout_s``, ``listen_any``, ``ur_timeout_s``.
        outputs: ``output`` (the recording, CSV or CSV.gz; required) and ``quiet``.

    Returns:
        0; 1 when no sample could be written (no file is then left).

    Raises:
        ConfigError: Sources that are not one channel source and at most one joint source, no
            robot, no output.
        FeedTimeout: A Net F/T box or a UR controller that never answered (naming it).
        DeviceLost: A serial device that cannot be opened (exit 14).
    """
    channels, joints = _sources([str(name) for name in source.given])
    if setup.robot_file is None:
        raise ConfigError("robot", None, "a robot definition", message="record writes the joints of a robot: give it with --robot")
    if outputs.output is None:
        raise ConfigError("output", None, "a recording file", message="record writes a recording: give it with -o FILE.csv")
    output = Path(outputs.output)
    figures = streams_path(output)
    check_outputs({"-o": output, "the streams' figures": figures}, setup.inputs())
    ending = StreamEnd(idle_timeout_s=source.idle_timeout_s, duration_s=source.window_s)
    kin = setup.kinematics
    udp = channels if channels.startswith("udp") else joints if joints is not None and joints.startswith("udp") else None
    host, port = live_address(udp) if udp is not None else ("", 0)
    progress = Progress([])

    def status(counts: FeedStatus) -> None:
        if not outputs.quiet:
            print(f"\r{progress.line(counts)}   ", end="", file=sys.stderr, flush=True)

    def listening(address: tuple[str, int]) -> None:
        print(f"listening on udp://{address[0]}:{address[1]}; Ctrl-C ends the recording (whole)", flush=True)

    with using_udp(host, port) if udp is not None else contextlib.nullcontext():
        feed = open_source(
            joints if channels.startswith("udp") and joints is not None else channels,
            kin.joint_names,
            None,
            continuous=kin.continuous,
            max_gap_s=setup.settings.live.max_gap_s,
            configuration=setup.configuration,
            listen_any=source.listen_any,
            udp=channels if channels.startswith("udp") and joints is not None else None,
            ur_timeout_s=source.ur_timeout_s,
            end=ending,
            on_status=status,
            status_interval_s=1.0,
            on_listening=listening,
            joints=None if channels.startswith("udp") else joints,
            host_clock=True,
        )
    if not isinstance(feed, LiveFeed):  # open_source opens a live feed for a live name: never
        raise FtsCalibError(f"internal error: {channels} did not open a live feed")
    print(f"recording {feed.description} into {output} (every stream on this host's monotonic clock)", flush=True)
    writer: RecordingWriter | None = None
    started = time.monotonic()
    try:
        with feed:
            for batch in feed:
                progress.names = feed.tool_names
                if writer is None:
                    with writing(output):
                        writer = RecordingWriter(output, kin.joint_names, batch.channels.shape[1])
                with writing(output):
                    writer.write(batch.time, batch.joints, batch.channels, progress.add(batch))
    except BaseException:
        if writer is not None:
            writer.abort()
        if not outputs.quiet:
            print(file=sys.stderr)  # the error on a line of its own, after the status line
        raise
    if not outputs.quiet:
        print(file=sys.stderr)
    if writer is None:
        print(f"nothing recorded: no sample could be placed ({feed.ended_by or 'ended'}); {_skipped(feed) or 'nothing skipped'}")
        for note in feed.notes():
            print(f"  note: {note}")
        return ExitCode.CHECK_FAILED
    with writing(output):
        written = writer.close()
    summary = _figures(feed, written, time.monotonic() - started)
    with writing(figures):
        atomic_write_text(figures, dump_yaml(summary))
    print(f"ended by {feed.ended_by}: {progress.line()}")
    for name, figure in summary["streams"].items():
        print(f"  {name}: {_described(figure)}")
    skipped = _skipped(feed)
    if skipped:
        print(f"  skipped: {skipped}")
    for note in feed.notes():
        print(f"  note: {note}")
    print(f"wrote {written} ({writer.rows:,} rows) and {figures}")
    return ExitCode.OK


def _skipped(feed: LiveFeed) -> str:
    return ", ".join(f"{count:,} {reason}" for reason, count in feed.skipped.items() if count)


def _described(figure: dict[str, Any]) -> str:
    """One stream's figures in words."""

    def ms(value: float | None) -> str:
        return "n/a" if value is None else f"{1e3 * value:.3f} ms"

    rate = figure.get("rate_hz")
    return (
        f"{figure['samples']:,} samples, {'n/a' if rate is None else f'{rate:.1f} Hz'}, interval jitter {ms(figure['interval_jitter_s'])}, "
        f"latency {ms(figure['latency_s'])} (above the fastest sample)"
    )


def _figures(feed: LiveFeed, recording: Path, wall_s: float) -> dict[str, Any]:
    """The YAML beside the recording: the clock, each stream's figures, what was skipped."""
    return {
        "recording": recording.name,
        "clock": "host time.monotonic() [s]: every stream stamped on arrival (a stream with its own stamps mapped onto it)",
        "source": feed.description,
        "ended_by": feed.ended_by,
        "wall_s": round(wall_s, 3),
        "rows": feed.samples,
        "streams": {name: clock.summary() for name, clock in feed.clocks.items()},
        "skipped": {reason: int(count) for reason, count in feed.skipped.items() if count},
        "lost_datagrams": int(feed.stats.gaps),
        "notes": feed.notes(),
        "units": {"rate_hz": "Hz", "interval_jitter_s": "s", "latency_s": "s", "clock_offset_s": "s"},
    }

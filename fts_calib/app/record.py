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
import os
import select
import sys
import time
from collections import Counter
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from ..core.exceptions import ConfigError, FtsCalibError
from ..core.files import atomic_write_text, check_outputs, dump_yaml
from ..session.plan_progress import load_plan_progress
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
    """Samples written per configuration, and the status line.

    Attributes:
        names: The feed's configuration names, by index.
        planned: Configuration name -> its planned duration [s] (``--plan``), shown as "x of y s".
    """

    def __init__(self, names: list[str], planned: dict[str, float] | None = None):
        self.names = names
        self.planned = planned or {}
        self.samples: Counter[str] = Counter()
        self.span: dict[str, list[float]] = {}

    def add(self, batch: SampleBatch) -> list[str]:
        """Count a batch; its configuration name per sample."""
        tools = [self.names[k] if 0 <= k < len(self.names) else "" for k in batch.configuration.tolist()]
        self.count(batch.time, tools)
        return tools

    def count(self, times: np.ndarray, tools: list[str]) -> None:
        """Count samples at ``times`` [s], shape (N,), of configurations ``tools`` (N names)."""
        for name, t in zip(tools, np.asarray(times).tolist(), strict=True):
            self.samples[name] += 1
            first_last = self.span.setdefault(name, [t, t])
            first_last[1] = t

    def _seconds(self, name: str) -> str:
        held = self.span[name][1] - self.span[name][0]
        return f"{held:.1f} of {self.planned[name]:.1f} s" if name in self.planned else f"{held:.1f} s"

    def line(self, status: FeedStatus | None = None) -> str:
        """Per configuration: samples and seconds (of the planned ones with ``--plan``); with the status, the streams' rates."""
        parts = [f"{name or '?'}: {n:,} samples ({self._seconds(name)})" for name, n in self.samples.items()]
        text = "; ".join(parts) or "no sample yet"
        if status is not None:
            text += f" | channels {status.strain_hz:.0f} Hz, joints {status.joints_hz:.0f} Hz, lost {status.lost:,}"
        return text


class PlanSteps:
    """The configurations of a plan, one after the other, each for the plan's duration (``record --plan``).

    On a terminal each tool change is asked for ("mount configuration B, then press Enter")
    and the configuration starts when Enter is read; samples before it (the tool being
    changed) are not written. When standard input is not a terminal nothing is asked: the
    configurations follow the plan's order, each starting where the one before ended (an
    end of input on the terminal does the same from then on). A configuration ends after
    the plan's duration per configuration [s] of samples; after the last, the run ends.

    Attributes:
        names: The plan's configurations, in order.
        duration_s: The planned motion per configuration [s].
        index: The configuration now recorded or asked for (``len(names)``: all done).
        start: The host time [s] the current configuration started, None while asking.
        skipped: Samples not written (before a configuration started: tool changes).
    """

    def __init__(self, names: list[str], duration_s: float, stdin: TextIO, out: TextIO):
        self.names, self.duration_s, self.out = names, duration_s, out
        self._fd = stdin.fileno() if stdin.isatty() else None
        self.index, self.skipped = 0, 0
        self.start: float | None = None
        if self._fd is None:
            print(
                f"following the plan's configurations {', '.join(names)} in order ({duration_s:.2f} s each; standard input is "
                "not a terminal: nothing asked)",
                file=out,
                flush=True,
            )
        else:
            self._ask()

    @property
    def done(self) -> bool:
        """Every configuration recorded."""
        return self.index >= len(self.names)

    def _ask(self) -> None:
        print(f"mount configuration {self.names[self.index]}, start the plan's motion and press Enter", file=self.out, flush=True)

    def _entered(self) -> bool:
        """A line (Enter) is waiting on the terminal (read); at the end of its input, asking stops."""
        if self._fd is None:
            return True
        if not select.select([self._fd], [], [], 0)[0]:
            return False
        if not os.read(self._fd, 4096):
            self._fd = None  # the terminal's input ended (Ctrl-D): the plan's order from here on
        return True

    def label(self, times: np.ndarray) -> list[str]:
        """The configuration of each sample at ``times`` [s] (host clock), shape (N,); "" for one not to write."""
        tools = [""] * len(times)
        for k, t in enumerate(np.asarray(times).tolist()):
            if self.done:
                break
            if self.start is None:
                if not self._entered():
                    continue
                self.start = t if self._fd is None else time.monotonic()  # Enter read now: the samples from now on
                print(f"recording configuration {self.names[self.index]} for {self.duration_s:.2f} s", file=self.out, flush=True)
            if t < self.start:
                continue
            if t > self.start + self.duration_s:
                self.index += 1
                end = self.start + self.duration_s
                self.start = None
                if self.done:
                    break
                if self._fd is None:
                    self.start = end  # the next at once, in the plan's order
                    print(f"recording configuration {self.names[self.index]} for {self.duration_s:.2f} s", file=self.out, flush=True)
                else:
                    self._ask()
                    continue
            tools[k] = self.names[self.index]
        self.skipped += tools.count("")
        return tools


def _plan_steps(plan: str, robot: str, stdin: TextIO, out: TextIO) -> PlanSteps:
    """The plan's steps (``--plan``): its configurations and duration, the robot checked.

    Raises:
        FileFormatError: Not a plan (names the file and field).
        ConfigError: A plan for another robot than ``--robot``.
    """
    planned = load_plan_progress(plan, 1.0)
    if planned.robot is not None and planned.robot != robot:
        message = f"--plan {plan} is a plan for {planned.robot}, but --robot is {robot}: give the plan made for this robot"
        raise ConfigError("--plan", plan, f"a plan for {robot}", message=message)
    return PlanSteps(list(planned.expected), planned.duration_s, stdin, out)


def run(setup: Setup, source: SourceOptions, outputs: OutputOptions, *, plan: str | None = None) -> int:
    """Record joints and channels on one clock (``fts-calib record``; see the module docstring).

    Args:
        setup: The robot (its joint names; required) and ``configuration``, the tool
            configuration mounted (tool datagrams may change it); not with ``plan``.
        source: The SOURCE texts (channels and joints), ``window_s`` (stop after so many
            seconds [s]), ``idle_timeout_s``, ``listen_any``, ``ur_timeout_s``.
        outputs: ``output`` (the recording, CSV or CSV.gz; required) and ``quiet``.
        plan: The plan being followed (``--plan``: its ``plan.yaml``, folder or shipped name):
            its configurations in order, each for its duration (:class:`PlanSteps`); the run
            ends after the last.

    Returns:
        0; 1 when no sample could be written (no file is then left).

    Raises:
        ConfigError: Sources that are not one channel source and at most one joint source, no
            robot, no output, ``plan`` with ``--configuration`` or for another robot.
        FileFormatError: ``plan`` is not a plan.yaml (names the file and field).
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
    if plan is not None and setup.configuration is not None:
        message = f"--plan {plan} gives the configurations (in its order): leave out --configuration {setup.configuration}"
        raise ConfigError("--configuration", setup.configuration, "not with --plan", message=message)
    steps = None if plan is None else _plan_steps(plan, kin.robot.name, sys.stdin, sys.stdout)
    progress = Progress([], None if steps is None else dict.fromkeys(steps.names, steps.duration_s))

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
            configuration=setup.configuration if steps is None else steps.names[0],  # with a plan: its labels (PlanSteps) win
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
                if steps is None:
                    stamps, q, values, tools = batch.time, batch.joints, batch.channels, progress.add(batch)
                else:
                    labels = steps.label(batch.time)  # "" before a configuration started (a tool change) or after the last
                    keep = np.array([bool(name) for name in labels], dtype=bool)
                    stamps, q, values, tools = batch.time[keep], batch.joints[keep], batch.channels[keep], [n for n in labels if n]
                    progress.count(stamps, tools)
                if len(stamps):
                    with writing(output):
                        if writer is None:
                            writer = RecordingWriter(output, kin.joint_names, values.shape[1])
                        writer.write(stamps, q, values, tools)
                if steps is not None and steps.done:
                    break
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
    ended = "the plan's last configuration" if steps is not None and steps.done else feed.ended_by
    summary = _figures(feed, written, time.monotonic() - started, ended)
    if steps is not None:
        summary["skipped"]["not in a configuration of the plan (tool changes)"] = steps.skipped
    with writing(figures):
        atomic_write_text(figures, dump_yaml(summary))
    print(f"ended by {ended}: {progress.line()}")
    for name, figure in summary["streams"].items():
        print(f"  {name}: {_described(figure)}")
    skipped = _skipped(feed)
    if skipped:
        print(f"  skipped: {skipped}")
    if steps is not None:
        print(f"  not written: {steps.skipped:,} samples outside the plan's configurations (tool changes)")
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


def _figures(feed: LiveFeed, recording: Path, wall_s: float, ended: str | None) -> dict[str, Any]:
    """The YAML beside the recording: the clock, each stream's figures, what was skipped, what ``ended`` the run."""
    return {
        "recording": recording.name,
        "clock": "host time.monotonic() [s]: every stream stamped on arrival (a stream with its own stamps mapped onto it)",
        "source": feed.description,
        "ended_by": ended,
        "wall_s": round(wall_s, 3),
        "rows": feed.samples,
        "streams": {name: clock.summary() for name, clock in feed.clocks.items()},
        "skipped": {reason: int(count) for reason, count in feed.skipped.items() if count},
        "lost_datagrams": int(feed.stats.gaps),
        "notes": feed.notes(),
        "units": {"rate_hz": "Hz", "interval_jitter_s": "s", "latency_s": "s", "clock_offset_s": "s"},
    }

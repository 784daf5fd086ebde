"""The ``tare`` command: new offsets D for a calibration file, from a short still window."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..core.exceptions import ConfigError, FtsCalibWarning
from ..core.files import check_outputs
from ..core.tables import table
from ..model.calibration import load_calibration, save_calibration
from ..model.channels import WRENCH_AXES, WRENCH_UNITS
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool
from ..service.retare_job import TareResult, tare_live, tare_recording
from ..sources.source import live_address
from .exit_codes import ExitCode, using_udp, writing
from .setup import Setup, SourceOptions, channel_device


def format_tare(result: TareResult) -> str:
    """The old and new offsets per axis, their change and standard error."""
    estimate = result.estimate
    rows = [
        [axis, f"{old:+.5f}", f"{new:+.5f}", f"{new - old:+.5f}", f"{drift:+.5f}", f"{se:.1g}", unit]
        for axis, old, new, drift, se, unit in zip(
            WRENCH_AXES, result.previous, estimate.D, result.since_calibration, estimate.stderr_D, WRENCH_UNITS, strict=True
        )
    ]
    text = f"re-tare from {estimate.samples_used:,} samples ({estimate.samples_skipped:,} skipped):\n" + table(
        ["axis", "old D", "new D", "change", "since calibration", "stderr", "unit"], rows, "  "
    )
    retares = len(result.calibration.offset_history)
    if result.elapsed_s is not None and result.elapsed_s > 0:
        hours = result.elapsed_s / 3600.0
        worst = int(np.argmax(np.abs(result.since_calibration[:3])))
        rate = result.since_calibration[worst] / hours
        text += (
            f"\ndrift since the calibration, {hours:.2f} h ago ({retares} offsets in the history): largest force drift "
            f"{WRENCH_AXES[worst]} {result.since_calibration[worst]:+.4f} N, {rate:+.3g} N/h on average"
        )
    return text


def run(setup: Setup, source: SourceOptions, *, calibration: str | Path, output: str | Path | None = None) -> int:
    """Estimate the offsets D again, C_bar kept, and write the calibration (``fts-calib tare``).

    Args:
        setup: With ``configuration`` (the tool configuration mounted; None: nothing mounted)
            the robot and the tool (each None: the files the calibration records,
            :meth:`Setup.recorded`; a calibration made without a robot file, or ``mount_rpy``
            given: a recording or feed that gives the sensor's orientation); the pipeline
            settings (filter thresholds).
        source: The recording with the sensor still, or a live feed ``udp://HOST:PORT`` read for
            ``window_s`` [s] (2 s when None; or to the sender's 'end', Ctrl-C).
        calibration: Calibration file to update.
        output: Where to write; None updates ``calibration`` in place.

    Returns:
        0.

    Raises:
        ConfigError: No source, or more than one; ``mount_rpy`` with a robot; or ``output``
            one of the inputs (the recording: ``-o`` is the calibration to write).
    """
    given = source.given
    if len(given) != 1:
        message = (
            "give a recording or a live feed udp://HOST:PORT to re-tare from"
            if not given
            else f"one source to re-tare from, not {len(given)}"
        )
        raise ConfigError("source", [str(name) for name in given], "a recording or a live address", message=message)
    live = source.live.get("udp")
    device = channel_device(source.live, "tare", joints=False)
    recording = None if live is not None or device is not None else given[0]
    if output is not None:  # without -o the calibration is updated in place: that is the job
        check_outputs(
            {"-o": output},
            {
                "the recording": recording,
                "the robot file": setup.robot_file,
                "the tool file": setup.tool_file,
                "the pipeline file": setup.pipeline_file,
            },
        )
    current = load_calibration(calibration)
    kin: Kinematics | None = None
    mounted: Tool | None = None
    configuration = setup.configuration
    if configuration is not None:  # the load depends on the orientation: the robot's joints, or the recording's orientation
        setup = setup.recorded(current.provenance, calibration)  # the robot and tool it was made with, unless given
        kin, mounted = setup.kinematics, setup.tool
        mounted.configuration(configuration)  # a clear error for an unknown name, before any waiting
    settings = setup.settings
    if recording is not None:
        result = tare_recording(current, recording, kin, mounted, configuration, settings)
    elif device is not None:
        if kin is not None:
            message = f"{device}: a re-tare from a channel device is made with nothing mounted (no --configuration)"
            raise ConfigError("configuration", configuration, "nothing mounted with a channel device", message=message)
        window_s = WINDOW_S if source.window_s is None else source.window_s
        print(f"reading {device} for {window_s:g} s: hold the sensor still...", flush=True)
        result = tare_live(current, "", 0, window_s, None, None, None, settings, device=device)
    else:
        host, port = live_address(str(live))
        window_s = WINDOW_S if source.window_s is None else source.window_s

        def listening(address: tuple[str, int]) -> None:  # the bound port, also when the source gave port 0
            print(f"listening on udp://{address[0]}:{address[1]} for {window_s:g} s: hold the sensor still...", flush=True)

        with using_udp(host, port):
            result = tare_live(current, host, port, window_s, kin, mounted, configuration, settings, listening)
    if mounted is None:
        known = setup if setup.tool_file is not None else _recorded_tool(setup, current.provenance, calibration)
        if known is not None:  # no tool known: no weight to compare with
            _warn_if_a_tool_seems_mounted(result, known.tool)
    target = calibration if output is None else output
    with writing(target):
        written = save_calibration(result.calibration, target)
    print(format_tare(result))
    for line in result.rails:
        print(f"  refused: {line}")
    print(f"wrote {written} (previous offsets kept in offset_history: {len(result.calibration.offset_history)} entries)")
    return ExitCode.OK


#: The length of a live window when ``--seconds`` is not given [s].
WINDOW_S = 2.0
#: How close the change of the force offsets must come to a configuration's weight to be taken for it.
WEIGHT_MATCH = 0.15


def _recorded_tool(setup: Setup, provenance, calibration: str | Path) -> Setup | None:
    """``setup`` with the tool the calibration records, or None when it records none (or it moved or changed)."""
    try:
        return setup.recorded(provenance, calibration, robot=False)
    except ConfigError:
        return None


def _warn_if_a_tool_seems_mounted(result: TareResult, tool: Tool) -> None:
    """Warn when a re-tare 'with nothing mounted' moved the force offsets by about a tool's weight.

    The offsets then hold the weight of a tool that is still on the sensor, and every later
    wrench is off by it (a 2 kg tool: 19.6 N).
    """
    shift = float(np.linalg.norm(result.calibration.D[:3] - result.previous[:3]))
    for configuration in tool.configurations:
        weight = configuration.mass * tool.gravity
        if abs(shift - weight) <= WEIGHT_MATCH * weight:
            warnings.warn(
                f"re-tared with nothing mounted, but the force offsets moved by {shift:.2f} N, about the weight of "
                f"configuration {configuration.name} of '{tool.name}' ({configuration.mass:g} kg, {weight:.2f} N): if it is "
                f"still mounted, re-tare with --robot ROBOT --configuration {configuration.name}",
                FtsCalibWarning,
                stacklevel=2,
            )
            return

"""The demo's drifting sensor (``fts-calib demo --drift``): offsets that move, calibrated right.

The simulated sensor's offsets drift (:meth:`fts_calib.sim.drift.OffsetDrift.typical`:
forces up to 1 N/min, moments 0.05 N m/min, a warm-up with its temperature channel, a jump
of up to 1 N at each tool change). The calibration models them (``offsets: auto``); this
module compares its offset trajectory with the truth, calibrates the same recording with
the paper's constant offsets for contrast, plots both, and gives the sensor as it is at
the end of the run, which the validation then reads.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..feeds.batch import SampleBatch
from ..feeds.recording import RecordingReader
from ..model.calibration import Calibration
from ..model.offset_basis import evaluate_offsets
from ..model.sensor import WRENCH_AXES, WRENCH_UNITS
from ..pipeline.calibrate import calibrate_recording
from ..pipeline.settings import PipelineConfig
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool
from ..sim.drift import OffsetDrift
from ..sim.sensor import SimulatedSensor


@dataclasses.dataclass(frozen=True)
class DriftReport:
    """What the drifting demo found.

    Attributes:
        sensor_at_end: The simulated sensor with its offsets as at the end of the run.
        constant: The calibration of the same recording with constant offsets (the paper's).
        max_error: Largest |estimated - true| offset over the run per axis, [N, N m]. Shape (6,).
        plot: The PNG of the offsets over time.
    """

    sensor_at_end: SimulatedSensor
    constant: Calibration
    max_error: np.ndarray
    plot: Path


def drift_stage(
    out: Path,
    kin: Kinematics,
    tool: Tool,
    recording: Path,
    calibration: Calibration,
    sensor: SimulatedSensor,
    drift: OffsetDrift,
    settings: PipelineConfig,
    say: Callable[[str], None],
) -> DriftReport:
    """Compare the calibration's offset trajectory with the truth, plot it, and report in words.

    Args:
        out: The demo's folder.
        kin: The robot's kinematics.
        tool: The calibration tool; the recording runs its configurations in order (the k-th
            follows k tool changes).
        recording: The drifting calibration recording (with its temperature column).
        calibration: Its calibration (with an offset model).
        sensor: The simulated sensor (offsets at the start).
        drift: How its offsets moved.
        settings: The pipeline settings of the calibration.
        say: Prints a line.
    """
    from . import plots

    with RecordingReader(recording, kin.joint_names, tool.names) as reader:
        samples = SampleBatch.concatenate(list(reader))
    step = max(1, len(samples) // 5_000)
    t, codes = samples.time[::step], samples.configuration[::step]
    heat = None if samples.temperature is None else samples.temperature[::step]
    true = sensor.D + drift.offsets(t - samples.time[0], codes)
    estimated = evaluate_offsets(calibration.offset_model or {}, t, codes, heat)
    constant = calibrate_recording(recording, kin, tool, settings.with_offsets("constant"), accept_poor_fit=True).calibration
    if constant is None:  # never: the same recording determines C with constant offsets too
        raise RuntimeError("the demo's constant-offset calibration gave no result")
    starts = np.flatnonzero(np.r_[True, codes[1:] != codes[:-1]])
    changes = [(float(t[k] - t[0]), tool.names[codes[k]]) for k in starts if codes[k] >= 0]
    plot = plots.plot_offsets(
        out / "offsets_drift.png",
        t - t[0],
        estimated,
        true,
        constant.D,
        "offsets over the calibration run (demo --drift): the estimated offsets against the simulated sensor's",
        changes,
    )
    error = np.abs(estimated - true).max(axis=0)
    model = calibration.offset_model or {}
    moved = true[-1] - true[0]
    say(f"      offsets: {model.get('model')} model ({', '.join(model.get('columns', []))}), chosen by BIC")
    say(
        "      true drift over the run: " + ", ".join(f"{a} {m:+.3f} {u}" for a, m, u in zip(WRENCH_AXES, moved, WRENCH_UNITS, strict=True))
    )
    say("      largest |estimated - true| offset over the run: " + _axes(error, signed=False))
    say("      constant offsets (the paper's model) on the same data: D - true at the end " + _axes(constant.D - true[-1]))
    return DriftReport(dataclasses.replace(sensor, D=true[-1]), constant, error, plot)


def _axes(values: np.ndarray, signed: bool = True) -> str:
    form = "+.2e" if signed else ".2e"
    return ", ".join(f"{a} {v:{form}} {u}" for a, v, u in zip(WRENCH_AXES, values, WRENCH_UNITS, strict=True))

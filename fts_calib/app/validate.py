"""The ``validate`` command: measured against expected wrenches over a recording (the paper's third stage)."""

from __future__ import annotations

import dataclasses
import json
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..core.exceptions import ConfigError
from ..core.files import atomic_write_text, check_outputs
from ..core.tables import table
from ..model.channels import WRENCH_AXES, WRENCH_UNITS
from ..service.ati import read_calibration
from ..service.validation import AxisErrors, RegionErrors, validate_recording
from ..sources.bag import BagTopics
from ..sources.recording_set import describe_files
from ..sources.source import MIN_COVERAGE, recording_paths
from .exit_codes import ExitCode, writing
from .setup import load_sensor, load_setup


def _cells(errors: AxisErrors, i: int, unit: str) -> tuple[str, str, str, str]:
    """Axis ``i``'s max error and its % FS, its RMS error and its % FS, as printed."""
    return (
        f"{errors.max_abs[i]:.4g} {unit}",
        f"{errors.max_percent[i]:.4f} %",
        f"{errors.rms[i]:.4g} {unit}",
        f"{errors.rms_percent[i]:.4f} %",
    )


def format_errors(label: str, errors: AxisErrors) -> str:
    """A table of the errors per axis, in N or N·m and in % of full scale, under ``label``."""
    rows = [[axis, *_cells(errors, i, unit)] for i, (axis, unit) in enumerate(zip(WRENCH_AXES, WRENCH_UNITS, strict=True))]
    return label + ":\n" + table(["axis", "max error", "max, % FS", "RMS error", "RMS, % FS"], rows, "  ")


#: What validate says of a calibration without a load region.
NO_REGION = "the calibration records no load region (typed in by hand, or written before regions were recorded)"


def format_region(label: str, split: RegionErrors | None) -> str:
    """The errors inside and outside a calibration's load region (by the expected wrench), under ``label``.

    Args:
        label: The calibration, e.g. its file name.
        split: Its errors split by its region, or None for a calibration that records none.

    Returns:
        A line when every sample lies on one side (or there is no region), else the counts
        and a table per axis of max and RMS error, each in N or N·m and % FS, inside and outside.
    """
    if split is None:
        return f"{label}: {NO_REGION}"
    n = split.inside_samples + split.outside_samples
    head = f"{label}, inside and outside the load region it was fitted on ({split.region.describe()}), by the expected wrench"
    if not split.outside_samples or not split.inside_samples:
        side = "inside" if not split.outside_samples else "outside"
        return f"{head}: all {n:,} samples {side} (the errors above)"
    counts = (
        f"inside the calibrated load region: {split.inside_samples:,} samples ({100 * split.inside_samples / n:.3g} %); "
        f"outside: {split.outside_samples:,} samples ({100 * split.outside_samples / n:.3g} %)"
    )
    rows = []
    for i, (axis, unit) in enumerate(zip(WRENCH_AXES, WRENCH_UNITS, strict=True)):
        inside, outside = _cells(split.inside, i, unit), _cells(split.outside, i, unit)
        rows.append([axis, *(f"{part[k]} ({part[k + 1]})" for part in (inside, outside) for k in (0, 2))])
    headers = ["axis", "max inside (% FS)", "RMS inside (% FS)", "max outside (% FS)", "RMS outside (% FS)"]
    return f"{head}:\n{counts}\n" + table(headers, rows, "  ")


def run(
    *,
    recording: str | Path | Sequence[str | Path],
    calibrations: Sequence[str | Path],
    reference: str | Path | None = None,
    robot: str | Path | None = None,
    tool: str | Path = "paper_tool",
    sensor: str | Path = "sensor",
    full_scale_force: float | None = None,
    full_scale_moment: float | None = None,
    dynamic: bool = True,
    plot_path: str | Path | None = None,
    max_error_percent: float | None = None,
    min_coverage: float = MIN_COVERAGE,
    joints_topic: str = BagTopics.joints,
    channels_topic: str = BagTopics.channels,
    configuration_topic: str = BagTopics.configuration,
    joint_stamps: str = BagTopics.joint_stamps,
    pose_topic: str = BagTopics.pose,
    json_path: str | Path | None = None,
    report: str | Path | None = None,
    mount_rpy: Sequence[float] | None = None,
) -> int:
    """Compare the wrench measured with each calibration against the tool's wrench (``fts-calib validate``).

    Args:
        recording: Recording (CSV or CSV.gz) made with ``tool``, or ROS 2 bags (each
            optionally ``BAG:CONFIGURATION``).
        calibrations: One calibration file, or two to compare them with each other too
            (fts-calib YAML or ATI ``.cal``, e.g. the factory calibration as a reference).
        reference: A calibration appended to ``calibrations`` (e.g. the factory ATI file).
        robot: Robot definition: a shipped name (e.g. 'ur5') or a YAML path; None for a
            recording that gives the sensor's orientation (:mod:`fts_calib.robot.orientation`).
        mount_rpy: Without ``robot``: roll, pitch, yaw [rad] from the frame the recording's
            orientation gives to the sensor; None for none.
        tool: Tool file of the tool mounted during the recording.
        sensor: Sensor configuration or ATI ``.cal``: its full scale.
        full_scale_force: Full scale of the forces, in [N]; the sensor file's when None.
        full_scale_moment: Full scale of the moments, in [N m]; the sensor file's when None.
        dynamic: The moving tool's wrench, Newton-Euler (False: its weight alone).
        plot_path: PNG of Fx and its error to write (the paper's Figs 9-10), or None.
        max_error_percent: Largest error allowed, in [%] of full scale; None for no check.
        min_coverage: Smallest share of the recording's channel samples that must be compared,
            in [0, 1]: a validation of a sliver of the recording fails.
        joints_topic: A bag's sensor_msgs/msg/JointState topic.
        channels_topic: A bag's std_msgs/msg/Float64MultiArray or geometry_msgs/msg/WrenchStamped topic.
        configuration_topic: A bag's std_msgs/msg/String topic of the tool configuration.
        joint_stamps: A bag's joint times: 'header' (their header stamps) or 'log' (the bag's log time).
        pose_topic: Without ``robot``: a bag's geometry_msgs/msg/PoseStamped topic of the sensor's orientation.
        json_path: Where to write the errors of the first calibration for scripts,
            ``{"axes": {"Fx": {"rms": ..., "max": ...}, ...}, "samples": N}`` (N, N·m), and, when
            the calibration records its load region, ``"region": {"inside": {"samples": n,
            "axes": {...} or null}, "outside": {...}}`` (no such key without one), atomically;
            None for none. Not written when no sample was compared.
        report: HTML report of the first calibration with this validation as its held-out
            error and residuals (:mod:`fts_calib.report.html`); None for none. Not
            written when no sample was compared.

    Returns:
        0, or 1 when an error exceeds ``max_error_percent`` or when fewer than
        ``min_coverage`` of the samples could be compared (the errors would describe a
        sliver of the recording, or nothing).

    Raises:
        ConfigError: ``min_coverage`` outside [0, 1].
    """
    if not 0.0 <= min_coverage <= 1.0:  # NaN too
        raise ConfigError("min_coverage", min_coverage, "a share in [0, 1] (e.g. 0.5)")
    calibrations = [*calibrations, *([reference] if reference is not None else [])]
    inputs = {f"calibration {k + 1}": p for k, p in enumerate(calibrations)}
    inputs.update({f"recording {k + 1}": p for k, p in enumerate(recording_paths(recording))})
    check_outputs(
        {"--json": json_path, "--plot": plot_path, "--report": report},
        {**inputs, "the robot file": robot, "the tool file": tool, "the sensor file": sensor},
    )
    kin, loaded, _ = load_setup(robot, tool, mount_rpy=mount_rpy)
    loaded_calibrations = [read_calibration(p) for p in calibrations]
    spec = load_sensor(sensor)
    full_scale = spec.full_scale.copy()
    if full_scale_force is not None:
        full_scale[:3] = full_scale_force
    if full_scale_moment is not None:
        full_scale[3:] = full_scale_moment
    full_scale = dataclasses.replace(spec, full_scale=full_scale).full_scale  # the sensor spec refuses <= 0, NaN
    topics = BagTopics(joints_topic, channels_topic, configuration_topic, joint_stamps, pose_topic)
    result = validate_recording(
        recording_paths(recording), kin, loaded, loaded_calibrations, full_scale, dynamic=dynamic, topics=topics, limits=spec.limits
    )
    recording = describe_files(recording_paths(recording))
    print(
        f"validation of {len(calibrations)} calibration(s) over {result.samples:,} of {result.rows_read:,} samples "
        f"({100 * result.coverage:.3g} %) of {recording} with "
        f"'{loaded.name}' (expected wrench: {'moving tool, Newton-Euler' if result.dynamic else 'static weight'}; full scale "
        f"{full_scale[0]:g} N, {full_scale[3]:g} N·m)"
    )
    for path, words in zip(calibrations, result.offsets, strict=True):
        print(f"offsets of {path}: {words}")
    skipped = ", ".join(f"{r}: {n:,}" for r, n in result.skipped.items())
    if skipped:
        print("skipped: " + skipped)
    for line in result.rails:
        print(f"  {line}")
    for problem in result.problems:
        print(f"  note: {problem}")
    if result.samples == 0:  # zeros would read as a perfect calibration
        why = f"every row was skipped ({skipped})" if skipped else "the recording has no usable row"
        print(f"fts-calib validate: error: no sample was compared: {why}; nothing is validated", file=sys.stderr)
        return ExitCode.CHECK_FAILED
    if result.coverage < min_coverage:  # the errors of a sliver say nothing of the recording
        why = f" (skipped: {skipped})" if skipped else ""
        print(
            f"fts-calib validate: error: only {result.samples:,} of {result.rows_read:,} samples ({100 * result.coverage:.3g} %) "
            f"were compared, below --min-coverage {min_coverage:g}{why}: the errors would describe a sliver of the recording; "
            "nothing is validated",
            file=sys.stderr,
        )
        return ExitCode.CHECK_FAILED
    for path, errors in zip(calibrations, result.errors, strict=True):
        print(format_errors(str(path), errors))
    if result.between is not None:
        print(format_errors(f"{calibrations[0]} against {calibrations[1]}", result.between))
    for path, split in zip(calibrations, result.regions, strict=True):
        print(format_region(str(path), split))
    if json_path is not None:
        with writing(json_path):
            written_json = atomic_write_text(json_path, json.dumps(result.as_json(), indent=2) + "\n")
        print(f"wrote {written_json}")
    if plot_path is not None:
        from ..report.plots import plot_validation

        with writing(plot_path):
            written = plot_validation(
                plot_path,
                result.time,
                result.expected[:, 0],
                [m[:, 0] for m in result.measured],
                [Path(p).name for p in calibrations],
                float(full_scale[0]),
                f"validation over {Path(recording).name}",
            )
        print(f"wrote {written}")
    if report is not None:
        from ..report.content import validation_content
        from ..report.html import render_report, write_report

        files = {**inputs, "the robot file": robot, "the tool file": tool, "the sensor file": sensor}
        content = validation_content(result, loaded_calibrations[0], Path(calibrations[0]).name, loaded, files)
        with writing(report):
            print(f"wrote {write_report(report, render_report(content))}")
    worst = float(np.max([e.max_percent.max() for e in result.errors]))
    if max_error_percent is not None and worst > max_error_percent:
        print(f"FAILED: largest error {worst:.4f} % of full scale, above the limit of {max_error_percent:g} % (--max-error)")
        return ExitCode.CHECK_FAILED
    return ExitCode.OK

"""The ``validate`` command: measured against expected wrenches over a recording (the paper's third stage)."""

from __future__ import annotations

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
from ..sources.recording_set import describe_files
from ..sources.source import MIN_COVERAGE
from .exit_codes import ExitCode, writing
from .setup import OutputOptions, Setup, SourceOptions


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
    setup: Setup,
    source: SourceOptions,
    outputs: OutputOptions | None = None,
    *,
    calibrations: Sequence[str | Path],
    reference: str | Path | None = None,
    max_error_percent: float | None = None,
    min_coverage: float = MIN_COVERAGE,
) -> int:
    """Compare the wrench measured with each calibration against the tool's wrench (``fts-calib validate``).

    Args:
        setup: The robot (None: the first calibration's, :meth:`Setup.recorded`; a calibration
            made without one: a recording that gives the sensor's orientation), the tool
            mounted during the recording (None: the first calibration's; refused when it
            records none), the sensor file or ATI
            ``.cal`` (its full scale, or ``full_scale_force`` and ``full_scale_moment``) and
            ``dynamic`` (the moving tool's wrench, Newton-Euler; False: its weight alone).
        source: The recording (CSV or CSV.gz) made with the tool, or ROS 2 bags (each
            optionally ``BAG:CONFIGURATION``), with a bag's topics.
        outputs: ``json_path``: the errors of the first calibration for scripts,
            ``{"axes": {"Fx": {"rms": ..., "max": ...}, ...}, "samples": N}`` (N, N·m), and, when
            the calibration records its load region, ``"region": {"inside": {"samples": n,
            "axes": {...} or null}, "outside": {...}}`` (no such key without one), atomically;
            ``plot_path``: a PNG of Fx and its error (the paper's Figs 9-10); ``report``: an
            HTML report of the first calibration with this validation as its held-out error
            (:mod:`fts_calib.report.html`). None of them is written when no sample was compared.
        calibrations: One calibration file, or two to compare them with each other too
            (fts-calib YAML or ATI ``.cal``, e.g. the factory calibration as a reference).
        reference: A calibration appended to ``calibrations`` (e.g. the factory ATI file).
        max_error_percent: Largest error allowed, in [%] of full scale; None for no check.
        min_coverage: Smallest share of the recording's channel samples that must be compared,
            in [0, 1]: a validation of a sliver of the recording fails.

    Returns:
        0, or 1 when an error exceeds ``max_error_percent`` or when fewer than
        ``min_coverage`` of the samples could be compared (the errors would describe a
        sliver of the recording, or nothing).

    Raises:
        ConfigError: ``min_coverage`` outside [0, 1].
    """
    outputs = outputs or OutputOptions()
    json_path, plot_path, report = outputs.json_path, outputs.plot_path, outputs.report
    if not 0.0 <= min_coverage <= 1.0:  # NaN too
        raise ConfigError("min_coverage", min_coverage, "a share in [0, 1] (e.g. 0.5)")
    calibrations = [*calibrations, *([reference] if reference is not None else [])]
    inputs = {f"calibration {k + 1}": p for k, p in enumerate(calibrations)}
    paths = source.paths()
    inputs.update({f"recording {k + 1}": p for k, p in enumerate(paths)})
    files = {**inputs, "the robot file": setup.robot_file, "the tool file": setup.tool_file, "the sensor file": setup.sensor_file}
    check_outputs({"--json": json_path, "--plot": plot_path, "--report": report}, files)
    loaded_calibrations = [read_calibration(p) for p in calibrations]
    spec = setup.sensor  # its full scale, or the one given (the sensor spec refuses <= 0, NaN)
    setup = setup.recorded(loaded_calibrations[0].provenance, calibrations[0])  # the robot and tool it was made with, unless given
    files.update({"the robot file": setup.robot_file, "the tool file": setup.tool_file})
    kin, loaded = setup.kinematics, setup.tool
    full_scale = spec.full_scale
    result = validate_recording(
        paths, kin, loaded, loaded_calibrations, full_scale, dynamic=setup.dynamic, topics=source.topics, limits=spec.limits
    )
    recording = describe_files(paths)
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

        content = validation_content(result, loaded_calibrations[0], Path(calibrations[0]).name, loaded, files)
        with writing(report):
            print(f"wrote {write_report(report, render_report(content))}")
    worst = float(np.max([e.max_percent.max() for e in result.errors]))
    if max_error_percent is not None and worst > max_error_percent:
        print(f"FAILED: largest error {worst:.4f} % of full scale, above the limit of {max_error_percent:g} % (--max-error)")
        return ExitCode.CHECK_FAILED
    return ExitCode.OK

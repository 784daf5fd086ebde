"""What a calibration report shows, as data: the kept samples and their residuals, the verdict's inputs, the model selection.

The commands hand a :class:`ReportContent` to :func:`fts_calib.report.html.render_report`:
``calibrate`` and ``live`` through :func:`calibrate_content` (also for a refused
calibration), ``validate`` through :func:`validation_content`, ``report`` from the
calibration file (and its recording, read again). Frames and units: the wrench is the load
on the sensor in S, ``[Fx Fy Fz Mx My Mz]`` in [N, N, N, N m, N m, N m]; a residual is the
measured wrench minus the known one.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..budget.propagation import DEFAULT_TARGET_PERCENT
from ..core.exceptions import ConfigError, FtsCalibError, ShapeError
from ..core.files import file_sha256
from ..core.resources import resolve
from ..model.calibration import Calibration
from ..model.channels import WRENCH_AXES, WRENCH_UNITS
from ..model.offset_models import evaluate_offsets

#: Cells of the sphere-coverage grid (Fibonacci points, about 4.6° apart).
SPHERE_CELLS = 1000


@dataclass(frozen=True)
class KeptSamples:
    """Samples shown in a report: the known wrench and the residual of each, per time.

    Attributes:
        time: Times [s], shape (N,).
        w_sensor: Known (expected) wrench on the sensor in S, [N, N, N, N m, N m, N m]. Shape (N, 6).
        residual: Measured minus known wrench, same units. Shape (N, 6).
        configuration: Tool configuration index per sample, shape (N,).
        label: What the samples are, e.g. 'kept samples of the calibration'.
    """

    time: np.ndarray
    w_sensor: np.ndarray
    residual: np.ndarray
    configuration: np.ndarray
    label: str = "kept samples"

    def __post_init__(self):
        n = len(self.time)
        for name in ("w_sensor", "residual"):
            if np.shape(getattr(self, name)) != (n, 6):
                raise ShapeError(f"{name}.shape={np.shape(getattr(self, name))} but expected ({n}, 6)")
        if np.shape(self.configuration) != (n,):
            raise ShapeError(f"configuration.shape={np.shape(self.configuration)} but expected ({n},)")


class KeptCollector:
    """Collects the kept samples of a session (pass it as ``on_kept``) for the report's pictures."""

    def __init__(self) -> None:
        self._parts: list[tuple[np.ndarray, ...]] = []

    def __call__(self, time, w_sensor, channels, configuration, joints, temperature=None) -> None:
        """Keep ``time`` (k,) [s], ``w_sensor`` (k, 6), ``channels`` (k, n), ``configuration`` (k,), ``temperature`` (k,) [°C] or None."""
        t = np.asarray(time, float)
        heat = np.full(len(t), np.nan) if temperature is None else np.asarray(temperature, float)
        self._parts.append((t, np.asarray(w_sensor, float), np.asarray(channels, float), np.asarray(configuration), heat))

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(time (N,) [s], w_sensor (N, 6), channels (N, n), configuration (N,))`` of everything collected, in order."""
        if not self._parts:
            return np.zeros(0), np.zeros((0, 6)), np.zeros((0, 0)), np.zeros(0, int)
        t, W, channels, codes = (np.concatenate([p[k] for p in self._parts]) for k in range(4))
        return t, W, channels, codes.astype(int)

    def temperature(self) -> np.ndarray | None:
        """The collected samples' temperatures [°C], shape (N,), or None when any is unknown."""
        heat = np.concatenate([p[4] for p in self._parts]) if self._parts else np.zeros(0)
        return heat if heat.size and np.all(np.isfinite(heat)) else None

    def samples(self, calibration: Calibration | None) -> KeptSamples | None:
        """The collected samples with their residuals through ``calibration`` (NaN without one); None when none was kept."""
        if not self._parts:
            return None
        t, W, channels, codes = self.arrays()
        if calibration is None or calibration.layout.n_channels != channels.shape[1]:
            return KeptSamples(t, W, np.full_like(W, np.nan), codes)
        return KeptSamples(t, W, residuals(calibration, t, W, channels, codes, self.temperature()), codes)


def residuals(calibration: Calibration, time, w_sensor, channels, configuration, temperature=None) -> np.ndarray:
    """Measured minus known wrench of samples, with the calibration's offset model (its D when it has none).

    Args:
        calibration: The calibration.
        time: Times [s], shape (N,).
        w_sensor: Known wrench in S, shape (N, 6).
        channels: Raw channels, shape (N, n).
        configuration: Tool configuration index per sample, shape (N,).
        temperature: Temperature per sample [°C], shape (N,), or None (a temperature-drift
            model is then evaluated at its temperature origin).

    Returns:
        Residuals in [N, N, N, N m, N m, N m], shape (N, 6).
    """
    measured = np.asarray(channels, float) @ calibration.C.T
    model = calibration.offset_model or {}
    if "basis" in model and model.get("model") != "constant":
        measured += evaluate_offsets(model, time, np.asarray(configuration, int), temperature)
    else:
        measured += calibration.D
    return measured - np.asarray(w_sensor, float)


@dataclass(frozen=True)
class ReportContent:
    """What a report shows.

    Attributes:
        title: The page's heading, e.g. 'Calibration of ur5 with RIM calibration tool'.
        calibration: The calibration (the refused one when the fit was poor), or None.
        diagnosis: Why no calibration was written, in words; '' when one was.
        fit: The fit check as plain data (``FitCheck.as_dict()``), or None: the calibration's.
        skipped: Samples not kept, by reason; None: the calibration's quality.
        seen: Samples seen; None: the calibration's quality.
        kept: Samples kept; None: the calibration's quality.
        samples: Samples to draw (gravity directions, residuals over time), or None.
        configurations: Names of the tool configurations, in the index order of ``samples``.
        files: Input and output files, label -> path; each is listed with its size and SHA-256.
        held_out: Error on data the fit did not see, ``{"label", "rms_percent" (6,), "max_percent" (6,)}``, or None.
        target_percent: Accuracy target of the budget's total, [% of full scale].
        notes: Lines shown under the verdict (e.g. rails detected).
    """

    title: str
    calibration: Calibration | None
    diagnosis: str = ""
    fit: Mapping[str, Any] | None = None
    skipped: Mapping[str, int] | None = None
    seen: int | None = None
    kept: int | None = None
    samples: KeptSamples | None = None
    configurations: tuple[str, ...] = ()
    files: Mapping[str, str | Path | None] = field(default_factory=dict)
    held_out: Mapping[str, Any] | None = None
    target_percent: float = DEFAULT_TARGET_PERCENT
    notes: tuple[str, ...] = ()


def file_record(path: str | Path) -> dict[str, Any]:
    """A file's path, size in bytes and SHA-256 (hex), or ``{"path", "missing": True}`` when it cannot be read.

    Args:
        path: The file, or the name of a shipped one (``ur5``, ``paper_tool``): its shipped file.
    """
    path = Path(path)
    if not path.exists():
        for kind in ("configs", "robots"):
            try:
                path = resolve(path, kind)
                break
            except FtsCalibError:  # not a shipped name of this kind
                continue
    try:
        return {"path": str(path), "size": path.stat().st_size, "sha256": file_sha256(path)}
    except OSError:
        return {"path": str(path), "missing": True}


def _quality_value(content: ReportContent, name: str, default):
    q = content.calibration.quality if content.calibration is not None else None
    return getattr(q, name, default) if q is not None else default


def _fit(content: ReportContent) -> Mapping[str, Any] | None:
    return content.fit if content.fit is not None else _quality_value(content, "fit", None)


def _budget(content: ReportContent) -> Mapping[str, Any] | None:
    return _quality_value(content, "budget", None) if content.calibration is not None else None


def model_selection(calibration: Calibration | None) -> tuple[str, list[dict[str, Any]]]:
    """The model chosen and the candidates the calibration file records (``model_selection``, then ``offset_model``).

    Data-driven: whatever keys the candidates carry become the table's columns.

    Returns:
        (the model chosen in words, or 'not recorded'; the candidates as flat dicts, maybe empty).
    """
    if calibration is None:
        return "not recorded", []
    sources = [getattr(calibration, "model_selection", None), calibration.extra.get("model_selection")]  # an attribute once read
    if calibration.quality is not None:
        sources.append(calibration.quality.extra.get("model_selection"))
    for table in sources:
        if isinstance(table, Mapping):
            rows = next((v for v in table.values() if isinstance(v, list) and v and all(isinstance(r, Mapping) for r in v)), [])
            chosen = table.get("chosen", table.get("model", "recorded"))
            chosen = ", ".join(f"{k} {v}" for k, v in chosen.items()) if isinstance(chosen, Mapping) else str(chosen)
            return chosen, [_flat(r) for r in rows]
        if isinstance(table, list) and table and all(isinstance(r, Mapping) for r in table):
            best = [r for r in table if r.get("chosen")]
            return (str(best[0].get("model", "recorded")) if best else "recorded"), [_flat(r) for r in table]
    model = calibration.offset_model
    if model:
        rows = [_flat(c) for c in model.get("candidates", [])]
        return f"linear C, offsets {model.get('model', '?')} ({model.get('criterion', model.get('setting', ''))})", rows
    return "linear C, constant offsets (not selected: no candidates recorded)", []


def _flat(row: Mapping[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in row.items():
        if isinstance(value, Mapping):
            out.update({f"{key} {k}": v for k, v in value.items()})
        elif isinstance(value, list | tuple):
            out[key] = ", ".join(f"{v:.4g}" if isinstance(v, float) else str(v) for v in value)
        else:
            out[key] = value
    return out


def _held_out(content: ReportContent) -> tuple[str, float | None]:
    if content.held_out is not None:
        rms = float(np.max(content.held_out["rms_percent"]))
        worst = float(np.max(content.held_out["max_percent"]))
        return f"RMS {rms:.4f} % FS, max {worst:.4f} % FS (largest axis; {content.held_out['label']})", rms
    own = _own_held_out(content)
    if own is not None:
        return own
    _, rows = model_selection(content.calibration)
    for row in rows:
        for key, value in row.items():
            if "held" in key and isinstance(value, int | float) and row.get("chosen", True):
                return f"{value:.4g} ({key})", None
    return "not recorded", None


def _own_held_out(content: ReportContent) -> tuple[str, float | None] | None:
    """The chosen model's leave-one-unit-out RMS that the calibration file records, in % FS (N, N·m without a full scale).

    The file's ``model_selection`` holds, per candidate, ``heldout_rms`` (6,) [N, N m] and a
    dimensionless ``heldout_error`` (the mean square over each axis's scale): the line shows
    the first, the largest axis, and what was held out. None when the file records no such table.
    """
    cal = content.calibration
    if cal is None:
        return None
    tables = [getattr(cal, "model_selection", None), cal.extra.get("model_selection")]
    if cal.quality is not None:
        tables.append(cal.quality.extra.get("model_selection"))
    table = next((t for t in tables if isinstance(t, Mapping) and isinstance(t.get("candidates"), list)), None)
    chosen = [c for c in (table or {}).get("candidates", []) if isinstance(c, Mapping) and c.get("chosen") and "heldout_rms" in c]
    if table is None or not chosen:
        return None
    rms = np.asarray(chosen[0]["heldout_rms"], dtype=float)
    if rms.shape != (6,) or not np.all(np.isfinite(rms)):
        return None
    units = table.get("units")
    what = f"one of {units} units of this recording left out at a time: a configuration and a cell of gravity's direction"
    full_scale = (_budget(content) or {}).get("full_scale")
    if isinstance(full_scale, Mapping) and all(isinstance(full_scale.get(a), int | float) and full_scale[a] > 0 for a in WRENCH_AXES):
        percent = 100.0 * rms / np.array([float(full_scale[a]) for a in WRENCH_AXES])
        k = int(np.argmax(percent))
        return f"RMS {percent[k]:.4f} % FS ({WRENCH_AXES[k]}, the largest axis; {what})", float(percent[k])
    shown = ", ".join(f"{a} {v:.3g} {u}" for a, v, u in zip(WRENCH_AXES, rms, WRENCH_UNITS, strict=True))
    return f"RMS {shown} ({what})", None


def _fibonacci(n: int) -> np.ndarray:
    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    phi = k * math.pi * (3 - math.sqrt(5))
    r = np.sqrt(1 - z * z)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


def sphere_gap(directions: np.ndarray, cells: int = SPHERE_CELLS) -> float:
    """The largest angle from any direction of the unit sphere to the nearest direction reached, in [rad].

    0 for a sphere covered densely, π/2 for one hemisphere, π for a single direction.

    Args:
        directions: Unit vectors, shape (N, 3).
        cells: Points of the grid the sphere is probed at (Fibonacci points, about 6° apart for 1000).
    """
    if len(directions) == 0:
        return math.pi
    grid = _fibonacci(cells)
    unique = np.unique(np.round(directions, 3), axis=0)  # samples at one stop share a direction
    nearest = np.full(cells, -1.0)
    for part in np.array_split(unique, max(1, len(unique) // 2000)):
        nearest = np.maximum(nearest, np.max(grid @ part.T, axis=1))
    return float(np.arccos(np.clip(nearest.min(), -1.0, 1.0)))


def calibrate_content(
    result, collector: KeptCollector | None, files: Mapping[str, str | Path | None], diagnosis: str = ""
) -> ReportContent:
    """The report of a ``calibrate`` or ``live`` run, written or refused.

    Args:
        result: A :class:`fts_calib.session.calibration_run.CalibrateResult` (or any object with
            ``calibration``, ``session`` and ``error``).
        collector: The kept samples of the run (its ``on_kept``), or None.
        files: Input and output files, label -> path.
        diagnosis: Why no calibration was written ('' when one was).
    """
    session = result.session
    calibration = result.calibration
    fit = None
    if calibration is None and getattr(result.error, "check", None) is not None:  # PoorFit: the refused calibration and its check
        calibration = result.error.calibration
        fit = result.error.check.as_dict()
    progress = session.progress()
    names = tuple(session.tool.names)
    robot = session.kin.robot.name
    notes = tuple(getattr(result, "detected", ()) and [f"detected in the data: {', '.join(result.detected)}"])
    notes += tuple(f"note: {p}" for p in getattr(result, "problems", [])[:5])
    return ReportContent(
        title=f"Calibration on {robot} with {session.tool.name}",
        calibration=calibration,
        diagnosis=diagnosis,
        fit=fit,
        skipped=progress.skipped,
        seen=progress.seen,
        kept=progress.kept,
        samples=None if collector is None else collector.samples(calibration),
        configurations=names,
        files=dict(files),
        notes=notes,
        target_percent=target_of(calibration),
    )


#: Key of the calibration file's accuracy budget that records the target it is judged against.
TARGET_KEY = "target_percent_fs"


def check_target(percent: float | None, option: str = "--target-error") -> float | None:
    """``percent`` when it is a finite percentage above 0 (or None); ConfigError naming ``option`` otherwise."""
    if percent is None:
        return None
    value = float(percent)
    if not (math.isfinite(value) and value > 0):
        raise ConfigError(option, percent, "a percentage of full scale above 0 (e.g. 0.05)")
    return value


def recorded_target(calibration: Calibration | None) -> float | None:
    """The accuracy target [% of full scale] the calibration file records (``calibrate --target-error``), or None."""
    budget = _quality_value(ReportContent("", calibration), "budget", None) if calibration is not None else None
    value = budget.get(TARGET_KEY) if isinstance(budget, Mapping) else None
    return float(value) if isinstance(value, int | float) and math.isfinite(value) and value > 0 else None


def with_target(calibration: Calibration, percent: float | None) -> Calibration:
    """The calibration with ``percent`` [% of full scale] recorded as its budget's target; unchanged when None or no budget."""
    quality = calibration.quality
    if percent is None or quality is None or not isinstance(quality.budget, Mapping):
        return calibration
    budget = {**quality.budget, TARGET_KEY: float(percent)}
    return dataclasses.replace(calibration, quality=dataclasses.replace(quality, budget=budget))


def target_of(calibration: Calibration | None, given: float | None = None) -> float:
    """The target a report judges against [% of full scale]: ``given``, else the file's, else the default (0.05)."""
    for value in (given, recorded_target(calibration)):
        if value is not None:
            return float(value)
    return DEFAULT_TARGET_PERCENT


def held_out(errors, label: str) -> dict[str, Any]:
    """A validation's errors (:class:`fts_calib.service.validation.AxisErrors`) as the report's held-out error.

    Args:
        errors: The errors of the calibration over data the fit did not see.
        label: Where they come from, e.g. 'validation.csv, another motion and tool'.
    """
    return {"label": label, "rms_percent": np.asarray(errors.rms_percent, float), "max_percent": np.asarray(errors.max_percent, float)}


def validation_content(result, calibration: Calibration, name: str, tool, files: Mapping[str, str | Path | None]) -> ReportContent:
    """The report of a ``validate`` run: the calibration, with the validation as its held-out error.

    Args:
        result: A :class:`fts_calib.service.validation.ValidationResult` with at least one calibration.
        calibration: The first calibration validated.
        name: Its file name.
        tool: The tool mounted during the validation (its name and configuration names).
        files: Input files, label -> path.
    """
    residual = np.asarray(result.measured[0], float) - np.asarray(result.expected, float)
    label = f"validation with '{tool.name}' ({'moving tool' if result.dynamic else 'static weight'})"
    codes = getattr(result, "configuration", None)  # each sample's configuration, as recorded (not all the first's)
    codes = np.zeros(len(result.time), int) if codes is None or len(codes) != len(result.time) else np.asarray(codes, int)
    samples = KeptSamples(np.asarray(result.time, float), np.asarray(result.expected, float), residual, codes, label)
    return ReportContent(
        title=f"Validation of {name} with {tool.name}",
        calibration=calibration,
        samples=samples,
        configurations=tuple(tool.names),
        files=dict(files),
        held_out=held_out(result.errors[0], label),
        target_percent=target_of(calibration),
        notes=tuple(result.rails) + tuple(f"note: {p}" for p in result.problems[:5]),
    )

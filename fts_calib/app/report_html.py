r"""The calibration report as one self-contained HTML page: a verdict at a glance, then each check as a picture with its numbers.

The page holds everything: CSS and SVG inline, no script, no font, no image file, no
link that leaves it; it reads on a phone (viewport meta, a one-column layout below 760 px)
and prints on one or two A4 pages (print CSS). The pictures are SVG written here by hand:
no plotting library at run time, a few hundred kB for a run of thousands of samples.

Sections, in order (each an element with the id given, which the tests look for):
``verdict`` (fit, budget total against the target, held-out error, model chosen; a
refused calibration's diagnosis), ``sphere`` (the gravity directions reached per tool
configuration on the unit sphere of the sensor frame S, two hemispheres in an equal-area
projection), ``residuals`` (per axis over time, and per configuration against the noise
band), ``budget`` (bars per term and axis, the target), ``model-selection`` (the table the
calibration file holds, whatever its candidates), ``matrix`` (C with its standard errors
as a heat map), ``offsets`` (D over the run and the tare history), ``skipped`` (what was
not kept and why), ``provenance`` (robot, tool, sensor, files with SHA-256, software).

Frames and units: the wrench is the load on the sensor in S, ``[Fx Fy Fz Mx My Mz]`` in
[N, N, N, N m, N m, N m]; a residual is the measured wrench minus the known one.

A comparison page (:func:`render_comparison`) shows the change of every coefficient of C
and D in units of its combined standard error, and the largest wrench difference over the
full-scale box, and says whether the sensor changed beyond its uncertainty:

.. math::

    z_{ij} = \frac{C^{new}_{ij} - C^{old}_{ij}}{\sqrt{\sigma^{new\,2}_{ij} + \sigma^{old\,2}_{ij}}}, \quad
    \text{changed} \iff \max |z| > 3 \ \text{or}\ \exists\,\text{axis}:
    \max_{box} |\Delta W| > \sqrt{B_{new}^2 + B_{old}^2}

with B the budget total of an axis (already at k = 2, about 95 %).
"""

from __future__ import annotations

import hashlib
import html
import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..core.exceptions import FtsCalibError, ShapeError
from ..core.outputs import atomic_write_text
from ..core.resources import resolve
from ..model.budget import DEFAULT_TARGET_PERCENT
from ..model.calibration import Calibration
from ..model.offset_basis import evaluate_offsets
from ..model.sensor import WRENCH_AXES, WRENCH_UNITS

#: The sections of a report, in order: (id, heading).
SECTIONS = (
    ("verdict", "Verdict"),
    ("sphere", "Gravity directions reached"),
    ("residuals", "Residuals"),
    ("budget", "Accuracy budget"),
    ("model-selection", "Model selection"),
    ("matrix", "Calibration matrix C"),
    ("offsets", "Offsets and tare history"),
    ("skipped", "What was skipped, and why"),
    ("provenance", "Provenance"),
)
#: |Δ|/σ beyond which a coefficient changed (comparison).
CHANGE_SIGMAS = 3.0
#: Largest number of points drawn per residual panel (thinned evenly beyond it).
MAX_POINTS = 1500
#: Colours of the tool configurations (colour-blind safe, Okabe-Ito).
COLOURS = ("#0072B2", "#E69F00", "#009E73", "#CC79A7", "#56B4E9", "#D55E00", "#F0E442", "#000000")
#: Colours of the budget's terms (the total is dark grey).
TERM_COLOURS = ("#56B4E9", "#E69F00", "#009E73", "#CC79A7", "#0072B2", "#D55E00", "#F0E442", "#999999")
#: Cells of the sphere-coverage grid (Fibonacci points, about 4.6° apart).
SPHERE_CELLS = 1000

_FORMAT = "fts-calib report/1"


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


# -- small helpers ----------------------------------------------------------------------


def _e(text: Any) -> str:
    return html.escape(str(text), quote=True)


def _num(value: float, digits: int = 3) -> str:
    if value is None or not math.isfinite(float(value)):
        return "–"
    return f"{float(value):.{digits}g}"


def _table(headers: Sequence[str], rows: Sequence[Sequence[Any]], cls: str = "") -> str:
    head = "".join(f"<th>{_e(h)}</th>" for h in headers)
    body = "".join("<tr>" + "".join(f"<td>{_e(c)}</td>" for c in row) + "</tr>" for row in rows)
    return f'<table class="{cls}"><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'


def _figure(svg: str, side: str) -> str:
    """A picture with its numbers beside it (below it on a phone)."""
    return f'<div class="pair"><div class="fig">{svg}</div><div class="nums">{side}</div></div>'


def _svg(width: float, height: float, body: str, label: str) -> str:
    return (
        f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {width:.0f} {height:.0f}" role="img" aria-label="{_e(label)}">{body}</svg>'
    )


def _text(x: float, y: float, text: str, anchor: str = "middle", size: float = 11, cls: str = "", fill: str = "") -> str:
    c = (f' class="{cls}"' if cls else "") + (f' style="fill:{fill}"' if fill else "")
    return f'<text x="{x:.1f}" y="{y:.1f}" text-anchor="{anchor}" font-size="{size:g}"{c}>{_e(text)}</text>'


def _dots(x: np.ndarray, y: np.ndarray, colour: str, width: float = 2.6) -> str:
    """Points as one path of zero-length round-capped segments (a few bytes each)."""
    if len(x) == 0:
        return ""
    d = "".join(f"M{a:.1f} {b:.1f}h0" for a, b in zip(x, y, strict=True))
    return f'<path d="{d}" stroke="{colour}" stroke-width="{width:g}" stroke-linecap="round" fill="none"/>'


def _scale(lo: float, hi: float, a: float, b: float):
    span = hi - lo if hi > lo else 1.0
    return lambda v: a + (np.asarray(v, float) - lo) / span * (b - a)


def _ticks(lo: float, hi: float, n: int = 4) -> list[float]:
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return [lo]
    step = 10 ** math.floor(math.log10((hi - lo) / n))
    for m in (1, 2, 5, 10):
        if (hi - lo) / (m * step) <= n:
            step *= m
            break
    start = math.ceil(lo / step) * step
    return [start + k * step for k in range(int((hi - start) / step + 1e-9) + 1)]


def _thin(n: int, limit: int = MAX_POINTS) -> np.ndarray:
    return np.arange(n) if n <= limit else np.linspace(0, n - 1, limit).astype(int)


def _legend(names: Sequence[str]) -> str:
    items = "".join(f'<span class="key"><i style="background:{COLOURS[k % len(COLOURS)]}"></i>{_e(n)}</span>' for k, n in enumerate(names))
    return f'<p class="legend">{items}</p>'


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
        digest = hashlib.sha256()
        with open(path, "rb") as handle:
            for block in iter(lambda: handle.read(1 << 20), b""):
                digest.update(block)
        return {"path": str(path), "size": path.stat().st_size, "sha256": digest.hexdigest()}
    except OSError:
        return {"path": str(path), "missing": True}


# -- the verdict --------------------------------------------------------------------------


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
    _, rows = model_selection(content.calibration)
    for row in rows:
        for key, value in row.items():
            if "held" in key and isinstance(value, int | float) and row.get("chosen", True):
                return f"{value:.4g} ({key})", None
    return "not recorded", None


def _verdict(content: ReportContent) -> str:
    fit = _fit(content)
    budget = _budget(content)
    verdict_fit = str(fit.get("verdict", "unchecked")) if fit else "unchecked"
    largest = float(budget["largest_percent_fs"]) if budget and "largest_percent_fs" in budget else None
    held_text, held_worst = _held_out(content)
    chosen, _ = model_selection(content.calibration)
    if content.diagnosis:
        state, word = "bad", "REFUSED"
        headline = content.diagnosis
    elif verdict_fit == "poor":
        state, word = "warn", "POOR FIT, ACCEPTED"
        headline = str(fit.get("diagnosis") or "the residuals exceed the noise") if fit else ""
    elif largest is not None and largest > content.target_percent:
        state, word = "warn", "ABOVE TARGET"
        headline = f"the accuracy budget, {largest:.4f} % FS, exceeds the target of {content.target_percent:g} % FS"
    elif held_worst is not None and held_worst > content.target_percent:
        state, word = "warn", "CHECK VALIDATION"
        headline = f"the held-out RMS error, {held_worst:.4f} % FS, exceeds the target of {content.target_percent:g} % FS"
    elif verdict_fit == "consistent":
        state, word = "good", "GOOD"
        headline = "the data fit the model at the noise level, and the budget meets the target"
    else:
        state, word = "warn", "UNCHECKED"
        headline = "the fit could not be checked against the noise (no noise level measured)"
    ratio = f"{float(fit['max_ratio']):.2f}× noise ({fit.get('worst', '')})" if fit and "max_ratio" in fit else "–"
    dominant = budget.get("dominant", {}) if budget else {}
    rows = [
        ("Fit", f"{verdict_fit}: largest residual {ratio}", "good" if verdict_fit == "consistent" else "warn"),
        (
            "Budget total",
            "not measured"
            if largest is None
            else f"{largest:.4f} % FS vs target {content.target_percent:g} % "
            f"(largest: {dominant.get('term', '?')}, {dominant.get('axis', '?')})",
            "good" if largest is not None and largest <= content.target_percent else "warn",
        ),
        ("Held-out error", held_text, "" if held_worst is None else ("good" if held_worst <= content.target_percent else "warn")),
        ("Model", chosen, ""),
    ]
    seen = content.seen if content.seen is not None else _quality_value(content, "samples_seen", None)
    kept = content.kept if content.kept is not None else _quality_value(content, "samples_used", None)
    if seen:
        rows.append(("Samples", f"{kept or 0:,} kept of {seen:,} seen ({100 * (kept or 0) / seen:.1f} %)", ""))
    cells = "".join(f'<div class="kv {c}"><span>{_e(k)}</span><b>{_e(v)}</b></div>' for k, v, c in rows)
    notes = "".join(f"<li>{_e(n)}</li>" for n in content.notes)
    return f'<div class="banner {state}"><strong>{word}</strong><span>{_e(headline)}</span></div><div class="kvs">{cells}</div>' + (
        f'<ul class="notes">{notes}</ul>' if notes else ""
    )


# -- the pictures ---------------------------------------------------------------------------


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


def _sphere(content: ReportContent) -> str:
    s = content.samples
    if s is None or len(s.time) == 0:
        return '<p class="none">not recorded: no sample at hand (give the recording: fts-calib report CALIBRATION RECORDING)</p>'
    force = s.w_sensor[:, :3]
    norm = np.linalg.norm(force, axis=1)
    ok = norm > 0
    u = force[ok] / norm[ok, None]
    codes = s.configuration[ok]
    R, gap = 110.0, 24.0
    n_conf = max(len(content.configurations), int(codes.max(initial=0)) + 1)
    body = []
    titles = ("toward +X (tool side)", "toward −X")
    for h, sign in enumerate((1.0, -1.0)):
        cx, cy = 20 + R + h * (2 * R + gap), 30 + R
        body.append(f'<circle cx="{cx:.0f}" cy="{cy:.0f}" r="{R:.0f}" fill="#f4f6f8" stroke="#888"/>')
        for ring in (30, 60):  # polar angle from ±X, equal-area radius
            body.append(
                f'<circle cx="{cx:.0f}" cy="{cy:.0f}" r="{R * math.sqrt(2) * math.sin(math.radians(ring) / 2):.1f}" '
                'fill="none" stroke="#ccc"/>'
            )
        body.append(_text(cx, 18, titles[h], size=12))
        body.append(_text(cx + sign * (R - 6), cy - 4, "+Y", "end" if h == 0 else "start", 10, "muted"))
        body.append(_text(cx + 4, cy - R + 12, "+Z", "start", 10, "muted"))
        for k in range(n_conf):
            pick = (codes == k) & (sign * u[:, 0] >= 0)
            v = u[pick][_thin(int(pick.sum()), 800)]
            size = 5.0 + 3.0 * (n_conf - 1 - k)  # the first largest: directions the configurations share show as rings
            # Lambert azimuthal equal-area about ±X: radius R·sqrt(1 - |x|) (R at the equator)
            rho = R * np.sqrt(np.clip(1 - np.abs(v[:, 0]), 0, 1)) / np.maximum(np.hypot(v[:, 1], v[:, 2]), 1e-12)
            x = cx + sign * v[:, 1] * rho
            y = cy - v[:, 2] * rho
            body.append(_dots(x, y, COLOURS[k % len(COLOURS)], size))
    svg = _svg(2 * (2 * R + 20) + gap, 2 * R + 44, "".join(body), "gravity directions in the sensor frame")
    rows = []
    names = content.configurations or tuple(str(k) for k in range(int(codes.max(initial=0)) + 1))
    for k, name in enumerate(names):
        pick = u[codes == k]
        rows.append([name, f"{len(pick):,}", f"{math.degrees(sphere_gap(pick)):.0f}°"])
    rows.append(["all", f"{len(u):,}", f"{math.degrees(sphere_gap(u)):.0f}°"])
    side = (
        _legend(names)
        + _table(["configuration", "samples", "largest gap"], rows)
        + f'<p class="small">Direction of the known force −m g in S ({_e(s.label)}). Largest gap: the angle from the '
        "direction of the sphere farthest from any reached to the nearest reached (90°: a hemisphere missing). Equal-area "
        "views of the two hemispheres; rings at 30° and 60° from ±X.</p>"
    )
    return _figure(svg, side)


def _panel(x0, y0, w, h, t, series, band, unit, axis) -> str:
    """One residual panel: dots per configuration over time, the ±2σ noise band shaded."""
    values = np.concatenate([v for _, v, _ in series]) if series else np.zeros(1)
    finite = values[np.isfinite(values)]
    lim = float(np.max(np.abs(finite))) if finite.size else 1.0
    lim = max(lim, 2.5 * band if band and math.isfinite(band) else 0.0, 1e-12) * 1.05
    sx = _scale(float(t.min()), float(t.max()), x0, x0 + w)
    sy = _scale(-lim, lim, y0 + h, y0)
    out = [f'<rect x="{x0}" y="{y0}" width="{w}" height="{h}" fill="#fff" stroke="#bbb"/>']
    if band and math.isfinite(band):
        top, bottom = float(sy(2 * band)), float(sy(-2 * band))
        out.append(f'<rect x="{x0}" y="{top:.1f}" width="{w}" height="{bottom - top:.1f}" fill="#d9ead3"/>')
    out.append(f'<line x1="{x0}" x2="{x0 + w}" y1="{float(sy(0)):.1f}" y2="{float(sy(0)):.1f}" stroke="#999" stroke-width="0.6"/>')
    for tx, v, colour in series:
        good = np.isfinite(v)
        out.append(_dots(sx(tx[good]), sy(v[good]), colour, 2.2))
    out.append(_text(x0 + 4, y0 + 12, f"{axis} [{unit}]", "start", 11, "axis"))
    out.append(_text(x0 - 3, y0 + 9, f"{lim:.2g}", "end", 9, "muted"))
    out.append(_text(x0 - 3, y0 + h, f"{-lim:.2g}", "end", 9, "muted"))
    return "".join(out)


def _residuals(content: ReportContent) -> str:
    fit = _fit(content) or {}
    expected = np.asarray(fit.get("expected_residual", [math.nan] * 6), float)
    parts = []
    s = content.samples
    if s is not None and len(s.time) and np.isfinite(s.residual).any():
        w, h, gx, gy = 300, 90, 60, 22
        idx = _thin(len(s.time))
        t, r, k = s.time[idx], s.residual[idx], s.configuration[idx]
        body = []
        for a in range(6):
            x0, y0 = 44 + (a % 2) * (w + gx), 8 + (a // 2) * (h + gy)
            series = [(t[k == c], r[k == c, a], COLOURS[c % len(COLOURS)]) for c in np.unique(k)]
            body.append(_panel(x0, y0, w, h, t, series, float(expected[a]), WRENCH_UNITS[a], WRENCH_AXES[a]))
        y = 8 + 3 * (h + gy)
        body.append(_text(44, y, f"{t.min():.1f} s", "start", 10, "muted"))
        body.append(_text(44 + 2 * w + gx, y, f"{t.max():.1f} s", "end", 10, "muted"))
        svg = _svg(2 * w + gx + 50, y + 6, "".join(body), "residuals per axis over time")
        rms = np.sqrt(np.nanmean(s.residual**2, axis=0))
        rows = [[a, f"{_num(v)} {u}", f"{_num(2 * e)} {u}"] for a, v, e, u in zip(WRENCH_AXES, rms, expected, WRENCH_UNITS, strict=True)]
        side = (
            _legend(content.configurations)
            + _table(["axis", "RMS", "noise band ±2σ"], rows)
            + f'<p class="small">Measured minus known wrench of the {_e(s.label)} over time; green: ±2σ of the noise the data show.</p>'
        )
        parts.append(_figure(svg, side))
    by_conf = fit.get("residual_rms_by_configuration") or {}
    if by_conf and np.isfinite(expected).all():
        names = list(by_conf)
        ratios = np.array([np.asarray(by_conf[n], float) / expected for n in names])
        allowed = float(fit.get("max_ratio_allowed", 3.0))
        top = max(allowed * 1.15, float(np.nanmax(ratios)) * 1.1)
        W, H, x0, y0 = 640, 190, 40, 10
        sy = _scale(0, top, y0 + H, y0)
        group = W / 6
        bw = min(18.0, 0.8 * group / max(len(names), 1))
        body = [f'<rect x="{x0}" y="{y0}" width="{W}" height="{H}" fill="#fff" stroke="#bbb"/>']
        body.append(f'<rect x="{x0}" y="{float(sy(1)):.1f}" width="{W}" height="{float(sy(0) - sy(1)):.1f}" fill="#d9ead3"/>')
        ya = float(sy(allowed))
        body.append(f'<line x1="{x0}" x2="{x0 + W}" y1="{ya:.1f}" y2="{ya:.1f}" stroke="#c0392b" stroke-dasharray="5 3"/>')
        body.append(_text(x0 + W - 4, ya - 3, f"poor beyond {allowed:g}×", "end", 10, "bad"))
        for a in range(6):
            gx0 = x0 + a * group + (group - bw * len(names)) / 2
            for c, _ in enumerate(names):
                v = float(ratios[c, a])
                yb = float(sy(v)) if math.isfinite(v) else y0 + H
                body.append(
                    f'<rect x="{gx0 + c * bw:.1f}" y="{yb:.1f}" width="{bw - 2:.1f}" height="{y0 + H - yb:.1f}" '
                    f'fill="{COLOURS[c % len(COLOURS)]}"/>'
                )
            body.append(_text(x0 + (a + 0.5) * group, y0 + H + 14, WRENCH_AXES[a], size=11))
        for tick in _ticks(0, top):
            body.append(_text(x0 - 4, float(sy(tick)) + 3, f"{tick:g}×", "end", 9, "muted"))
        svg = _svg(W + x0 + 10, H + y0 + 22, "".join(body), "residual RMS per configuration over the expected noise")
        rows = [[n, *[f"{v:.2f}" for v in ratios[c]]] for c, n in enumerate(names)]
        rows.append(["noise", *[f"{_num(e)} {u}" for e, u in zip(expected, WRENCH_UNITS, strict=True)]])
        side = (
            _legend(names)
            + _table(["RMS / noise", *WRENCH_AXES], rows, "compact")
            + '<p class="small">Residual RMS of each configuration and axis in units of the noise the data show (green up to 1×).</p>'
        )
        parts.append(_figure(svg, side))
    return "".join(parts) or '<p class="none">not recorded: no fit check and no sample at hand</p>'


def _budget_section(content: ReportContent) -> str:
    budget = _budget(content)
    if not budget or "terms_percent_fs" not in budget:
        return '<p class="none">not measured (a calibration resumed from a checkpoint, refused, or typed in by hand)</p>'
    terms = {name: np.array([float(v[a]) for a in WRENCH_AXES]) for name, v in budget["terms_percent_fs"].items()}
    total = np.array([float(budget["total_percent_fs"][a]) for a in WRENCH_AXES])
    target = content.target_percent
    names = [n for n, v in terms.items() if np.any(v > 0)]
    top = max(float(total.max()), target) * 1.15
    W, H, x0, y0 = 640, 200, 48, 10
    sy = _scale(0, top, y0 + H, y0)
    group = W / 6
    bars = len(names) + 1
    bw = 0.85 * group / bars
    body = [f'<rect x="{x0}" y="{y0}" width="{W}" height="{H}" fill="#fff" stroke="#bbb"/>']
    for tick in _ticks(0, top):
        y = float(sy(tick))
        body.append(f'<line x1="{x0}" x2="{x0 + W}" y1="{y:.1f}" y2="{y:.1f}" stroke="#eee"/>')
        body.append(_text(x0 - 4, y + 3, f"{tick:g}", "end", 9, "muted"))
    for a in range(6):
        gx0 = x0 + a * group + 0.075 * group
        for c, name in enumerate([*names, "total"]):
            v = total[a] if name == "total" else terms[name][a]
            yb = float(sy(v))
            colour = "#333" if name == "total" else TERM_COLOURS[c % len(TERM_COLOURS)]
            body.append(f'<rect x="{gx0 + c * bw:.1f}" y="{yb:.1f}" width="{bw - 1.5:.1f}" height="{y0 + H - yb:.1f}" fill="{colour}"/>')
        body.append(_text(x0 + (a + 0.5) * group, y0 + H + 14, WRENCH_AXES[a], size=11))
    yt = float(sy(target))
    body.append(f'<line x1="{x0}" x2="{x0 + W}" y1="{yt:.1f}" y2="{yt:.1f}" stroke="#c0392b" stroke-width="1.5" stroke-dasharray="6 3"/>')
    body.append(_text(x0 + W - 4, yt - 4, f"target {target:g} % FS", "end", 10, "bad"))
    body.append(_text(12, y0 + H / 2, "% FS", "middle", 10, "muted"))
    svg = _svg(W + x0 + 10, H + y0 + 22, "".join(body), "accuracy budget per term and axis")
    rows = [[n, *[f"{v:.4f}" for v in terms[n]]] for n in terms]
    rows.append(["total, % FS", *[f"{v:.4f}" for v in total]])
    if "total" in budget:
        rows.append(["total", *[f"{float(budget['total'][a]):.3g} {u}" for a, u in zip(WRENCH_AXES, WRENCH_UNITS, strict=True)]])
    legend = "".join(
        f'<span class="key"><i style="background:{TERM_COLOURS[c % len(TERM_COLOURS)]}"></i>{_e(n)}</span>' for c, n in enumerate(names)
    )
    side = (
        f'<p class="legend">{legend}<span class="key"><i style="background:#333"></i>total</span></p>'
        + _table(["% of full scale", *WRENCH_AXES], rows, "compact")
        + f'<p class="small">Each term ×{_e(budget.get("coverage_factor", 2))} (about 95 %), {_e(budget.get("range", ""))}.</p>'
    )
    return _figure(svg, side)


def _model_selection_section(content: ReportContent) -> str:
    chosen, rows = model_selection(content.calibration)
    if not rows:
        return f'<p class="none">not recorded (model: {_e(chosen)})</p>'
    columns = list(dict.fromkeys(k for r in rows for k in r))
    cells = [[(f"{r[c]:.4g}" if isinstance(r.get(c), float) else r.get(c, "")) for c in columns] for r in rows]
    return f"<p>Chosen: <b>{_e(chosen)}</b></p>" + _table(columns, cells, "compact")


def _colour(value: float) -> str:
    """Diverging blue-white-red for value in [-1, 1]."""
    v = max(-1.0, min(1.0, value))
    if v >= 0:
        r, g, b = 255, int(255 - 120 * v), int(255 - 140 * v)
    else:
        r, g, b = int(255 + 140 * v), int(255 + 90 * v), 255
    return f"#{r:02x}{g:02x}{b:02x}"


def _heatmap(matrix: np.ndarray, text: list[list[str]], colour: np.ndarray, columns: Sequence[str], label: str) -> str:
    rows, cols = matrix.shape
    cw, ch, x0, y0 = 78, 34, 34, 18
    body = []
    for j, name in enumerate(columns):
        body.append(_text(x0 + (j + 0.5) * cw, 12, name, size=11))
    for i in range(rows):
        body.append(_text(x0 - 4, y0 + (i + 0.5) * ch + 4, WRENCH_AXES[i], "end", 11))
        for j in range(cols):
            x, y = x0 + j * cw, y0 + i * ch
            body.append(f'<rect x="{x}" y="{y}" width="{cw - 1}" height="{ch - 1}" fill="{_colour(float(colour[i, j]))}"/>')
            first, _, second = text[i][j].partition("\n")
            body.append(_text(x + cw / 2, y + 14, first, size=10.5))
            if second:
                body.append(_text(x + cw / 2, y + 27, second, size=9, cls="cell"))
    return _svg(x0 + cols * cw + 4, y0 + rows * ch + 4, "".join(body), label)


def _matrix(content: ReportContent) -> str:
    cal = content.calibration
    if cal is None:
        return '<p class="none">not recorded: no calibration</p>'
    C = cal.C
    n = C.shape[1]
    row_max = np.max(np.abs(C), axis=1, keepdims=True)
    q = cal.quality
    se = q.stderr_C if q is not None else np.full_like(C, np.nan)
    text = [[f"{C[i, j]:.4g}\n±{se[i, j]:.2g}" for j in range(n)] for i in range(6)]
    svg = _heatmap(C, text, C / row_max, [f"Δ{j + 1}" for j in range(n)], "calibration matrix C with standard errors")
    rel = 100 * se / row_max
    rows = [
        [a, f"{np.nanmax(rel[i]):.2g} %", f"{cal.D[i]:+.4g} ± {_num(q.stderr_D[i] if q else math.nan, 2)} {u}"]
        for i, (a, u) in enumerate(zip(WRENCH_AXES, WRENCH_UNITS, strict=True))
    ]
    extra = ""
    if q is not None:
        extra = (
            f'<p class="small">Rank {q.rank} of {q.full_rank}, condition number {q.condition_number:.1f} '
            "(S_XX scaled to a unit diagonal).</p>"
        )
    side = (
        _table(["row", "largest σ, % of row max", "D ± σ"], rows)
        + extra
        + '<p class="small">Colour: coefficient over its row\'s largest |coefficient| (red +, blue −); in each cell the '
        "coefficient [N or N·m per strain unit] and its standard error.</p>"
    )
    return _figure(svg, side)


def _offsets(content: ReportContent) -> str:
    cal = content.calibration
    if cal is None:
        return '<p class="none">not recorded: no calibration</p>'
    parts = []
    trajectory = (cal.offset_model or {}).get("trajectory") or []
    if len(trajectory) >= 2 and (cal.offset_model or {}).get("model") != "constant":
        t = np.array([p["time_s"] for p in trajectory], float)
        D = np.array([p["D"] for p in trajectory], float)
        moved = D - D[-1]
        W, H, x0, y0 = 300, 110, 50, 10
        body = []
        for panel, axes in enumerate(((0, 1, 2), (3, 4, 5))):
            px = x0 + panel * (W + 60)
            values = moved[:, list(axes)]
            lim = max(float(np.max(np.abs(values))), 1e-12) * 1.1
            sx, sy = _scale(float(t.min()), float(t.max()), px, px + W), _scale(-lim, lim, y0 + H, y0)
            body.append(f'<rect x="{px}" y="{y0}" width="{W}" height="{H}" fill="#fff" stroke="#bbb"/>')
            for c, a in enumerate(axes):
                pts = " ".join(f"{float(x):.1f},{float(y):.1f}" for x, y in zip(sx(t), sy(moved[:, a]), strict=True))
                body.append(f'<polyline points="{pts}" fill="none" stroke="{COLOURS[c]}" stroke-width="1.6"/>')
                body.append(_text(px + 6 + 40 * c, y0 + 13, WRENCH_AXES[a], "start", 11, "axis", COLOURS[c]))
            body.append(_text(px - 3, y0 + 9, f"{lim:.2g}", "end", 9, "muted"))
            body.append(_text(px - 3, y0 + H, f"{-lim:.2g}", "end", 9, "muted"))
            body.append(_text(px + W / 2, y0 + H + 14, f"D − D(end) [{'N' if panel == 0 else 'N·m'}] over {t[-1] - t[0]:.0f} s", size=10))
        svg = _svg(2 * W + x0 + 70, H + y0 + 22, "".join(body), "offsets over the run")
        span = D[-1] - D[0]
        rows = [[a, f"{d:+.4g} {u}", f"{m:+.3g} {u}"] for a, d, m, u in zip(WRENCH_AXES, D[-1], span, WRENCH_UNITS, strict=True)]
        side = _table(["axis", "D at the end", "moved over the run"], rows) + (
            f'<p class="small">Offset model {_e(cal.offset_model.get("model") if cal.offset_model else "constant")}; '
            f"{len(trajectory)} points of the run.</p>"
        )
        parts.append(_figure(svg, side))
    else:
        parts.append(
            "<p>Offsets: constant over the run. D = "
            + _e(", ".join(f"{a} {d:+.4g} {u}" for a, d, u in zip(WRENCH_AXES, cal.D, WRENCH_UNITS, strict=True)))
            + "</p>"
        )
    history = list(cal.offset_history)
    if history:
        rows = [[h.get("replaced", "?"), h.get("reason", ""), ", ".join(f"{float(v):+.4g}" for v in h.get("D", []))] for h in history]
        rows.append(["now", "in use", ", ".join(f"{v:+.4g}" for v in cal.D)])
        parts.append("<h3>Tare history</h3>" + _table(["replaced", "reason", "D (N, N, N, N·m, N·m, N·m)"], rows, "compact"))
    else:
        parts.append('<p class="small">Tare history: none (the offsets are those of the calibration).</p>')
    return "".join(parts)


def _skipped(content: ReportContent) -> str:
    skipped = content.skipped if content.skipped is not None else _quality_value(content, "skipped", {})
    seen = content.seen if content.seen is not None else _quality_value(content, "samples_seen", None)
    kept = content.kept if content.kept is not None else _quality_value(content, "samples_used", None)
    if not skipped:
        return f"<p>Nothing skipped{f': {kept:,} of {seen:,} samples kept' if seen else ''}.</p>"
    items = sorted(skipped.items(), key=lambda x: -x[1])
    top = max(n for _, n in items)
    bh, x0, W = 20, 210, 360
    body = []
    for k, (reason, n) in enumerate(items):
        y = 4 + k * (bh + 4)
        w = W * n / top
        body.append(_text(x0 - 6, y + 14, reason if len(reason) <= 32 else reason[:31] + "…", "end", 11))
        body.append(f'<rect x="{x0}" y="{y}" width="{w:.1f}" height="{bh}" fill="#7f8c8d"/>')
        body.append(_text(x0 + w + 4, y + 14, f"{n:,}", "start", 10, "muted"))
    svg = _svg(x0 + W + 60, 8 + len(items) * (bh + 4), "".join(body), "samples skipped by reason")
    side = _table(["reason", "samples"], [[r, f"{n:,}"] for r, n in items]) + (
        f'<p class="small">{kept or 0:,} of {seen:,} samples kept. A sample the filter refuses can fail several rules; '
        "samples at a channel's rail are counted here too.</p>"
        if seen
        else ""
    )
    return _figure(svg, side)


def _provenance(content: ReportContent) -> str:
    cal = content.calibration
    prov: Mapping[str, Any] = dict(cal.provenance) if cal is not None else {}
    rows = []
    robot = prov.get("robot") or {}
    if robot:
        rows.append(["robot", f"{robot.get('name', '?')} ({robot.get('urdf', '')})"])
    frame = prov.get("sensor_frame") or {}
    if frame:
        rows.append(
            ["sensor frame", f"{frame.get('name')} on {frame.get('parent_frame')}, xyz {frame.get('xyz')} m, rpy {frame.get('rpy')} rad"]
        )
    tools = prov.get("tools") or {}
    if tools:
        confs = "; ".join(f"{c.get('name')} {c.get('mass')} kg at {c.get('com')} m" for c in tools.get("configurations", []))
        rows.append(["tool", f"{tools.get('name')}: {confs}"])
    if cal is not None:
        rows.append(
            [
                "sensor channels",
                f"{cal.layout.n_channels} ({_e(cal.layout.to_config() if isinstance(cal.layout.to_config(), str) else 'projection')})",
            ]
        )
    for key in ("method", "source", "time", "software_version"):
        if key in prov:
            rows.append([key.replace("_", " "), prov[key]])
    rows.append(["report by", f"fts-calib {__version__} ({_FORMAT})"])
    files = [file_record(p) | {"label": label} for label, p in content.files.items() if p is not None]
    table = _table(
        ["file", "path", "size", "SHA-256"],
        [
            [f["label"], f["path"], "missing" if f.get("missing") else f"{f['size']:,} B", "" if f.get("missing") else f["sha256"]]
            for f in files
        ],
        "files",
    )
    return _table(["", ""], rows, "prov") + (table if files else "")


# -- the page ------------------------------------------------------------------------------

_CSS = """
*{box-sizing:border-box}
body{font:15px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,Helvetica,Arial,sans-serif;color:#1d232a;margin:0;background:#eef1f4}
main{max-width:1180px;margin:0 auto;padding:12px}
header h1{font-size:1.35em;margin:.2em 0}
header p{margin:0;color:#555}
section{background:#fff;border-radius:8px;padding:10px 14px;margin:12px 0;box-shadow:0 1px 2px rgba(0,0,0,.08)}
h2{font-size:1.1em;margin:.2em 0 .5em;border-bottom:1px solid #e3e6ea;padding-bottom:.25em}
h3{font-size:1em;margin:.8em 0 .3em}
.banner{display:flex;flex-wrap:wrap;align-items:baseline;gap:.3em 1em;padding:14px 18px;border-radius:8px;color:#fff}
.banner strong{font-size:2em;letter-spacing:.03em}
.banner span{font-size:1.1em}
.good{--c:#1e8449}.warn{--c:#b9770e}.bad{--c:#b03a2e}
.banner.good,.banner.warn,.banner.bad{background:var(--c)}
.kvs{display:grid;grid-template-columns:repeat(auto-fit,minmax(250px,1fr));gap:8px;margin-top:10px}
.kv{border-left:5px solid var(--c,#95a5a6);background:#f7f9fa;padding:6px 10px}
.kv span{display:block;font-size:.8em;color:#555;text-transform:uppercase;letter-spacing:.04em}
.kv b{font-weight:600;overflow-wrap:anywhere}
.pair{display:flex;flex-wrap:wrap;gap:12px;align-items:flex-start;margin:6px 0}
.fig{flex:1 1 520px;min-width:0}
.fig svg{width:100%;height:auto;display:block}
.nums{flex:1 1 300px;min-width:0;overflow-x:auto}
svg text{fill:#1d232a;font-family:inherit}
svg text.muted{fill:#666}
svg text.cell{fill:#333}
svg text.bad{fill:#b03a2e}
svg text.axis{font-weight:600}
table{border-collapse:collapse;font-size:.85em;margin:4px 0}
th,td{padding:2px 7px;border-bottom:1px solid #e3e6ea;text-align:left;vertical-align:top}
th{background:#f3f5f7}
table.compact td,table.compact th{padding:1px 5px;font-variant-numeric:tabular-nums}
table.files td:nth-child(4){font-family:ui-monospace,Menlo,Consolas,monospace;font-size:.85em;word-break:break-all}
table.prov th{display:none}
.legend{margin:0 0 4px}
.key{display:inline-block;margin-right:12px;font-size:.85em}
.key i{display:inline-block;width:11px;height:11px;border-radius:50%;margin-right:4px;vertical-align:-1px}
.small{font-size:.8em;color:#555;margin:4px 0}
.none{color:#666;font-style:italic}
.notes{margin:8px 0 0;padding-left:1.2em;font-size:.9em}
footer{font-size:.75em;color:#777;text-align:center;margin:8px 0 20px}
@media (max-width:760px){
 body{font-size:14px}main{padding:6px}section{padding:8px}.banner strong{font-size:1.6em}.fig,.nums{flex-basis:100%}
}
@media print{
 @page{size:A4;margin:8mm}
 body{background:#fff;font-size:7.5pt;line-height:1.3}
 main{max-width:none;padding:0}
 header h1{font-size:11pt}
 section{box-shadow:none;border:0;border-top:1px solid #bbb;border-radius:0;margin:2px 0;padding:2px 0;break-inside:avoid}
 h2{font-size:9pt;margin:0 0 2px;border:0;padding:0}
 .banner{padding:4px 10px}.banner strong{font-size:14pt}.banner span{font-size:9pt}
 .kvs{grid-template-columns:repeat(4,1fr);gap:4px;margin-top:4px}.kv{padding:2px 6px}
 .banner,.kv,th,rect{-webkit-print-color-adjust:exact;print-color-adjust:exact}
 .pair{flex-wrap:nowrap;gap:8px;margin:2px 0}
 .fig{flex:0 0 52%}.nums{flex:1 1 48%}
 #sphere .fig{flex-basis:40%}
 #residuals .fig,#budget .fig{flex-basis:45%}
 table{font-size:6.5pt;margin:1px 0}th,td{padding:0 4px;white-space:nowrap}
 table.files td,table.prov td{white-space:normal}
 .small{font-size:6.5pt;margin:1px 0}
 footer{display:none}
}
"""


def _page(title: str, subtitle: str, sections: Sequence[tuple[str, str, str]]) -> str:
    body = "".join(f'<section id="{sid}"><h2>{_e(heading)}</h2>{content}</section>' for sid, heading, content in sections)
    return (
        "<!DOCTYPE html>\n"
        '<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f'<meta name="generator" content="fts-calib {_e(__version__)}">'
        f"<title>{_e(title)}</title><style>{_CSS}</style></head>"
        f"<body><main><header><h1>{_e(title)}</h1><p>{_e(subtitle)}</p></header>{body}"
        f"<footer>{_e(_FORMAT)}: one self-contained page, no network.</footer></main></body></html>\n"
    )


def render_report(content: ReportContent) -> str:
    """The report page of one calibration (see the module docstring) as HTML text.

    Args:
        content: What to show.

    Returns:
        A complete HTML5 document, self-contained.
    """
    prov = dict(content.calibration.provenance) if content.calibration is not None else {}
    subtitle = f"{prov.get('time', '')} · fts-calib {prov.get('software_version', __version__)}"
    builders = {
        "verdict": _verdict,
        "sphere": _sphere,
        "residuals": _residuals,
        "budget": _budget_section,
        "model-selection": _model_selection_section,
        "matrix": _matrix,
        "offsets": _offsets,
        "skipped": _skipped,
        "provenance": _provenance,
    }
    return _page(content.title, subtitle, [(sid, heading, builders[sid](content)) for sid, heading in SECTIONS])


def write_report(path: str | Path, html_text: str) -> Path:
    """Write a report page through the output guard (whole file, one writer); returns the path."""
    return atomic_write_text(path, html_text)


# -- comparing two calibrations ---------------------------------------------------------------


@dataclass(frozen=True)
class Comparison:
    """Two calibrations of one sensor compared.

    Attributes:
        z_C: Change of each coefficient of C in units of its combined standard error, shape (6, n).
        z_D: The same for D, shape (6,).
        wrench_difference: Largest |W_new - W_old| over the full-scale box per axis,
            [N, N, N, N m, N m, N m], shape (6,).
        allowed: The combined budget total per axis (same units), shape (6,); NaN when a file has none.
        full_scale: Full scale per axis, shape (6,).
        changed: Whether the sensor changed beyond its uncertainty (the module docstring's rule).
        reasons: Why, in words (empty when unchanged).
    """

    z_C: np.ndarray
    z_D: np.ndarray
    wrench_difference: np.ndarray
    allowed: np.ndarray
    full_scale: np.ndarray
    changed: bool
    reasons: tuple[str, ...]


def _budget_totals(cal: Calibration) -> tuple[np.ndarray, np.ndarray | None]:
    budget = cal.quality.budget if cal.quality is not None else None
    if not budget or "total" not in budget:
        return np.full(6, np.nan), None
    total = np.array([float(budget["total"][a]) for a in WRENCH_AXES])
    scale = budget.get("full_scale")
    return total, None if scale is None else np.array([float(scale[a]) for a in WRENCH_AXES])


def compare(new: Calibration, old: Calibration, full_scale=None) -> Comparison:
    """Compare two calibrations of the same sensor (see the module docstring for the rule).

    Args:
        new: The newer calibration.
        old: The older one (of the same channel layout).
        full_scale: Full scale per axis [N, N m], shape (6,); the budgets' when None (50 N, 5 N·m without).

    Raises:
        ShapeError: The two have different numbers of channels.
    """
    if new.C.shape != old.C.shape:
        raise ShapeError(f"the calibrations have C of shape {new.C.shape} and {old.C.shape}: not of the same sensor layout")
    se = [c.quality.stderr_C if c.quality is not None else np.zeros_like(c.C) for c in (new, old)]
    se_D = [c.quality.stderr_D if c.quality is not None else np.zeros(6) for c in (new, old)]
    sigma = np.hypot(*se)
    sigma_D = np.hypot(*se_D)
    with np.errstate(divide="ignore", invalid="ignore"):
        z_C = np.where(sigma > 0, (new.C - old.C) / sigma, np.where(new.C == old.C, 0.0, np.inf))
        z_D = np.where(sigma_D > 0, (new.D - old.D) / sigma_D, np.where(new.D == old.D, 0.0, np.inf))
    (b_new, fs_new), (b_old, fs_old) = _budget_totals(new), _budget_totals(old)
    if full_scale is None:
        full_scale = fs_new if fs_new is not None else fs_old if fs_old is not None else np.array([50.0] * 3 + [5.0] * 3)
    full_scale = np.asarray(full_scale, float)
    # loads over the box, read by the old calibration: channels = pinv(C_old) (W - D_old); the difference is linear in W,
    # so its extremes are at the box's 64 corners
    M = (new.C - old.C) @ np.linalg.pinv(old.C)
    corners = np.array(list(itertools.product((-1.0, 1.0), repeat=6))) * full_scale
    diff = (corners - old.D) @ M.T + (new.D - old.D)
    wrench_difference = np.max(np.abs(diff), axis=0)
    allowed = np.hypot(b_new, b_old)
    reasons = []
    worst = float(np.max(np.abs(np.concatenate([z_C.ravel(), z_D]))))
    if worst > CHANGE_SIGMAS:
        i, j = np.unravel_index(int(np.argmax(np.abs(z_C))), z_C.shape)
        reasons.append(f"max |Δ|/σ = {worst:.3g} > {CHANGE_SIGMAS:g} (largest in C: {WRENCH_AXES[i]}, Δ{j + 1}: {z_C[i, j]:+.3g}σ)")
    beyond = [a for a in range(6) if math.isfinite(allowed[a]) and wrench_difference[a] > allowed[a]]
    if beyond:
        reasons.append(
            "wrench difference beyond the combined budget on "
            + ", ".join(f"{WRENCH_AXES[a]} ({wrench_difference[a]:.3g} > {allowed[a]:.3g} {WRENCH_UNITS[a]})" for a in beyond)
        )
    return Comparison(z_C, z_D, wrench_difference, allowed, full_scale, bool(reasons), tuple(reasons))


def render_comparison(
    new: Calibration, old: Calibration, new_name: str, old_name: str, files: Mapping[str, str | Path] | None = None
) -> str:
    """The comparison page of two calibrations (``fts-calib report NEW --against OLD``) as HTML text."""
    cmp = compare(new, old)
    state, word = ("bad", "CHANGED") if cmp.changed else ("good", "UNCHANGED")
    headline = "; ".join(cmp.reasons) if cmp.changed else "every change lies within the uncertainty of the two calibrations"
    worst = float(np.max(np.abs(np.concatenate([cmp.z_C.ravel(), cmp.z_D]))))
    ratio = np.max(cmp.wrench_difference / np.where(np.isfinite(cmp.allowed), cmp.allowed, np.inf))
    kvs = [
        ("Largest |Δ|/σ", f"{worst:.3g} (rule: > {CHANGE_SIGMAS:g} is a change)", "bad" if worst > CHANGE_SIGMAS else "good"),
        (
            "Wrench difference / budget",
            f"{ratio:.3g} (rule: > 1 is a change)" if math.isfinite(ratio) else "no budget recorded",
            "bad" if ratio > 1 else "good",
        ),
        ("New", new_name, ""),
        ("Old", old_name, ""),
    ]
    cells = "".join(f'<div class="kv {c}"><span>{_e(k)}</span><b>{_e(v)}</b></div>' for k, v, c in kvs)
    verdict = (
        f'<div class="banner {state}"><strong>{word}</strong><span>{_e(headline)}</span></div><div class="kvs">{cells}</div>'
        f'<p class="small">Rule: the sensor changed when a coefficient of C or D moved by more than {CHANGE_SIGMAS:g} combined '
        "standard errors (σ = √(σ_new² + σ_old²)), or when the wrench the two give over the full-scale box differs on an axis by "
        "more than the combined accuracy budget √(B_new² + B_old²) (each at k = 2, about 95 %).</p>"
    )
    n = cmp.z_C.shape[1]
    dC = new.C - old.C
    text = [[f"{cmp.z_C[i, j]:+.2f}σ\n{dC[i, j]:+.2g}" for j in range(n)] for i in range(6)]
    heat = _heatmap(cmp.z_C, text, cmp.z_C / (2 * CHANGE_SIGMAS), [f"Δ{j + 1}" for j in range(n)], "change of C in standard errors")
    rows = [[a, f"{z:+.2f}σ", f"{d:+.3g} {u}"] for a, z, d, u in zip(WRENCH_AXES, cmp.z_D, new.D - old.D, WRENCH_UNITS, strict=True)]
    coef = _figure(
        heat,
        _table(["D", "Δ/σ", "Δ"], rows)
        + '<p class="small">Each cell: the change of C in combined standard errors, and in N or N·m per strain unit. '
        f"Red or blue beyond ±{CHANGE_SIGMAS:g}σ at full colour ±{2 * CHANGE_SIGMAS:g}σ.</p>",
    )
    W, H, x0, y0 = 640, 180, 48, 10
    pct = 100 * cmp.wrench_difference / cmp.full_scale
    pct_allowed = 100 * cmp.allowed / cmp.full_scale
    top = max(float(np.nanmax(np.concatenate([pct, pct_allowed]))), 1e-9) * 1.15
    sy = _scale(0, top, y0 + H, y0)
    group = W / 6
    body = [f'<rect x="{x0}" y="{y0}" width="{W}" height="{H}" fill="#fff" stroke="#bbb"/>']
    for a in range(6):
        gx = x0 + a * group + 0.2 * group
        yb = float(sy(pct[a]))
        colour = "#b03a2e" if math.isfinite(pct_allowed[a]) and pct[a] > pct_allowed[a] else "#0072B2"
        body.append(f'<rect x="{gx:.1f}" y="{yb:.1f}" width="{0.6 * group:.1f}" height="{y0 + H - yb:.1f}" fill="{colour}"/>')
        if math.isfinite(pct_allowed[a]):
            ya = float(sy(pct_allowed[a]))
            body.append(
                f'<line x1="{gx - 4:.1f}" x2="{gx + 0.6 * group + 4:.1f}" y1="{ya:.1f}" y2="{ya:.1f}" '
                'stroke="#333" stroke-width="2" stroke-dasharray="4 2"/>'
            )
        body.append(_text(x0 + (a + 0.5) * group, y0 + H + 14, WRENCH_AXES[a], size=11))
    for tick in _ticks(0, top):
        body.append(_text(x0 - 4, float(sy(tick)) + 3, f"{tick:g}", "end", 9, "muted"))
    svg = _svg(W + x0 + 10, H + y0 + 22, "".join(body), "wrench difference over the full-scale box")
    rows = [
        [a, f"{d:.3g} {u}", f"{p:.4f} %", f"{_num(b)} {u}"]
        for a, d, p, b, u in zip(WRENCH_AXES, cmp.wrench_difference, pct, cmp.allowed, WRENCH_UNITS, strict=True)
    ]
    box = ", ".join(f"±{v:g} {u}" for v, u in zip(cmp.full_scale, WRENCH_UNITS, strict=True))
    wrench = _figure(
        svg,
        _table(["axis", "largest difference", "% FS", "combined budget"], rows)
        + f'<p class="small">Largest difference of the wrench the two calibrations read, over loads in the box {_e(box)} '
        "(bars, % of full scale); dashed: the combined budget.</p>",
    )
    sections = [
        ("verdict", "Verdict", verdict),
        ("coefficients", "Change of every coefficient", coef),
        ("wrench", "Wrench difference over the full-scale box", wrench),
        ("provenance", "Provenance", _provenance(ReportContent("", new, files=dict(files or {})))),
    ]
    title = f"Has the sensor changed? {Path(new_name).name} against {Path(old_name).name}"
    return _page(title, f"fts-calib {__version__}", sections)


# -- what the commands hand over ------------------------------------------------------------


def calibrate_content(
    result, collector: KeptCollector | None, files: Mapping[str, str | Path | None], diagnosis: str = ""
) -> ReportContent:
    """The report of a ``calibrate`` or ``live`` run, written or refused.

    Args:
        result: A :class:`fts_calib.pipeline.calibrate.CalibrateResult` (or any object with
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
    )


def held_out(errors, label: str) -> dict[str, Any]:
    """A validation's errors (:class:`fts_calib.service.validate.AxisErrors`) as the report's held-out error.

    Args:
        errors: The errors of the calibration over data the fit did not see.
        label: Where they come from, e.g. 'validation.csv, another motion and tool'.
    """
    return {"label": label, "rms_percent": np.asarray(errors.rms_percent, float), "max_percent": np.asarray(errors.max_percent, float)}


def validation_content(result, calibration: Calibration, name: str, tool, files: Mapping[str, str | Path | None]) -> ReportContent:
    """The report of a ``validate`` run: the calibration, with the validation as its held-out error.

    Args:
        result: A :class:`fts_calib.service.validate.ValidationResult` with at least one calibration.
        calibration: The first calibration validated.
        name: Its file name.
        tool: The tool mounted during the validation (its name and configuration names).
        files: Input files, label -> path.
    """
    residual = np.asarray(result.measured[0], float) - np.asarray(result.expected, float)
    label = f"validation with '{tool.name}' ({'moving tool' if result.dynamic else 'static weight'})"
    samples = KeptSamples(
        np.asarray(result.time, float), np.asarray(result.expected, float), residual, np.zeros(len(result.time), int), label
    )
    return ReportContent(
        title=f"Validation of {name} with {tool.name}",
        calibration=calibration,
        samples=samples,
        configurations=tuple(tool.names[:1]),
        files=dict(files),
        held_out=held_out(result.errors[0], label),
        notes=tuple(result.rails) + tuple(f"note: {p}" for p in result.problems[:5]),
    )

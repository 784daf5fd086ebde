"""The report's calibrated load region: per axis the region's band and the samples' known wrench, with its numbers.

The region is the calibration's (:mod:`fts_calib.model.region`): the loads it was fitted on.
Each axis is a row of its own scale, symmetric about zero: the dark band is [low, high], the
light one the margin around it, and each drawn sample's known wrench a dot, red when the
region's rule puts the sample outside (an axis beyond its band, or |F|, |M| beyond their
largest values). Units: [N] for the forces, [N m] for the moments.

The calibration report as one self-contained HTML page: a verdict at a glance, then each check as a picture with its numbers.

The page holds everything: CSS and SVG inline, no script, no font, no image file, no
link that leaves it; it reads on a phone (viewport meta, a one-column layout below 760 px)
and prints on one or two A4 pages (print CSS). The pictures are SVG written by hand:
no plotting library at run time, a few hundred kB for a run of thousands of samples.

Sections, in order (each an element with the id given, which the tests look for):
``verdict`` (fit, budget total against the target, held-out error, model chosen; a
refused calibration's diagnosis), ``sphere`` (the gravity directions reached per tool
configuration on the unit sphere of the sensor frame S, two hemispheres in an equal-area
projection), ``residuals`` (per axis over time, and per configuration against the noise
band), ``region`` (the calibrated load region per axis as a band, the samples' known wrench as
dots, its numbers), ``budget`` (bars per term and axis, the target), ``model-selection`` (the table the
calibration file holds, whatever its candidates), ``matrix`` (C with its standard errors
as a heat map), ``offsets`` (D over the run and the tare history), ``skipped`` (what was
not kept and why), ``provenance`` (robot, tool, sensor, files with SHA-256, software).

Frames and units: the wrench is the load on the sensor in S, ``[Fx Fy Fz Mx My Mz]`` in
[N, N, N, N m, N m, N m]; a residual is the measured wrench minus the known one.

The pictures are drawn by :mod:`fts_calib.report.svg` (the load region by
:mod:`fts_calib.report.html`), the data gathered by
:mod:`fts_calib.report.content`; a comparison of two calibrations is
:mod:`fts_calib.report.compare`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..core.files import atomic_write_text
from ..model.channels import WRENCH_AXES, WRENCH_UNITS
from .content import ReportContent, _budget, _fit, _held_out, _quality_value, file_record, model_selection
from .svg import (
    _budget_section,
    _dots,
    _e,
    _figure,
    _heatmap,
    _num,
    _offsets,
    _residuals,
    _scale,
    _skipped,
    _sphere,
    _svg,
    _table,
    _text,
    _thin,
)


def region_section(content: ReportContent) -> str:
    """Per axis the calibration's load region [low, high] as a band (the margin lighter), the samples' known wrench as dots.

    Args:
        content: What the report shows: its calibration's ``region`` and its ``samples``
            (their known wrench, shape (N, 6), [N, N m]; at most 600 drawn, thinned evenly).

    Returns:
        The section's HTML: the picture beside a table of low, high and margin per axis and
        the counts; a line saying "not recorded" for a calibration without a region.
    """
    region = content.calibration.region if content.calibration is not None else None
    if region is None:
        return '<p class="none">not recorded: the calibration records no load region (typed in by hand, or written before regions were)</p>'
    s = content.samples
    W = s.w_sensor if s is not None and len(s.time) else np.zeros((0, 6))
    outside = ~region.contains(W) if len(W) else np.zeros(0, dtype=bool)
    idx = _thin(len(W), 600)
    w, h, x0, gap = 440, 22, 70, 6
    body = []
    for a in range(6):
        y = 4 + a * (h + gap)
        values = W[idx, a]
        lim = max(float(np.max(np.abs(values), initial=0.0)), abs(float(region.lower[a])), abs(float(region.upper[a])), 1e-12) * 1.08
        sx = _scale(-lim, lim, x0, x0 + w)
        body.append(f'<rect x="{x0}" y="{y}" width="{w}" height="{h}" fill="#fff" stroke="#bbb"/>')
        for lo, hi, fill in ((region.lower[a], region.upper[a], "#e3eef8"), (region.low[a], region.high[a], "#a9c8e8")):
            left, right = float(sx(lo)), float(sx(hi))
            body.append(f'<rect x="{left:.1f}" y="{y}" width="{max(right - left, 1.0):.1f}" height="{h}" fill="{fill}"/>')
        zero = float(sx(0.0))
        body.append(f'<line x1="{zero:.1f}" x2="{zero:.1f}" y1="{y}" y2="{y + h}" stroke="#999" stroke-width="0.6"/>')
        for mask, colour in ((~outside[idx], "#333"), (outside[idx], "#b03a2e")):
            body.append(_dots(sx(values[mask]), np.full(int(mask.sum()), y + h / 2), colour, 2.4))
        body.append(_text(x0 - 6, y + 15, f"{WRENCH_AXES[a]} [{WRENCH_UNITS[a]}]", "end", 11, "axis"))
        body.append(_text(x0 + w + 4, y + 15, f"±{lim:.3g}", "start", 9, "muted"))
    svg = _svg(x0 + w + 50, 8 + 6 * (h + gap), "".join(body), "calibrated load region per axis and the samples' known wrench")
    rows = [
        [axis, f"{region.low[a]:+.4g} {u}", f"{region.high[a]:+.4g} {u}", f"{region.margin[a]:.3g} {u}"]
        for a, (axis, u) in enumerate(zip(WRENCH_AXES, WRENCH_UNITS, strict=True))
    ]
    drawn = ""
    if s is not None and len(W):
        drawn = f" Dots: the known wrench of the {_e(s.label)}; {int(outside.sum()):,} of {len(W):,} lie outside the region (red)."
    side = (
        _table(["axis", "low", "high", "margin"], rows, "compact")
        + f"<p>|F| ≤ {region.force_max:.4g} N, |M| ≤ {region.moment_max:.4g} N·m, from the {region.samples:,} samples of the fit.</p>"
        + '<p class="small">The loads the calibration was fitted on: dark band [low, high] per axis, light band the margin. Inside: '
        "every axis within its band and |F|, |M| within their largest values (plus the margins); the box also holds loads "
        f"between those the fit saw (no load, a lighter tool).{drawn}</p>"
    )
    return _figure(svg, side)


#: The sections of a report, in order: (id, heading).
SECTIONS = (
    ("verdict", "Verdict"),
    ("sphere", "Gravity directions reached"),
    ("residuals", "Residuals"),
    ("region", "Calibrated load region"),
    ("budget", "Accuracy budget"),
    ("model-selection", "Model selection"),
    ("matrix", "Calibration matrix C"),
    ("offsets", "Offsets and tare history"),
    ("skipped", "What was skipped, and why"),
    ("provenance", "Provenance"),
)


_FORMAT = "fts-calib report/1"


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


def _model_selection_section(content: ReportContent) -> str:
    chosen, rows = model_selection(content.calibration)
    if not rows:
        return f'<p class="none">not recorded (model: {_e(chosen)})</p>'
    columns = list(dict.fromkeys(k for r in rows for k in r))
    cells = [[(f"{r[c]:.4g}" if isinstance(r.get(c), float) else r.get(c, "")) for c in columns] for r in rows]
    return f"<p>Chosen: <b>{_e(chosen)}</b></p>" + _table(columns, cells, "fit")  # cells wrap: the page never scrolls sideways


def _matrix(content: ReportContent) -> str:
    cal = content.calibration
    if cal is None:
        return '<p class="none">not recorded: no calibration</p>'
    C = cal.C
    n = C.shape[1]
    row_max = np.max(np.abs(C), axis=1, keepdims=True)
    q = cal.quality
    se = q.stderr_C if q is not None else np.full_like(C, np.nan)
    text = [[f"{C[i, j]:.4g}" + ("" if q is None else f"\n±{se[i, j]:.2g}") for j in range(n)] for i in range(6)]
    svg = _heatmap(C, text, C / row_max, [f"Δ{j + 1}" for j in range(n)], "calibration matrix C with standard errors")
    rel = 100 * se / row_max if q is not None else np.zeros_like(C)  # no standard errors: a calibration typed in by hand
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
.panels{display:grid;grid-template-columns:1fr 1fr;gap:2px 10px}
.nums{flex:1 1 300px;min-width:0;overflow-x:auto}
svg text{fill:#1d232a;font-family:inherit}
svg text.muted{fill:#666}
svg text.cell{fill:#333}
svg text.bad{fill:#b03a2e}
svg text.axis{font-weight:600}
table{border-collapse:collapse;font-size:.85em;margin:4px 0}
th,td{padding:2px 7px;border-bottom:1px solid #e3e6ea;text-align:left;vertical-align:top}
th{background:#f3f5f7}
table.compact td,table.compact th{padding:1px 5px;font-variant-numeric:tabular-nums;white-space:nowrap}
.nums.wide{flex-basis:640px}
table.fit{width:100%;font-variant-numeric:tabular-nums}table.fit td,table.fit th{overflow-wrap:anywhere}
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
 .panels{grid-template-columns:1fr}
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
 #residuals .fig,#budget .fig,#region .fig{flex-basis:40%}
 .nums{overflow:visible}
 .panels{grid-template-columns:1fr 1fr 1fr;gap:0 4px}
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
        "region": region_section,
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

"""The pictures of the calibration report: SVG written by hand, each with its numbers beside it (HTML).

No plotting library at run time: a path of zero-length round-capped segments draws thousands
of points in a few bytes each, so the full demo's page stays near 200 kB. Every picture is an
``<svg>`` with a ``viewBox`` (it scales to the column it is in) and an ``aria-label``.
Units: the wrench in [N, N, N, N m, N m, N m]; percentages of full scale where stated.
"""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..model.channels import WRENCH_AXES, WRENCH_UNITS
from .content import ReportContent, _budget, _fit, _quality_value, sphere_gap

#: Largest number of points drawn per residual panel (thinned evenly beyond it).
MAX_POINTS = 1500


#: Colours of the tool configurations (colour-blind safe, Okabe-Ito).
COLOURS = ("#0072B2", "#E69F00", "#009E73", "#CC79A7", "#56B4E9", "#D55E00", "#F0E442", "#000000")


#: Colours of the budget's terms (the total is dark grey).
TERM_COLOURS = ("#56B4E9", "#E69F00", "#009E73", "#CC79A7", "#0072B2", "#D55E00", "#F0E442", "#999999")


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


def _figure(svg: str, side: str, wide: bool = False) -> str:
    """A picture with its numbers beside it (below it on a phone).

    ``wide``: a table of seven columns, below the picture unless the page is wide enough for both
    (a 1,000 px window puts it below: never a sideways scroll).
    """
    return f'<div class="pair"><div class="fig">{svg}</div><div class="nums{" wide" if wide else ""}">{side}</div></div>'


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


def _residuals(content: ReportContent) -> str:
    fit = _fit(content) or {}
    expected = np.asarray(fit.get("expected_residual", [math.nan] * 6), float)
    parts = []
    s = content.samples
    if s is not None and len(s.time) and np.isfinite(s.residual).any():
        w, h = 300, 90
        idx = _thin(len(s.time))
        t, r, k = s.time[idx], s.residual[idx], s.configuration[idx]
        panels = []  # one picture per axis: two columns on a screen, one on a phone
        for a in range(6):
            series = [(t[k == c], r[k == c, a], COLOURS[c % len(COLOURS)]) for c in np.unique(k)]
            drawn = _panel(44, 4, w, h, t, series, float(expected[a]), WRENCH_UNITS[a], WRENCH_AXES[a])
            drawn += _text(44, h + 18, f"{t.min():.1f} s", "start", 10, "muted") + _text(
                44 + w, h + 18, f"{t.max():.1f} s", "end", 10, "muted"
            )
            panels.append(_svg(w + 50, h + 22, drawn, f"residual of {WRENCH_AXES[a]} over time"))
        svg = '<div class="panels">' + "".join(panels) + "</div>"
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
        parts.append(_figure(svg, side, wide=True))
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
    return _figure(svg, side, wide=True)


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

"""The report's calibrated load region: per axis the region's band and the samples' known wrench, with its numbers.

The region is the calibration's (:mod:`fts_calib.model.region`): the loads it was fitted on.
Each axis is a row of its own scale, symmetric about zero: the dark band is [low, high], the
light one the margin around it, and each drawn sample's known wrench a dot, red when the
region's rule puts the sample outside (an axis beyond its band, or |F|, |M| beyond their
largest values). Units: [N] for the forces, [N m] for the moments.
"""

from __future__ import annotations

import numpy as np

from ..model.sensor import WRENCH_AXES, WRENCH_UNITS
from .report_content import ReportContent
from .report_svg import _dots, _e, _figure, _scale, _svg, _table, _text, _thin


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

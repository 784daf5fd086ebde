r"""Two calibrations of one sensor compared: has the sensor changed beyond its uncertainty? (``fts-calib report NEW --against OLD``).

.. math::

    z_{ij} = \frac{C^{new}_{ij} - C^{old}_{ij}}{\sqrt{\sigma^{new\,2}_{ij} + \sigma^{old\,2}_{ij}}}

Rule: the sensor changed when max |z| over C and D exceeds :data:`CHANGE_SIGMAS`, or when the
largest difference of the wrench the two read over the full-scale box exceeds, on an axis,
the combined accuracy budget √(B_new² + B_old²) (each total at k = 2, about 95 %). Units: C
in [N or N m per strain unit], D and wrenches in [N, N, N, N m, N m, N m].
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._version import __version__
from ..core.exceptions import ShapeError
from ..model.calibration import Calibration
from ..model.channels import WRENCH_AXES, WRENCH_UNITS
from .content import ReportContent
from .html import _page, _provenance
from .svg import _e, _figure, _heatmap, _num, _scale, _svg, _table, _text, _ticks

#: |Δ|/σ beyond which a coefficient changed (comparison).
CHANGE_SIGMAS = 3.0


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
        unknown = " (a file without standard errors: any change counts)" if math.isinf(worst) else ""
        reasons.append(
            f"max |Δ|/σ = {worst:.3g} > {CHANGE_SIGMAS:g} (largest in C: {WRENCH_AXES[i]}, Δ{j + 1}: {z_C[i, j]:+.3g}σ){unknown}"
        )
    beyond = [a for a in range(6) if math.isfinite(allowed[a]) and wrench_difference[a] > allowed[a]]
    if beyond:
        reasons.append(
            "wrench difference beyond the combined budget on "
            + ", ".join(f"{WRENCH_AXES[a]} ({wrench_difference[a]:.3g} > {allowed[a]:.3g} {WRENCH_UNITS[a]})" for a in beyond)
        )
    return Comparison(z_C, z_D, wrench_difference, allowed, full_scale, bool(reasons), tuple(reasons))


def _budget_verdict(cmp: Comparison, new: Calibration, old: Calibration, new_name: str, old_name: str) -> tuple[str, str]:
    """The wrench difference over the combined budget (text, CSS class); without a budget, the difference in % FS, not judged."""
    judged = np.isfinite(cmp.allowed)
    if judged.any():
        ratio = float(np.max(cmp.wrench_difference[judged] / cmp.allowed[judged]))
        return f"{ratio:.3g} (rule: > 1 is a change)", "bad" if ratio > 1 else "good"
    missing = [name for name, cal in ((new_name, new), (old_name, old)) if not np.isfinite(_budget_totals(cal)[0]).all()]
    pct = 100 * cmp.wrench_difference / cmp.full_scale
    a = int(np.argmax(pct))
    largest = f"the largest difference is {pct[a]:.3g} % FS ({WRENCH_AXES[a]})"
    return f"not judged: no accuracy budget in {' or '.join(missing)}; {largest}", "warn"


def render_comparison(
    new: Calibration, old: Calibration, new_name: str, old_name: str, files: Mapping[str, str | Path] | None = None
) -> str:
    """The comparison page of two calibrations (``fts-calib report NEW --against OLD``) as HTML text."""
    cmp = compare(new, old)
    state, word = ("bad", "CHANGED") if cmp.changed else ("good", "UNCHANGED")
    headline = "; ".join(cmp.reasons) if cmp.changed else "every change lies within the uncertainty of the two calibrations"
    worst = float(np.max(np.abs(np.concatenate([cmp.z_C.ravel(), cmp.z_D]))))
    kvs = [
        ("Largest |Δ|/σ", f"{worst:.3g} (rule: > {CHANGE_SIGMAS:g} is a change)", "bad" if worst > CHANGE_SIGMAS else "good"),
        ("Wrench difference / budget", *_budget_verdict(cmp, new, old, new_name, old_name)),
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
    text = [
        [(f"{cmp.z_C[i, j]:+.2f}σ" if math.isfinite(cmp.z_C[i, j]) else "no σ") + f"\n{dC[i, j]:+.2g}" for j in range(n)] for i in range(6)
    ]
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

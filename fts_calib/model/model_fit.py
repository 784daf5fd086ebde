"""The fit of a nonlinear (or full-channel) sensor model from the estimator's per-unit sums.

The estimator (:mod:`fts_calib.model.estimator`) keeps the sums of ``z z^T`` per held-out unit
(:mod:`fts_calib.model.model_choice`); once the choice is made, the model it chose is solved on
every unit at minimum norm (the directions no load excites held), its residual per tool
configuration judged, and the calibration built: the model's coefficients over named features
(:mod:`fts_calib.model.features`), C_bar the model linearised at the centre of the data, D the
offset at the end of the run. Units: W in [N, N, N, N m, N m, N m], channels raw.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from .._version import __version__
from ..core.exceptions import ConfigError
from .calibration import Calibration, now_iso
from .features import SensorModel
from .least_squares import fit_quality, residual_sums
from .model_choice import HOLD_RULE, Chooser, Selection
from .offset_basis import describe

if TYPE_CHECKING:
    from .estimator import OnlineEstimator


def fit_chosen(est: OnlineEstimator, selection: Selection):
    """``(units, M, sums, (Theta, rank, condition, pseudo-inverse))`` of the chosen candidate on every unit."""
    units = est.units
    if units is None:  # selection() is None without unit sums
        raise ConfigError("model", est.model, "a model with held-out sums")
    chooser = Chooser(units, est.basis, (est.model, est.offsets), est.full_scale)
    M = chooser.maps(selection.chosen.family, selection.chosen.offsets)
    sums = M @ units.total() @ M.T
    return units, M, sums, chooser.fit(sums, selection.chosen.family)


def model_residuals(est: OnlineEstimator, selection: Selection) -> tuple[dict[int, np.ndarray], np.ndarray]:
    """The chosen nonlinear (or full-channel) model's residual RMS per configuration, and its linear C_bar.

    Returns:
        ``({configuration index: RMS per axis (6,) in N, N m}, C_bar (6, 6))``, or None when
        the model in use is the linear one on ``P Delta`` (its fit check is the session's own).
    """
    units, M, _, (theta, *_) = fit_chosen(est, selection)
    K, first = est.basis.n_configurations, 6 + units.n_features
    rss: dict[int, np.ndarray] = {}
    weight: dict[int, float] = {}
    for g, sums in units.sums.items():
        c = int(np.argmax(np.diag(sums)[first : first + K]))  # a unit lies within one configuration
        mine = M @ sums @ M.T
        rss[c] = rss.get(c, np.zeros(6)) + residual_sums(mine[:6, :6], mine[:6, 6:], mine[6:, 6:], theta)
        weight[c] = weight.get(c, 0.0) + units.weights[g]
    model = SensorModel(selection.chosen.family, _features_first(theta, units.inputs, len(selection.chosen.offsets.A)), None, units.inputs)
    slope = model.slope(mean_inputs(est))
    C_bar = slope @ est.layout.pinv if est.full_channels else slope
    return {c: np.sqrt(rss[c] / max(weight[c], 1e-300)) for c in sorted(rss)}, C_bar


def mean_inputs(est: OnlineEstimator) -> np.ndarray:
    """The mean of the model's inputs u over the samples (d,): the centre of the calibration data."""
    units = est.units
    if units is None:
        raise ConfigError("model", est.model, "a model with held-out sums")
    total, K = units.total(), est.basis.n_configurations
    first = 6 + units.n_features
    counts = np.diag(total)[first : first + K].sum()  # the one-hot columns: one per sample
    return total[6 : 6 + units.inputs, first : first + K].sum(axis=1) / max(counts, 1e-300)


def solve_model(est: OnlineEstimator, selection: Selection, configurations, at) -> Calibration:
    """The calibration of a nonlinear family or of the raw channels, from the per-unit sums (minimum norm)."""
    score = selection.chosen
    units, _, sums, (theta, rank, condition, inv) = fit_chosen(est, selection)
    S_XX, S_WX, S_WW = sums[6:, 6:], sums[:6, 6:], sums[:6, :6]
    d, k_m = units.inputs, len(score.offsets.A)
    origins, end = est._end(at)
    a_end = score.offsets.A @ est._basis_row(end, origins)
    padded = np.zeros(theta.shape[1] - 6)
    padded[d - 6 : d - 6 + k_m] = a_end  # where the offsets sit among the regressors after the first six
    P = est.layout.projection if not est.full_channels else np.eye(6, est.layout.n_channels)
    quality = fit_quality(
        S_WW, S_WX, S_XX, theta, inv, est.weight_sum, est.samples_used, est.samples_seen, rank, condition, est.skipped, P, padded
    )
    coefficients = _features_first(theta, d, k_m)
    model = SensorModel(score.family, coefficients, None if est.full_channels else est.layout.projection, est.layout.n_channels)
    if est.full_channels:  # the free C's standard errors are those of its own columns
        sigma = np.sqrt(np.maximum(quality.residual_rms**2 * est.weight_sum / max(est.weight_sum - theta.shape[1], 1.0), 0.0))
        stderr_C = sigma[:, None] * np.sqrt(np.maximum(np.diag(inv)[:d], 0.0))[None, :]
        quality = replace(quality, stderr_C=stderr_C)
    held = theta.shape[1] - rank
    quality = replace(quality, held_directions={"count": held, "rule": HOLD_RULE})
    trace = est.trace.with_end()
    trace += [end] if not trace or trace[-1] != end else []
    names = est.basis.column_names(configurations)
    offset_model = describe(est.offsets, score.offsets, est.basis, theta[:, d : d + k_m], origins, [], trace, configurations)
    offset_model["criterion"] = "held-out error (see model_selection)"
    slope = model.slope(mean_inputs(est))  # linearised at the centre of the data, not at u = 0
    return Calibration(
        C_bar=slope @ est.layout.pinv if est.full_channels else slope,
        D=theta[:, d : d + k_m] @ a_end,
        quality=quality,
        provenance={
            "method": f"least squares of a {score.family} model (held-out choice)",
            "time": now_iso(),
            "software_version": __version__,
        },
        layout=est.layout,
        offset_model=offset_model,
        model=model if (score.family != "linear" or est.full_channels) else None,
        model_selection=selection.as_dict(names, configurations),
    )


def _features_first(theta: np.ndarray, d: int, k_m: int) -> np.ndarray:
    """The coefficients over the features (6, p) of a fit whose regressors are ``[u (d); offsets (k_m); higher features]``."""
    return np.hstack([theta[:, :d], theta[:, d + k_m :]])

r"""Experiment design under moving offsets: how well a plan determines C_bar when D drifts.

With the drift offset model (:mod:`fts_calib.model.offset_basis`) the estimator regresses
the wrench on ``z = [C_bar^-1 (W - D); e_c; tau, ..., tau^d]`` (one offset per tool
configuration, powers of ``tau = (t - t_0) / s``): a plan whose sweep visits the same
directions at the same times in every configuration confounds the time terms with the
orientation, and the standard errors grow. This module predicts them as
:func:`fts_calib.planning.excitation.predict_excitation` does for constant offsets (white
strain noise through C, ``Cov(row j) = sigma_W,j^2 S_XX^-1``), from the planned quasi-static
samples and their times in the run (configurations one after the other, each after a tool
change of ``tool_change_s``). No temperature term: a plan cannot know the temperature.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..core.arrays import frozen
from ..model.least_squares import RCOND, coefficient_stderr, information_rank
from ..model.offset_basis import OffsetBasis

#: The pause between configurations assumed, in [s] (that of ``fts-calib simulate``).
TOOL_CHANGE_S = 2.0


@dataclass(frozen=True)
class DriftPrediction:
    """Predicted quality of a calibration under the drift offset model.

    Attributes:
        columns: The offset columns (e.g. ``['offset A', 'offset B', 'offset C', 'time^1', 'time^2']``).
        rank: Predicted rank of S_XX; ``full_rank`` (6 + columns) determines every coefficient.
        full_rank: 6 + the number of offset columns.
        condition_number: Of the scaled S_XX (inf below full rank).
        stderr_C_bar: Predicted standard errors of C_bar. Shape (6, 6).
        stderr_D: Predicted standard errors of D at the end of the run, [N, N, N, N m, N m, N m]. Shape (6,).
        relative_stderr_C: Standard errors of C over the largest |C| of its row. Shape (6, n).
    """

    columns: list[str]
    rank: int
    full_rank: int
    condition_number: float
    stderr_C_bar: np.ndarray
    stderr_D: np.ndarray
    relative_stderr_C: np.ndarray

    def __post_init__(self):
        for name in ("stderr_C_bar", "stderr_D", "relative_stderr_C"):
            object.__setattr__(self, name, frozen(getattr(self, name)))

    @property
    def max_relative_stderr(self) -> float:
        """Largest standard error of C relative to its row's largest coefficient."""
        return float(np.max(self.relative_stderr_C))


def predict_drift(
    x_bar: Mapping[str, np.ndarray],
    time_s: Mapping[str, np.ndarray],
    names: list[str],
    C_bar: np.ndarray,
    sigma_W: np.ndarray,
    projection: np.ndarray,
    drift_degree: int = 2,
    rcond: float = RCOND,
) -> DriftPrediction:
    """Predict rank, condition and standard errors under the drift offset model.

    Args:
        x_bar: Per configuration name, the projected strains ``C_bar^-1 (W - D)`` of its
            quasi-static samples (eq 22). Shape (N_c, 6) each.
        time_s: Per configuration name, the samples' times in the run [s]. Shape (N_c,) each.
        names: The tool's configuration names, in order.
        C_bar: Nominal modified calibration matrix. Shape (6, 6).
        sigma_W: Strain noise through C per wrench axis, [N, N m]. Shape (6,).
        projection: The layout's P. Shape (6, n).
        drift_degree: The highest power of time of the model.
        rcond: Rank threshold, as the estimator's.
    """
    basis = OffsetBasis(len(names), drift_degree, temperature=False)
    seen = [k for k, name in enumerate(names) if len(x_bar.get(name, ()))]
    t0 = min(float(np.min(time_s[names[k]])) for k in seen) if seen else 0.0
    rows = []
    for k in seen:
        x, t = np.asarray(x_bar[names[k]], dtype=float), np.asarray(time_s[names[k]], dtype=float)
        rows.append(np.hstack([x, basis.rows(t, np.full(len(t), k), None, t0, 0.0)]))
    keep = [*range(6), *(6 + k for k in seen), *range(6 + basis.n_configurations, 6 + basis.size)]
    Z = np.vstack(rows)[:, keep] if rows else np.zeros((0, len(keep)))
    S_XX = Z.T @ Z
    full = len(keep)
    rank, condition = information_rank(S_XX, rcond) if len(Z) else (0, math.inf)
    columns = [basis.column_names(names)[i - 6] for i in keep[6:]]
    n = projection.shape[1]
    if rank < full:
        return DriftPrediction(columns, rank, full, math.inf, np.full((6, 6), math.inf), np.full(6, math.inf), np.full((6, n), math.inf))
    scale = 1.0 / np.sqrt(np.diag(S_XX))
    inv = np.linalg.solve(S_XX * scale[:, None] * scale[None, :], np.eye(full)) * scale[:, None] * scale[None, :]
    stderr_theta, stderr_C = coefficient_stderr(sigma_W, inv, projection)
    end = Z[-1, 6:]  # the offset basis of the last sample: where the file's D belongs
    stderr_D = sigma_W * math.sqrt(max(float(end @ inv[6:, 6:] @ end), 0.0))
    C = C_bar @ projection
    return DriftPrediction(
        columns, rank, full, condition, stderr_theta[:, :6], stderr_D, stderr_C / np.max(np.abs(C), axis=1, keepdims=True)
    )

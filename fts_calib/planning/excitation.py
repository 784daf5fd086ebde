r"""Experiment design under moving offsets: how well a plan determines C_bar when D drifts.

With the drift offset model (:mod:`fts_calib.model.offset_models`) the estimator regresses
the wrench on ``z = [C_bar^-1 (W - D); e_c; tau, ..., tau^d]`` (one offset per tool
configuration, powers of ``tau = (t - t_0) / s``): a plan whose sweep visits the same
directions at the same times in every configuration confounds the time terms with the
orientation, and the standard errors grow. This module predicts them as
:func:`fts_calib.planning.excitation.predict_excitation` does for constant offsets (white
strain noise through C, ``Cov(row j) = sigma_W,j^2 S_XX^-1``), from the planned quasi-static
samples and their times in the run (configurations one after the other, each after a tool
change of ``tool_change_s``). No temperature term: a plan cannot know the temperature.

Experiment design: how well a planned motion will determine C_bar and D, before it runs.

From the gravity directions a plan shows the sensor at its quasi-static samples, the tool
configurations and a nominal sensor (C_bar, D), the report predicts what the online
estimator will see: the projected strains ``x = [C_bar^-1 (W - D); 1]`` (eq 22) of every
sample, the rank and the condition number of ``S_XX = sum x x^T`` (scaled to a unit
diagonal, as the estimator does), and the standard error of every coefficient for white
strain noise of standard deviation sigma per bridge. To first order the noise enters the
fit as a residual on each wrench axis with variance

.. math::

    \sigma_{W,j}^2 = \left(\bar C P \,\mathrm{diag}(\sigma^2)\, P^T \bar C^T\right)_{jj},
    \qquad \mathrm{Cov}(\text{row } j) = \sigma_{W,j}^2 S_{XX}^{-1}.

It also measures coverage: the largest angle between any direction on the unit sphere and
the nearest gravity direction seen by the sensor.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..budget.propagation import wrench_noise
from ..core.arrays import frozen
from ..model.channels import MALTESE_CROSS_8, ChannelLayout
from ..model.estimator import RANK_ADVICE
from ..model.least_squares import RCOND, coefficient_stderr, information_rank
from ..model.offset_models import OffsetBasis
from ..robot.tool import Tool

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


_SPHERE_POINTS = 2000  # probe directions for the coverage angle (mean spacing about 4.5 deg)


@dataclass(frozen=True)
class ExcitationReport:
    """Predicted quality of a calibration from a planned motion.

    Attributes:
        samples: Quasi-static samples per tool configuration.
        rank: Predicted rank of S_XX (7 determines every coefficient).
        condition_number: Of the scaled S_XX (inf when rank < 7).
        noise_std: Noise per channel assumed, raw units. Shape (n,).
        stderr_C_bar: Predicted standard errors of C_bar (inf when undetermined). Shape (6, 6).
        stderr_D: Predicted standard errors of D, [N, N, N, N m, N m, N m]. Shape (6,).
        stderr_C: Predicted standard errors of C. Shape (6, n).
        relative_stderr_C: ``stderr_C`` over the largest |C| of its row. Shape (6, n).
        coverage_deg: Largest angle in [deg] from any direction to the nearest gravity
            direction seen by the sensor (small is good; 180 with one direction).
        advice: What is missing, in words, or '' when the plan determines every coefficient.
        drift: The same prediction under the drift offset model (one offset per
            configuration and powers of time, :mod:`fts_calib.planning.excitation`),
            or None when the samples' times were not given.
    """

    samples: Mapping[str, int]
    rank: int
    condition_number: float
    noise_std: np.ndarray
    stderr_C_bar: np.ndarray
    stderr_D: np.ndarray
    stderr_C: np.ndarray
    relative_stderr_C: np.ndarray
    coverage_deg: float
    advice: str
    drift: DriftPrediction | None = None

    def __post_init__(self):
        for name in ("noise_std", "stderr_C_bar", "stderr_D", "stderr_C", "relative_stderr_C"):
            object.__setattr__(self, name, frozen(getattr(self, name)))

    @property
    def max_relative_stderr(self) -> float:
        """Largest standard error of C relative to its row's largest coefficient."""
        return float(np.max(self.relative_stderr_C))


def _fibonacci_sphere(n: int) -> np.ndarray:
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    phi = math.pi * (1.0 + math.sqrt(5.0)) * k
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def coverage_angle(directions: np.ndarray) -> float:
    """Largest angle [deg] from any direction on the sphere to the nearest of ``directions`` (N, 3)."""
    if len(directions) == 0:
        return 180.0
    unit = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    unit = np.unique(np.round(unit, 3), axis=0)  # dwell samples repeat the same direction
    probes = _fibonacci_sphere(_SPHERE_POINTS)
    best = np.full(len(probes), -1.0)
    for start in range(0, len(unit), 512):
        best = np.maximum(best, np.max(probes @ unit[start : start + 512].T, axis=1))
    return float(np.degrees(np.arccos(np.clip(best.min(), -1.0, 1.0))))


def predict_excitation(
    g_sensor: Mapping[str, np.ndarray],
    tool: Tool,
    C_bar: np.ndarray,
    D: np.ndarray,
    noise_std,
    rcond: float = RCOND,
    layout: ChannelLayout = MALTESE_CROSS_8,
    time_s: Mapping[str, np.ndarray] | None = None,
    drift_degree: int = 2,
) -> ExcitationReport:
    """Predict the estimator's rank, condition and standard errors for planned samples.

    Args:
        g_sensor: Per tool configuration name, gravity in the sensor frame at each
            quasi-static sample, [m/s^2]. Shape (N_c, 3) each.
        tool: The tool whose configurations are named in ``g_sensor``.
        C_bar: Nominal modified calibration matrix. Shape (6, 6).
        D: Nominal offsets, [N, N, N, N m, N m, N m]. Shape (6,).
        noise_std: Noise per channel, raw units; one number or shape (n,).
        rcond: Rank threshold, as the estimator's.
        layout: The sensor's channel layout (n channels, its P); the paper's by default.
        time_s: Per configuration name, the samples' times in the run [s] (configurations one
            after the other); with them the report also predicts the drift model's errors.
        drift_degree: The highest power of time of that drift model.
    """
    P, n = layout.projection, layout.n_channels
    noise = np.broadcast_to(np.asarray(noise_std, dtype=float), (n,)).copy()
    S_XX = np.zeros((7, 7))
    counts = {}
    directions = []
    projected = {}
    for name, g in g_sensor.items():
        g = np.asarray(g, dtype=float).reshape(-1, 3)
        counts[name] = len(g)
        if not len(g):
            continue
        W = tool.configuration(name).static_wrench(g)
        x = np.hstack([np.linalg.solve(C_bar, (W - D).T).T, np.ones((len(g), 1))])  # eq 22, then eq 13
        S_XX += x.T @ x
        projected[name] = x[:, :6]
        directions.append(g)
    rank, condition = information_rank(S_XX, rcond) if any(counts.values()) else (0, math.inf)
    C = C_bar @ P
    sigma_W = wrench_noise(C, noise)  # strain noise through C, per axis [N, N m]
    if rank == 7:
        scale = 1.0 / np.sqrt(np.diag(S_XX))
        inv = np.linalg.solve(S_XX * scale[:, None] * scale[None, :], np.eye(7)) * scale[:, None] * scale[None, :]
        stderr_theta, stderr_C = coefficient_stderr(sigma_W, inv, P)
        advice = ""
    else:
        stderr_theta, stderr_C = np.full((6, 7), math.inf), np.full((6, n), math.inf)
        used = [name for name, n in counts.items() if n]
        advice = (
            f"predicted rank {rank} of 7 ({7 - rank} direction(s) missing) with quasi-static samples from "
            f"{len(used)} configuration(s) {used}. {RANK_ADVICE}"
        )
    coverage = coverage_angle(np.vstack(directions)) if directions else 180.0
    drift = None if time_s is None else predict_drift(projected, time_s, tool.names, C_bar, sigma_W, P, drift_degree, rcond)
    return ExcitationReport(
        samples=counts,
        rank=rank,
        condition_number=condition,
        noise_std=noise,
        stderr_C_bar=stderr_theta[:, :6],
        stderr_D=stderr_theta[:, 6],
        stderr_C=stderr_C,
        relative_stderr_C=stderr_C / np.max(np.abs(C), axis=1, keepdims=True),
        coverage_deg=coverage,
        advice=advice,
        drift=drift,
    )

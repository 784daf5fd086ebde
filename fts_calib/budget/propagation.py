r"""The accuracy budget: how each error source of a calibration spreads into its wrench error.

Every source is a perturbation of the regression's known wrench: sample i's wrench is off
by ``dw_i = B_i u_g`` (shape (6,)), where ``u_g`` (shape (r,)) is one random draw shared by
the samples of group g (a constant error: one group; an error per stop: one group per stop;
white noise: one group per sample) with covariance U. Strain noise enters the same way to
first order (``dw_i = -C dDelta_i``). Least squares ``Theta = S_WX S_XX^-1`` (shape (6, 7):
``[C_bar, D]``, regressors ``x = [P Delta; 1]``) maps them linearly to

.. math::

    \delta\Theta_j = \sum_g u_g^T G_{gj}, \qquad
    G_{gj} = \sum_{i \in g} B_{i,j}^T\, (S_{XX}^{-1} x_i)^T \quad (r \times 7),

and the wrench error of axis j at a load W in the sensor's range is ``e_j(W) = dTheta_j
x(W)`` with ``x(W) = [C_bar^-1 (W - D); 1]``. The budget states, per axis and source, the
RMS over the range of the error's standard deviation, for loads spread uniformly over the
full-scale box ``|W_k| <= FS_k``:

.. math::

    \sigma_j^2 = E_W\,\mathrm{Var}\, e_j(W) = \sum_g \mathrm{tr}(U\, G_{gj} M G_{gj}^T),
    \qquad M = E_W[x(W) x(W)^T] \quad (7 \times 7).

A measured budget also holds the *model error*: what the calibration's residual on samples it
was not fitted to (the held-out RMS of :mod:`fts_calib.model.model_choice`, or the fit's own
residual) holds beyond the strain noise, ``sqrt(max(r_j^2 - sigma_noise,j^2, 0))``. It is an
error of the model at every load, not a random one that averages out, so it enters as is: a
run whose residuals are 10 % of full scale cannot print a total below 10 %.

Independent sources add in quadrature; the budget's total is the expanded uncertainty
``k sqrt(sum sigma^2)`` with coverage factor k = 2 (about 95 %). Units: N for Fx, Fy, Fz
and N m for Mx, My, Mz, and % of each axis's full scale. Nothing here knows the channel
layout: it works from regressors and the 6 x 6 C_bar.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.arrays import frozen
from ..model.channels import WRENCH_AXES

#: Coverage factor of the budget's total (k = 2: about 95 % of the errors fall within it).
COVERAGE = 2.0

#: Name of the budget's model-error term (:func:`model_error`).
MODEL_ERROR = "model error"

#: Name of the budget's term of a sensor that does not repeat from pose to pose (the sensor file's ``repeatability``).
REPEATABILITY = "sensor repeatability"

#: Default accuracy target of a sized plan: every axis's budget total within this, [% of full scale].
DEFAULT_TARGET_PERCENT = 0.05


@dataclass(frozen=True)
class ErrorSource:
    """One perturbation of the known wrench: ``dw_i = sensitivity[i] @ u[groups[i]]``.

    Attributes:
        name: The term of the budget it belongs to (sources of one name add in quadrature).
        sensitivity: B, [N or N m per unit of u]. Shape (N, 6, r).
        covariance: Covariance U of each draw u. Shape (r, r).
        groups: Group of each sample (samples of a group share one draw), shape (N,) int;
            None for a draw per sample (white). With ``time``: the stretch of each sample
            (the derivatives are taken within a stretch).
        time: Sample times [s], shape (N,), for white noise of readings estimated through
            linear filters (:func:`filtered_sensitivity`): ``sensitivity`` is then (N, 6, 3r),
            the parts of the readings' value, rate and second rate, and ``covariance`` (r, r)
            that of one reading; None otherwise.
        period: Period of those readings [s] (with ``time``).
        kernels: The filters' kernels (value, rate, second rate) over a centred window of
            readings, shape (3, 2h + 1) (with ``time``).
    """

    name: str
    sensitivity: np.ndarray
    covariance: np.ndarray
    groups: np.ndarray | None = None
    time: np.ndarray | None = None
    period: float = 0.0
    kernels: np.ndarray | None = None


def wrench_noise(C: np.ndarray, noise_std) -> np.ndarray:
    """Standard deviation of the wrench from white channel noise, per axis, [N, N m]. Shape (6,).

    Args:
        C: Calibration matrix. Shape (6, n).
        noise_std: Noise per channel, raw units; one number or shape (n,).
    """
    C = np.asarray(C, dtype=float)
    noise = np.broadcast_to(np.asarray(noise_std, dtype=float), (C.shape[1],))
    return np.sqrt(np.einsum("jk,k,jk->j", C, noise**2, C))


#: How much larger than the misfit the calibration loads show a model's error elsewhere is taken to be. A linear
#: fit absorbs most of a bend: of ``x |x|`` over a range of loads it leaves a residual of a quarter of the bend's
#: RMS (uniform x: 0.112 against 0.447), and on another load the absorbed part shows too.
MODEL_ERROR_EXTRAPOLATION = 4.0


def model_error(residual_rms, sigma_noise, full_scale=None) -> np.ndarray:
    """The model-error term: the residual beyond the strain noise, [N, N m]. Shape (6,).

    With ``full_scale``, :data:`MODEL_ERROR_EXTRAPOLATION` times the largest of the axes' terms in %
    of full scale, on every axis. A bend the data show on one axis is one they may hide on another:
    the loads of one mass have one force magnitude, so a bend that grows with the force is absorbed
    by the force's gain there and shows only on another tool, and the part of it a fit absorbs
    shows on every other load (a sensor bent by 0.1 FS |u| u per axis, calibrated with 1.2 kg on the
    shipped UR5 plan: residuals beyond the noise of 0.002-0.006 % FS on the forces and 0.1 % on the
    moments; on a 1.4 kg tool 0.11-0.16 % RMS on the forces, on a 1.0 kg tool up to 0.17 %).

    Args:
        residual_rms: RMS of the residual per axis on held-out (or fitted) samples, [N, N m]. Shape (6,).
        sigma_noise: The strain noise through C per axis, [N, N m]. Shape (6,).
        full_scale: Full scale per axis [N, N m], shape (6,), or None: each axis its own term.
    """
    r, s = np.asarray(residual_rms, dtype=float), np.asarray(sigma_noise, dtype=float)
    beyond = np.sqrt(np.maximum(r**2 - s**2, 0.0))
    if full_scale is None:
        return beyond
    full_scale = np.asarray(full_scale, dtype=float)
    return MODEL_ERROR_EXTRAPOLATION * float(np.max(beyond / full_scale)) * full_scale


def range_moments(C_bar, D, full_scale) -> np.ndarray:
    """``M = E[x x^T]`` over loads uniform in the full-scale box, ``x = [C_bar^-1 (W - D); 1]``.

    Args:
        C_bar: Modified calibration matrix. Shape (6, 6).
        D: Offsets, [N, N, N, N m, N m, N m]. Shape (6,).
        full_scale: Full scale per axis, same units. Shape (6,).

    Returns:
        Shape (7, 7).
    """
    inv = np.linalg.inv(np.asarray(C_bar, dtype=float))
    D = np.asarray(D, dtype=float)
    mean = -inv @ D
    second = inv @ (np.diag(np.asarray(full_scale, dtype=float) ** 2 / 3.0) + np.outer(D, D)) @ inv.T
    M = np.ones((7, 7))
    M[:6, :6], M[:6, 6], M[6, :6] = second, mean, mean
    return M


def filtered_sensitivity(source: ErrorSource, A: np.ndarray) -> list[np.ndarray]:
    r"""Each reading's share of the error from white readings estimated through linear filters.

    A sample's value, rate and second-rate estimates are ``sum_k K_d[k] q_{i+k}`` (kernels
    ``K_d``, d = 0, 1, 2, of ``2h + 1`` taps at the readings' period); the least squares' error
    ``sum_i sum_d (B_d A)_i (K_d * n)_i`` is then ``sum_t n_t E_t`` with

    .. math::

        E_t = \sum_d \sum_k K_d[k]\, (B_d A)_{t-k},

    a convolution of each sample's share with the kernels: over a smooth motion the
    differentiating kernels (they sum to zero) cancel the noise's share, except where the
    samples begin and end. The planned samples are spread over the readings by linear
    interpolation in time, each reading standing for ``period / step`` of a planned sample.

    Returns:
        One array per stretch of ``groups`` (its readings, half a window beyond each end
        included), shape (T, 6, r, 7).
    """
    B = np.asarray(source.sensitivity, dtype=float)
    r = B.shape[2] // 3
    kernels = np.asarray(source.kernels, dtype=float)
    half = kernels.shape[1] // 2
    time = np.asarray(source.time, dtype=float)
    groups = np.zeros(len(time), dtype=np.int64) if source.groups is None else np.asarray(source.groups)
    out = []
    for g in np.unique(groups):
        rows = np.nonzero(groups == g)[0]
        t = time[rows]
        step = float(np.median(np.diff(t))) if len(t) > 1 else source.period
        readings = np.arange(t[0], t[-1] + 0.5 * source.period, source.period)
        P = np.einsum("njr,nk->njrk", B[rows], A[rows]).reshape(len(rows), -1) * (source.period / step)
        index = np.clip(np.searchsorted(t, readings, side="right") - 1, 0, max(len(t) - 2, 0))
        frac = np.clip((readings - t[index]) / step, 0.0, 1.0)[:, None] if len(t) > 1 else np.zeros((len(readings), 1))
        upper = np.minimum(index + 1, len(t) - 1)
        spread = (P[index] * (1 - frac) + P[upper] * frac).reshape(len(readings), 6, 3, r * 7)
        length = len(readings) + 2 * half
        size = 1 << int(np.ceil(np.log2(length)))  # FFT convolution of every column with its kernel
        E_f = sum(
            np.fft.rfft(spread[:, :, d].reshape(len(readings), -1), size, axis=0) * np.fft.rfft(kernels[d], size)[:, None] for d in range(3)
        )
        E = np.fft.irfft(E_f, size, axis=0)[:length].reshape(length, 6, r, 7)
        out.append(E)
    return out


def propagate(
    x: np.ndarray,
    sources: Sequence[ErrorSource],
    moments: np.ndarray,
    weight: float = 1.0,
    ridge: np.ndarray | None = None,
    row_weight: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """Standard deviation of the wrench error over the range, per axis, of each named term.

    Args:
        x: Regressors of the samples, ``[P Delta; 1]``. Shape (N, 7).
        sources: The perturbations.
        moments: ``M`` of :func:`range_moments`. Shape (7, 7).
        weight: Samples each row stands for (e.g. channel samples per planned sample): the
            white sources average over them, the shared ones do not.
        ridge: The prior's term added to ``x^T x`` (a ridge on C_bar, :mod:`fts_calib.model.prior`),
            shape (7, 7), in the units of ``x^T x`` of these rows; None for plain least squares.
        row_weight: The weight of each sample in a weighted least squares (``S = x^T diag(w) x``,
            each sample's error enters as ``w_i x_i``), shape (N,); None for equal weights.

    Returns:
        Term name -> sigma per axis, [N, N, N, N m, N m, N m]. Shape (6,) each.
    """
    x = np.asarray(x, dtype=float)
    wx = x if row_weight is None else np.asarray(row_weight, dtype=float)[:, None] * x
    S = x.T @ wx if ridge is None else x.T @ wx + ridge
    scale = 1.0 / np.sqrt(np.diag(S))
    S_inv = np.linalg.pinv(S * scale[:, None] * scale[None, :], hermitian=True) * scale[:, None] * scale[None, :]
    A = wx @ S_inv  # (N, 7): the least-squares weight of each sample
    variance: dict[str, np.ndarray] = {}
    for source in sources:
        B, U = np.asarray(source.sensitivity, dtype=float), np.asarray(source.covariance, dtype=float)
        if source.time is not None:
            var = sum(np.einsum("rs,njrk,kl,njsl->j", U, E, moments, E) for E in filtered_sensitivity(source, A))
        elif source.groups is None:
            per_axis = np.einsum("njr,rs,njs->nj", B, U, B)
            spread = np.einsum("nk,kl,nl->n", A, moments, A)
            var = per_axis.T @ spread / weight
        else:
            _, groups = np.unique(source.groups, return_inverse=True)
            order = np.argsort(groups, kind="stable")
            starts = np.concatenate([[0], np.nonzero(np.diff(groups[order]))[0] + 1])
            shares = np.einsum("njr,nk->njrk", B[order], A[order]).reshape(len(order), -1)
            G = np.add.reduceat(shares, starts, axis=0).reshape(len(starts), 6, B.shape[2], 7)  # sum per group
            var = np.einsum("rs,gjrk,kl,gjsl->j", U, G, moments, G)
        variance[source.name] = variance.get(source.name, np.zeros(6)) + np.maximum(var, 0.0)
    return {name: np.sqrt(v) for name, v in variance.items()}


@dataclass(frozen=True)
class AccuracyBudget:
    """Where a calibration's error comes from, per wrench axis.

    Attributes:
        terms: Source name -> standard deviation of the wrench error over the range,
            [N, N, N, N m, N m, N m]. Shape (6,) each.
        full_scale: Full scale per axis, same units. Shape (6,).
        coverage: Coverage factor of the total.
        kind: 'predicted' (from a plan) or 'measured' (from the data of a calibration).
    """

    terms: Mapping[str, np.ndarray]
    full_scale: np.ndarray
    coverage: float = COVERAGE
    kind: str = "predicted"

    def __post_init__(self):
        object.__setattr__(self, "terms", {k: frozen(np.asarray(v, dtype=float)) for k, v in self.terms.items()})
        object.__setattr__(self, "full_scale", frozen(np.asarray(self.full_scale, dtype=float)))

    @property
    def sigma(self) -> np.ndarray:
        """Combined standard deviation per axis (quadrature sum of the terms), [N or N m]. Shape (6,)."""
        return np.sqrt(sum((v**2 for v in self.terms.values()), np.zeros(6)))

    @property
    def total(self) -> np.ndarray:
        """Expanded uncertainty per axis, ``coverage * sigma``, [N or N m]. Shape (6,)."""
        return self.coverage * self.sigma

    @property
    def total_percent(self) -> np.ndarray:
        """The total in % of each axis's full scale. Shape (6,)."""
        return 100.0 * self.total / self.full_scale

    @property
    def largest_percent(self) -> float:
        """The largest total of any axis, in % of full scale (what a user reads first)."""
        return float(np.max(self.total_percent))

    def percent(self, name: str) -> np.ndarray:
        """One term, expanded by the coverage factor, in % of full scale. Shape (6,)."""
        return 100.0 * self.coverage * self.terms[name] / self.full_scale

    def dominant(self) -> tuple[str, str]:
        """The term and the axis that contribute most: ``(term, axis)``."""
        axis = int(np.argmax(self.total_percent))
        name = max(self.terms, key=lambda k: float(self.terms[k][axis])) if self.terms else ""
        return name, WRENCH_AXES[axis]

    def without(self, names: Sequence[str]) -> AccuracyBudget:
        """The budget with some terms left out (e.g. what no plan can shrink)."""
        return AccuracyBudget({k: v for k, v in self.terms.items() if k not in names}, self.full_scale, self.coverage, self.kind)

    def to_dict(self) -> dict[str, Any]:
        """Plain data for the files: per term and for the total, per axis, in N or N m and in % FS."""

        def axes(values: np.ndarray, digits: int = 4) -> dict[str, float]:
            return {a: float(f"{v:.{digits}g}") for a, v in zip(WRENCH_AXES, values, strict=True)}

        term, axis = self.dominant()
        return {
            "kind": self.kind,
            "coverage_factor": self.coverage,
            "range": "loads uniform over the full-scale box, RMS of the error's standard deviation",
            "full_scale": axes(self.full_scale),
            "terms_percent_fs": {k: axes(self.percent(k)) for k in self.terms},
            "total": axes(self.total),
            "total_percent_fs": axes(self.total_percent),
            "largest_percent_fs": float(f"{self.largest_percent:.4g}") if math.isfinite(self.largest_percent) else None,
            "dominant": {"term": term, "axis": axis},
        }

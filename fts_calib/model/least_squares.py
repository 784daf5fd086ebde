r"""Least-squares numerics shared by the estimators: rank, normal equations, standard errors.

A fit regresses the wrench W (shape (6,), [N, N, N, N m, N m, N m]) on the projected
strains x (shape (p,): ``P Delta``, p = 6, or with a trailing 1 for the offsets, p = 7)
from its normal matrices, the sums ``S_WW = sum w W W^T`` (6, 6), ``S_WX = sum w W x^T``
(6, p) and ``S_XX = sum w x x^T`` (p, p):

.. math::

    \Theta = S_{WX} S_{XX}^{-1}, \qquad
    \mathrm{RSS}_j = (S_{WW} - 2\,\Theta S_{WX}^T + \Theta S_{XX} \Theta^T)_{jj}

Rank: one tool centre of mass gives S_XX rank 4, two give 6, three non-collinear ones
give the full 7 (paper eqs 18-20). The numerical rank counts the eigenvalues of S_XX,
scaled to a unit diagonal, above ``rcond`` times the largest, so it does not depend on the
strain unit.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from ..core.exceptions import InsufficientExcitation
from .calibration import Quality

#: Default relative eigenvalue threshold for the numerical rank of the scaled S_XX.
#: A direction whose strain amplitude is below about 3e-4 of the typical one
#: (eigenvalue ratio 1e-7) counts as missing.
RCOND = 1e-7


#: Columns of the widest block of a product in :func:`gram`.
_GRAM_BLOCK = 16


def gram(Z: np.ndarray, weight: np.ndarray | None = None) -> np.ndarray:
    """``Z^T diag(w) Z`` (shape (m, m)) of rows ``Z`` (N, m), in products of at most 16 columns.

    OpenBLAS (numpy's) runs a product with more than 16 columns on its worker threads, which
    then spin: with one offset column per configuration (18 columns for three) a live run
    used two cores instead of half of one and a block of 1,700 rows took 118 us instead of 68.
    The estimator's 12 + k columns are one block of 12 and one of k; wider rows (the features of
    a nonlinear model) are cut in blocks of 16.

    Args:
        Z: Rows, shape (N, m).
        weight: Weight of each row, shape (N,), or None (all 1).
    """
    R = Z if weight is None else Z * weight[:, None]
    m = Z.shape[1]
    if m <= _GRAM_BLOCK:
        return Z.T @ R
    edges = [0, 12, *range(12 + _GRAM_BLOCK, m, _GRAM_BLOCK), m]
    blocks = [slice(a, b) for a, b in zip(edges[:-1], edges[1:], strict=True)]
    left = [np.ascontiguousarray(Z[:, b]) for b in blocks]
    right = left if weight is None else [np.ascontiguousarray(R[:, b]) for b in blocks]
    out = np.empty((m, m))
    for i, bi in enumerate(blocks):
        for j in range(i, len(blocks)):
            out[bi, blocks[j]] = left[i].T @ right[j]
            if j > i:
                out[blocks[j], bi] = out[bi, blocks[j]].T
    return out


def information_rank(S_XX, rcond: float = RCOND) -> tuple[int, float]:
    """Numerical rank and condition number of an information matrix, after diagonal scaling.

    The matrix is scaled to a unit diagonal first, so the result does not depend on the
    strain unit; a zero diagonal entry is a missing direction.

    Args:
        S_XX: Symmetric positive semi-definite matrix. Shape (n, n).
        rcond: Eigenvalues below ``rcond`` times the largest count as zero.

    Returns:
        ``(rank, condition_number)``; the condition number is inf when rank < n.
    """
    scaled, _ = _equilibrate(np.asarray(S_XX, dtype=float))
    eig = np.linalg.eigvalsh(scaled)
    top = eig[-1] if eig.size and eig[-1] > 0 else 0.0
    rank = int(np.sum(eig > rcond * top)) if top > 0 else 0
    condition = float(top / eig[0]) if rank == len(eig) else math.inf
    return rank, condition


def excitation_rank(sums: np.ndarray, rcond: float = RCOND) -> int:
    """Rank of what the known loads excite: the information of ``[W; b]``, noise-free.

    The regressor's signal is an affine map of the known wrench (eq 22: ``P Delta =
    C_bar^-1 (W - D b)``), so the rank of the sums of ``[W; b][W; b]^T`` is the rank that
    S_XX would have without strain noise. S_XX alone over-counts: noise fills every
    missing direction a little (one tool centre of mass reads rank 5 to 7 instead of 4
    on a noisy sensor), and a deficient problem would pass as determined.

    Args:
        sums: Sums of ``z z^T`` with ``z = [W; P Delta; b]``, shape (12 + k, 12 + k).
        rcond: Threshold of :func:`information_rank`.

    Returns:
        The rank, 0 to 6 + k.
    """
    known = np.r_[0:6, 12 : len(sums)]
    return information_rank(sums[np.ix_(known, known)], rcond)[0]


def load_information(sums: np.ndarray, rcond: float = RCOND) -> tuple[int, float, np.ndarray, np.ndarray]:
    """What the known loads excite, direction by direction: the information of ``[W; b]`` scaled to a unit diagonal.

    Args:
        sums: Sums of ``z z^T`` with ``z = [W; P Delta; b]``, shape (12 + k, 12 + k).
        rcond: Eigenvalues below ``rcond`` times the largest count as missing.

    Returns:
        ``(rank, condition number (inf below full rank), eigenvalues (6 + k,) ascending,
        eigenvectors (6 + k, 6 + k) as columns)``; rows 0-5 are the wrench axes, then the offset columns.
    """
    known = np.r_[0:6, 12 : len(sums)]
    scaled, _ = _equilibrate(np.asarray(sums, dtype=float)[np.ix_(known, known)])
    eig, vec = np.linalg.eigh(scaled)
    top = eig[-1] if eig[-1] > 0 else 1.0
    rank = int(np.sum(eig > rcond * top)) if eig[-1] > 0 else 0
    return rank, (float(top / eig[0]) if rank == len(eig) else math.inf), eig, vec


def undetermined_columns(S: np.ndarray, names: list[str], rcond: float = RCOND, share: float = 0.2) -> list[list[str]]:
    """The columns an information matrix cannot separate: for each direction it misses, the columns that direction mixes.

    Scaled to a unit diagonal like :func:`information_rank`; a column with no data at all
    is a group of one. A missing direction's columns are those whose weight in it is at
    least ``share`` of its largest, largest first: ``['time^1', 'temperature']`` when the
    temperature followed time linearly over the samples.

    Args:
        S: Symmetric positive semi-definite matrix. Shape (n, n).
        names: The name of each column. Length n.
        rcond: Eigenvalues below ``rcond`` times the largest count as missing.
        share: Smallest weight of a column in a missing direction, relative to the largest.

    Returns:
        One list of names per missing direction (empty when the matrix has full rank).
    """
    S = np.asarray(S, dtype=float)
    empty = np.diag(S) <= 0
    groups = [[names[i]] for i in np.flatnonzero(empty)]
    filled = np.flatnonzero(~empty)
    if not len(filled):
        return groups
    scaled, _ = _equilibrate(S[np.ix_(filled, filled)])
    eig, vec = np.linalg.eigh(scaled)
    for k in np.flatnonzero(eig <= rcond * max(float(eig[-1]), 0.0)):
        weight = np.abs(vec[:, k])
        order = [i for i in np.argsort(-weight) if weight[i] >= share * weight.max()]
        groups.append([names[filled[i]] for i in order])
    return groups


def unexplained_strain(sums: np.ndarray, noise_cov: np.ndarray, n_eff: float, rcond: float = RCOND) -> float:
    """How much of the strains the known loads leave unexplained, in units of the noise alone.

    The projected strains ``x = P Delta`` are regressed on the known side ``[W; b]`` (any
    rank: a pseudo-inverse); their residual covariance per sample, whitened by the noise
    covariance, has largest eigenvalue about 1 when the loads explain the strains up to
    noise (a legitimately deficient sweep), and far more when the strains carry a signal
    the loads do not (a wrong tool file or joint unit: a poor fit, not a missing sweep).

    Args:
        sums: Sums of ``z z^T`` with ``z = [W; P Delta; b]``, shape (12 + k, 12 + k).
        noise_cov: Covariance of one sample's ``P Delta``, ``P Sigma P^T``, shape (6, 6).
        n_eff: Effective number of samples.
        rcond: Threshold of the pseudo-inverse of the known side's sums (scaled).

    Returns:
        The largest whitened residual variance (dimensionless); 0 when the loads explain
        the strains to rounding, inf when they do not and the noise is zero.
    """
    known = np.r_[0:6, 12 : len(sums)]
    S_kk = sums[np.ix_(known, known)]
    S_xk = sums[6:12][:, known]
    scaled, scale = _equilibrate(S_kk)
    pinv = np.linalg.pinv(scaled, rcond=rcond, hermitian=True) * scale[:, None] * scale[None, :]
    residual = (sums[6:12, 6:12] - S_xk @ pinv @ S_xk.T) / max(n_eff, 1.0)
    eig, vec = np.linalg.eigh(np.asarray(noise_cov, dtype=float))
    if not eig[-1] > 0:  # noiseless data: explained when only rounding is left
        explained = np.linalg.eigvalsh(residual)[-1] <= 1e-9 * np.trace(sums[6:12, 6:12]) / max(n_eff, 1.0)
        return 0.0 if explained else math.inf
    whiten = vec / np.sqrt(np.maximum(eig, eig[-1] * 1e-12))
    return float(np.linalg.eigvalsh(whiten.T @ residual @ whiten)[-1])


def _equilibrate(S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    d = np.diag(S).copy()
    scale = np.where(d > 0, 1.0 / np.sqrt(np.where(d > 0, d, 1.0)), 0.0)
    return S * scale[:, None] * scale[None, :], scale


def solve_normal(S_XX: np.ndarray, S_WX: np.ndarray, rcond: float, min_norm: bool):
    """Solve ``Theta S_XX = S_WX``; return (Theta, rank, condition, inverse of S_XX).

    Full rank: Cholesky factor L of the scaled matrix, then triangular solves (no explicit
    inverse of S_XX for Theta). Rank deficient with ``min_norm``: the minimum-norm solution
    from the truncated eigen-decomposition.

    Args:
        S_XX: Sum of ``w x x^T`` of the regressors, shape (p, p).
        S_WX: Sum of ``w W x^T``, W in [N, N, N, N m, N m, N m], shape (6, p).
        rcond: Threshold of the numerical rank, relative to the largest eigenvalue of the
            scaled S_XX (:func:`information_rank`).
        min_norm: Below full rank, return the minimum-norm solution instead of None.

    Returns:
        ``(Theta (6, p) or None, rank, condition number (inf below full rank), (pseudo-)inverse
        of S_XX (p, p) or None)``; Theta and the inverse are None below full rank without
        ``min_norm``.
    """
    scaled, scale = _equilibrate(S_XX)
    eig, vec = np.linalg.eigh(scaled)
    top = eig[-1] if eig[-1] > 0 else 0.0
    keep = eig > rcond * top if top > 0 else np.zeros_like(eig, dtype=bool)
    rank = int(keep.sum())
    n = len(eig)
    condition = float(top / eig[0]) if rank == n else math.inf
    if rank == n:
        L = np.linalg.cholesky(scaled)
        y = np.linalg.solve(L, scale[:, None] * S_WX.T)
        theta_t = scale[:, None] * np.linalg.solve(L.T, y)
        L_inv = np.linalg.solve(L, np.eye(n))
        inv = (L_inv.T @ L_inv) * scale[:, None] * scale[None, :]
    elif min_norm:
        v = vec[:, keep]
        pinv_scaled = (v / eig[keep]) @ v.T
        inv = pinv_scaled * scale[:, None] * scale[None, :]
        theta_t = inv @ S_WX.T
    else:
        return None, rank, condition, None
    return theta_t.T, rank, condition, inv


def coefficient_stderr(sigma, inv, projection) -> tuple[np.ndarray, np.ndarray]:
    """Standard errors of the coefficients of an ordinary least-squares fit of W on x.

    ``Cov(row j) = sigma_j^2 S_XX^-1``; for ``C = C_bar P``, ``Var(C_jk) = sigma_j^2 p_k^T
    Cov6 p_k`` with ``p_k`` the column k of P and Cov6 the C_bar block.

    Args:
        sigma: Residual standard deviation per wrench axis, [N or N m]. Shape (6,).
        inv: Inverse of S_XX. Shape (p, p), p >= 6: the C_bar block first, then the
            offset terms.
        projection: The channel layout's P, shape (6, n).

    Returns:
        ``(stderr of every regression coefficient (6, p), stderr of C (6, n))``.
    """
    P = np.asarray(projection, dtype=float)
    sigma = np.asarray(sigma, dtype=float)
    stderr_theta = sigma[:, None] * np.sqrt(np.maximum(np.diag(inv), 0.0))[None, :]
    inv6 = inv[:6, :6]
    stderr_C = sigma[:, None] * np.sqrt(np.maximum(np.einsum("ik,ij,jk->k", P, inv6, P), 0.0))[None, :]
    return stderr_theta, stderr_C


def residual_sums(S_WW, S_WX, S_XX, theta) -> np.ndarray:
    """Residual sum of squares per wrench axis of ``W ~ theta x`` from the normal matrices, shape (6,)."""
    rss = np.diag(S_WW) - 2.0 * np.sum(theta * S_WX, axis=1) + np.sum((theta @ S_XX) * theta, axis=1)
    return np.maximum(rss, 0.0)  # cancellation can leave -1e-16 relative on exact data


def residual_sigma(rss, observations: float, p: int, used: int) -> np.ndarray:
    """Residual standard deviation per wrench axis, ``sqrt(RSS / (observations - p))``, shape (6,).

    Args:
        rss: Weighted residual sum of squares per axis, [N^2 or (N m)^2]. Shape (6,).
        observations: Observations (samples of positive weight, after forgetting).
        p: Coefficients per wrench axis.
        used: Samples that entered the sums, for the message.

    Raises:
        InsufficientExcitation: Fewer than one degree of freedom (``observations - p < 1``):
            the residual variance, hence every standard error, is not determined.
    """
    dof = observations - p
    if not dof >= 1.0:  # also NaN
        counted = "" if observations == used else f" ({observations:.3g} observations after weights and forgetting)"
        raise InsufficientExcitation(
            0,
            0,
            f"{used:,} samples{counted} for {p} coefficients per wrench axis leave {max(dof, 0.0):.3g} degrees of freedom for "
            f"the residual noise, at least 1 needed: the standard errors are not determined; record more samples (at least "
            f"{p + 1} kept, a longer still span at each stop or a higher rate)",
            full=p,
        )
    return np.sqrt(np.asarray(rss, dtype=float) / dof)


def fit_quality(
    S_WW,
    S_WX,
    S_XX,
    theta,
    inv,
    n_eff: float,
    used: int,
    seen: int,
    rank: int,
    condition: float,
    skipped: Mapping[str, int],
    projection,
    offset_row=None,
    observations: float | None = None,
) -> Quality:
    """Residuals and standard errors of a least-squares fit from its normal matrices.

    ``theta`` is (6, p) with p = 6 (C_bar only), 7 (C_bar and D) or 6 + k (C_bar and the k
    offset terms of :mod:`fts_calib.model.offset_models`); ``inv`` is the (p, p)
    (pseudo-)inverse of S_XX; ``projection`` the layout's P (6, n). The residual variance
    per axis is RSS / (observations - p): the weights are inverse variances relative to the
    unit weight's (the dynamic filter's ``1 / (1 + rho^2)``), so a weighted sample is still one
    observation and ``n_eff`` (their sum) is not the count to subtract p from. ``offset_row`` (k,) is the offset basis of the time the
    reported D belongs to (``D = theta[:, 6:] @ offset_row``): its standard error is
    ``sigma_j sqrt(a^T S_XX^-1 a)``; None means the single constant column (p = 7).

    Args:
        S_WW: Sum of ``w W W^T``, W in [N, N, N, N m, N m, N m], shape (6, 6).
        S_WX: Sum of ``w W x^T``, shape (6, p).
        S_XX: Sum of ``w x x^T``, shape (p, p).
        theta: The solution ``[C_bar, offset terms]``, shape (6, p).
        inv: (Pseudo-)inverse of S_XX (or the covariance over sigma^2 of a ridge fit), shape (p, p).
        n_eff: Effective number of samples (sum of weights).
        used: Samples that entered the sums.
        seen: Samples offered.
        rank: Numerical rank reported.
        condition: Condition number reported (inf below full rank).
        skipped: Samples not used, by reason.
        projection: The channel layout's P, shape (6, n).
        offset_row: Offset basis row of the reported D, shape (k,), or None (see above).
        observations: Samples of positive weight (after forgetting), for the degrees of
            freedom; ``n_eff`` when None (unit weights).

    Returns:
        The :class:`~fts_calib.model.calibration.Quality` (residual RMS and standard errors
        in N and N m), every standard error finite.

    Raises:
        InsufficientExcitation: No degree of freedom is left for the residual variance
            (observations <= p): the standard errors are not determined.
    """
    p = theta.shape[1]
    rss = residual_sums(S_WW, S_WX, S_XX, theta)
    residual_rms = np.sqrt(rss / n_eff) if n_eff > 0 else np.full(6, np.nan)
    sigma = residual_sigma(rss, n_eff if observations is None else observations, p, used)
    stderr_theta, stderr_C = coefficient_stderr(sigma, inv, projection)
    if offset_row is not None:
        a = np.asarray(offset_row, dtype=float)
        stderr_D = sigma * math.sqrt(max(float(a @ inv[6:, 6:] @ a), 0.0))
    else:
        stderr_D = stderr_theta[:, 6] if p == 7 else np.zeros(6)
    return Quality(
        samples_used=used,
        samples_seen=seen,
        rank=rank,
        condition_number=condition,
        residual_rms=residual_rms,
        stderr_C_bar=stderr_theta[:, :6],
        stderr_D=stderr_D,
        stderr_C=stderr_C,
        skipped=skipped,
        full_rank=p,
    )

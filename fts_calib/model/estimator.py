r"""Least-squares estimators of the calibration (paper eqs 9, 12-16) and the offset re-tare.

The online estimator regresses the known wrench W (shape (6,), [N, N, N, N m, N m, N m])
on the augmented projected strain ``x = [P Delta; 1]`` (shape (7,), eq 13) and keeps only
sums, so its memory does not grow with the number of samples:

.. math::

    S_{WX} \mathrel{+}= w\,W x^T, \qquad S_{XX} \mathrel{+}= w\,x x^T, \qquad
    [\bar C, D] = S_{WX} S_{XX}^{-1} \quad \text{(eqs 12, 14-16)}

Internally one symmetric 13x13 sum of ``z z^T`` with ``z = [W; P Delta; 1]`` holds
S_WW, S_WX and S_XX as blocks; S_WW gives the residuals and the standard errors.

Weights are frequency weights: a sample of weight 2 counts exactly like the same sample
given twice. The forgetting factor ``lam`` in (0, 1] multiplies the sums by ``lam``
before each accepted sample (1 keeps everything).

Rank: one tool centre of mass gives S_XX rank 4, two give 6, three non-collinear ones
give the full 7 (paper eqs 18-20). The numerical rank counts the eigenvalues of S_XX,
scaled to a unit diagonal, above ``rcond`` times the largest.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from .._version import __version__
from ..core.arrays import as_matrix, as_samples, frozen
from ..core.exceptions import InsufficientExcitation, ShapeError
from .calibration import Calibration, Quality, now_iso
from .sensor import P, c_from_c_bar

#: Default relative eigenvalue threshold for the numerical rank of the scaled S_XX.
#: A direction whose strain amplitude is below about 3e-4 of the typical one
#: (eigenvalue ratio 1e-7) counts as missing.
RCOND = 1e-7

_CHUNK = 1 << 16  # rows per block in batch updates: bounds temporary memory to ~7 MB
_NON_FINITE = "non-finite wrench, strain or weight"

_RANK_ADVICE = (
    "One tool centre of mass gives at most rank 4, two give 6, three non-collinear ones "
    "give 7 (paper eqs 18-20); within each, the sensor must see gravity from directions "
    "that span 3-D."
)


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


def _equilibrate(S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    d = np.diag(S).copy()
    scale = np.where(d > 0, 1.0 / np.sqrt(np.where(d > 0, d, 1.0)), 0.0)
    return S * scale[:, None] * scale[None, :], scale


def _solve_normal(S_XX: np.ndarray, S_WX: np.ndarray, rcond: float, min_norm: bool):
    """Solve ``Theta S_XX = S_WX``; return (Theta, rank, condition, inverse of S_XX).

    Full rank: Cholesky factor L of the scaled matrix, then triangular solves (no explicit
    inverse of S_XX for Theta). Rank deficient with ``min_norm``: the minimum-norm solution
    from the truncated eigen-decomposition.
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


def coefficient_stderr(sigma, inv) -> tuple[np.ndarray, np.ndarray]:
    """Standard errors of the coefficients of an ordinary least-squares fit of W on x.

    ``Cov(row j) = sigma_j^2 S_XX^-1``; for ``C = C_bar P``, ``Var(C_jk) = sigma_j^2 p_k^T
    Cov6 p_k`` with ``p_k`` the column k of P and Cov6 the C_bar block.

    Args:
        sigma: Residual standard deviation per wrench axis, [N or N m]. Shape (6,).
        inv: Inverse of S_XX. Shape (p, p), p = 6 or 7 (the last entry is the offset).

    Returns:
        ``(stderr of [C_bar, D] (6, p), stderr of C (6, 8))``.
    """
    sigma = np.asarray(sigma, dtype=float)
    stderr_theta = sigma[:, None] * np.sqrt(np.maximum(np.diag(inv), 0.0))[None, :]
    inv6 = inv[:6, :6]
    stderr_C = sigma[:, None] * np.sqrt(np.maximum(np.einsum("ik,ij,jk->k", P, inv6, P), 0.0))[None, :]
    return stderr_theta, stderr_C


def _quality(
    S_WW, S_WX, S_XX, theta, inv, n_eff: float, used: int, seen: int, rank: int, condition: float, skipped: Mapping[str, int]
) -> Quality:
    """Residuals and standard errors of a least-squares fit from its normal matrices.

    ``theta`` is (6, p) with p = 7 (C_bar and D) or 6 (C_bar only); ``inv`` is the (p, p)
    (pseudo-)inverse of S_XX. The residual variance per axis is RSS / (n_eff - p).
    """
    p = theta.shape[1]
    rss = np.diag(S_WW) - 2.0 * np.sum(theta * S_WX, axis=1) + np.sum((theta @ S_XX) * theta, axis=1)
    rss = np.maximum(rss, 0.0)  # cancellation can leave -1e-16 relative on exact data
    residual_rms = np.sqrt(rss / n_eff) if n_eff > 0 else np.full(6, np.nan)
    dof = n_eff - p
    sigma = np.sqrt(rss / dof) if dof > 0 else np.full(6, math.inf)
    stderr_theta, stderr_C = coefficient_stderr(sigma, inv)
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
    )


class OnlineEstimator:
    """Online least squares of the calibration (paper eqs 12-16), with weights and forgetting.

    Example:
        >>> est = OnlineEstimator()
        >>> est.update(w_sensor, strain)           # one sample: (6,) in N, N m; (8,) raw
        >>> est.update_batch(W, strains)           # many: (N, 6) and (N, 8)
        >>> calibration = est.solve()              # C_bar, D, C and their quality

    Single samples are staged in a small buffer of ``z`` rows and added to the sums in
    blocks by the same code as :meth:`update_batch` (one matrix product per block instead
    of one outer product per sample); every method that reads the sums adds the staged
    rows first, so the buffer is invisible to a caller.

    Args:
        forgetting: Exponential forgetting factor in (0, 1]; 1 weighs all samples equally.
    """

    _STAGE = 64  # rows staged by update() before they are added to the sums

    def __init__(self, forgetting: float = 1.0):
        if not (0.0 < forgetting <= 1.0):
            raise ValueError(f"forgetting={forgetting!r} but expected a number in (0, 1]")
        self.forgetting = float(forgetting)
        self._sums = np.zeros((13, 13))
        self._staged = np.zeros((self._STAGE, 13))
        self._staged[:, 12] = 1.0
        self._staged_weight = np.ones(self._STAGE)
        self._n_staged = 0
        self._weight_sum = 0.0
        self.samples_used = 0
        self.samples_seen = 0
        self.skipped: dict[str, int] = {}

    # -- accumulation -------------------------------------------------------------------

    def update(self, w_sensor, strain, weight: float = 1.0) -> bool:
        """Add one sample (eqs 15-16).

        Args:
            w_sensor: Known wrench on the sensor, in [N, N, N, N m, N m, N m]. Shape (6,).
            strain: Raw bridge strains. Shape (8,).
            weight: Frequency weight >= 0.

        Returns:
            True when the sample was used; False when it was skipped (a non-finite value)
            and counted in ``skipped``.
        """
        w = np.asarray(w_sensor, dtype=float)
        s = np.asarray(strain, dtype=float)
        if w.shape != (6,) or s.shape != (8,):
            raise ShapeError(f"w_sensor.shape={w.shape}, strain.shape={s.shape} but expected (6,) and (8,)")
        self.samples_seen += 1
        # sums of squares: inf or NaN when any value is (or would overflow the sums), and
        # never inf - inf, so the check itself raises no floating-point warning
        if not (math.isfinite(s.dot(s) + w.dot(w)) and math.isfinite(weight) and weight >= 0):
            self._skip(_NON_FINITE, 1)
            return False
        row = self._staged[self._n_staged]
        row[:6] = w
        np.dot(P, s, out=row[6:12])
        self._staged_weight[self._n_staged] = weight
        self._n_staged += 1
        self.samples_used += 1
        if self._n_staged == self._STAGE:
            self._flush()
        return True

    def update_batch(self, w_sensor, strain, weight=None) -> int:
        """Add many samples; the sums equal those of calling :meth:`update` on each in order.

        Args:
            w_sensor: Known wrenches, in [N, N, N, N m, N m, N m]. Shape (N, 6).
            strain: Raw bridge strains. Shape (N, 8).
            weight: Frequency weights >= 0, shape (N,); all 1 when None.

        Returns:
            Number of samples used; rows with a non-finite value are skipped and counted.
        """
        W, _ = as_samples(w_sensor, 6, "w_sensor")
        S, _ = as_samples(strain, 8, "strain")
        if W.shape[0] != S.shape[0]:
            raise ShapeError(f"w_sensor has {W.shape[0]} rows but strain has {S.shape[0]}: expected the same N")
        n = W.shape[0]
        if weight is not None:
            weight = np.asarray(weight, dtype=float)
            if weight.shape != (n,):
                raise ShapeError(f"weight.shape={weight.shape} but expected ({n},)")
        self._flush()
        used = 0
        for start in range(0, n, _CHUNK):
            stop = min(start + _CHUNK, n)
            used += self._add_block(W[start:stop], S[start:stop], None if weight is None else weight[start:stop])
        self.samples_seen += n
        self.samples_used += used
        return used

    def _add_block(self, W: np.ndarray, S: np.ndarray, weight: np.ndarray | None) -> int:
        Z = np.empty((W.shape[0], 13))
        Z[:, :6] = W
        Z[:, 12] = 1.0
        with np.errstate(over="ignore", invalid="ignore"):  # bad rows are found below
            np.matmul(S, P.T, out=Z[:, 6:12])
            if weight is None and self.forgetting == 1.0:
                gram = Z.T @ Z  # fast path: one bad row makes the whole sum non-finite
                if np.all(np.isfinite(gram)):
                    self._sums += gram
                    self._weight_sum += float(len(Z))
                    return len(Z)
            # the rule of update(): a row is bad when its sum of squares is not finite
            ok = np.isfinite(np.einsum("ij,ij->i", S, S) + np.einsum("ij,ij->i", W, W))
        if weight is not None:
            ok &= np.isfinite(weight) & (weight >= 0)
        rejected = int(len(ok) - np.count_nonzero(ok))
        if rejected:
            self._skip(_NON_FINITE, rejected)
            Z = Z[ok]
            weight = None if weight is None else weight[ok]
        self._accumulate(Z, weight)
        return len(Z)

    def _accumulate(self, Z: np.ndarray, weight: np.ndarray | None) -> None:
        """Add finite rows ``z`` (in order) to the sums, with weights and forgetting."""
        if self.forgetting != 1.0 and len(Z):
            # row i of m is multiplied by lam once per later row, the old sums m times
            decay = self.forgetting ** np.arange(len(Z) - 1, -1, -1, dtype=float)
            weight = decay if weight is None else weight * decay
            self._sums *= self.forgetting ** len(Z)
            self._weight_sum *= self.forgetting ** len(Z)
        if weight is None:
            self._sums += Z.T @ Z
            self._weight_sum += float(len(Z))
        else:
            self._sums += Z.T @ (Z * weight[:, None])
            self._weight_sum += float(weight.sum())

    def _flush(self) -> None:
        n = self._n_staged
        if n:
            weights = self._staged_weight[:n]
            self._accumulate(self._staged[:n], None if np.all(weights == 1.0) else weights.copy())
            self._n_staged = 0

    def _skip(self, reason: str, count: int) -> None:
        self.skipped[reason] = self.skipped.get(reason, 0) + count

    def merge(self, other: OnlineEstimator) -> OnlineEstimator:
        """A new estimator holding the data of both (as one pass over both would).

        Both must have the same forgetting factor; with forgetting < 1, ``other``'s data
        count as the more recent.
        """
        if other.forgetting != self.forgetting:
            raise ValueError(f"cannot merge estimators with forgetting {self.forgetting} and {other.forgetting}")
        self._flush()
        other._flush()
        out = OnlineEstimator(self.forgetting)
        decay = self.forgetting**other.samples_used
        out._sums = self._sums * decay + other._sums
        out._weight_sum = self._weight_sum * decay + other._weight_sum
        out.samples_used = self.samples_used + other.samples_used
        out.samples_seen = self.samples_seen + other.samples_seen
        for source in (self.skipped, other.skipped):
            for reason, count in source.items():
                out._skip(reason, count)
        return out

    # -- views --------------------------------------------------------------------------

    @property
    def S_WX(self) -> np.ndarray:
        """Sum of ``w W x^T`` (eq 15), shape (6, 7); a copy."""
        return self._current()[:6, 6:].copy()

    @property
    def S_XX(self) -> np.ndarray:
        """Sum of ``w x x^T`` (eq 16), shape (7, 7); a copy."""
        return self._current()[6:, 6:].copy()

    @property
    def S_WW(self) -> np.ndarray:
        """Sum of ``w W W^T``, shape (6, 6); a copy (used for residuals)."""
        return self._current()[:6, :6].copy()

    def _current(self) -> np.ndarray:
        self._flush()
        return self._sums

    @property
    def weight_sum(self) -> float:
        """Effective number of samples (sum of weights, after forgetting)."""
        self._flush()
        return self._weight_sum

    def rank(self, rcond: float = RCOND) -> tuple[int, float]:
        """Numerical rank (0 to 7) and condition number of S_XX so far; see :func:`information_rank`."""
        if self.samples_used == 0:
            return 0, math.inf
        return information_rank(self._current()[6:, 6:], rcond)

    # -- solution -----------------------------------------------------------------------

    def solve(self, rcond: float = RCOND, min_norm: bool = False) -> Calibration:
        """C_bar, D and C from the sums (eq 12), with the quality of the fit.

        Args:
            rcond: Threshold of the numerical rank; see :func:`information_rank`.
            min_norm: When S_XX is rank deficient, return the minimum-norm solution
                instead of raising (for convergence plots; undetermined parts are zero).

        Raises:
            InsufficientExcitation: S_XX has rank below 7 (and ``min_norm`` is False);
                carries the rank and the number of missing directions.
        """
        if self.samples_used == 0:
            raise InsufficientExcitation(0, 7, "no sample has been added yet.")
        sums = self._current()
        S_XX, S_WX, S_WW = sums[6:, 6:], sums[:6, 6:], sums[:6, :6]
        theta, rank, condition, inv = _solve_normal(S_XX, S_WX, rcond, min_norm)
        if theta is None:
            raise InsufficientExcitation(rank, 7 - rank, _RANK_ADVICE)
        quality = _quality(
            S_WW, S_WX, S_XX, theta, inv, self._weight_sum, self.samples_used, self.samples_seen, rank, condition, self.skipped
        )
        provenance = {
            "method": "online least squares (paper eqs 12-16)",
            "time": now_iso(),
            "software_version": __version__,
        }
        return Calibration(C_bar=theta[:, :6], D=theta[:, 6], quality=quality, provenance=provenance)

    # -- checkpoints --------------------------------------------------------------------

    def state(self) -> dict:
        """Everything needed to resume: plain types, safe to write as YAML or JSON."""
        return {
            "forgetting": self.forgetting,
            "S": self._current().tolist(),
            "weight_sum": self._weight_sum,
            "samples_used": self.samples_used,
            "samples_seen": self.samples_seen,
            "skipped": dict(self.skipped),
        }

    @classmethod
    def from_state(cls, state: Mapping) -> OnlineEstimator:
        """Rebuild an estimator from :meth:`state`."""
        out = cls(float(state["forgetting"]))
        out._sums = as_matrix(state["S"], (13, 13), "state['S']").copy()
        out._weight_sum = float(state["weight_sum"])
        out.samples_used = int(state["samples_used"])
        out.samples_seen = int(state["samples_seen"])
        out.skipped = {str(k): int(v) for k, v in state.get("skipped", {}).items()}
        return out


def jig_calibration(w_sensor, strain, rcond: float = 1e-12) -> Calibration:
    """Offline calibration from a jig (paper eq 9 and its first validation stage).

    Pure axial loads are applied step by step and the strains recorded with their offsets
    already removed; C_bar is the least-squares solution through the pseudo-inverse of the
    projected strains (SVD), and ``C = C_bar P`` (eq 7). D is zero by construction.

    Args:
        w_sensor: Applied wrenches, in [N, N, N, N m, N m, N m]. Shape (N, 6).
        strain: Strains with offsets removed. Shape (N, 8).
        rcond: Singular values below ``rcond`` times the largest count as zero.

    Raises:
        InsufficientExcitation: The projected strains do not span 6 directions.
    """
    W, _ = as_samples(w_sensor, 6, "w_sensor")
    S, _ = as_samples(strain, 8, "strain")
    if W.shape[0] != S.shape[0]:
        raise ShapeError(f"w_sensor has {W.shape[0]} rows but strain has {S.shape[0]}: expected the same N")
    ok = np.all(np.isfinite(W), axis=1) & np.all(np.isfinite(S), axis=1)
    W, X = W[ok], S[ok] @ P.T
    U, s, Vt = np.linalg.svd(X, full_matrices=False)
    rank = int(np.sum(s > rcond * s[0])) if s.size and s[0] > 0 else 0
    if rank < 6:
        raise InsufficientExcitation(rank, 6 - rank, "the jig loads must include all six axes.", full=6)
    C_bar = ((Vt.T / s) @ (U.T @ W)).T  # eq 9: W X^#, with X^# the pseudo-inverse
    inv = (Vt.T / s**2) @ Vt
    skipped = {"non-finite wrench or strain": int((~ok).sum())} if (~ok).any() else {}
    _, condition = information_rank(X.T @ X)
    quality = _quality(W.T @ W, W.T @ X, X.T @ X, C_bar, inv, float(len(W)), len(W), len(ok), rank, condition, skipped)
    provenance = {
        "method": "offline jig, pseudo-inverse (paper eq 9); offsets removed beforehand, D = 0",
        "time": now_iso(),
        "software_version": __version__,
    }
    return Calibration(C_bar=C_bar, D=np.zeros(6), quality=quality, provenance=provenance)


@dataclass(frozen=True)
class OffsetEstimate:
    """Offsets estimated with C_bar known (re-tare).

    Attributes:
        D: Wrench offsets in [N, N, N, N m, N m, N m]. Shape (6,).
        stderr_D: Standard error of each offset, same units. Shape (6,).
        samples_used: Samples averaged.
        samples_skipped: Samples with non-finite values, skipped.
    """

    D: np.ndarray
    stderr_D: np.ndarray
    samples_used: int
    samples_skipped: int

    def __post_init__(self):
        object.__setattr__(self, "D", frozen(self.D))
        object.__setattr__(self, "stderr_D", frozen(self.stderr_D))


def estimate_offsets(C_bar, strain, w_sensor=None) -> OffsetEstimate:
    """Re-tare: the offsets D alone, with C_bar known, from a few samples of a known load.

    ``D = mean(W_known - C Delta)``: the frequent use the paper stresses (offset removal
    just before use).

    Args:
        C_bar: Known modified calibration matrix. Shape (6, 6).
        strain: Raw strains under the known load. Shape (N, 8) or (8,).
        w_sensor: The known load in [N, N, N, N m, N m, N m], shape (N, 6) or (6,);
            zero (nothing mounted) when None.

    Raises:
        InsufficientExcitation: No finite sample.
    """
    C = c_from_c_bar(C_bar)
    S, _ = as_samples(strain, 8, "strain")
    W = np.zeros((len(S), 6)) if w_sensor is None else as_samples(w_sensor, 6, "w_sensor")[0]
    if len(W) == 1 and len(S) > 1:
        W = np.repeat(W, len(S), axis=0)
    if len(W) != len(S):
        raise ShapeError(f"w_sensor has {len(W)} rows but strain has {len(S)}: expected the same N")
    residual = W - S @ C.T
    ok = np.all(np.isfinite(residual), axis=1)
    n = int(ok.sum())
    if n == 0:
        raise InsufficientExcitation(0, 1, "no finite sample to estimate the offsets from.")
    residual = residual[ok]
    D = residual.mean(axis=0)
    stderr = residual.std(axis=0, ddof=1) / math.sqrt(n) if n > 1 else np.full(6, math.inf)
    return OffsetEstimate(D=D, stderr_D=stderr, samples_used=n, samples_skipped=int(len(ok) - n))

r"""The online least-squares estimator of the calibration (paper eqs 12-16).

The online estimator regresses the known wrench W (shape (6,), [N, N, N, N m, N m, N m])
on the augmented projected strain ``x = [P Delta; 1]`` (shape (7,), eq 13) and keeps only
sums, so its memory does not grow with the number of samples. P is the sensor's channel
layout (6 x n, :mod:`fts_calib.model.channels`): the paper's 6 x 8 by default.

.. math::

    S_{WX} \mathrel{+}= w\,W x^T, \qquad S_{XX} \mathrel{+}= w\,x x^T, \qquad
    [\bar C, D] = S_{WX} S_{XX}^{-1} \quad \text{(eqs 12, 14-16)}

Internally one symmetric 13x13 sum of ``z z^T`` with ``z = [W; P Delta; 1]`` holds
S_WW, S_WX and S_XX as blocks; S_WW gives the residuals and the standard errors.

Weights are frequency weights: a sample of weight 2 counts exactly like the same sample
given twice. The forgetting factor ``lam`` in (0, 1] multiplies the sums by ``lam``
before each accepted sample (1 keeps everything).

The rank of S_XX and the solve of the normal equations are those of
:mod:`fts_calib.model.least_squares`: three non-collinear tool centres of mass give the
full rank 7 (paper eqs 18-20).
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Mapping

import numpy as np

from .._version import __version__
from ..core.arrays import as_matrix, as_samples
from ..core.exceptions import ConfigError, InsufficientExcitation, ShapeError
from .calibration import Calibration, now_iso
from .channels import MALTESE_CROSS_8, ChannelLayout, channel_layout
from .least_squares import RCOND, fit_quality, information_rank, solve_normal

_CHUNK = 1 << 16  # rows per block in batch updates: bounds temporary memory to ~7 MB
_NON_FINITE = "non-finite wrench, strain or weight"

#: What rank 7 needs, in words: the one advice text of the estimator and the excitation report.
RANK_ADVICE = (
    "One tool centre of mass gives at most rank 4, two give 6, three non-collinear ones "
    "give 7 (paper eqs 18-20); within each, the sensor must see gravity from directions "
    "that span 3-D."
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
        layout: The sensor's channel layout (or its sensor-YAML ``channels`` value); the
            paper's 8-bridge sensor by default.
    """

    _STAGE = 64  # rows staged by update() before they are added to the sums

    def __init__(self, forgetting: float = 1.0, layout: ChannelLayout | str | None = MALTESE_CROSS_8):
        if not (0.0 < forgetting <= 1.0):
            raise ConfigError("forgetting", forgetting, "a number in (0, 1]")
        self.forgetting = float(forgetting)
        self.layout = channel_layout(layout)
        self._P = self.layout.projection
        self._sums = np.zeros((13, 13))
        self._staged = np.zeros((self._STAGE, 13))
        self._staged[:, 12] = 1.0
        self._staged_weight = np.ones(self._STAGE)
        self._n_staged = 0
        self._weight_sum = 0.0
        self.samples_used = 0
        self.samples_seen = 0
        self.skipped: Counter[str] = Counter()

    # -- accumulation -------------------------------------------------------------------

    def update(self, w_sensor, strain, weight: float = 1.0) -> bool:
        """Add one sample (eqs 15-16).

        Args:
            w_sensor: Known wrench on the sensor, in [N, N, N, N m, N m, N m]. Shape (6,).
            strain: Raw channel readings. Shape (n,), n = ``layout.n_channels``.
            weight: Frequency weight >= 0.

        Returns:
            True when the sample was used; False when it was skipped (a non-finite value)
            and counted in ``skipped``.
        """
        wrench = np.asarray(w_sensor, dtype=float)
        s = np.asarray(strain, dtype=float)
        n = self.layout.n_channels
        if wrench.shape != (6,) or s.shape != (n,):
            raise ShapeError(f"w_sensor.shape={wrench.shape}, strain.shape={s.shape} but expected (6,) and ({n},)")
        self.samples_seen += 1
        # sums of squares: inf or NaN when any value is (or would overflow the sums), and
        # never inf - inf, so the check itself raises no floating-point warning
        if not (math.isfinite(s.dot(s) + wrench.dot(wrench)) and math.isfinite(weight) and weight >= 0):
            self._skip(_NON_FINITE, 1)
            return False
        row = self._staged[self._n_staged]
        row[:6] = wrench
        np.dot(self._P, s, out=row[6:12])
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
            strain: Raw channel readings. Shape (N, n), n = ``layout.n_channels``.
            weight: Frequency weights >= 0, shape (N,); all 1 when None.

        Returns:
            Number of samples used; rows with a non-finite value are skipped and counted.
        """
        W, _ = as_samples(w_sensor, 6, "w_sensor")
        S, _ = as_samples(strain, self.layout.n_channels, "strain")
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
            np.matmul(S, self._P.T, out=Z[:, 6:12])
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
        self.skipped[reason] += count

    def merge(self, other: OnlineEstimator) -> OnlineEstimator:
        """A new estimator holding the data of both (as one pass over both would).

        Both must have the same forgetting factor and channel layout; with forgetting < 1,
        ``other``'s data count as the more recent.
        """
        if other.forgetting != self.forgetting:
            message = f"cannot merge estimators with forgetting {self.forgetting} and {other.forgetting}"
            raise ConfigError("forgetting", other.forgetting, f"{self.forgetting}, the same as this estimator's", message=message)
        if other.layout != self.layout:
            message = f"cannot merge estimators of channel layouts {self.layout.name} and {other.layout.name}"
            raise ConfigError("channels", other.layout.name, self.layout.name, message=message)
        self._flush()
        other._flush()
        out = OnlineEstimator(self.forgetting, self.layout)
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
        theta, rank, condition, inv = solve_normal(S_XX, S_WX, rcond, min_norm)
        if theta is None:
            raise InsufficientExcitation(rank, 7 - rank, RANK_ADVICE)
        quality = fit_quality(
            S_WW, S_WX, S_XX, theta, inv, self._weight_sum, self.samples_used, self.samples_seen, rank, condition, self.skipped, self._P
        )
        provenance = {
            "method": "online least squares (paper eqs 12-16)",
            "time": now_iso(),
            "software_version": __version__,
        }
        return Calibration(C_bar=theta[:, :6], D=theta[:, 6], quality=quality, provenance=provenance, layout=self.layout)

    # -- checkpoints --------------------------------------------------------------------

    def state(self) -> dict:
        """Everything needed to resume: plain types, safe to write as YAML or JSON."""
        return {
            "forgetting": self.forgetting,
            "channels": self.layout.to_config(),
            "S": self._current().tolist(),
            "weight_sum": self._weight_sum,
            "samples_used": self.samples_used,
            "samples_seen": self.samples_seen,
            "skipped": dict(self.skipped),
        }

    @classmethod
    def from_state(cls, state: Mapping) -> OnlineEstimator:
        """Rebuild an estimator from :meth:`state`."""
        out = cls(float(state["forgetting"]), channel_layout(state.get("channels")))
        out._sums = as_matrix(state["S"], (13, 13), "state['S']").copy()
        out._weight_sum = float(state["weight_sum"])
        out.samples_used = int(state["samples_used"])
        out.samples_seen = int(state["samples_seen"])
        out.skipped = Counter({str(k): int(v) for k, v in state.get("skipped", {}).items()})
        return out

r"""The estimator's sums per held-out unit and per load group, for the choice of the sensor model.

The estimator (:mod:`fts_calib.model.estimator`) keeps, beside its own sums, one sum of
``z z^T`` per *unit* with ``z = [W; phi(u); b]``: W the known wrench (6,) in [N, N m], ``phi``
the features of the largest family asked for (:mod:`fts_calib.model.features`) and ``b`` the
full offset basis (:mod:`fts_calib.model.offset_basis`). A unit is what may be held out as a
whole: a tool configuration and an orientation cell (:mod:`fts_calib.pipeline.units`), an
integer key: the same key in two batches, or two estimators merged, is the same unit. Every
candidate of :mod:`fts_calib.model.model_choice` is a block of these sums.

Beside them, per tool configuration, the sums of the weight-only loads' features
(:class:`fts_calib.model.determination.LoadSums`): what the jig determines of each family.
"""

from __future__ import annotations

import numpy as np

from .determination import LoadSums
from .features import features, monomials
from .least_squares import gram


class UnitSums:
    """Per-unit sums of ``z z^T`` with ``z = [W; phi(u); b]`` (see the module docstring).

    Args:
        projection: P (6, n) of the layout (``u = P Delta``), or None for ``u = Delta``.
        n_channels: n.
        degree: The largest family's degree (1 to 3).
        basis_size: k, the columns of the offset basis.
    """

    def __init__(self, projection: np.ndarray | None, n_channels: int, degree: int, basis_size: int):
        self.projection = None if projection is None else np.asarray(projection, dtype=float)
        self.n_channels = int(n_channels)
        self.degree = int(degree)
        self.inputs = 6 if self.projection is not None else self.n_channels
        self.n_features = len(monomials(self.inputs, self.degree))
        self.basis_size = int(basis_size)
        self.width = 6 + self.n_features + self.basis_size
        self.sums: dict[int, np.ndarray] = {}
        self.weights: dict[int, float] = {}
        #: Per tool configuration, the sums of the weight-only loads' features: what the jig gave
        #: (:mod:`fts_calib.model.determination`).
        self.loads = LoadSums(self.degree)

    def add(
        self,
        W: np.ndarray,
        channels: np.ndarray,
        b: np.ndarray,
        unit: np.ndarray,
        weight: np.ndarray | None = None,
        w_static: np.ndarray | None = None,
        configuration: np.ndarray | None = None,
    ) -> None:
        """Add finite rows to their units' sums.

        Args:
            W: Known wrenches [N, N m], shape (N, 6).
            channels: Raw channels, shape (N, n).
            b: Offset basis rows, shape (N, k).
            unit: Held-out unit of each row, integers, shape (N,).
            weight: Frequency weights, shape (N,), or None (all 1).
            w_static: The weight-only part of each known wrench (paper eqs 17-18) [N, N m],
                shape (N, 6): the load the jig gave; ``W`` when None (quasi-static samples).
            configuration: Tool configuration index of each row, shape (N,); all 0 when None.
        """
        if not len(W):
            return
        Z = np.empty((len(W), self.width))
        Z[:, :6] = W
        u = channels if self.projection is None else channels @ self.projection.T
        features(u, self.degree, out=Z[:, 6 : 6 + self.n_features])
        Z[:, 6 + self.n_features :] = b
        unit = np.asarray(unit, dtype=np.int64)
        self.loads.add(W if w_static is None else w_static, np.zeros(len(W), dtype=np.int64) if configuration is None else configuration)
        order = np.argsort(unit, kind="stable")  # one product per unit of the batch
        unit, Z = unit[order], Z[order]
        weight = None if weight is None else np.asarray(weight)[order]
        starts = np.r_[0, np.flatnonzero(np.diff(unit)) + 1, len(unit)]
        for a, e in zip(starts[:-1], starts[1:], strict=True):
            rows = Z[a:e]
            g = int(unit[a])
            if g not in self.sums:
                self.sums[g], self.weights[g] = np.zeros((self.width, self.width)), 0.0
            self.sums[g] += gram(rows, None if weight is None else weight[a:e])
            self.weights[g] += float(e - a) if weight is None else float(weight[a:e].sum())

    def configurations(self, n_configurations: int) -> dict[int, int]:
        """Unit -> the tool configuration its samples belong to (the one-hot offset column they fill)."""
        first = 6 + self.n_features
        return {g: int(np.argmax(np.diag(s)[first : first + n_configurations])) for g, s in self.sums.items()}

    def merged(self, other: UnitSums, shift: np.ndarray) -> UnitSums:
        """A copy holding both, ``other``'s offset basis moved by ``shift`` (k, k).

        A unit is a key (a tool load and an orientation cell, :mod:`fts_calib.pipeline.units`):
        the same unit in both holds the samples of both, as one pass over both would.
        """
        out = UnitSums(self.projection, self.n_channels, self.degree, self.basis_size)
        H = np.eye(self.width)
        H[-self.basis_size :, -self.basis_size :] = shift
        out.sums = {g: s.copy() for g, s in self.sums.items()}
        out.weights = dict(self.weights)
        for g, s in other.sums.items():
            out.sums[g] = out.sums.get(g, 0.0) + H @ s @ H.T
            out.weights[g] = out.weights.get(g, 0.0) + other.weights[g]
        out.loads = self.loads.merged(other.loads)
        return out

    def total(self) -> np.ndarray:
        """The sum over units, shape (width, width)."""
        return sum(self.sums.values(), np.zeros((self.width, self.width)))

    def state(self) -> dict:
        """Plain data for checkpoints."""
        return {
            "degree": self.degree,
            "full_channels": self.projection is None,
            "units": {str(g): s.tolist() for g, s in self.sums.items()},
            "weights": {str(g): w for g, w in self.weights.items()},
            "loads": self.loads.state(),
        }

    def restore(self, state: dict) -> None:
        """Load :meth:`state` (of the same shape)."""
        self.sums = {int(g): np.asarray(s, dtype=float).reshape(self.width, self.width) for g, s in state["units"].items()}
        self.weights = {int(g): float(w) for g, w in state["weights"].items()}
        self.loads.restore(state.get("loads"))

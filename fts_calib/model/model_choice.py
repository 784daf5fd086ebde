r"""The estimator's sums per held-out unit and per load group, for the choice of the sensor model.

The estimator (:mod:`fts_calib.model.estimator`) keeps, beside its own sums, one sum of
``z z^T`` per *unit* with ``z = [W; phi(u); b]``: W the known wrench (6,) in [N, N m], ``phi``
the features of the largest family asked for (:mod:`fts_calib.model.features`) and ``b`` the
full offset basis (:mod:`fts_calib.model.offset_models`). A unit is what may be held out as a
whole: a tool configuration and an orientation cell (:mod:`fts_calib.session.held_out`), an
integer key: the same key in two batches, or two estimators merged, is the same unit. Every
candidate of :mod:`fts_calib.model.model_choice` is a block of these sums.

Beside them, per tool configuration, the sums of the weight-only loads' features
(:class:`fts_calib.model.determination.LoadSums`): what the jig determines of each family.

The choice of the sensor model and the offset model by held-out error (leave one unit out).

Every candidate (a family and an offset model) is a block of the estimator's per-unit sums
(:mod:`fts_calib.model.model_choice`), so leave-one-unit-out residuals are exact from the sums alone:

.. math::

    \Theta_{-g} = \text{solve}(S - S_g), \qquad
    \mathrm{RSS}_g = \mathrm{diag}(S_{WW,g} - 2\,\Theta_{-g} S_{XW,g} + \Theta_{-g} S_{XX,g} \Theta_{-g}^T)

A unit is a tool configuration and a cell of gravity's direction (:mod:`fts_calib.session.held_out`),
wherever its samples are in the run: a unit that revisits another's orientation is not held out,
and the held-out error would reward fitting what repeats (the filter's dynamic residue, a pose's
systematic error). The score of a candidate is its held-out mean square over units and axes, each
axis divided by the smallest held-out RMS any candidate reaches on it (the noise level the data
allow), so that forces and moments count alike and an axis brought down to its noise counts
whatever its share of full scale. Among the candidates whose score is within
:data:`EQUAL_WITHIN_SE` standard errors (of the per-unit differences to the best, over units) of
the best one's, the one of fewest parameters wins: an ideal sensor keeps the linear model and
constant offsets, while a model that is wrong (a nonlinearity, offsets that move) loses by far
more than its noise. BIC, which rewards any column that lowers the in-sample residual, chose
drift terms on a nonlinear sensor's data.

**Nonlinear families only where the loads determine them.** The loads of one configuration lie on
one gravity sphere; a quadratic or cubic model is free off the spheres the jig gave. A nonlinear
family is a candidate only when the loads determine it beyond their own, each configuration
predicted by the others (:mod:`fts_calib.model.determination`: on the paper's jig, one mass at
three centres of mass, never); asked for by name where they do not, it is ``refused`` (the
estimator raises :class:`~fts_calib.core.exceptions.ModelNotDetermined`). Chosen under ``auto``,
it must also beat the linear model leaving one whole configuration out, each with its own offset
(:meth:`Chooser.score_groups`), or the linear model is chosen: an error measured on a
configuration's own sphere says nothing of how a model extrapolates to another tool.

Directions of a candidate that the loads do not excite (quadratic forms of ``u`` that are
constant on the gravity sphere alias with the offsets; ``channels: full`` has n - 6 load-free
channel patterns) are held at minimum norm: the truncated eigen-decomposition of the normal
matrix scaled to a unit diagonal, eigenvalues below :data:`MODEL_RCOND` times the largest
dropped (:func:`fts_calib.model.least_squares.solve_normal`). Their number is reported.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from .determination import Determination, LoadSums, determine
from .features import AUTO_FAMILIES, FAMILIES, degree_of, features, monomials
from .least_squares import RCOND, gram, residual_sums, solve_normal
from .offset_models import Candidate, candidates


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

        A unit is a key (a tool load and an orientation cell, :mod:`fts_calib.session.held_out`):
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


#: Relative eigenvalue threshold of the minimum-norm rule for the directions of a nonlinear
#: family that no load excites: those at the data's round-off. Directions that strain noise
#: fills a little, or that the nonlinearity itself excites weakly (a few 1e-8 to 1e-6 of the
#: largest eigenvalue on the gravity sphere), are fitted: dropping them loses the part of the
#: model the held-out poses need, and a candidate that fits noise loses the held-out choice.
MODEL_RCOND = 1e-9
#: The rule, in words, for reports.
HOLD_RULE = (
    f"minimum norm: directions of the normal matrix (scaled to a unit diagonal) whose eigenvalue is below {MODEL_RCOND:g} "
    f"of the largest (nonlinear families; {RCOND:g} for the linear one) are set to zero"
)
#: Standard errors within which a simpler candidate counts as equal to the best. On a linear sensor
#: (static poses of five configurations, 100 seeds) the quadratic model's advantage over the linear
#: one reads -7 to +1.1 standard errors, while a 2 % FS quadratic nonlinearity reads +4.8 and more:
#: two leaves a margin both ways (one picked a quadratic model on 1 linear sensor in 20).
EQUAL_WITHIN_SE = 2.0
#: The rule of the choice, in words, for the calibration file.
CRITERION = (
    "leave one unit out (a tool configuration and a cell of gravity's direction in the sensor frame, wherever its samples "
    "are in the run); a nonlinear family only when the loads determine it beyond their own (each configuration predicted "
    "by the others) and it beats the linear model leaving one configuration out; among candidates within "
    f"{EQUAL_WITHIN_SE:g} standard errors of the best held-out error, the fewest parameters"
)


@dataclass(frozen=True)
class Score:
    """One candidate's held-out error.

    Attributes:
        family: One of :data:`fts_calib.model.features.FAMILIES`.
        offsets: The offset model (its columns in the basis).
        parameters: Coefficients per axis (features + offset columns).
        heldout_rms: Held-out RMS per axis, [N, N, N, N m, N m, N m]. Shape (6,).
        error: Held-out mean square, each axis over its scale squared, averaged over axes and units.
        per_unit: Each unit's normalised mean square, shape (G,).
        held: Directions held at minimum norm in the fit on all units.
        unit_ms: Each unit's held-out mean square per axis, [N², N² ..., N² m²]. Shape (G, 6).
    """

    family: str
    offsets: Candidate
    parameters: int
    heldout_rms: np.ndarray
    error: float
    per_unit: np.ndarray
    held: int
    unit_ms: np.ndarray | None = None


@dataclass(frozen=True)
class Selection:
    """The outcome of the choice: every candidate's score, the best and the one chosen.

    Attributes:
        scores: Every candidate's held-out error over the units.
        chosen: The candidate the calibration uses.
        best: The candidate of least held-out error.
        setting: ``(model setting, offset setting)``.
        units: Held-out units.
        scale: Per-axis scale of the errors [N, N m], shape (6,).
        determinations: Family -> what the loads determine of it (:mod:`fts_calib.model.determination`).
        groups: The load-group check of a nonlinear family against the linear one (leaving one
            configuration out, each with its own offset), or empty when none was made.
        refused: The determination of a nonlinear family the setting asks for and the loads do
            not determine (the estimator refuses to solve), or None.
    """

    scores: list[Score]
    chosen: Score
    best: Score
    setting: tuple[str, str]
    units: int
    scale: np.ndarray
    determinations: dict[str, Determination] = field(default_factory=dict)
    groups: list[Score] = field(default_factory=list)
    refused: Determination | None = None

    def as_dict(self, column_names: Sequence[str], configurations: Sequence[str] | None = None) -> dict:
        """The calibration file's ``model_selection``: the rule, the table of candidates and what the loads determine.

        Args:
            column_names: The offset basis's column names.
            configurations: The tool configurations' names (for the determination's words).
        """

        def label(score: Score) -> str:
            return _label(score, column_names)

        out = {
            "setting": {"model": self.setting[0], "offsets": self.setting[1]},
            "criterion": CRITERION,
            "units": self.units,
            "equal_within_standard_errors": EQUAL_WITHIN_SE,
            "scale": self.scale.tolist(),
            "chosen": label(self.chosen),
            "candidates": [
                {
                    "model": s.family,
                    "offsets": label(s).split(" + ", 1)[1],
                    "parameters_per_axis": s.parameters,
                    "heldout_rms": s.heldout_rms.tolist(),
                    "heldout_error": s.error,
                    "standard_error_vs_best": _paired_se(s, self.best)[1],
                    "held_directions": s.held,
                    "chosen": s is self.chosen,
                }
                for s in self.scores
            ],
            "held_directions": {"count": self.chosen.held, "rule": HOLD_RULE},
            "determination": {
                f: {**d.as_dict(), **({"lacks": d.lacks(configurations)} if not d.determined else {})}
                for f, d in self.determinations.items()
            },
        }
        if self.groups:
            out["load_groups"] = {
                "criterion": "leave one tool configuration out, each with its own offset",
                "groups": len(self.groups[0].per_unit),
                "candidates": [{"model": g.family, "heldout_rms": g.heldout_rms.tolist(), "heldout_error": g.error} for g in self.groups],
            }
        return out


def _label(score: Score, names: Sequence[str]) -> str:
    if score.offsets.model == "constant":
        return f"{score.family} + constant"
    if score.offsets.model == "per-configuration":
        return f"{score.family} + per-configuration"
    drift = [names[i] for i in score.offsets.columns if not names[i].startswith("offset")]
    return f"{score.family} + drift ({', '.join(drift)})"


class Chooser:
    """Scores the candidates of a setting from :class:`UnitSums` (see the module docstring).

    Args:
        sums: The per-unit sums.
        basis: The offset basis (for the candidates: :func:`fts_calib.model.offset_models.candidates`).
        setting: ``(model setting, offset setting)``.
        scale: Per-axis scale of the error [N, N m], shape (6,), or None (the RMS of W).
        rcond: The minimum-norm threshold of the nonlinear families (:data:`MODEL_RCOND`).
    """

    def __init__(self, sums: UnitSums, basis, setting: tuple[str, str], scale=None, rcond: float = MODEL_RCOND):
        self.sums = sums
        self.basis = basis
        self.setting = setting
        self.rcond = rcond
        self.total = sums.total()
        n_eff = sum(sums.weights.values())
        rms_w = np.sqrt(np.maximum(np.diag(self.total)[:6], 0.0) / max(n_eff, 1e-300))
        self.scale = np.asarray(scale, dtype=float) if scale is not None else np.maximum(rms_w, 1e-12 * max(float(rms_w.max()), 1e-300))
        self._determined: dict[tuple[str, bool], Determination] = {}

    def families(self) -> list[str]:
        """The families the model setting asks for, simplest first ('auto': :data:`AUTO_FAMILIES`)."""
        return list(AUTO_FAMILIES) if self.setting[0] == "auto" else [self.setting[0]]

    def determination(self, family: str, candidate: Candidate) -> Determination:
        """What the units' loads determine of ``family`` with the offset columns of ``candidate``."""
        per_configuration = candidate.model != "constant"
        key = (family, per_configuration)
        if key not in self._determined:
            self._determined[key] = determine(self.sums.loads.sums, family, per_configuration)
        return self._determined[key]

    def maps(self, family: str, candidate: Candidate) -> np.ndarray:
        """The rows selecting ``[W; u; A b; higher features]`` of a candidate from z.

        The offsets come right after the degree-1 features, as in the estimator's own
        regressor, so the least-squares helpers find the linear part first and the offsets after it.
        """
        d = len(monomials(self.sums.inputs, degree_of(family)))
        first = self.sums.inputs
        k_m = len(candidate.A)
        M = np.zeros((6 + d + k_m, self.sums.width))
        M[:6, :6] = np.eye(6)
        M[6 : 6 + first, 6 : 6 + first] = np.eye(first)
        M[6 + first : 6 + first + k_m, 6 + self.sums.n_features :] = candidate.A
        M[6 + first + k_m :, 6 + first : 6 + d] = np.eye(d - first)
        return M

    def fit(self, S: np.ndarray, family: str):
        """``(Theta (6, p), rank, condition, pseudo-inverse (p, p))`` of a candidate's sums, minimum norm."""
        return solve_normal(S[6:, 6:], S[:6, 6:], RCOND if family == "linear" else self.rcond, True)

    def score(self, family: str, candidate: Candidate) -> Score:
        """The held-out error of one candidate, leaving one unit out at a time.

        The directions held are those of the fit on every unit (one eigen-decomposition per
        candidate); each fold solves in the others, by one linear solve (LAPACK's eigenvector
        solver runs on every core and is 15x slower than a solve on a busy machine).
        """
        units = sorted(self.sums.sums)
        return self._held_out(family, candidate, [self.sums.sums[g] for g in units], [self.sums.weights[g] for g in units])

    def score_groups(self, family: str, candidate: Candidate) -> Score:
        """The held-out error of one candidate leaving one tool configuration (a load group) out at a time.

        The held-out configuration's own offset is refitted on its samples (one constant per
        axis), so every offset model is judged on how the model carries the *loads* of the others
        over to it.
        """
        codes = self.sums.configurations(self.basis.n_configurations)
        parts: dict[int, np.ndarray] = {}
        weights: dict[int, float] = {}
        for g, S in self.sums.sums.items():
            parts[codes[g]] = parts.get(codes[g], 0.0) + S
            weights[codes[g]] = weights.get(codes[g], 0.0) + self.sums.weights[g]
        keys = sorted(parts)
        own = [6 + self.sums.n_features + k for k in keys]  # the one-hot column of each configuration in z
        return self._held_out(family, candidate, [parts[k] for k in keys], [weights[k] for k in keys], own)

    def _held_out(self, family: str, candidate: Candidate, parts: list, counts: list[float], own: list[int] | None = None) -> Score:
        """The score of a candidate over folds that each leave one of ``parts`` (sums of z z^T) out.

        Args:
            family: The family.
            candidate: The offset model.
            parts: The sums of each fold's held-out samples, (width, width) each.
            counts: Their weights.
            own: Per part, the column of z that is 1 on its samples: its residual's mean is removed (its own offset); None: not.
        """
        M = self.maps(family, candidate)
        total = M @ self.total @ M.T
        scale, kept = self._range(total, family)
        rss = np.zeros((len(parts), 6))
        weights = np.array(counts, dtype=float)
        for i, raw in enumerate(parts):
            mine = M @ raw @ M.T
            theta = self._fold(total - mine, scale, kept)
            rss[i] = residual_sums(mine[:6, :6], mine[:6, 6:], mine[6:, 6:], theta)
            if own is not None and weights[i] > 0:  # sum of the residuals, over the held-out part's samples
                column = (M @ raw)[:, own[i]]
                residual_sum = column[:6] - theta @ column[6:]
                rss[i] = np.maximum(rss[i] - residual_sum**2 / weights[i], 0.0)
        p = M.shape[0] - 6
        per_unit = (rss / self.scale**2).sum(axis=1) / np.maximum(weights, 1e-300) / 6.0
        n = max(float(weights.sum()), 1e-300)
        heldout = np.sqrt(rss.sum(axis=0) / n)
        unit_ms = rss / np.maximum(weights, 1e-300)[:, None]
        return Score(family, candidate, p, heldout, float(per_unit.mean()), per_unit, p - kept.shape[1], unit_ms)

    def _range(self, S: np.ndarray, family: str) -> tuple[np.ndarray, np.ndarray]:
        """(diagonal scaling (p,), orthonormal basis (p, r) of the directions kept) of a candidate's normal matrix."""
        X = S[6:, 6:]
        d = np.diag(X)
        scale = np.where(d > 0, 1.0 / np.sqrt(np.where(d > 0, d, 1.0)), 0.0)
        eig, vec = np.linalg.eigh(X * scale[:, None] * scale[None, :])
        top = eig[-1] if eig.size and eig[-1] > 0 else 0.0
        return scale, vec[:, eig > (RCOND if family == "linear" else self.rcond) * top] if top > 0 else vec[:, :0]

    @staticmethod
    def _fold(S: np.ndarray, scale: np.ndarray, kept: np.ndarray) -> np.ndarray:
        """Theta (6, p) of a fold's sums, in the kept directions (minimum norm in the scaled coordinates)."""
        A = kept.T @ (S[6:, 6:] * scale[:, None] * scale[None, :]) @ kept
        B = (S[:6, 6:] * scale[None, :]) @ kept
        try:
            y = np.linalg.solve(A, B.T)
        except np.linalg.LinAlgError:  # the fold lost a direction the other units held: least squares
            y = np.linalg.lstsq(A, B.T, rcond=None)[0]
        return (kept @ y).T * scale[None, :]

    def select(self) -> Selection:
        """Score every candidate and choose (see the module docstring).

        A nonlinear family is a candidate only with the offset models whose columns leave it
        determined by the loads (:meth:`determination`); one the setting asks for by name and
        the loads do not determine is ``refused`` (the linear candidates are scored instead, for
        the diagnosis). A nonlinear family chosen under ``auto`` must also beat the linear model
        leaving one configuration out (:meth:`score_groups`) by :data:`EQUAL_WITHIN_SE` standard
        errors, or the linear model is chosen.
        """
        options = candidates(self.basis, np.diag(self.total)[6 + self.sums.n_features :] > 0, self.setting[1])
        asked = self.families()
        pairs = [(f, c) for f in asked for c in options if f == FAMILIES[0] or self.determination(f, c).determined]
        refused = None
        if self.setting[0] in FAMILIES[1:] and not pairs:
            refused = self.determination(self.setting[0], options[0])
            pairs = [(FAMILIES[0], c) for c in options]
        determinations = {f: self.determination(f, options[0]) for f in asked if f != FAMILIES[0]}
        scores = _per_noise([self.score(f, c) for f, c in pairs])
        chosen, best = _choose(scores)
        groups: list[Score] = []
        if chosen.family != FAMILIES[0]:
            groups = _per_noise([self.score_groups(FAMILIES[0], chosen.offsets), self.score_groups(chosen.family, chosen.offsets)])
            excess, se = _paired_se(groups[0], groups[1])
            if self.setting[0] == "auto" and not excess > EQUAL_WITHIN_SE * se:  # not clearly better on another load
                chosen = _choose([s for s in scores if s.family == FAMILIES[0]])[0]
        return Selection(scores, chosen, best, self.setting, len(self.sums.sums), self.scale, determinations, groups, refused)


def _choose(scores: list[Score]) -> tuple[Score, Score]:
    """(chosen, best): among the candidates within :data:`EQUAL_WITHIN_SE` standard errors of the best, the fewest parameters."""
    finite = [s for s in scores if math.isfinite(s.error)] or scores
    best = min(finite, key=lambda s: s.error)
    equal = [s for s in finite if s is best or _paired_se(s, best)[0] <= EQUAL_WITHIN_SE * _paired_se(s, best)[1]]
    return min(equal, key=lambda s: (s.parameters, s.error)), best


def _per_noise(scores: list[Score]) -> list[Score]:
    """The scores with each axis over the smallest held-out RMS any candidate reaches on it.

    That RMS is the noise level the data allow on the axis: an axis whose error a candidate
    brings down to it counts as much as any other, whatever its unit or full scale (on a
    low-cost sensor the forces' noise is 0.6 % of their full scale and the moments' 0.09 %:
    scaled by the full scale, a nonlinearity seen on the moments alone was lost in the forces'
    noise).
    """
    if any(s.unit_ms is None for s in scores):
        return scores
    reached = [s.heldout_rms for s in scores if np.all(np.isfinite(s.heldout_rms))]
    if not reached:
        return scores
    noise = np.min(reached, axis=0)
    noise = np.maximum(noise, 1e-12 * max(float(noise.max()), 1e-300))
    rescored = []
    for s in scores:
        per_unit = (s.unit_ms / noise**2).mean(axis=1)
        rescored.append(replace(s, per_unit=per_unit, error=float(per_unit.mean())))
    return rescored


def _paired_se(score: Score, best: Score) -> tuple[float, float]:
    """(mean excess error over the best, its standard error over units), per-unit differences."""
    diff = score.per_unit - best.per_unit
    G = len(diff)
    if G < 2:
        return float(diff.mean()) if G else 0.0, math.inf
    return float(diff.mean()), float(diff.std(ddof=1) / math.sqrt(G))

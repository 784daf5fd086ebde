r"""What the loads of a calibration determine: which sensor model families a jig of weights can fix.

A calibration sees the known wrench of a weight, ``W = m [g; c x g]`` (paper eqs 17-18), for
each tool configuration (a *load group*: a mass m at a centre of mass c) over the orientations
the motion gives: the loads of one group lie on one gravity sphere. A model is determined
*beyond its own loads* when its features, evaluated on the loads, are fixed by the data, and
still fixed with any one load group left out, so that every group is predicted by the others
and a held-out error can tell whether the model extrapolates:

.. math::

    r = \operatorname{rank}[\varphi(W); B] - \operatorname{rank} B, \qquad
    r \ge r_{\max} \quad\text{and}\quad r_{-k} = r \ \ \forall k

with ``phi`` the family's features of the wrench (:mod:`fts_calib.model.features`; a polynomial
of ``u = P Delta`` is one of W), ``B`` the offset columns (one constant, or one per
configuration), and ``r_max`` the most any jig of weights reaches. No weight excites everything:
every weight's load has ``F . M = 0`` (paper eq 20), so a quadratic model has one direction
(``F . M``) and a cubic one seven (``F . M`` times 1, F and M) that no jig can fix; with one offset
per configuration, ``|F|^2 = (m g)^2`` is constant in each group and joins its offset (a new tool
then needs a tare anyway). Those do not count against a jig. (In the features of ``u`` the sensor's
own bend and its noise fill them weakly, and the fit keeps what they give, as the held-out poses
need; a load with ``F . M`` far from 0, a push or a contact, is outside every weight's region.)
Loads beyond any jig of weights (a rig that pushes and twists: ``r > r_max``) determine a model
on their own.

Measured on generic centres of mass and orientations (:func:`minimal_jig`): the linear model
needs three centres of mass not on one line (the paper); a quadratic one two masses, each at five
centres of mass not in one plane (26 of 26 directions); a cubic one two masses at eight (76 of 76).
The paper's jig (one mass at three centres of mass) fixes at most 20 of the quadratic model's 26
directions and 41 of the cubic's 76: a quadratic or cubic model fitted there is free off the three
gravity spheres.

The loads are the weight-only (static) wrenches: a dynamic filter's inertial wrenches do not count
as loads a jig gave. The rank is read from the sums of ``phi(W) phi(W)^T`` of each group
(:class:`LoadSums`), scaled to a unit diagonal. Units: W in [N, N m].
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from .features import FAMILIES, degree_of, features, monomials

#: Eigenvalues of the scaled sums of the load features (unit diagonal) below this fraction of the
#: largest are directions the loads do not excite. Those no weight can excite read 1e-17 to 1e-15;
#: the weakest excited ones of a jig of two masses (2.0 and 2.1 kg) 1e-4.
EIG_RTOL = 1e-11
#: Relative difference of two force magnitudes (or centres of mass) below which they are one mass (one centre).
SAME_LOAD = 1e-6


class LoadSums:
    """Per load group, the sum of ``phi phi^T`` with ``phi = [1; features(W)]`` of the weight-only loads W.

    Args:
        degree: The largest family's degree (1 to 3).
    """

    def __init__(self, degree: int):
        self.degree = int(degree)
        self.width = 1 + len(monomials(6, self.degree))
        self.sums: dict[int, np.ndarray] = {}

    def add(self, W: np.ndarray, groups: np.ndarray) -> None:
        """Add loads [N, N m] (N, 6) of groups (N,) (configuration indices)."""
        W = np.asarray(W, dtype=float).reshape(-1, 6)
        groups = np.asarray(groups, dtype=np.int64).reshape(-1)
        phi = np.empty((len(W), self.width))
        phi[:, 0] = 1.0
        features(W, self.degree, out=phi[:, 1:])
        for k in np.unique(groups):
            mine = phi[groups == k]
            self.sums[int(k)] = self.sums.get(int(k), 0.0) + mine.T @ mine

    def merged(self, other: LoadSums) -> LoadSums:
        """A copy holding both."""
        out = LoadSums(self.degree)
        out.sums = {k: s.copy() for k, s in self.sums.items()}
        for k, s in other.sums.items():
            out.sums[k] = out.sums.get(k, 0.0) + s
        return out

    def state(self) -> dict:
        """Plain data for checkpoints."""
        return {str(k): s.tolist() for k, s in self.sums.items()}

    def restore(self, state: Mapping | None) -> None:
        """Load :meth:`state` (None: nothing saved, a checkpoint of an older version)."""
        self.sums = {int(k): np.asarray(s, dtype=float).reshape(self.width, self.width) for k, s in (state or {}).items()}


@dataclass(frozen=True)
class Determination:
    """What the loads determine of one model family (see the module docstring).

    Attributes:
        family: 'linear', 'quadratic' or 'cubic'.
        per_configuration: One offset per configuration (else one for all).
        rank: Feature directions the loads excite, beyond the offset columns.
        achievable: The most a jig of weights excites (:func:`achievable_rank`).
        held_out: Load group (configuration index) -> the rank with it left out.
        masses: Distinct masses among the load groups.
        centres: Distinct centres of mass among the load groups.
    """

    family: str
    per_configuration: bool
    rank: int
    achievable: int
    held_out: dict[int, int] = field(default_factory=dict)
    masses: int = 0
    centres: int = 0

    @property
    def requirement(self) -> tuple[int, int]:
        """The smallest grid (masses, centres of mass per mass) that determines the family (:func:`minimal_jig`)."""
        return minimal_jig(self.family, self.per_configuration)

    @property
    def fixed(self) -> bool:
        """The loads excite every direction a jig of weights can."""
        return self.rank >= self.achievable

    @property
    def determined(self) -> bool:
        """Fixed, and still fixed with any one load group left out (each group predicted by the others).

        Loads beyond any jig of weights (more directions than :attr:`achievable`) determine the
        model on their own, one group or many.
        """
        if self.rank > self.achievable:
            return True
        return self.fixed and len(self.held_out) >= 2 and all(r >= self.rank for r in self.held_out.values())

    def lacks(self, names: Sequence[str] | None = None) -> str:
        """What the jig lacks for this family, in words (empty when determined).

        Args:
            names: Configuration names, by index (indices when None).
        """
        if self.determined:
            return ""
        m, c = self.requirement
        need = (
            f"a {self.family} model needs loads of at least {_count(m, 'mass', 'masses')}, each at {c} centres of mass not all in one plane"
        )
        jig = f"{_count(self.masses, 'mass', 'masses')} at {_count(self.centres, 'centre', 'centres')} of mass"
        if not self.fixed:
            return f"{need}; these loads ({jig}) fix {self.rank} of its {self.achievable} directions that weights can fix"
        names = list(names) if names is not None else []
        weak = [k for k, r in sorted(self.held_out.items()) if r < self.rank]
        groups = ", ".join(names[k] if k < len(names) else str(k) for k in weak) or "any one"
        return f"{need}; these loads ({jig}) fix it only with every configuration in: without {groups} it is free (no held-out check)"

    def as_dict(self) -> dict:
        """Plain data for the calibration file."""
        return {
            "rank": self.rank,
            "achievable": self.achievable,
            "determined": self.determined,
            "masses": self.masses,
            "centres_of_mass": self.centres,
            "needs": {"masses": self.requirement[0], "centres_of_mass": self.requirement[1]},
        }


def _count(n: int, one: str, many: str) -> str:
    return f"{n} {one if n == 1 else many}"


def _rank(G: np.ndarray) -> int:
    """Numerical rank of a sum of squares (p, p), scaled to a unit diagonal (:data:`EIG_RTOL`)."""
    d = np.diag(G)
    keep = d > 0
    if not keep.any():
        return 0
    s = 1.0 / np.sqrt(d[keep])
    eig = np.linalg.eigvalsh(G[np.ix_(keep, keep)] * s[:, None] * s[None, :])
    return int(np.count_nonzero(eig > EIG_RTOL * eig[-1]))


def _extended(sums: Mapping[int, np.ndarray], degree: int, per_configuration: bool) -> np.ndarray:
    """The sums of ``[phi(W); B] [phi(W); B]^T``: features of ``degree`` (no constant), then the offset columns.

    ``B`` is one constant column, or one column per group (in the order of the sorted groups) that is 1 on its samples.
    """
    p = 1 + len(monomials(6, degree))
    keys = sorted(sums)
    total = sum((sums[k][:p, :p] for k in keys), np.zeros((p, p)))
    if not per_configuration:  # the constant column is the features' first: move it last
        order = np.r_[1:p, 0]
        return total[np.ix_(order, order)]
    K = len(keys)
    G = np.zeros((p - 1 + K, p - 1 + K))
    G[: p - 1, : p - 1] = total[1:, 1:]
    for j, k in enumerate(keys):  # one offset column per group: 1 on its samples
        G[: p - 1, p - 1 + j] = G[p - 1 + j, : p - 1] = sums[k][1:p, 0]
        G[p - 1 + j, p - 1 + j] = sums[k][0, 0]
    return G


def _feature_rank(sums: Mapping[int, np.ndarray], degree: int, per_configuration: bool) -> int:
    """Directions of the features of ``degree`` excited beyond the offset columns, from per-group sums (:class:`LoadSums`)."""
    if not sums:
        return 0
    return _rank(_extended(sums, degree, per_configuration)) - (len(sums) if per_configuration else 1)


def determine(sums: Mapping[int, np.ndarray], family: str, per_configuration: bool) -> Determination:
    """What the loads of ``sums`` (:attr:`LoadSums.sums`) determine of ``family`` (see the module docstring).

    Args:
        sums: Per group (configuration index), the sum of ``phi phi^T`` of its weight-only loads, of degree at least the family's.
        family: 'linear', 'quadratic' or 'cubic'.
        per_configuration: One offset per configuration (else one for all).
    """
    degree = degree_of(family)
    rank = _feature_rank(sums, degree, per_configuration)
    held = {}
    if len(sums) > 1:
        for k in sums:
            held[k] = _feature_rank({j: S for j, S in sums.items() if j != k}, degree, per_configuration)
    masses, centres = _distinct_loads(sums)
    return Determination(family, per_configuration, rank, achievable_rank(family, per_configuration), held, masses, centres)


def _distinct_loads(sums: Mapping[int, np.ndarray]) -> tuple[int, int]:
    """(distinct masses, distinct centres of mass) among the groups, from their first and second moments.

    The force magnitude of a weight is ``m |g|`` on every sample; its centre of mass solves
    ``M = c x F`` in least squares: ``(tr S_FF I - S_FF) c = sum F x M``.
    """
    weights, centres = [], []
    for S in sums.values():
        n = max(S[0, 0], 1e-300)
        S_FF, S_FM = S[1:4, 1:4], S[1:4, 4:7]
        weights.append(np.sqrt(max(np.trace(S_FF), 0.0) / n))
        rhs = np.array([S_FM[1, 2] - S_FM[2, 1], S_FM[2, 0] - S_FM[0, 2], S_FM[0, 1] - S_FM[1, 0]])
        centres.append(np.linalg.lstsq(np.trace(S_FF) * np.eye(3) - S_FF, rhs, rcond=None)[0])
    return _distinct(np.array(weights)[:, None]), _distinct(np.array(centres))


def _distinct(values: np.ndarray) -> int:
    out: list[np.ndarray] = []
    size = max(float(np.abs(values).max()) if values.size else 0.0, 1e-300)
    for v in values:
        if all(np.abs(v - o).max() > SAME_LOAD * size for o in out):
            out.append(v)
    return len(out)


def jig_sums(
    masses: Sequence[float], coms: np.ndarray, directions: np.ndarray, degree: int, gravity: float = 9.81
) -> dict[int, np.ndarray]:
    """The :class:`LoadSums` of a grid of masses [kg] x centres of mass [m] (n, 3) over gravity directions (unit, (d, 3)).

    Groups are numbered mass by mass, centre by centre.
    """
    loads = LoadSums(degree)
    for i, m in enumerate(masses):
        for j, c in enumerate(np.asarray(coms, dtype=float)):
            F = m * gravity * np.asarray(directions, dtype=float)
            loads.add(np.hstack([F, np.cross(c, F)]), np.full(len(F), i * len(coms) + j))
    return loads.sums


def _generic(n_coms: int, n_directions: int = 40) -> tuple[np.ndarray, np.ndarray]:
    """Generic centres of mass [m] (n, 3) around the tool axis and gravity directions (unit, (d, 3)), fixed seed."""
    rng = np.random.default_rng(20261207)
    coms = np.array([0.1, 0.0, 0.0]) + 0.06 * rng.normal(size=(n_coms, 3))
    directions = rng.normal(size=(n_directions, 3))
    return coms, directions / np.linalg.norm(directions, axis=1, keepdims=True)


@lru_cache(maxsize=8)
def achievable_rank(family: str, per_configuration: bool) -> int:
    """The most feature directions a jig of weights excites (three masses at twelve generic centres of mass)."""
    coms, directions = _generic(12)
    return _feature_rank(jig_sums((1.0, 1.7, 2.3), coms, directions, degree_of(family)), degree_of(family), per_configuration)


@lru_cache(maxsize=8)
def minimal_jig(family: str, per_configuration: bool) -> tuple[int, int]:
    """The smallest grid (masses, centres of mass per mass) of generic loads that determines ``family``.

    The linear model: (1, 3), the paper's jig. Searched over 1 to 3 masses and 3 to 12 centres.
    """
    if family == FAMILIES[0]:
        return (1, 3)
    for n in range(3, 13):
        for m in (1, 2, 3):
            coms, directions = _generic(n)
            sums = jig_sums(list(np.linspace(1.0, 2.0, m)) if m > 1 else [2.0], coms, directions, degree_of(family))
            if determine(sums, family, per_configuration).determined:
                return (m, n)
    return (3, 12)

r"""Sensor model families: the wrench as a polynomial of the laid-out channels, and its one evaluator.

The paper's model is linear in the projected channels, ``W = C_bar u + D`` with ``u = P Delta``
(:mod:`fts_calib.model.channels`). A real low-cost sensor is not: its bridges and amplifiers
bend by a few % of the range. A *family* names the features the wrench is linear in:

.. math::

    W = \Theta\,\varphi(u) + D, \qquad
    \varphi(u) = [u_i;\ u_i u_j\ (i \le j);\ u_i u_j u_k\ (i \le j \le k)]

- ``linear``: ``phi = u`` (d features, d = 6: today's ``C_bar``);
- ``quadratic``: plus the d(d+1)/2 products (6 + 21 = 27);
- ``cubic``: plus the d(d+1)(d+2)/6 triple products (6 + 21 + 56 = 83).

The features are ordered by degree, so each family's are the first columns of the next
one's: the estimator accumulates the largest family once and every smaller one is a block of
its sums. ``u`` is the layout's ``P Delta`` (d = 6), or the raw channels themselves
(``channels: full``, d = n: a free 6 x n C, and products of the n channels).

Units: ``u`` in raw channel units; ``Theta`` in [N or N m] per unit of each feature.
:class:`SensorModel` holds a family and its coefficients, and :meth:`SensorModel.wrench` is the
evaluator every reader of a calibration uses (Python, the C header's polynomial).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import numpy as np

from ..core.arrays import as_samples, frozen
from ..core.exceptions import ConfigError

#: The model families, simplest first (their degree is the index + 1).
FAMILIES = ("linear", "quadratic", "cubic")
#: The value of the model setting that chooses the family from the data.
AUTO_MODEL = "auto"
#: Every value of the model setting (``--model``).
MODEL_SETTINGS = (AUTO_MODEL, *FAMILIES)


def model_setting(value: str) -> str:
    """Check a model setting ('auto', 'linear', 'quadratic' or 'cubic').

    Raises:
        ConfigError: Another value; the message lists the accepted ones.
    """
    if value not in MODEL_SETTINGS:
        raise ConfigError("model", value, " or ".join(repr(s) for s in MODEL_SETTINGS))
    return value


#: The families ``auto`` chooses from. Not the cubic one: 84 coefficients per axis fit the
#: dynamic residue of a sweep as a function of where it is (a simulated ideal sensor on a UR5
#: sweep read 27 % less held-out error on Fy and Fz with it), at three times the cost per
#: sample; ``--model cubic`` asks for it.
AUTO_FAMILIES = ("linear", "quadratic")


def degree_of(family: str) -> int:
    """The highest degree of a family's monomials: 1, 2 or 3 (``auto``: that of :data:`AUTO_FAMILIES`)."""
    return FAMILIES.index(model_setting(family)) + 1 if family != AUTO_MODEL else len(AUTO_FAMILIES)


@lru_cache(maxsize=32)
def monomials(d: int, degree: int) -> tuple[tuple[int, ...], ...]:
    """The index tuples of the monomials of ``u`` (d,) up to ``degree``, ordered by degree then lexically.

    Example: ``monomials(2, 2) == ((0,), (1,), (0, 0), (0, 1), (1, 1))``.
    """
    return tuple(m for k in range(1, degree + 1) for m in itertools.combinations_with_replacement(range(d), k))


def n_features(d: int, family: str) -> int:
    """Number of features of a family over d inputs (6, 27 or 83 for d = 6)."""
    return len(monomials(d, degree_of(family)))


def feature_names(d: int, degree: int, symbol: str = "u") -> list[str]:
    """Names of the features, e.g. ``['u1', ..., 'u1*u1', 'u1*u2', ...]`` (1-based)."""
    return ["*".join(f"{symbol}{i + 1}" for i in m) for m in monomials(d, degree)]


@lru_cache(maxsize=32)
def _plan(d: int, degree: int) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
    """Per degree above 1, (index of the lower-degree feature, index of u) whose product is each feature."""
    terms = monomials(d, degree)
    where = {m: i for i, m in enumerate(terms)}
    out = []
    for k in range(2, degree + 1):
        mine = [m for m in terms if len(m) == k]
        out.append((np.array([where[m[:-1]] for m in mine]), np.array([m[-1] for m in mine])))
    return tuple(out)


def features(u, degree: int, out: np.ndarray | None = None) -> np.ndarray:
    """The monomials of ``u`` up to ``degree`` (:func:`monomials` order), vectorised.

    Each degree's columns are products of the previous degree's and one entry of u: one
    multiplication per feature and sample, no power function.

    Args:
        u: Inputs, shape (N, d).
        degree: 1, 2 or 3.
        out: Optional output buffer, shape (N, p).

    Returns:
        Shape (N, p), p = len(monomials(d, degree)).
    """
    u = np.asarray(u, dtype=float)
    n, d = u.shape
    p = len(monomials(d, degree))
    rows = np.empty((p, n))  # one feature per row: the products run on contiguous memory (twice as fast)
    rows[:d] = u.T
    offset = d
    for first, last in _plan(d, degree):
        np.multiply(rows[first], rows[last], out=rows[offset : offset + len(first)])
        offset += len(first)
    if out is None:
        return np.ascontiguousarray(rows.T)
    out[:] = rows.T
    return out


@dataclass(frozen=True, eq=False)
class SensorModel:
    """A sensor model: the family, its inputs and its coefficients (see the module docstring).

    Attributes:
        family: One of :data:`FAMILIES`.
        coefficients: Theta, shape (6, p), [N or N m] per unit of each feature (no offset:
            the calibration's D is added after).
        projection: P (6, n) of the layout whose ``P Delta`` are the inputs, or None when
            the inputs are the n raw channels (``channels: full``).
        n_channels: n, the raw channels the model reads.
        names: The feature names (derived).
    """

    family: str
    coefficients: np.ndarray
    projection: np.ndarray | None
    n_channels: int
    names: tuple[str, ...] = field(init=False, repr=False)

    def __post_init__(self):
        if self.family not in FAMILIES:
            raise ConfigError("family", self.family, " or ".join(repr(s) for s in FAMILIES))
        n = int(self.n_channels)
        object.__setattr__(self, "n_channels", n)
        if self.projection is not None:
            P = np.asarray(self.projection, dtype=float)
            if P.ndim != 2 or P.shape != (6, n):
                raise ConfigError("projection", P.shape, f"(6, {n})")
            object.__setattr__(self, "projection", frozen(P))
        p = len(monomials(self.inputs, self.degree))
        theta = np.asarray(self.coefficients, dtype=float)
        if theta.shape != (6, p):
            raise ConfigError("coefficients", theta.shape, f"(6, {p}): one row per axis, one column per {self.family} feature")
        if not np.all(np.isfinite(theta)):
            raise ConfigError("coefficients", "a NaN or inf entry", "finite numbers")
        object.__setattr__(self, "coefficients", frozen(theta))
        symbol = "u" if self.projection is not None else "s"
        object.__setattr__(self, "names", tuple(feature_names(self.inputs, self.degree, symbol)))

    @property
    def degree(self) -> int:
        """The highest degree of the monomials: 1, 2 or 3."""
        return degree_of(self.family)

    @property
    def inputs(self) -> int:
        """d, the number of inputs u: 6 with a projection, n without."""
        return 6 if self.projection is not None else self.n_channels

    @property
    def full(self) -> bool:
        """Whether the inputs are the raw channels (``channels: full``)."""
        return self.projection is None

    def slope(self, u) -> np.ndarray:
        """The model linearised at the inputs ``u`` (d,): ``Theta d phi / d u``, shape (6, d), [N or N m per unit of u]."""
        u = np.asarray(u, dtype=float).reshape(self.inputs)
        jacobian = np.zeros((len(self.names), self.inputs))
        for f, term in enumerate(monomials(self.inputs, self.degree)):
            for a in set(term):
                rest = list(term)
                rest.remove(a)
                jacobian[f, a] = term.count(a) * float(np.prod(u[rest]))
        return self.coefficients @ jacobian

    def inputs_of(self, channels) -> np.ndarray:
        """The model's inputs u of raw channels (N, n): ``P Delta`` or the channels; shape (N, d)."""
        batch, _ = as_samples(channels, self.n_channels, "channels")
        return batch if self.projection is None else batch @ self.projection.T

    def wrench(self, channels) -> np.ndarray:
        """``Theta phi(u)`` of raw channels (without the offsets D).

        Args:
            channels: Raw channel readings. Shape (n,) or (N, n).

        Returns:
            ``[Fx, Fy, Fz, Mx, My, Mz]`` in [N] and [N m] less D. Shape (6,) or (N, 6).
        """
        batch, single = as_samples(channels, self.n_channels, "channels")
        u = batch if self.projection is None else batch @ self.projection.T
        out = features(u, self.degree) @ self.coefficients.T
        return out[0] if single else out

    def to_config(self) -> dict[str, Any]:
        """Plain data for the calibration file: family, inputs, feature names, coefficients."""
        return {
            "family": self.family,
            "inputs": "P @ channels (the layout's u)" if self.projection is not None else "channels (full: no projection)",
            "full_channels": self.full,
            "n_channels": self.n_channels,
            "features": list(self.names),
            "coefficients": self.coefficients.tolist(),
        }

    @classmethod
    def from_config(cls, raw: Mapping, projection) -> SensorModel:
        """Inverse of :meth:`to_config`; ``projection`` is the calibration layout's P (6, n).

        Raises:
            ConfigError: A field is missing or malformed (the loader names the file).
        """
        missing = [key for key in ("family", "coefficients") if key not in raw]
        if missing:
            raise ConfigError(missing[0], None, "a value", reason="is missing")
        full = bool(raw.get("full_channels", False))
        try:
            n = int(raw["n_channels"]) if "n_channels" in raw else np.shape(projection)[1]
            coefficients = np.asarray(raw["coefficients"], dtype=float)
        except (TypeError, ValueError) as exc:
            raise ConfigError("coefficients", "a malformed matrix", "", reason=f"is not a 6 x p matrix of numbers ({exc})") from None
        return cls(str(raw["family"]), coefficients, None if full else projection, n)

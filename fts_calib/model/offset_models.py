r"""Offsets that move: the offset basis of the estimator, its nested models and their choice.

The paper's model has constant offsets (eq 3). Real ones drift with time and temperature
and jump when the tool is reconfigured, so the estimator regresses the wrench on
``z = [P Delta; b]`` where ``b`` (shape (k,)) is the *offset basis* of one sample:

.. math::

    W = \bar C\,P\Delta + \Theta_b\,b, \qquad
    b = [e_c;\ \tau, \tau^2, \dots, \tau^d;\ \theta], \qquad
    \tau = (t - t_0) / s, \quad \theta = T - T_0

with ``e_c`` the one-hot vector of the sample's tool configuration (K columns), ``t`` the
sample time in [s], ``s`` the time scale ``time_scale_s`` [s], ``T`` the sensor temperature
in [°C] (0 when the feed has none) and ``t_0``, ``T_0`` those of the first sample (fixed
online: no look-ahead). ``Theta_b`` (6, k) holds the offset terms in [N, N m] per unit.

The offset models are nested linear maps ``A`` (k_m, k) of this one basis, so the
estimator accumulates the largest sums once and every model's sums are ``A S A^T``:

- ``constant`` (the paper): ``A = [1 ... 1, 0 ... 0]``, one column (the configurations'
  one-hot columns sum to 1 on every sample);
- ``per-configuration``: one offset per configuration seen (K columns);
- ``drift``: per-configuration plus the time polynomial up to degree ``d`` and, when the
  data carry a varying temperature, the temperature term.

``auto`` picks, among the models whose normal matrix has full rank, the one of least
Bayesian information criterion (BIC, over the six axes, Gaussian residuals):

.. math::

    \mathrm{BIC}_m = n \sum_{j=1}^{6} \ln(\mathrm{RSS}_{m,j} / n) + 6\,(6 + k_m) \ln n

BIC rather than AIC or an F-test at a fixed level: its penalty grows with ``ln n``, so on
data with constant offsets the chance of choosing a larger model falls as the run grows
(one spurious column needs a chi-square with 6 degrees of freedom above ``6 ln n``, about
48 at n = 3,000: probability below 1e-8), while a drift of a few noise standard deviations
over the run is picked up at once. The candidates are the constant and per-configuration
models and the drift model at each degree 1 to ``d``, with and without temperature.

The offset trajectory's sample points: time, configuration and temperature of a few samples of a run.

The estimator keeps only sums; to report the offset D over time (the calibration file's
``offset_model.trajectory``) it also keeps, in bounded memory, the time [s], configuration
index and temperature [°C] of at most :data:`TRACE_POINTS` samples: one at least every
``spacing_s`` seconds and one at each change of configuration, the spacing doubling (and
every other point dropped) whenever the list is full; and always the last sample, the one
the calibration's D belongs to.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..core import arrays as validation
from ..core.exceptions import ConfigError
from .least_squares import excitation_rank, residual_sums, solve_normal

#: The offset models, simplest first.
OFFSET_MODELS = ("constant", "per-configuration", "drift")
#: The value of the offset setting that chooses the model from the data.
AUTO = "auto"
#: Every value of the offset setting (``--offsets``).
OFFSET_SETTINGS = (AUTO, *OFFSET_MODELS)
#: Relative floor of a residual sum of squares in the criterion: noiseless data (RSS at
#: round-off) fit every model alike, and then the penalty picks the simplest.
RSS_FLOOR = 1e-18


def offset_setting(value: str) -> str:
    """Check an offset setting ('auto', 'constant', 'per-configuration' or 'drift').

    Raises:
        ConfigError: Another value; the message lists the accepted ones.
    """
    if value not in OFFSET_SETTINGS:
        raise ConfigError("offsets", value, " or ".join(repr(s) for s in OFFSET_SETTINGS))
    return value


@dataclass(frozen=True)
class OffsetBasis:
    """The full offset basis ``b = [e_c; tau .. tau^d; theta]`` (see the module docstring).

    Attributes:
        n_configurations: K, the number of tool configurations (one offset column each).
        drift_degree: d, the highest power of the time term (0: no time term).
        time_scale_s: s, the unit of ``tau`` in [s] (conditioning only: any value gives the
            same fit).
        temperature: Whether the basis has the temperature column.
    """

    n_configurations: int = 1
    drift_degree: int = 2
    time_scale_s: float = 600.0
    temperature: bool = True

    def __post_init__(self):
        for name, low in (("n_configurations", 1), ("drift_degree", 0)):
            value = validation.number(name, getattr(self, name))
            if not (value.is_integer() and value >= low):
                raise ConfigError(name, getattr(self, name), f"an integer >= {low}")
            object.__setattr__(self, name, int(value))
        object.__setattr__(self, "time_scale_s", validation.positive("time_scale_s", self.time_scale_s, "s"))
        object.__setattr__(self, "temperature", bool(self.temperature))

    @property
    def size(self) -> int:
        """k, the number of columns of the basis."""
        return self.n_configurations + self.drift_degree + int(self.temperature)

    @property
    def n_drift(self) -> int:
        """Columns after the configurations' ones (time powers, then temperature)."""
        return self.drift_degree + int(self.temperature)

    def column_names(self, configurations: Sequence[str] | None = None) -> list[str]:
        """Names of the k columns, e.g. ``['offset A', 'offset B', 'time^1', 'temperature']``."""
        names = list(configurations) if configurations is not None else [str(c) for c in range(self.n_configurations)]
        out = [f"offset {n}" for n in names[: self.n_configurations]]
        out += [f"time^{j}" for j in range(1, self.drift_degree + 1)]
        return out + (["temperature"] if self.temperature else [])

    def rows(self, time, configuration, temperature, time_origin: float, temperature_origin: float) -> np.ndarray:
        """The basis rows of N samples.

        Args:
            time: Sample times [s], shape (N,), or None (every sample at the time origin).
            configuration: Configuration index per sample in [0, K), shape (N,), or None
                (all 0). With K = 1 every sample is in the one column.
            temperature: Temperatures [°C], shape (N,), or None (at the origin).
            time_origin: t_0 [s].
            temperature_origin: T_0 [°C].

        Returns:
            Shape (N, k).
        """
        n = len(time) if time is not None else len(configuration) if configuration is not None else 0
        if temperature is not None:
            n = len(temperature)
        return self._fill(np.zeros((n, self.size)), time, configuration, temperature, time_origin, temperature_origin)

    def _fill(self, out, time, configuration, temperature, time_origin, temperature_origin) -> np.ndarray:
        n, K, d = len(out), self.n_configurations, self.drift_degree
        out[:, :K] = 0.0
        if configuration is None or K == 1:
            out[:, 0] = 1.0
        else:
            out[np.arange(n), np.asarray(configuration, dtype=np.int64)] = 1.0
        if d:  # tau, tau^2, ...: one product per power (a batch's hot path: no power function)
            drift = out[:, K : K + d]
            if time is None:
                drift[:] = 0.0
            else:
                np.divide(np.asarray(time, dtype=float) - time_origin, self.time_scale_s, out=drift[:, 0])
                for j in range(1, d):
                    np.multiply(drift[:, j - 1], drift[:, 0], out=drift[:, j])
        if self.temperature:
            out[:, -1] = 0.0 if temperature is None else np.asarray(temperature, dtype=float) - temperature_origin
        return out

    def shift(self, time_shift: float, temperature_shift: float) -> np.ndarray:
        """The map G (k, k) with ``b(origin) = G b(origin + shift)``.

        Rows of a basis whose origins are ``t_0 + time_shift`` and ``T_0 + temperature_shift``
        become rows of origins ``t_0`` and ``T_0`` (binomial expansion of ``(tau + delta)^j``;
        the constant 1 is the sum of the one-hot columns). Used to merge estimators.
        """
        K, d = self.n_configurations, self.drift_degree
        G = np.eye(self.size)
        delta = time_shift / self.time_scale_s
        for j in range(1, d + 1):
            G[K + j - 1, :K] = delta**j  # the tau^0 = sum(e_c) term
            for i in range(1, j):
                G[K + j - 1, K + i - 1] = math.comb(j, i) * delta ** (j - i)
        if self.temperature:
            G[-1, :K] = temperature_shift
        return G

    def to_config(self) -> dict:
        """Plain data for checkpoints and calibration files."""
        return {
            "n_configurations": self.n_configurations,
            "drift_degree": self.drift_degree,
            "time_scale_s": self.time_scale_s,
            "temperature": self.temperature,
        }

    @classmethod
    def from_config(cls, raw: Mapping) -> OffsetBasis:
        """Inverse of :meth:`to_config`."""
        return cls(int(raw["n_configurations"]), int(raw["drift_degree"]), float(raw["time_scale_s"]), bool(raw["temperature"]))


#: The basis of the paper's model alone: z = [W; P Delta; 1] (checkpoints of older versions).
CONSTANT_ONLY = OffsetBasis(n_configurations=1, drift_degree=0, temperature=False)


@dataclass(frozen=True)
class Candidate:
    """One offset model over a basis: its name, degree, and the map A (k_m, k) of its columns.

    Attributes:
        model: One of :data:`OFFSET_MODELS`.
        columns: Indices into the basis of the columns it keeps (after the configurations'
            columns, which ``A`` sums for the constant model).
        A: The map from the full basis to the model's, shape (k_m, k).
    """

    model: str
    columns: tuple[int, ...]
    A: np.ndarray


def candidates(basis: OffsetBasis, present: np.ndarray, setting: str) -> list[Candidate]:
    """The models a setting may choose from, simplest first.

    Args:
        basis: The full basis.
        present: Whether each basis column holds any data (a non-zero diagonal of the
            sums), shape (k,): configurations never seen, time never given or a constant
            temperature leave their columns empty.
        setting: One of :data:`OFFSET_SETTINGS`.

    Returns:
        For 'auto' every distinct model; for a model, that model alone (for 'drift' with
        every time power and the temperature term the data have).
    """
    K, k = basis.n_configurations, basis.size
    seen = [c for c in range(K) if present[c]] or [0]
    powers = [K + j for j in range(basis.drift_degree) if present[K + j]]
    heat = [k - 1] if basis.temperature and present[k - 1] else []
    constant = np.zeros((1, k))
    constant[0, seen] = 1.0
    out = [Candidate("constant", (), constant)]
    if len(seen) > 1:
        out.append(Candidate("per-configuration", tuple(seen), np.eye(k)[seen]))
    drifts = []
    for degree in range(1, len(powers) + 1):
        drifts.append(tuple(seen + powers[:degree]))
        if heat:
            drifts.append(tuple(seen + powers[:degree] + heat))
    if heat:
        drifts.insert(0, tuple(seen + heat))
    out += [Candidate("drift", cols, np.eye(k)[list(cols)]) for cols in drifts]
    if setting == AUTO:
        return out
    if setting == "drift":
        return [c for c in out if c.model == "drift"][-1:] or out[-1:]
    return [c for c in out if c.model == setting] or [c for c in out if c.model == "constant"]


def bic(rss: np.ndarray, n_eff: float, n_offset: int, scale: np.ndarray) -> float:
    """The criterion of the module docstring for a fit of 6 + n_offset columns per axis.

    Args:
        rss: Residual sum of squares per axis, shape (6,).
        n_eff: Effective number of samples (sum of weights).
        n_offset: k_m, the model's offset columns.
        scale: Sum of squares of the wrench per axis (the RSS floor is
            :data:`RSS_FLOOR` of it), shape (6,).
    """
    floor = RSS_FLOOR * np.maximum(scale, 1e-300)
    return float(n_eff * np.sum(np.log(np.maximum(rss, floor) / n_eff)) + 6 * (6 + n_offset) * math.log(n_eff))


def describe(
    setting: str,
    chosen: Candidate,
    basis: OffsetBasis,
    coefficients: np.ndarray,
    origins: tuple[float, float],
    scores: Sequence[tuple[Candidate, float]],
    trace: Sequence[tuple[float, int, float]],
    configurations: Sequence[str] | None = None,
) -> dict:
    """The offset model of a calibration as plain data (the file's ``offset_model``).

    Args:
        setting: The offset setting the run used (:data:`OFFSET_SETTINGS`).
        chosen: The model fitted.
        basis: The full basis the estimator accumulated.
        coefficients: The model's offset terms Theta_b in [N, N m] per unit of each column.
            Shape (6, k_m).
        origins: ``(t_0 [s], T_0 [°C])`` of the basis.
        scores: BIC of every candidate the setting allowed (with a full-rank fit).
        trace: ``(time [s], configuration index, temperature [°C])`` of a few samples of the
            run, oldest first; the last is the end of the run.
        configurations: The configuration names (indices when None).

    Returns:
        ``{model, setting, criterion, candidates, columns, basis, A, coefficients,
        time_origin_s, temperature_origin_C, end, trajectory}``; the trajectory is the
        offset D at each traced sample, ``{time_s, configuration, temperature_C, D}``.
    """
    names = list(configurations) if configurations is not None else [str(c) for c in range(basis.n_configurations)]
    all_columns = basis.column_names(names)
    best = min(score for _, score in scores) if scores else 0.0
    description: dict = {
        "model": chosen.model,
        "setting": setting,
        "criterion": "BIC (lowest wins)" if setting == AUTO else "set by the user",
        "candidates": [{"model": c.model, "columns": _columns(c, all_columns), "bic_above_best": float(s - best)} for c, s in scores],
        "columns": model_columns(chosen, basis, names),
        "basis": basis.to_config(),
        "A": np.asarray(chosen.A).tolist(),
        "coefficients": np.asarray(coefficients).tolist(),
        "time_origin_s": float(origins[0]),
        "temperature_origin_C": float(origins[1]),
    }
    points = [{"time_s": float(t), "configuration": names[int(c)], "temperature_C": float(T)} for t, c, T in trace]
    if points:
        codes = [int(c) for _, c, _ in trace]
        D = evaluate_offsets(description, [t for t, _, _ in trace], codes, [T for _, _, T in trace])
        for point, d in zip(points, D, strict=True):
            point["D"] = d.tolist()
        description["end"] = {k: points[-1][k] for k in ("time_s", "configuration", "temperature_C")}
    description["trajectory"] = points
    return description


def model_columns(candidate: Candidate, basis: OffsetBasis, configurations: Sequence[str] | None = None) -> list[str]:
    """The names of a model's offset columns, as the calibration file gives them ('offset', or 'offset A', 'time^1', 'temperature').

    Args:
        candidate: The model.
        basis: The basis it maps.
        configurations: The tool configuration names (indices when None).
    """
    return _columns(candidate, basis.column_names(configurations))


def _columns(candidate: Candidate, names: Sequence[str]) -> list[str]:
    if candidate.model == "constant":
        return ["offset"]
    return [names[i] for i in candidate.columns]


def evaluate_offsets(description: Mapping, time, configuration, temperature=None) -> np.ndarray:
    """The offset D of a calibration's offset model at given samples.

    Args:
        description: A calibration's ``offset_model`` (:func:`describe`).
        time: Times [s], shape (N,).
        configuration: Configuration index per sample (the tool's order), shape (N,).
        temperature: Temperatures [°C], shape (N,), or None (at the origin).

    Returns:
        Offsets in [N, N, N, N m, N m, N m], shape (N, 6).
    """
    basis = OffsetBasis.from_config(description["basis"])
    time = np.atleast_1d(np.asarray(time, dtype=float))
    rows = basis.rows(
        time,
        np.atleast_1d(np.asarray(configuration, dtype=np.int64)),
        None if temperature is None else np.atleast_1d(np.asarray(temperature, dtype=float)),
        float(description["time_origin_s"]),
        float(description["temperature_origin_C"]),
    )
    return rows @ np.asarray(description["A"], dtype=float).T @ np.asarray(description["coefficients"], dtype=float).T


def model_sums(sums: np.ndarray, candidate: Candidate) -> np.ndarray:
    """The sums of ``[W; P Delta; A b][...]^T`` of one model from the full ones, shape (12 + k_m, 12 + k_m).

    Args:
        sums: The estimator's sums of ``z z^T``, ``z = [W; P Delta; b]``. Shape (12 + k, 12 + k).
        candidate: The model.
    """
    M = np.zeros((12 + len(candidate.A), len(sums)))
    M[:12, :12] = np.eye(12)
    M[12:, 12:] = candidate.A
    return M @ sums @ M.T


def choose(
    sums: np.ndarray, basis: OffsetBasis, setting: str, n_eff: float, rcond: float
) -> tuple[Candidate, list[tuple[Candidate, float]]]:
    """The model a setting fits, and the BIC of every candidate of full rank.

    With 'auto' the candidate of least BIC among those of full rank (the constant model
    while none is); with a model setting, that model.

    Args:
        sums: The estimator's full sums, shape (12 + k, 12 + k).
        basis: Its basis.
        setting: One of :data:`OFFSET_SETTINGS`.
        n_eff: Effective number of samples (sum of weights).
        rcond: Threshold of the numerical rank (:func:`fts_calib.model.least_squares.information_rank`).
    """
    options = candidates(basis, np.diag(sums)[12:] > 0, setting)
    scores = []
    for candidate in options:
        model = model_sums(sums, candidate)
        theta, *_ = solve_normal(model[6:, 6:], model[:6, 6:], rcond, False)
        determined = excitation_rank(model, rcond) == 6 + len(candidate.A)
        if theta is not None and determined and n_eff > 6 + len(candidate.A):
            rss = residual_sums(model[:6, :6], model[:6, 6:], model[6:, 6:], theta)
            scores.append((candidate, bic(rss, n_eff, len(candidate.A), np.diag(sums)[:6])))
    if not scores:
        return options[0], []
    return min(scores, key=lambda item: item[1])[0], scores


#: Points kept at most.
TRACE_POINTS = 64

Point = tuple[float, int, float]


class OffsetTrace:
    """Bounded list of ``(time [s], configuration, temperature [°C])`` points (see the module docstring)."""

    def __init__(self, spacing_s: float = 1.0):
        self.points: list[Point] = []
        self.spacing_s = float(spacing_s)
        self.end: Point | None = None

    def note(self, time: np.ndarray | None, codes: np.ndarray | None, temperature: np.ndarray | None, default_temperature: float) -> None:
        """Record samples, in time order.

        Args:
            time: Sample times [s], shape (N,); nothing is recorded when None.
            codes: Configuration index per sample, shape (N,); all 0 when None.
            temperature: Temperatures [°C], shape (N,); ``default_temperature`` when None.
            default_temperature: The temperature of samples without one [°C].
        """
        if time is None or not len(time):
            return
        c = np.zeros(len(time), dtype=np.int64) if codes is None else codes
        T = np.full(len(time), default_temperature) if temperature is None else temperature
        i = 0
        while i < len(time):
            if self.points and self.points[-1][1] == c[i]:
                later = np.flatnonzero((time[i:] >= self.points[-1][0] + self.spacing_s) | (c[i:] != c[i]))
                if not len(later):
                    break
                i += int(later[0])
            self.points.append((float(time[i]), int(c[i]), float(T[i])))
            self._bound()
            i += 1
        self.end = (float(time[-1]), int(c[-1]), float(T[-1]))

    def _bound(self) -> None:
        while len(self.points) > TRACE_POINTS:
            self.points = self.points[::2]
            self.spacing_s *= 2.0

    def with_end(self) -> list[Point]:
        """The points, ending with the last sample."""
        if self.end is None or (self.points and self.points[-1] == self.end):
            return list(self.points)
        return [*self.points, self.end]

    def merged(self, other: OffsetTrace) -> OffsetTrace:
        """The points of both, in time order, bounded again."""
        out = OffsetTrace(max(self.spacing_s, other.spacing_s))
        out.points = sorted(self.points + other.points)
        out._bound()
        ends = [e for e in (self.end, other.end) if e is not None]
        out.end = max(ends) if ends else None
        return out

    def state(self) -> dict:
        """Plain data for checkpoints."""
        return {"points": [list(p) for p in self.points], "spacing_s": self.spacing_s, "end": None if self.end is None else list(self.end)}

    @classmethod
    def from_state(cls, state: Mapping | None) -> OffsetTrace:
        """Inverse of :meth:`state` (an empty trace for None: a checkpoint of an older version)."""
        out = cls(float((state or {}).get("spacing_s", 1.0)))
        if state:
            out.points = [(float(t), int(c), float(T)) for t, c, T in state.get("points", [])]
            end = state.get("end")
            out.end = None if not end else (float(end[0]), int(end[1]), float(end[2]))
        return out

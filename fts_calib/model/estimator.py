r"""The online least-squares estimator of the calibration (paper eqs 12-16), with moving offsets.

The online estimator regresses the known wrench W (shape (6,), [N, N, N, N m, N m, N m])
on the projected strain ``P Delta`` and an offset basis ``b`` (shape (k,),
:mod:`fts_calib.model.offset_models`) and keeps only sums, so its memory does not grow with
the number of samples. P is the sensor's channel layout (6 x n,
:mod:`fts_calib.model.channels`): the paper's 6 x 8 by default. With the paper's constant
offsets ``b = [1]`` and ``x = [P Delta; 1]`` (eq 13):

.. math::

    S_{WX} \mathrel{+}= w\,W x^T, \qquad S_{XX} \mathrel{+}= w\,x x^T, \qquad
    [\bar C, D] = S_{WX} S_{XX}^{-1} \quad \text{(eqs 12, 14-16)}

Internally one symmetric (12 + k) x (12 + k) sum of ``z z^T`` with ``z = [W; P Delta; b]``
holds S_WW, S_WX and S_XX as blocks of the *full* basis ``b = [e_c; tau .. tau^d; theta]``
(one offset column per tool configuration, powers of time, temperature); each offset
model (constant, per-configuration, drift) is a linear map ``A`` of it, its sums
``A S A^T``, so the choice between them (``offsets="auto"``: least BIC) needs no second
pass. S_WW gives the residuals and the standard errors. The calibration's D is the offset
at the last sample (its configuration, time and temperature).

Weights are frequency weights: a sample of weight 2 counts exactly like the same sample
given twice. The forgetting factor ``lam`` in (0, 1] multiplies the sums by ``lam``
before each accepted sample (1 keeps everything).

The rank of S_XX and the solve of the normal equations are those of
:mod:`fts_calib.model.least_squares`: with constant offsets three non-collinear tool
centres of mass give the full rank 7 (paper eqs 18-20); with one offset per configuration
the full rank is 6 + K, reached with the same three centres of mass (see :data:`RANK_ADVICE`).

The online estimator's sums carried between instances: its checkpoint state and the merge of two.

:func:`estimator_state` turns an :class:`~fts_calib.model.estimator.OnlineEstimator` into
plain data (its sums ``z z^T``, weights, counts, origins and offset trace) and
:func:`restore_estimator` builds one back; :func:`merge_estimators` adds the sums of two
estimators as one pass over both samples would. Units are the estimator's: W in
[N, N, N, N m, N m, N m], time in [s], temperature in [°C].

The fit of a nonlinear (or full-channel) sensor model from the estimator's per-unit sums.

The estimator (:mod:`fts_calib.model.estimator`) keeps the sums of ``z z^T`` per held-out unit
(:mod:`fts_calib.model.model_choice`); once the choice is made, the model it chose is solved on
every unit at minimum norm (the directions no load excites held), its residual per tool
configuration judged, and the calibration built: the model's coefficients over named features
(:mod:`fts_calib.model.features`), C_bar the model linearised at the centre of the data, D the
offset at the end of the run. Units: W in [N, N, N, N m, N m, N m], channels raw.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np

from .._version import __version__
from ..core.arrays import as_matrix
from ..core.exceptions import ConfigError, InsufficientExcitation, ModelNotDetermined
from .accumulator import SampleSums
from .calibration import Calibration, now_iso
from .channels import MALTESE_CROSS_8, WRENCH_AXES, ChannelLayout, channel_layout
from .features import SensorModel
from .least_squares import (
    RCOND,
    excitation_rank,
    fit_quality,
    information_rank,
    residual_sigma,
    residual_sums,
    solve_normal,
    undetermined_columns,
)
from .model_choice import HOLD_RULE, Chooser, Selection
from .offset_models import (
    AUTO,
    CONSTANT_ONLY,
    Candidate,
    OffsetBasis,
    OffsetTrace,
    candidates,
    choose,
    describe,
    model_columns,
    model_sums,
    offset_setting,
)
from .prior import Prior

#: What full rank needs, in words: the one advice text of the estimator and the excitation report.
RANK_ADVICE = (
    "One tool centre of mass gives at most rank 4, two give 6, three non-collinear ones "
    "give 7 (paper eqs 18-20); within each, the sensor must see gravity from directions "
    "that span 3-D. Each further offset column (one per configuration, the drift terms) "
    "adds one to the full rank: drift needs the directions revisited as time goes on."
)


class OnlineEstimator(SampleSums):
    """Online least squares of the calibration (paper eqs 12-16), with weights, forgetting and moving offsets.

    Example:
        >>> est = OnlineEstimator()
        >>> est.update(w_sensor, strain)           # one sample: (6,) in N, N m; (8,) raw
        >>> est.update_batch(W, strains, time=t)   # many: (N, 6), (N, 8), times (N,) in s
        >>> calibration = est.solve()              # C_bar, D, C and their quality

    The sums and their updates are those of :class:`fts_calib.model.accumulator.SampleSums`.

    Args:
        forgetting: Exponential forgetting factor in (0, 1]; 1 weighs all samples equally.
        layout: The sensor's channel layout (or its sensor-YAML ``channels`` value); the
            paper's 8-bridge sensor by default.
        offsets: The offset model: 'auto' (least BIC), 'constant', 'per-configuration' or
            'drift' (:mod:`fts_calib.model.offset_models`).
        basis: The full offset basis accumulated (configurations, drift degree, time
            scale, temperature); one configuration, time up to degree 2 and temperature
            when None.
        model: The sensor model (:mod:`fts_calib.model.features`): 'linear' (the paper's,
            offsets chosen by BIC), 'quadratic', 'cubic', or 'auto' (the family and the
            offset model chosen together by held-out error, :mod:`fts_calib.model.model_choice`).
        full_channels: Regress on the raw channels (a free 6 x n C) instead of ``P Delta``.
        full_scale: Per-axis scale of the held-out error [N, N m], shape (6,); the RMS of
            the known wrench when None.

    Attributes:
        samples_per_draw: Samples that share one error draw, for the offset model's BIC (its
            sample count is the weight sum over this): 1 for independent samples; a sensor that
            does not repeat from pose to pose shares one offset over the samples of a still pose.
    """

    def __init__(
        self,
        forgetting: float = 1.0,
        layout: ChannelLayout | str | None = MALTESE_CROSS_8,
        offsets: str = AUTO,
        basis: OffsetBasis | None = None,
        model: str = "linear",
        full_channels: bool = False,
        full_scale=None,
    ):
        super().__init__(forgetting, layout, basis, model, full_channels)
        self.offsets = offset_setting(offsets)
        self.full_scale = None if full_scale is None else np.asarray(full_scale, dtype=float)
        self.samples_per_draw = 1.0
        self._selection: tuple[int, Selection | None] | None = None  # (rows it was made from, selection)

    def merge(self, other: OnlineEstimator) -> OnlineEstimator:
        """A new estimator holding the data of both (as one pass over both would).

        Both must have the same forgetting factor, channel layout, offset setting and basis;
        with forgetting < 1, ``other``'s data count as the more recent. ``other``'s sums are
        moved to this estimator's time and temperature origins first
        (:func:`~fts_calib.model.estimator.merge_estimators`).
        """
        return merge_estimators(self, other)

    # -- views --------------------------------------------------------------------------

    @property
    def S_WX(self) -> np.ndarray:
        """Sum of ``w W x^T`` (eq 15) of the paper's model ``x = [P Delta; 1]``, shape (6, 7); a copy."""
        return self.model_sums(self._constant())[:6, 6:]

    @property
    def S_XX(self) -> np.ndarray:
        """Sum of ``w x x^T`` (eq 16) of the paper's model ``x = [P Delta; 1]``, shape (7, 7); a copy."""
        return self.model_sums(self._constant())[6:, 6:]

    @property
    def S_WW(self) -> np.ndarray:
        """Sum of ``w W W^T``, shape (6, 6); a copy (used for residuals)."""
        return self._current()[:6, :6].copy()

    def _current(self) -> np.ndarray:
        self._flush()
        return self._sums

    def _present(self) -> np.ndarray:
        return np.diag(self._current())[12:] > 0

    def _constant(self) -> Candidate:
        return candidates(self.basis, self._present(), "constant")[0]

    def model_sums(self, candidate: Candidate) -> np.ndarray:
        """The sums of ``[W; P Delta; A b][...]^T`` of one offset model, shape (12 + k_m, 12 + k_m)."""
        return model_sums(self._current(), candidate)

    @property
    def weight_sum(self) -> float:
        """Effective number of samples (sum of weights, after forgetting)."""
        self._flush()
        return self._weight_sum

    @property
    def observations(self) -> float:
        """Observations for the residual's degrees of freedom, after forgetting: frequency weights summed, precision weights counted.

        A precision weight (``update_batch(..., precision=True)``, the dynamic filter's) is an inverse
        variance relative to the strain noise's: ``sum(w r^2) / (observations - p)`` estimates that noise's
        variance with one observation per sample, whatever its weight.
        """
        self._flush()
        return self._count_sum

    def rank(self, rcond: float = RCOND) -> tuple[int, float]:
        """Numerical rank and condition number of S_XX of the model in use; see :func:`information_rank`.

        The rank counts only the directions the known loads excite
        (:func:`~fts_calib.model.least_squares.excitation_rank`), not those strain noise
        alone fills. The full rank is :meth:`full_rank`: 7 for constant offsets, 6 + k for
        k offset columns.
        """
        if self.samples_used == 0:
            return 0, math.inf
        sums = self.model_sums(self._by_bic(rcond)[0])
        rank, condition = information_rank(sums[6:, 6:], rcond)
        excited = excitation_rank(sums, rcond)
        return (rank, condition) if excited >= rank else (excited, math.inf)

    def full_rank(self, rcond: float = RCOND) -> int:
        """The rank that determines every coefficient of the model in use (6 + its offset columns)."""
        return 6 + len(self._by_bic(rcond)[0].A)

    def model_in_use(self, rcond: float = RCOND) -> tuple[Candidate, list[tuple[Candidate, float]]]:
        """The offset model :meth:`solve` fits now, and the BIC of every full-rank candidate.

        With a model other than 'linear' and at least two held-out units, the offset model of
        :meth:`selection` (and no BIC); otherwise, with offsets 'auto', the candidate of least
        BIC among those of full rank (the constant model while none is); with an offset model
        setting, that model.
        """
        selection = self.selection()
        if selection is not None:
            return selection.chosen.offsets, []
        return self._by_bic(rcond)

    def _by_bic(self, rcond: float = RCOND) -> tuple[Candidate, list[tuple[Candidate, float]]]:
        return choose(self._current(), self.basis, self.offsets, self._weight_sum / max(self.samples_per_draw, 1.0), rcond)

    def selection(self) -> Selection | None:
        """The choice of the sensor model and offset model by held-out error, or None.

        None for the linear model on ``P Delta`` (no per-unit sums), or while fewer than two
        units hold samples. Computed once per state of the sums.
        """
        self._flush()
        if self.units is None or len(self.units.sums) < 2:
            return None
        if self._selection is None or self._selection[0] != self.unit_rows:
            chooser = Chooser(self.units, self.basis, (self.model, self.offsets), self.full_scale)
            self._selection = (self.unit_rows, chooser.select())
        return self._selection[1]

    # -- solution -----------------------------------------------------------------------

    def solve(
        self,
        rcond: float = RCOND,
        min_norm: bool = False,
        configurations: Sequence[str] | None = None,
        at: tuple[float, int, float | None] | None = None,
        prior: Prior | None = None,
    ) -> Calibration:
        """C_bar, D and C from the sums (eq 12), with the quality of the fit and the offset model.

        D is the offset at the end of the run: at ``at``, or at the last sample added (its
        configuration, time and temperature).

        Args:
            rcond: Threshold of the numerical rank; see :func:`information_rank`.
            min_norm: When S_XX is rank deficient, return the minimum-norm solution
                instead of raising (for convergence plots; undetermined parts are zero).
            configurations: Names of the tool configurations, for the offset model's report.
            at: ``(time [s], configuration index, temperature [°C] or None)`` of the end of
                the run (e.g. the last sample seen, kept or not); the last sample added when
                None. A configuration no sample was added for takes the last added one's.
            prior: Shrink C_bar toward a known one (ridge, :mod:`fts_calib.model.prior`);
                reported in the quality. None: the plain least squares.

        Raises:
            InsufficientExcitation: S_XX of the offset model has less than full rank (and
                ``min_norm`` is False); carries the rank and the number of missing directions.
        """
        if self.samples_used == 0:
            raise InsufficientExcitation(0, 7, "no sample has been added yet.")
        selection = self.selection()
        if selection is not None and selection.refused is not None:
            found = selection.refused
            raise ModelNotDetermined(found.family, found.rank, found.achievable, found.lacks(configurations))
        if selection is not None and (selection.chosen.family != "linear" or self.full_channels) and prior is None:
            excited = excitation_rank(self.model_sums(self._constant()), rcond)
            if excited < 7:  # the model's linear part needs what the paper's does (eqs 18-20)
                raise InsufficientExcitation(excited, 7 - excited, RANK_ADVICE, full=7)
            return solve_model(self, selection, configurations, at)
        chosen, scores = self.model_in_use(rcond)
        sums = self.model_sums(chosen)
        S_XX, S_WX, S_WW = sums[6:, 6:], sums[:6, 6:], sums[:6, :6]
        prior_report = None
        full = 6 + len(chosen.A)
        excited = excitation_rank(sums, rcond)
        if prior is None:
            theta, rank, condition, inv = solve_normal(S_XX, S_WX, rcond, min_norm)
            if excited < full and not min_norm:
                theta, rank = None, min(rank, excited)  # noise alone fills the missing directions
        else:
            theta, rank, condition, inv, prior_report = prior.solve(S_XX, S_WX, rcond)
            if prior_report is not None:
                prior_report["rank_without_prior"] = min(prior_report["rank_without_prior"], excited)
        if theta is None:
            raise InsufficientExcitation(rank, full - rank, RANK_ADVICE, full=full)
        if prior is None and excited < rank:
            rank, condition = excited, math.inf
        origins, end = self._end(at)
        a_end = chosen.A @ self._basis_row(end, origins)
        quality = fit_quality(
            S_WW,
            S_WX,
            S_XX,
            theta,
            inv,
            self._weight_sum,
            self.samples_used,
            self.samples_seen,
            rank,
            condition,
            self.skipped,
            self._P,
            a_end,
            self._count_sum,
        )
        trace = self.trace.with_end()
        trace += [end] if not trace or trace[-1] != end else []
        offset_model = describe(self.offsets, chosen, self.basis, theta[:, 6:], origins, scores, trace, configurations)
        provenance = {"method": "online least squares (paper eqs 12-16)", "time": now_iso(), "software_version": __version__}
        if prior_report is not None:
            quality = replace(quality, prior=prior_report)
        selected = None
        if selection is not None and prior is None:
            selected = selection.as_dict(self.basis.column_names(configurations), configurations)
            offset_model["criterion"] = "held-out error (see model_selection)"
            quality = replace(quality, held_directions={"count": 0, "rule": HOLD_RULE})
        return Calibration(
            C_bar=theta[:, :6],
            D=theta[:, 6:] @ a_end,
            quality=quality,
            provenance=provenance,
            layout=self.layout,
            offset_model=offset_model,
            model_selection=selected,
        )

    def undetermined(self, configurations: Sequence[str] | None = None, rcond: float = RCOND) -> list[list[str]]:
        """The offset-model columns the data cannot determine, grouped by missing direction (none at full rank).

        The groups of the known side ``[W; b]`` of the model in use (:func:`excitation_rank`)
        that hold offset columns only, named as in the calibration file ('offset B',
        'time^1', 'temperature'): a drift term that cannot be told from another one or
        from a configuration's offset. Missing directions of C (too few centres of mass or
        gravity directions) mix wrench axes and are left to the tool's advice.

        Args:
            configurations: Names of the tool configurations (indices when None).
            rcond: Threshold of the numerical rank.
        """
        chosen = self.model_in_use(rcond)[0]
        sums = self.model_sums(chosen)
        known = np.r_[0:6, 12 : len(sums)]
        names = [*WRENCH_AXES, *model_columns(chosen, self.basis, configurations)]
        groups = undetermined_columns(sums[np.ix_(known, known)], names, rcond)
        return [g for g in groups if not any(name in WRENCH_AXES for name in g)]

    def _end(self, at) -> tuple[tuple[float, float], tuple[float, int, float]]:
        """The basis origins and the end of the run ``(time, configuration, temperature)`` (see :meth:`solve`)."""
        origins = (self.time_origin or 0.0, self.temperature_origin or 0.0)
        end = self.trace.end if self.trace.end is not None else (origins[0], 0, origins[1])
        if at is not None:
            seen = np.diag(self._current())[12 + at[1]] > 0 if at[1] < self.basis.n_configurations else False
            end = (float(at[0]), int(at[1]) if seen else end[1], origins[1] if at[2] is None else float(at[2]))
        return origins, end

    def _basis_row(self, end: tuple[float, int, float], origins: tuple[float, float]) -> np.ndarray:
        t_end, c_end, T_end = end
        return self.basis.rows(np.array([t_end]), np.array([c_end]), np.array([T_end]), *origins)[0]

    def model_residuals(self) -> tuple[dict[int, np.ndarray], np.ndarray] | None:
        """The chosen nonlinear (or full-channel) model's residual RMS per configuration, and its slope C_bar.

        Returns:
            ``({configuration index: RMS per axis (6,) in N, N m}, C_bar (6, 6))``, the model
            linearised at the centre of the data; None when the model in use is the linear
            one on ``P Delta`` (its fit check is the session's own).
        """
        selection = self.selection()
        if selection is None or (selection.chosen.family == "linear" and not self.full_channels):
            return None
        return model_residuals(self, selection)

    # -- checkpoints --------------------------------------------------------------------

    def state(self) -> dict:
        """Everything needed to resume: plain types, safe to write as YAML or JSON.

        See :func:`~fts_calib.model.estimator.estimator_state`.
        """
        return estimator_state(self)

    @classmethod
    def from_state(cls, state: Mapping) -> OnlineEstimator:
        """Rebuild an estimator from :meth:`state` (a state of an older version, without offset models, too)."""
        return restore_estimator(cls, state)


def merge_estimators(first: OnlineEstimator, other: OnlineEstimator) -> OnlineEstimator:
    """A new estimator holding the data of both (as one pass over both would).

    Both must have the same forgetting factor, channel layout, offset setting and basis;
    with forgetting < 1, ``other``'s data count as the more recent. ``other``'s sums are
    moved to ``first``'s time and temperature origins first.

    Args:
        first: The estimator of the earlier data.
        other: The estimator of the later data.

    Returns:
        A new estimator of ``first``'s class; its sums are (12 + k) x (12 + k), k the basis size.

    Raises:
        ConfigError: The two differ in a setting named above, or in the sensor model.
    """
    for name, mine, theirs in (
        ("forgetting", first.forgetting, other.forgetting),
        ("channels", first.layout, other.layout),
        ("offsets", first.offsets, other.offsets),
        ("offset basis", first.basis, other.basis),
        ("model", (first.model, first.full_channels), (other.model, other.full_channels)),
    ):
        if mine != theirs:
            label = f"channel layouts {first.layout.name} and {other.layout.name}" if name == "channels" else f"{name} {mine} and {theirs}"
            message = f"cannot merge estimators {'of' if name == 'channels' else 'with'} {label}"
            raise ConfigError(name, theirs, f"{mine}, the same as this estimator's", message=message)
    first._flush()
    other._flush()
    out = type(first)(first.forgetting, first.layout, first.offsets, first.basis, first.model, first.full_channels, first.full_scale)
    out.time_origin = first.time_origin if first.time_origin is not None else other.time_origin
    out.temperature_origin = first.temperature_origin if first.temperature_origin is not None else other.temperature_origin
    shift = [
        0.0 if b is None or a is None else b - a
        for a, b in ((out.time_origin, other.time_origin), (out.temperature_origin, other.temperature_origin))
    ]
    G = np.eye(len(first._sums))
    G[12:, 12:] = first.basis.shift(*shift)
    decay = first.forgetting**other.samples_used
    out._sums = first._sums * decay + G @ other._sums @ G.T
    out._weight_sum = first._weight_sum * decay + other._weight_sum
    out._count_sum = first._count_sum * decay + other._count_sum
    out.samples_used = first.samples_used + other.samples_used
    out.samples_seen = first.samples_seen + other.samples_seen
    out.trace = first.trace.merged(other.trace)
    if first.units is not None and other.units is not None:
        out.units, out.unit_rows = first.units.merged(other.units, G[12:, 12:]), first.unit_rows + other.unit_rows
    for source in (first.skipped, other.skipped):
        for reason, count in source.items():
            out._skip(reason, count)
    return out


def estimator_state(est: OnlineEstimator) -> dict:
    """Everything needed to resume an estimator: plain types, safe to write as YAML or JSON.

    Args:
        est: The estimator; its staged samples are added to the sums first.

    Returns:
        A mapping of settings, the sums ``S`` ((12 + k) x (12 + k) nested lists), weights and counts.
    """
    return {
        "forgetting": est.forgetting,
        "channels": est.layout.to_config(),
        "offsets": est.offsets,
        "model": est.model,
        "full_channels": est.full_channels,
        **({"units": est.units.state(), "unit_rows": est.unit_rows} if est.units is not None else {}),
        "basis": est.basis.to_config(),
        "time_origin": est.time_origin,
        "temperature_origin": est.temperature_origin,
        "trace": est.trace.state(),
        "S": est._current().tolist(),
        "weight_sum": est._weight_sum,
        "observations": est._count_sum,
        "samples_used": est.samples_used,
        "samples_seen": est.samples_seen,
        "skipped": dict(est.skipped),
    }


def restore_estimator(cls: type[OnlineEstimator], state: Mapping) -> OnlineEstimator:
    """Rebuild an estimator from :func:`estimator_state` (a state of an older version, without offset models, too).

    Args:
        cls: The estimator class to build.
        state: The mapping :func:`estimator_state` wrote.

    Returns:
        The estimator, its sums of shape (12 + k, 12 + k) as saved.

    Raises:
        ShapeError: The sums do not match the offset basis.
    """
    basis = OffsetBasis.from_config(state["basis"]) if "basis" in state else CONSTANT_ONLY
    offsets = str(state.get("offsets", "constant"))
    model, full = str(state.get("model", "linear")), bool(state.get("full_channels", False))
    out = cls(float(state["forgetting"]), channel_layout(state.get("channels")), offsets, basis, model, full)
    if out.units is not None and "units" in state:
        out.units.restore(state["units"])
        out.unit_rows = int(state.get("unit_rows", 0))
    width = 12 + basis.size
    out._sums = as_matrix(state["S"], (width, width), "state['S']").copy()
    out._weight_sum = float(state["weight_sum"])
    out._count_sum = float(state.get("observations", state["samples_used"]))  # an older state: every sample one observation
    out.samples_used = int(state["samples_used"])
    out.samples_seen = int(state["samples_seen"])
    out.skipped = Counter({str(k): int(v) for k, v in state.get("skipped", {}).items()})
    for name in ("time_origin", "temperature_origin"):
        value = state.get(name)
        setattr(out, name, None if value is None else float(value))
    out.trace = OffsetTrace.from_state(state.get("trace"))
    return out


def fit_chosen(est: OnlineEstimator, selection: Selection):
    """``(units, M, sums, (Theta, rank, condition, pseudo-inverse))`` of the chosen candidate on every unit."""
    units = est.units
    if units is None:  # selection() is None without unit sums
        raise ConfigError("model", est.model, "a model with held-out sums")
    chooser = Chooser(units, est.basis, (est.model, est.offsets), est.full_scale)
    M = chooser.maps(selection.chosen.family, selection.chosen.offsets)
    sums = M @ units.total() @ M.T
    return units, M, sums, chooser.fit(sums, selection.chosen.family)


def model_residuals(est: OnlineEstimator, selection: Selection) -> tuple[dict[int, np.ndarray], np.ndarray]:
    """The chosen nonlinear (or full-channel) model's residual RMS per configuration, and its linear C_bar.

    Returns:
        ``({configuration index: RMS per axis (6,) in N, N m}, C_bar (6, 6))``, or None when
        the model in use is the linear one on ``P Delta`` (its fit check is the session's own).
    """
    units, M, _, (theta, *_) = fit_chosen(est, selection)
    K, first = est.basis.n_configurations, 6 + units.n_features
    rss: dict[int, np.ndarray] = {}
    weight: dict[int, float] = {}
    for g, sums in units.sums.items():
        c = int(np.argmax(np.diag(sums)[first : first + K]))  # a unit lies within one configuration
        mine = M @ sums @ M.T
        rss[c] = rss.get(c, np.zeros(6)) + residual_sums(mine[:6, :6], mine[:6, 6:], mine[6:, 6:], theta)
        weight[c] = weight.get(c, 0.0) + units.weights[g]
    model = SensorModel(selection.chosen.family, _features_first(theta, units.inputs, len(selection.chosen.offsets.A)), None, units.inputs)
    slope = model.slope(mean_inputs(est))
    C_bar = slope @ est.layout.pinv if est.full_channels else slope
    return {c: np.sqrt(rss[c] / max(weight[c], 1e-300)) for c in sorted(rss)}, C_bar


def mean_inputs(est: OnlineEstimator) -> np.ndarray:
    """The mean of the model's inputs u over the samples (d,): the centre of the calibration data."""
    units = est.units
    if units is None:
        raise ConfigError("model", est.model, "a model with held-out sums")
    total, K = units.total(), est.basis.n_configurations
    first = 6 + units.n_features
    counts = np.diag(total)[first : first + K].sum()  # the one-hot columns: one per sample
    return total[6 : 6 + units.inputs, first : first + K].sum(axis=1) / max(counts, 1e-300)


def solve_model(est: OnlineEstimator, selection: Selection, configurations, at) -> Calibration:
    """The calibration of a nonlinear family or of the raw channels, from the per-unit sums (minimum norm)."""
    score = selection.chosen
    units, _, sums, (theta, rank, condition, inv) = fit_chosen(est, selection)
    S_XX, S_WX, S_WW = sums[6:, 6:], sums[:6, 6:], sums[:6, :6]
    d, k_m = units.inputs, len(score.offsets.A)
    origins, end = est._end(at)
    a_end = score.offsets.A @ est._basis_row(end, origins)
    padded = np.zeros(theta.shape[1] - 6)
    padded[d - 6 : d - 6 + k_m] = a_end  # where the offsets sit among the regressors after the first six
    P = est.layout.projection if not est.full_channels else np.eye(6, est.layout.n_channels)
    quality = fit_quality(
        S_WW,
        S_WX,
        S_XX,
        theta,
        inv,
        est.weight_sum,
        est.samples_used,
        est.samples_seen,
        rank,
        condition,
        est.skipped,
        P,
        padded,
        est.observations,
    )
    coefficients = _features_first(theta, d, k_m)
    model = SensorModel(score.family, coefficients, None if est.full_channels else est.layout.projection, est.layout.n_channels)
    if est.full_channels:  # the free C's standard errors are those of its own columns
        sigma = residual_sigma(quality.residual_rms**2 * est.weight_sum, est.observations, theta.shape[1], est.samples_used)
        stderr_C = sigma[:, None] * np.sqrt(np.maximum(np.diag(inv)[:d], 0.0))[None, :]
        quality = replace(quality, stderr_C=stderr_C)
    held = theta.shape[1] - rank
    quality = replace(quality, held_directions={"count": held, "rule": HOLD_RULE})
    trace = est.trace.with_end()
    trace += [end] if not trace or trace[-1] != end else []
    names = est.basis.column_names(configurations)
    offset_model = describe(est.offsets, score.offsets, est.basis, theta[:, d : d + k_m], origins, [], trace, configurations)
    offset_model["criterion"] = "held-out error (see model_selection)"
    slope = model.slope(mean_inputs(est))  # linearised at the centre of the data, not at u = 0
    return Calibration(
        C_bar=slope @ est.layout.pinv if est.full_channels else slope,
        D=theta[:, d : d + k_m] @ a_end,
        quality=quality,
        provenance={
            "method": f"least squares of a {score.family} model (held-out choice)",
            "time": now_iso(),
            "software_version": __version__,
        },
        layout=est.layout,
        offset_model=offset_model,
        model=model if (score.family != "linear" or est.full_channels) else None,
        model_selection=selection.as_dict(names, configurations),
    )


def _features_first(theta: np.ndarray, d: int, k_m: int) -> np.ndarray:
    """The coefficients over the features (6, p) of a fit whose regressors are ``[u (d); offsets (k_m); higher features]``."""
    return np.hstack([theta[:, :d], theta[:, d + k_m :]])

r"""The online least-squares estimator of the calibration (paper eqs 12-16), with moving offsets.

The online estimator regresses the known wrench W (shape (6,), [N, N, N, N m, N m, N m])
on the projected strain ``P Delta`` and an offset basis ``b`` (shape (k,),
:mod:`fts_calib.model.offset_basis`) and keeps only sums, so its memory does not grow with
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
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np

from .._version import __version__
from ..core.exceptions import InsufficientExcitation, ModelNotDetermined
from .accumulator import SampleSums
from .calibration import Calibration, now_iso
from .channels import MALTESE_CROSS_8, ChannelLayout
from .estimator_state import estimator_state, merge_estimators, restore_estimator
from .least_squares import RCOND, excitation_rank, fit_quality, information_rank, solve_normal, undetermined_columns
from .model_choice import HOLD_RULE, Chooser, Selection
from .model_fit import model_residuals, solve_model
from .offset_basis import (
    AUTO,
    Candidate,
    OffsetBasis,
    candidates,
    choose,
    describe,
    model_columns,
    model_sums,
    offset_setting,
)
from .prior import Prior
from .sensor import WRENCH_AXES

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
            'drift' (:mod:`fts_calib.model.offset_basis`).
        basis: The full offset basis accumulated (configurations, drift degree, time
            scale, temperature); one configuration, time up to degree 2 and temperature
            when None.
        model: The sensor model (:mod:`fts_calib.model.features`): 'linear' (the paper's,
            offsets chosen by BIC), 'quadratic', 'cubic', or 'auto' (the family and the
            offset model chosen together by held-out error, :mod:`fts_calib.model.model_choice`).
        full_channels: Regress on the raw channels (a free 6 x n C) instead of ``P Delta``.
        full_scale: Per-axis scale of the held-out error [N, N m], shape (6,); the RMS of
            the known wrench when None.
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
        self._selection: tuple[int, Selection | None] | None = None  # (rows it was made from, selection)

    def merge(self, other: OnlineEstimator) -> OnlineEstimator:
        """A new estimator holding the data of both (as one pass over both would).

        Both must have the same forgetting factor, channel layout, offset setting and basis;
        with forgetting < 1, ``other``'s data count as the more recent. ``other``'s sums are
        moved to this estimator's time and temperature origins first
        (:func:`~fts_calib.model.estimator_state.merge_estimators`).
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
        return choose(self._current(), self.basis, self.offsets, self._weight_sum, rcond)

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

        See :func:`~fts_calib.model.estimator_state.estimator_state`.
        """
        return estimator_state(self)

    @classmethod
    def from_state(cls, state: Mapping) -> OnlineEstimator:
        """Rebuild an estimator from :meth:`state` (a state of an older version, without offset models, too)."""
        return restore_estimator(cls, state)

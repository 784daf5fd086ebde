"""What a calibration session keeps of its kept samples per tool configuration, and what it tells.

Per configuration ``c`` the session (:class:`fts_calib.pipeline.session.CalibrationSession`)
keeps the sum of ``[u; 1][u; 1]^T`` with ``u = g / |g|`` (4 x 4: the gravity directions the
sensor saw, for the advice on what is missing) and the sum of ``y y^T`` with
``y = [g_sensor; P Delta; 1; drift]`` ((10 + m) x (10 + m), :func:`fts_calib.pipeline.fit.fit_rows`,
for the fit check); over all of them, the load region of the known wrenches
(:class:`fts_calib.model.region.RegionBuilder`). From them: the progress in words, the fit
check of the model in use, and the error raised when a solve lacks rank. Units: gravity in
[m/s^2], channels raw, wrenches [N, N, N, N m, N m, N m].
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from ..core.exceptions import InsufficientExcitation, ModelNotDetermined, PoorFit
from ..model.least_squares import unexplained_strain
from ..model.region import RegionBuilder
from .advice import missing_words, moving_words, refused_words
from .diagnosis import RECORDING_KINDS, Cause, cause, missing_centres, session_allowance, weak_excitation
from .dynamic import DynamicFilter
from .fit import MAX_RATIO, UNEXPLAINED, FitCheck, check_fit, check_model_fit, fit_rows, model_fit_sums
from .progress import Progress
from .settings import DYNAMIC
from .units import UNIT_GAP_S

if TYPE_CHECKING:
    from .session import CalibrationSession


def empty_sums(n_configurations: int, n_drift: int, full_scale) -> tuple[np.ndarray, np.ndarray, RegionBuilder]:
    """The empty sums of a new session: gravity directions and fit rows, per configuration, and its load region.

    Args:
        n_configurations: k, the tool's configurations.
        n_drift: m, the drift columns of the estimator's offset basis.
        full_scale: The sensor's full scale [N, N, N, N m, N m, N m], shape (6,): the region's margin is 1 % of it.

    Returns:
        ``(directions (k, 4, 4), fit sums (k, 10 + m, 10 + m), region)``, zeros and an empty region.
    """
    m = 10 + n_drift  # sum of y y^T per configuration, y = [g; P Delta; 1; drift] (fit checks)
    directions = np.zeros((n_configurations, 4, 4))  # sum of [u; 1][u; 1]^T, u = g / |g|
    return directions, np.zeros((n_configurations, m, m)), RegionBuilder(full_scale)


def add_kept(
    session: CalibrationSession,
    g: np.ndarray,
    w_sensor: np.ndarray,
    channels: np.ndarray,
    codes: np.ndarray,
    time,
    temperature,
    fit: np.ndarray | None = None,
) -> None:
    """Add kept samples to the session's counts, gravity directions and fit sums, per configuration, and to its load region.

    Args:
        session: The session (its ``kept``, directions, fit sums and ``kept_region`` are updated in place).
        g: Gravity in the sensor frame [m/s^2], shape (N, 3).
        w_sensor: The known wrench the least squares took [N, N, N, N m, N m, N m], shape (N, 6).
        channels: Raw channels, shape (N, n).
        codes: Configuration indices in the tool's order, shape (N,).
        time: Times [s], shape (N,) (the estimator's drift columns).
        temperature: Sensor temperatures [°C], shape (N,), or None.
        fit: Which samples enter the fit sums (whose wrench is the weight alone: the fit check's
            model), shape (N,) bool; None: all.
    """
    session.kept += np.bincount(codes, minlength=len(session.kept))
    session.kept_region.add(w_sensor)
    unit = np.hstack([g / np.linalg.norm(g, axis=1, keepdims=True), np.ones((len(g), 1))])
    rows = fit_rows(g, channels, session.layout, session.estimator.drift_rows(time, temperature))
    for c in np.unique(codes):
        mine = codes == c
        u = unit[mine]
        session._directions[c] += u.T @ u
        mine_fit = mine if fit is None else mine & fit
        session._fit_sums[c] += rows[mine_fit].T @ rows[mine_fit]


def session_progress(session: CalibrationSession) -> Progress:
    """Counts, rank and what is missing, in words (:meth:`CalibrationSession.progress`).

    Args:
        session: The session.

    Returns:
        The progress; ``missing`` is '' at full rank.
    """
    rank, condition = session.estimator.rank()
    full, last = session.estimator.full_rank(), session.checks.last_time
    return Progress(
        seen=session.seen,
        kept=int(session.kept.sum()),
        kept_by_configuration={name: int(n) for name, n in zip(session.tool.names, session.kept, strict=True)},
        rank=rank,
        condition_number=condition,
        missing="" if rank == full else missing_words(session.tool, session.kept, session._directions),
        skipped=session.all_skipped(),
        last_time=None if last == -math.inf else last,
        full_rank=full,
    )


def session_fit_check(session: CalibrationSession, hint: str = "") -> FitCheck:
    """Whether the session's kept samples fit the tool's model at the noise level of the data.

    The noise is the filter's noise floor (the strain scatter of the still windows, raw units,
    shape (n,)); without the filter, or with a fixed strain threshold, none is measured and
    the verdict is 'unchecked'. The tool file's tolerance, the robot file's mount and encoders and the
    setting ``fit.floor`` (of the session's full scale) widen what is expected
    (:mod:`fts_calib.pipeline.fit_tolerance`). See :mod:`fts_calib.pipeline.fit`; a poor fit's diagnosis is
    the first cause the data support (:mod:`fts_calib.pipeline.diagnosis`).

    Args:
        session: The session.
        hint: Words added to a poor fit's diagnosis when no alternative explains it.

    Returns:
        The check of the model in use (a nonlinear model's by its residual per configuration).
    """
    return _checked(session, hint)[0]


def _checked(session: CalibrationSession, hint: str) -> tuple[FitCheck, Cause | None]:
    """The fit check of :func:`session_fit_check`, and the cause of a poor linear fit (None otherwise)."""
    noise = None if session.filter is None else session.filter.noise_floor
    in_sums = session._fit_sums[:, 9, 9]  # samples the sums hold (the last entry of y is 1)
    missing = int(session.kept.sum() - round(float(in_sums.sum())))
    # resumed from a checkpoint of a version without fit sums: a part is not judged (dynamic: only near-still samples are in them)
    if missing > 0 and session.settings.filter.mode != DYNAMIC:
        reason = f"{missing:,} kept samples came from a checkpoint without fit sums: run again with --restart to check the fit"
        return FitCheck("unchecked", math.nan, {}, np.full(6, math.nan), reason), None
    chosen = session.estimator.model_in_use()[0]
    sums, per_configuration = model_fit_sums(session._fit_sums, chosen.model, chosen.columns, session.estimator.basis.n_configurations)
    allowance = session_allowance(session)
    linear = check_fit(session.tool, sums, in_sums, noise, hint, session.layout, per_configuration, allowance)  # noise: >= step/sqrt(12)
    dynamic = session.filter.fit_residuals() if isinstance(session.filter, DynamicFilter) else None
    if dynamic is not None:  # the moving samples' residual, of the dynamic wrench (the static model's check gives the diagnosis)
        named = {name: dynamic[0][k] for k, name in enumerate(session.tool.names) if k in dynamic[0]}
        return check_model_fit(session.tool, named, dynamic[1], noise, session.layout, linear), None
    residuals = session.estimator.model_residuals()
    final = linear  # the linear model on P Delta: the check above is the model's
    if residuals is not None:
        rms, C_bar = residuals
        named = {name: rms[k] for k, name in enumerate(session.tool.names) if k in rms}
        final = check_model_fit(session.tool, named, C_bar, noise, session.layout, linear)
    if final.verdict != "poor" or linear.verdict != "poor":
        return final, None
    # a quadratic model is named only when the linear one is in use
    found = cause(session, linear, per_configuration, hint or UNEXPLAINED, session.joints_in_degrees, residuals is None)
    return replace(final, diagnosis=found.text), found


def _moving_words(session: CalibrationSession) -> str:
    """The quasi-static filter's advice for a recording without stops (:func:`fts_calib.pipeline.advice.moving_words`)."""
    still, kept = session.filter, int(session.kept.sum())
    if still is None or isinstance(still, DynamicFilter):
        return ""
    time, _, _, codes, _ = session._kept_samples.arrays()
    if len(time) != kept:  # resumed: the kept samples are not all at hand
        return ""
    starts = 1 + int(np.count_nonzero((np.diff(codes) != 0) | (np.diff(time) > UNIT_GAP_S))) if kept else 0
    per_configuration = starts / max(len(np.unique(codes)), 1)
    return moving_words(still.rejected, session.seen, kept, per_configuration)


def strains_unexplained(session: CalibrationSession) -> bool:
    """Whether the strains carry a signal the tool file's loads cannot produce (:func:`unexplained_strain`).

    Args:
        session: The session (its filter's noise floor; False without one).
    """
    if session.filter is None or session.filter.noise_floor is None:
        return False
    estimator = session.estimator
    sums, noise = estimator.model_sums(estimator.model_in_use()[0]), session.layout.projected_noise(session.filter.noise_floor)
    return unexplained_strain(sums, noise, estimator.weight_sum) > MAX_RATIO**2


def refusal(session: CalibrationSession, exc: InsufficientExcitation, hint: str, accept_poor_fit: bool) -> PoorFit | InsufficientExcitation:
    """The error for a solve the estimator refused for rank: what the recording lacks, unless the strains show a wrong file.

    In the order of :mod:`fts_calib.pipeline.diagnosis`: configurations recorded that lack a
    centre of mass of the tool file are named first, whatever the fit; then, when the strains
    carry a signal the loads cannot produce, a cause the data support (joint units, the tool
    file's alternatives, a collinear tool file) is a poor fit; a weak excitation or no cause
    at all leaves the missing rank, with the weakly excited axis named.

    Args:
        session: The session.
        exc: The estimator's refusal (its rank, missing directions and full rank).
        hint: See :func:`session_fit_check`.
        accept_poor_fit: Do not turn the refusal into a :class:`PoorFit`.

    Returns:
        :class:`PoorFit` (no calibration) when a wrong tool file or joint unit, not the
        recording, explains the missing rank; otherwise :class:`InsufficientExcitation` in words.
    """
    if isinstance(exc, ModelNotDetermined):  # a model the jig cannot fix, whatever the samples: its words say what the jig lacks
        return exc
    short = missing_centres(session)
    if not short and not accept_poor_fit and strains_unexplained(session):
        check, found = _checked(session, hint)
        if not check.ok and (found is None or found.kind not in RECORDING_KINDS):  # a wrong file or unit, not a short sweep
            return PoorFit(check, None)
    weak = None if short else weak_excitation(session)
    refused = refused_words(session.checks.skipped, session.seen, int(session.kept.sum()))
    undetermined = session.estimator.undetermined(session.tool.names)
    moving = _moving_words(session)
    said = "; ".join(w for w in (hint, moving, "" if weak is None else weak.text) if w)
    words = missing_words(session.tool, session.kept, session._directions, undetermined, said, refused)
    return InsufficientExcitation(exc.rank, exc.missing, words, exc.full)

r"""The measured accuracy budget of a calibration, and the samples it is measured from.

Every error source of the budget (:mod:`fts_calib.budget.propagation`) is a perturbation of the
regression's inputs: the tool's mass and centre-of-mass tolerance, the sensor mount, the
joint encoders, the latency and jitter between the joint and channel streams
(:mod:`fts_calib.budget.sensitivities`), and channel noise, white on each channel, which
reaches wrench axis j with the standard deviation

.. math::

    \sigma_{W,j} = \sqrt{(C\,\mathrm{diag}(\sigma^2)\,C^T)_{jj}}.

Every route to a calibration (:meth:`fts_calib.session.session.CalibrationSession.solve`,
so the ``calibrate`` and ``live`` commands, :func:`fts_calib.session.calibration_run.calibrate_recording`
and :func:`fts_calib.calibrate`) measures it from the samples kept, and writes it in the
calibration's ``quality.accuracy_budget`` with the stream-latency estimate
(:mod:`fts_calib.filters.latency`): one file, the same fields, whichever route. The
``trajectory`` job predicts it from a plan (:mod:`fts_calib.budget.predicted`). Units: N,
N m, and % of each axis's full scale.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from ..filters.latency import LatencyEstimate, estimate_latency
from ..model.calibration import Calibration
from ..model.least_squares import information_rank
from ..robot.definition import RobotAccuracy
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool
from .propagation import MODEL_ERROR, REPEATABILITY, AccuracyBudget, ErrorSource, model_error, propagate, range_moments, wrench_noise
from .sensitivities import SOURCE_NAMES, load_error_sources, stops

#: [s] a gap this long between kept samples: the arm moved to another stop.
STOP_GAP_S = 0.05
_MAX_BUDGET_SAMPLES = 20_000  # samples the measured budget uses (every k-th beyond)


def sample_budget(
    kin: Kinematics,
    tool: Tool,
    joints: np.ndarray,
    configuration: np.ndarray,
    joint_velocity: np.ndarray,
    stop: np.ndarray | None,
    x: np.ndarray,
    sigma_w: np.ndarray,
    C_bar: np.ndarray,
    D: np.ndarray,
    full_scale: np.ndarray,
    kind: str = "predicted",
    weight: float = 1.0,
    accuracy: RobotAccuracy | None = None,
    prior_weight: float | None = None,
    extra: Sequence[ErrorSource] = (),
    row_weight: np.ndarray | None = None,
) -> AccuracyBudget:
    """The budget of a calibration from its samples (every term inf when they do not determine C, rank < 7).

    Args:
        kin: Kinematics (its robot's ``accuracy``: encoders, timing, mount).
        tool: The tool (its ``tolerance``).
        joints: Joint readings of the samples [rad]. Shape (N, n_joints).
        configuration: Tool configuration index of each sample. Shape (N,) int.
        joint_velocity: Joint velocities at the samples [rad/s]. Shape (N, n_joints).
        stop: Still stretch of each sample, shape (N,) int; None when every sample moves.
        x: Regressors ``[P Delta; 1]`` (``[C_bar^-1 (W - D); 1]``). Shape (N, 7).
        sigma_w: Strain noise through C, per axis [N, N m]. Shape (6,).
        C_bar: Modified calibration matrix (nominal, or the result). Shape (6, 6).
        D: Offsets [N, N, N, N m, N m, N m]. Shape (6,).
        full_scale: Full scale per axis, same units. Shape (6,).
        kind: 'predicted' or 'measured'.
        weight: Channel samples each row stands for (white terms average over them).
        accuracy: Encoder resolution, timing and mount tolerance; the robot definition's when None.
        prior_weight: The weight lambda of a prior C_bar was shrunk toward (:mod:`fts_calib.model.prior`): the
            errors propagate through the shrunk least squares, so every term is finite; None for none.
        extra: More sources (e.g. the moving tool's, :mod:`fts_calib.budget.sensitivities`);
            a static source of the same name as one of them is left out (they replace it).
        row_weight: Weight of each sample in a weighted least squares, shape (N,); None for equal weights.
    """
    accuracy = kin.robot.accuracy if accuracy is None else accuracy
    n = len(joints)
    ridge = None
    if prior_weight is not None and n:
        ridge = np.zeros((7, 7))
        ridge[:6, :6] = prior_weight * np.diag(np.einsum("ni,ni->i", x[:, :6], x[:, :6]))
    wx = x if row_weight is None else np.asarray(row_weight, dtype=float)[:, None] * x
    if n == 0 or (ridge is None and information_rank(x.T @ wx)[0] < 7):
        names = [name for name in ("strain noise", *SOURCE_NAMES) if tool.tolerance is not None or not name.startswith("tool")]
        return AccuracyBudget({name: np.full(6, np.inf) for name in names}, full_scale, kind=kind)
    replaced = {source.name for source in extra}
    sources = [s for s in load_error_sources(kin, tool, joints, configuration, joint_velocity, stop, accuracy) if s.name not in replaced]
    noise = ErrorSource("strain noise", np.broadcast_to(np.eye(6), (n, 6, 6)), np.diag(np.asarray(sigma_w, dtype=float) ** 2))
    terms = propagate(x, [noise, *sources, *extra], range_moments(C_bar, D, full_scale), weight, ridge, row_weight)
    return AccuracyBudget(terms, full_scale, kind=kind)


class KeptSamples:
    """The samples entering the least squares, collected for the measured budget.

    Pass it as the session's ``on_kept``: it is called with ``(time (k,), w_sensor (k, 6),
    channels (k, n), configuration (k,), joints (k, n_joints))`` and the temperature (k,) or None.
    """

    def __init__(self) -> None:
        self._parts: list[tuple[np.ndarray, ...]] = []

    def __call__(self, time, w_sensor, channels, configuration, joints, temperature=None) -> None:
        """Keep one batch of kept samples (the session's ``on_kept``; the temperature is not needed here)."""
        self._parts.append(tuple(np.array(a) for a in (time, w_sensor, channels, configuration, joints)))

    def __len__(self) -> int:
        return sum(len(part[0]) for part in self._parts)

    def samples_per_stop(self, gap_s: float = STOP_GAP_S) -> float:
        """Kept samples per still stretch (a gap longer than ``gap_s`` [s] or a tool change starts one); 1 when none is kept."""
        time, _, _, codes, _ = self.arrays()
        return len(time) / (int(stops(time, codes, gap_s)[-1]) + 1) if len(time) else 1.0

    def arrays(self) -> tuple[np.ndarray, ...]:
        """``(time, w_sensor, channels, configuration, joints)``, every batch in order."""
        if not self._parts:
            return (np.zeros(0), np.zeros((0, 6)), np.zeros((0, 0)), np.zeros(0, dtype=np.int64), np.zeros((0, 0)))
        return tuple(np.concatenate(column) for column in zip(*self._parts, strict=True))


def measured_budget(
    kin: Kinematics,
    tool: Tool,
    kept: KeptSamples,
    calibration: Calibration,
    sigma_w,
    full_scale,
    gap_s: float = STOP_GAP_S,
    residual_rms=None,
    prior_weight: float | None = None,
    accuracy: RobotAccuracy | None = None,
    repeatability=None,
) -> AccuracyBudget:
    """The budget of a calibration from the samples it was solved from, with its model error.

    Args:
        kin: Kinematics.
        tool: The tool.
        kept: The samples that entered the least squares.
        calibration: The result (its C_bar, D and C).
        sigma_w: Strain noise measured in the data, through C (:func:`fts_calib.budget.propagation.wrench_noise` of the
            filter's noise floor), per axis [N, N m]. Shape (6,).
        full_scale: Full scale per axis [N, N m]. Shape (6,).
        gap_s: A gap between kept samples longer than this [s] starts a new stop.
        residual_rms: The calibration's residual RMS per axis on held-out samples (or its fit's), [N, N m], shape
            (6,): what exceeds ``sigma_w``, its largest in % of full scale on every axis, is the
            budget's "model error" term (:func:`fts_calib.budget.propagation.model_error`); None for no such term.
        prior_weight: The weight of the prior C_bar was shrunk toward, or None (see :func:`sample_budget`).
        accuracy: Encoders, timing and mount; the robot definition's when None (the dynamic mode
            gives the latency it fitted and applied, :meth:`fts_calib.filters.dynamic.DynamicFilter.budget_accuracy`).
        repeatability: The sensor's scatter from one still pose to another per axis [N, N m], shape (6,), or None:
            the term :data:`fts_calib.budget.propagation.REPEATABILITY`, in quadrature a new offset at every stop
            through the least squares, the bias it gives the fit (:func:`attenuation`) and the reading's own
            scatter; it is not model error (the residual beyond the noise and this term is).
    """
    time, _, channels, codes, joints = kept.arrays()
    stride = max(1, int(math.ceil(len(time) / _MAX_BUDGET_SAMPLES)))  # bounded memory: white terms weigh the rest
    stop = stops(time, codes, gap_s)[::stride]
    time, channels, codes, joints = time[::stride], channels[::stride], codes[::stride], joints[::stride]
    same = np.diff(stop) == 0
    velocity = np.zeros_like(joints)
    if len(time) > 1:
        slope = np.diff(joints, axis=0) / np.maximum(np.diff(time), 1e-12)[:, None]
        velocity[1:][same] = slope[same]
    x_bar = np.linalg.solve(calibration.C_bar, (calibration.wrench(channels, region_check=False) - calibration.D).T).T
    x = np.hstack([x_bar, np.ones((len(x_bar), 1))])
    budget = sample_budget(
        kin,
        tool,
        joints,
        codes,
        velocity,
        stop,
        x,
        sigma_w,
        calibration.C_bar,
        calibration.D,
        full_scale,
        "measured",
        weight=stride,
        prior_weight=prior_weight,
        accuracy=accuracy,
        extra=() if repeatability is None else [repeatability_source(repeatability, stop)],
    )
    terms, random = dict(budget.terms), np.asarray(sigma_w, dtype=float)
    if repeatability is not None:  # the fitted C and D are off by what the stops' offsets leave, and every reading by its own
        scatter = np.asarray(repeatability, dtype=float).reshape(6)
        bias = attenuation(calibration.C_bar, calibration.D, x, scatter, full_scale)
        terms[REPEATABILITY] = np.sqrt(terms[REPEATABILITY] ** 2 + bias**2 + scatter**2)
        random = np.hypot(random, terms[REPEATABILITY])  # a held-out residual holds the scatter and what it costs the fit
    if residual_rms is not None:
        terms[MODEL_ERROR] = model_error(residual_rms, random, full_scale)
    return AccuracyBudget(terms, budget.full_scale, budget.coverage, budget.kind)


def attenuation(C_bar, D, x: np.ndarray, repeatability, full_scale) -> np.ndarray:
    r"""The bias of the fit from a scatter in the readings it regresses on, over the range, per axis [N, N m]. Shape (6,).

    The offsets of a sensor that does not repeat are in the regressors ``x`` (the readings), not in the
    known loads: least squares then shrinks the fitted map toward zero (regression dilution),
    ``E[dTheta] = -Theta Sigma_d (x^T x / N)^{-1}`` with ``Sigma_d`` the covariance of the readings'
    error, ``C_bar^{-1} diag(repeatability^2) C_bar^{-T}`` (the constant column has none), and
    ``Theta = [C_bar, D]``: a systematic error of the calibration, ``sqrt(dTheta_j M dTheta_j^T)`` over
    the full-scale box (:func:`fts_calib.budget.propagation.range_moments`). It grows as the loads
    spread less along an axis than the scatter (a tool of one mass: the forces' magnitude).

    Args:
        C_bar: Modified calibration matrix, shape (6, 6).
        D: Offsets [N, N m], shape (6,).
        x: Regressors of the samples as measured, ``[P Delta; 1]``, shape (N, 7).
        repeatability: Per axis [N, N, N, N m, N m, N m], shape (6,).
        full_scale: Full scale per axis, same units, shape (6,).
    """
    C_bar, D = np.asarray(C_bar, dtype=float), np.asarray(D, dtype=float)
    inverse = np.linalg.inv(C_bar)
    sigma = np.zeros((7, 7))
    sigma[:6, :6] = inverse @ np.diag(np.asarray(repeatability, dtype=float) ** 2) @ inverse.T
    theta = np.hstack([C_bar, D[:, None]])
    S = np.asarray(x, dtype=float).T @ np.asarray(x, dtype=float) / max(len(x), 1)
    change = -theta @ sigma @ np.linalg.pinv(S, hermitian=True)
    M = range_moments(C_bar, D, full_scale)
    return np.sqrt(np.maximum(np.einsum("jk,kl,jl->j", change, M, change), 0.0))


def repeatability_source(repeatability, stop: np.ndarray) -> ErrorSource:
    """A sensor that does not repeat as an error source: one wrench offset per stop, of standard deviation ``repeatability``.

    Args:
        repeatability: Per axis [N, N, N, N m, N m, N m], shape (6,).
        stop: Still stretch of each sample, shape (N,) int.
    """
    scatter = np.asarray(repeatability, dtype=float).reshape(6)
    return ErrorSource(REPEATABILITY, np.broadcast_to(np.eye(6), (len(stop), 6, 6)), np.diag(scatter**2), np.asarray(stop))


#: Valid samples kept for the stream-latency estimate, at most: 100 s at 1 kHz (a whole sized run of three
#: configurations holds about 60,000) has dozens of moves, enough for a spread of microseconds, and bounds the memory.
LATENCY_SAMPLES = 100_000


class MovingSamples:
    """The first valid samples of a run, moving ones included, for the stream-latency estimate.

    Args:
        limit: Samples kept at most (the first ones).
    """

    def __init__(self, limit: int = LATENCY_SAMPLES) -> None:
        self.limit = limit
        self._parts: list[tuple[np.ndarray, ...]] = []
        self._count = 0

    def add(self, time, joints, channels, configuration) -> None:
        """Keep a batch of valid samples (time [s] (k,), joints [rad] (k, n_joints), channels (k, n), configuration (k,))."""
        room = self.limit - self._count
        if room <= 0:
            return
        part = tuple(np.array(a[:room]) for a in (time, joints, channels, configuration))
        self._parts.append(part)
        self._count += len(part[0])

    def __len__(self) -> int:
        return self._count

    def arrays(self) -> tuple[np.ndarray, ...]:
        """``(time, joints, channels, configuration)``, every batch in order (empty arrays before any)."""
        if not self._parts:
            return (np.zeros(0), np.zeros((0, 0)), np.zeros((0, 0)), np.zeros(0, dtype=np.int64))
        return tuple(np.concatenate(column) for column in zip(*self._parts, strict=True))


def with_measured_budget(
    calibration: Calibration,
    kin: Kinematics,
    tool: Tool,
    kept: KeptSamples,
    n_kept: int,
    noise_floor,
    moving: MovingSamples,
    full_scale,
    accuracy: RobotAccuracy | None = None,
    repeatability=None,
) -> tuple[Calibration, AccuracyBudget | None, LatencyEstimate | None]:
    """The calibration with its measured accuracy budget and stream-latency estimate in ``quality``.

    Channel noise as the data show it (the filter's noise floor through C, else the fit's
    residual: an upper bound, it holds every random error), the tool's tolerance, the
    robot's encoders, timing and mount (:func:`measured_budget`), the model error (the held-out
    residual of the chosen model, or the fit's residual, beyond the noise), and the latency of the
    joint stream from the moving samples (:func:`fts_calib.filters.latency.estimate_latency`)
    under ``quality.accuracy_budget.stream_latency_estimate`` when there are any.

    Args:
        calibration: The solved calibration (with its quality).
        kin: Kinematics.
        tool: The tool.
        kept: The samples that entered the least squares.
        n_kept: How many samples the least squares holds: when ``kept`` holds fewer (a
            session resumed from a checkpoint), nothing is measured from a part.
        noise_floor: The filter's channel noise floor, shape (n,), or None.
        moving: The first valid samples, for the latency.
        full_scale: Full scale per axis [N, N m], shape (6,).
        accuracy: Encoders, timing and mount for the budget; the robot definition's when None.
        repeatability: The sensor file's ``repeatability`` per axis [N, N m], shape (6,), or None (:func:`measured_budget`).

    Returns:
        ``(calibration, budget, latency)``; the calibration unchanged and None, None when
        nothing can be measured.
    """
    if calibration.quality is None or len(kept) != n_kept or n_kept == 0:
        return calibration, None, None
    full_scale = np.asarray(full_scale, dtype=float)
    quality = calibration.quality
    sigma_w = quality.residual_rms if noise_floor is None else wrench_noise(calibration.C, noise_floor)
    selection = calibration.model_selection
    chosen = [c for c in selection["candidates"] if c["chosen"]] if selection else []
    residual = np.asarray(chosen[0]["heldout_rms"]) if chosen else quality.residual_rms  # held out when chosen so
    prior_weight = None if quality.prior is None else float(quality.prior["weight"])
    budget = measured_budget(
        kin,
        tool,
        kept,
        calibration,
        sigma_w,
        full_scale,
        residual_rms=residual,
        prior_weight=prior_weight,
        accuracy=accuracy,
        repeatability=repeatability,
    )
    record = budget.to_dict()
    latency = None
    if len(moving):
        time, joints, channels, codes = moving.arrays()
        latency = estimate_latency(kin, tool, calibration, time, joints, channels, codes, full_scale)
    if latency is not None:
        record["stream_latency_estimate"] = latency.as_dict()
    calibration = replace(calibration, quality=replace(quality, budget=record))
    return calibration, budget, latency

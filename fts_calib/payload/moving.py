r"""Payload identification from a continuous motion: mass, centre of mass and inertia, physically consistent.

The wrench a moving rigid payload exerts on the sensor is linear in its ten inertial
parameters ``pi`` (:mod:`fts_calib.robot.inertial`: mass, first moment ``m c``, inertia about
the origin of S), and the calibrated measurement adds the unknown wrench offsets ``d``:

.. math::

    W_{meas} = Y(\omega, \alpha, a - g)\,\pi + d

with the sensor frame's motion from the joint readings (velocities and accelerations by
:func:`fts_calib.filters.joint_rates.joint_rates`, a least-squares quadratic over the filter's
``derivative_window_s``: no phase lag) and the kinematics. The offsets are estimated with the
payload (16 unknowns; 22 with a linear drift of the offsets along the motion, when the sample
times are given, as from a recording: a sensor warming up moves its moments by 1e-3 N m in
seconds, the size of the inertial torques), not taken from a tare: the motion turns gravity about the sensor, which
separates them from the weight as the still-pose identification does, and a tare would have
to be taken with nothing mounted just before.

Fit: least squares weighted by each axis's residual spread (two passes); the offsets are
eliminated (Schur complement), leaving ``pi_hat`` and its normal matrix ``S``. When
``pi_hat`` is not physically consistent (a pseudo-inertia that is not positive definite:
Wensing, Kim and Slotine, RA-L 2018), the fit is redone over the consistent bodies only, by
Levenberg-Marquardt on the log-Cholesky parameters (Rucker and Wensing, RA-L 2022;
:func:`fts_calib.robot.inertial.consistent_fit`), and the offsets follow. Standard errors: those
of the unconstrained fit, from the residuals by a block "sandwich" (:func:`_block_covariance`:
the residuals are correlated over a joint-rate window, and most of their power, joint-rate
noise, lies far above the motion's frequencies where the regressors hardly see it),
propagated to the centre of mass ``c = h / m`` and the inertia about it by first order. Where
the constraint binds they overstate the error along the boundary. On the simulated UR5 (12
seeds) the seeds' scatter is 0.2 to 0.5 of them: they also carry the model's error that is
the same in every run.

A motion that does not determine a parameter is refused with its name and what to add: the
inertia about an axis needs angular acceleration about it (the joint turning about it is
named); the mass and centre of mass need gravity from several directions. A parameter is
undetermined when the data do not see it at all, or its standard error exceeds
:data:`MAX_STDERR_MASS` of the mass, :data:`MAX_STDERR_COM`, or :data:`MAX_STDERR_INERTIA` of
the inertia's scale (its largest principal moment, within ``m (3 cm)^2`` and ``m (5 cm)^2``):
two standard errors within 0.5 % of the mass, 1 mm and 10 % of the inertia.

From recorded or collected samples (:func:`fit_motion_samples`, after the filter chain's checks:
:mod:`fts_calib.payload.samples`): the calibrated wrench, and the sensor frame's motion from the
joint readings aligned by the stream latency (joint rates by
:func:`fts_calib.filters.joint_rates.joint_rates` over the chain's ``derivative_window_s``, then
:meth:`Kinematics.sensor_motion`). The latency starts at the one given (the pipeline's
``live.latency_s`` for a recording, 0 for a live feed: its synchronizer applied it) and is then
estimated from the residuals of the payload just identified
(:func:`fts_calib.filters.latency.latency_regression` on the fit's residuals, with the offsets'
drift left out), the joints re-aligned and the payload fitted again, until the latency moves by
less than 20 us. Samples within half a derivative window of the samples' ends, or of a sample
missing (a row refused, a datagram lost), are left out (their rates come from a cut or uneven
window). Times in [s].
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np

from ..core.arrays import as_samples
from ..core.exceptions import PayloadError, ShapeError
from ..filters.joint_rates import MISSING_PERIODS, half_window, joint_rates, smoothed_like_acceleration
from ..filters.latency import latency_regression, latency_sums, wrench_rate
from ..filters.quasi_static import sample_period
from ..model.calibration import Calibration
from ..robot import inertial
from ..robot.kinematics import Kinematics
from ..robot.tool import STANDARD_GRAVITY
from ..sources.batch import SampleBatch
from .estimate import MOVING, NAMES, PAIRS, PayloadEstimate

#: Largest standard error of the mass, relative to it, that counts as determined (two of them: 0.5 %).
MAX_STDERR_MASS = 0.0025
#: Largest standard error of each coordinate of the centre of mass that counts as determined [m] (two: 1 mm).
MAX_STDERR_COM = 0.0005
#: Largest standard error of an element of the inertia, relative to its scale, that counts as determined (two: 10 %).
MAX_STDERR_INERTIA = 0.05
_INERTIA_FLOOR_M = 0.03  # [m] the inertia's scale is at least m times this squared (a body a few cm across)
_INERTIA_CEILING_M = 0.05  # [m] and at most m times this squared (an estimate the data do not support sets no scale)
_SIZE_M = 0.1  # [m] a payload's size: scales the parameters to compare what the data see of each
_UNSEEN = 1e-10  # singular value of the scaled design, relative to the largest: a direction the data do not see


def _derived(pi: np.ndarray) -> np.ndarray:
    """``[m, c (3), I_c elements (6)]`` of parameters ``pi`` (10,)."""
    mass, c, inertia = inertial.body(pi)
    return np.concatenate([[mass], c, [inertia[i, j] for i, j in PAIRS]])


def _derived_jacobian(pi: np.ndarray) -> np.ndarray:
    """``d derived / d pi`` (10, 10) by central differences (the map is a rational function, smooth for m > 0)."""
    steps = 1e-6 * np.maximum(np.abs(pi), 1e-6 * abs(pi[0]) + 1e-12)
    cols = [(_derived(pi + h * e) - _derived(pi - h * e)) / (2 * h) for h, e in zip(steps, np.eye(10), strict=True)]
    return np.stack(cols, axis=1)


def fit_payload_motion(
    w_measured,
    g_sensor,
    omega_sensor,
    alpha_sensor,
    a_sensor,
    joint_axes: Mapping[str, np.ndarray] | None = None,
    where: str = "the motion",
    check: bool = True,
    block_samples: int = 400,
    time=None,
) -> PayloadEstimate:
    """Identify a payload's ten inertial parameters and the offsets from samples of a motion (module docstring).

    Args:
        w_measured: Calibrated wrenches with the payload on, in time order [N, N m]. Shape (N, 6).
        g_sensor: Gravity in S [m/s^2]. Shape (N, 3).
        omega_sensor: Angular velocity of S in S [rad/s]. Shape (N, 3).
        alpha_sensor: Angular acceleration of S in S [rad/s^2]. Shape (N, 3).
        a_sensor: Classical acceleration of the origin of S in S [m/s^2]. Shape (N, 3).
        joint_axes: Joint name -> its axis in S (unit, shape (3,)) along the motion, to name
            the joint to move in a refusal; None: the refusal names sensor axes only.
        where: What the samples are, for messages (e.g. the recording's path).
        check: Refuse parameters whose standard error is beyond the bounds (False for a first
            fit that a later one refines; what the data do not see at all is always refused).
        block_samples: Consecutive samples per block of the standard errors (longer than the
            residuals' correlation: a few joint-rate windows).
        time: Sample times [s], shape (N,): the offsets drift linearly along the motion (six
            more unknowns, their rates); None: constant offsets.

    Raises:
        PayloadError: The motion does not determine a parameter; the message names it and what to add.
        ShapeError: Arrays of different lengths.
    """
    W, _ = as_samples(w_measured, 6, "w_measured")
    given = {"g_sensor": g_sensor, "omega_sensor": omega_sensor, "alpha_sensor": alpha_sensor, "a_sensor": a_sensor}
    arrays = [as_samples(v, 3, name)[0] for name, v in given.items()]
    if any(len(v) != len(W) for v in arrays):
        raise ShapeError(f"w_measured has {len(W)} rows but the motion arrays have {[len(v) for v in arrays]}: expected the same N")
    ok = np.all([np.all(np.isfinite(v), axis=1) for v in arrays], axis=0)
    Y = np.full((len(W), 6, 10), np.nan)
    Y[ok] = inertial.body_regressor(*[v[ok] for v in arrays])
    return fit_payload_regressor(W, Y, joint_axes, where, check, block_samples, time)


def fit_payload_regressor(
    w_measured,
    regressor: np.ndarray,
    joint_axes: Mapping[str, np.ndarray] | None = None,
    where: str = "the motion",
    check: bool = True,
    block_samples: int = 400,
    time=None,
) -> PayloadEstimate:
    """:func:`fit_payload_motion` from the regressor itself (e.g. filtered like the measurement).

    Args:
        w_measured: Calibrated wrenches, in time order [N, N m]. Shape (N, 6).
        regressor: ``Y`` with ``W = Y pi + d`` (:func:`fts_calib.robot.inertial.body_regressor`). Shape (N, 6, 10).
        joint_axes: See :func:`fit_payload_motion`.
        where: See :func:`fit_payload_motion`.
        check: See :func:`fit_payload_motion`.
        block_samples: See :func:`fit_payload_motion`.
        time: See :func:`fit_payload_motion`.

    Raises:
        PayloadError: The motion does not determine a parameter; the message names it and what to add.
        ShapeError: Arrays of different lengths.
    """
    W, _ = as_samples(w_measured, 6, "w_measured")
    Y = np.asarray(regressor, dtype=float)
    if Y.shape != (len(W), 6, 10):
        raise ShapeError(f"regressor has shape {Y.shape} but expected ({len(W)}, 6, 10), one (6, 10) per row of w_measured")
    ok = np.all(np.isfinite(W), axis=1) & np.all(np.isfinite(Y), axis=(1, 2))
    columns = [Y[ok], np.broadcast_to(np.eye(6), (int(ok.sum()), 6, 6))]
    half_s = 0.0
    if time is not None:
        t = np.asarray(time, dtype=float)
        if t.shape != (len(W),):
            raise ShapeError(f"time has shape {t.shape} but expected ({len(W)},), one per row of w_measured")
        t = t[ok]
        middle, half_s = (t[0] + t[-1]) / 2 if len(t) else 0.0, (t[-1] - t[0]) / 2 if len(t) > 1 else 0.0
        columns.append(np.eye(6)[None] * ((t - middle) / max(half_s, 1e-9))[:, None, None])  # within [-1, 1]
    W = W[ok]
    A = np.concatenate(columns, axis=2)
    p = A.shape[2]
    if len(W) < p:
        raise PayloadError(f"{where}: {len(W)} usable samples, but the payload and offsets are {p} unknowns")
    sigma = np.ones(6)
    for _ in range(2):  # unweighted, then weighted by each axis's residual spread
        w = 1.0 / sigma
        Aw = (A * w[None, :, None]).reshape(-1, p)
        normal = Aw.T @ Aw
        rhs = Aw.T @ (W * w).reshape(-1)
        scale = 1.0 / np.sqrt(np.maximum(np.diag(normal), 1e-300))
        x = scale * (np.linalg.pinv(normal * scale[:, None] * scale[None, :], rcond=1e-13, hermitian=True) @ (scale * rhs))
        residual = W - np.einsum("nij,j->ni", A, x)
        sigma = np.maximum(np.sqrt(np.mean(residual**2, axis=0)), 1e-12 * np.max(np.abs(W)) + 1e-15)
    # the offsets eliminated: the normal matrix of pi alone
    Npp, Npd, Ndd = normal[:10, :10], normal[:10, 10:], normal[10:, 10:]
    schur = Npp - Npd @ np.linalg.solve(Ndd, Npd.T)
    pi_hat = x[:10]
    _refuse_unseen(Aw, pi_hat, where, joint_axes)
    full_cov = _block_covariance(A * w[None, :, None], residual * w, normal, block_samples)
    cov = full_cov[:10, :10]
    stderr = np.sqrt(np.maximum(np.diag((G := _derived_jacobian(pi_hat)) @ cov @ G.T), 0.0))
    if check:
        _check_determined(_derived(pi_hat), stderr, where, joint_axes)
    pi, constrained = inertial.consistent_fit(pi_hat, schur)
    offsets = x[10:] - np.linalg.solve(Ndd, Npd.T @ (pi - pi_hat))  # the offsets' best fit for these parameters
    residual = W - np.einsum("nij,j->ni", A, np.concatenate([pi, offsets]))
    rate = offsets[6:] / half_s if len(offsets) > 6 and half_s > 0 else np.zeros(6)
    mass, com, inertia = inertial.body(pi)
    stderr = np.sqrt(np.maximum(np.diag((G := _derived_jacobian(pi)) @ cov @ G.T), 0.0))
    stderr_inertia = np.zeros((3, 3))
    for k, (i, j) in enumerate(PAIRS):
        stderr_inertia[i, j] = stderr_inertia[j, i] = stderr[4 + k]
    return PayloadEstimate(
        mass=mass,
        stderr_mass=float(stderr[0]),
        com=com,
        stderr_com=stderr[1:4],
        offsets=offsets[:6],
        stderr_offsets=np.sqrt(np.maximum(np.diag(full_cov)[10:16], 0.0)),
        residual_rms=np.sqrt(np.mean(residual**2, axis=0)),
        samples=len(W),
        motion=MOVING,
        inertia_com=inertia,
        stderr_inertia=stderr_inertia,
        offset_rate=rate,
        parameters=pi,
        unconstrained=pi_hat,
        constrained=constrained,
        latency_s=0.0,
    )


def _block_covariance(Aw: np.ndarray, rw: np.ndarray, normal: np.ndarray, block_samples: int) -> np.ndarray:
    """The covariance of the weighted least squares from its residuals, robust to their correlation in time.

    The "sandwich" ``N^-1 M N^-1`` with ``s_k = A_k^T r_k`` the score of the k-th block of
    consecutive samples (blocks longer than the residuals' correlation: the joint-rate
    estimates share their window) and ``M = K / (K - 1) sum_k (s_k s_k^T + (s_k s_{k+1}^T +
    s_{k+1} s_k^T) / 2)`` (Newey and West, Econometrica 1987, over blocks, one lag). A residual that the
    regressors cannot see (joint-rate noise far above the motion's frequencies) adds nothing,
    where the usual ``sigma^2 N^-1`` would count it in full.

    Args:
        Aw: Weighted regressor, shape (N, 6, p).
        rw: Weighted residuals, shape (N, 6).
        normal: ``Aw^T Aw``, shape (p, p).
        block_samples: Samples per block.

    Returns:
        Shape (p, p).
    """
    scores = np.einsum("nij,ni->nj", Aw, rw)
    blocks = max(2, len(scores) // max(int(block_samples), 1))
    block_scores = np.add.reduceat(scores, np.linspace(0, len(scores), blocks + 1).astype(int)[:-1], axis=0)
    cross = block_scores[1:].T @ block_scores[:-1]
    # neighbouring blocks share the residuals across their boundary (a differentiated noise: of
    # opposite sign), one lag with Bartlett's weight 1/2 (Newey-West; positive semi-definite)
    meat = (block_scores.T @ block_scores + 0.5 * (cross + cross.T)) * blocks / (blocks - 1)
    scale = 1.0 / np.sqrt(np.maximum(np.diag(normal), 1e-300))
    inverse = np.linalg.pinv(normal * scale[:, None] * scale[None, :], rcond=1e-13, hermitian=True) * np.outer(scale, scale)
    return inverse @ meat @ inverse


def _refuse_unseen(Aw: np.ndarray, pi_hat: np.ndarray, where: str, joint_axes) -> None:
    """Refuse directions of the parameters the data do not see at all, named.

    The singular values of the weighted design ``Aw`` (6N, 16 or 22), its columns scaled by their
    physical size (mass, mass times 10 cm, mass times (10 cm)^2, the weight and its moment at
    10 cm for the offsets): a direction below 1e-10 of the largest is not seen (rounding leaves
    about 1e-16; a weakly seen one is judged by its standard error), and a parameter more than
    half in those directions is named.
    """
    mass = max(abs(float(pi_hat[0])), 1e-9)
    weight = mass * STANDARD_GRAVITY
    scale = np.array([mass, *[mass * _SIZE_M] * 3, *[mass * _SIZE_M**2] * 6, *[weight] * 3, *[weight * _SIZE_M] * 3])
    scale = np.concatenate([scale, scale[10:]])[: Aw.shape[1]]  # the offsets' drift: its size over the motion like theirs
    _, values, vt = np.linalg.svd(Aw * scale[None, :], full_matrices=False)
    unseen = values <= _UNSEEN * values[0]
    if np.any(unseen):
        share = np.linalg.norm(vt[unseen, :10], axis=0)  # how much of each parameter lies in the unseen space (any basis of it)
        _refuse([NAMES[k] for k in np.nonzero(share > 0.5)[0]], {}, where, joint_axes)


def _check_determined(derived: np.ndarray, stderr: np.ndarray, where: str, joint_axes) -> None:
    """Refuse parameters whose standard error is beyond the module's bounds."""
    mass = abs(float(derived[0]))
    inertia = np.zeros((3, 3))
    for k, (i, j) in enumerate(PAIRS):
        inertia[i, j] = inertia[j, i] = derived[4 + k]
    largest = min(float(np.max(np.abs(np.linalg.eigvalsh(inertia)))), mass * _INERTIA_CEILING_M**2)  # a wild estimate sets no scale
    inertia_scale = max(largest, mass * _INERTIA_FLOOR_M**2)
    bounds = np.array([MAX_STDERR_MASS * mass, *[MAX_STDERR_COM] * 3, *[MAX_STDERR_INERTIA * inertia_scale] * 6])
    weak = {NAMES[k]: (float(stderr[k]), float(bounds[k])) for k in np.nonzero(~(stderr <= bounds))[0]}
    if weak:
        _refuse(list(weak), weak, where, joint_axes)


_AXES = "xyz"


def _refuse(names: list[str], weak: Mapping[str, tuple[float, float]], where: str, joint_axes) -> None:
    """Raise the PayloadError naming the undetermined parameters and what motion would add them."""

    def told(name: str) -> str:
        if name not in weak:
            return f"{name} (not seen at all)"
        err, bound = weak[name]
        unit = {"mass": "kg", "com": "m"}.get(name.split()[0], "kg·m²")
        return f"{name} (± {err:.2g} {unit}, above {bound:.2g})"

    inertia = [n for n in names if n.startswith("I")]
    others = [n for n in names if not n.startswith("I")]
    parts, advice = [], []
    if others:
        parts.append(", ".join(told(n) for n in others))
        advice.append("the mass and centre of mass need gravity seen from several directions: tilt the payload about two axes")
    if inertia:
        parts.append("the inertia about the centre of mass " + ", ".join(told(n) for n in inertia))
        axes = sorted({_AXES.index(n[1]) for n in inertia if n[1] == n[2]} or {_AXES.index(c) for n in inertia for c in n[1:]})
        about = " and ".join(_AXES[k] for k in axes)
        plural = "axes" if len(axes) > 1 else "axis"
        hint = f"the inertia about {about} is not excited: turn the sensor about its {about} {plural} with more angular acceleration"
        if joint_axes:
            hint += " (" + "; ".join(_joint_for(k, joint_axes) for k in axes) + ")"
        if len(inertia) == 6 and not others:
            hint += " (held still, the payload's mass and centre of mass come from the still poses: --motion still)"
        advice.append(hint)
    raise PayloadError(
        f"{where} does not determine the payload: {'; '.join(parts)}. " + "; ".join(advice)[0].upper() + "; ".join(advice)[1:]
    )


def _joint_for(axis: int, joint_axes: Mapping[str, np.ndarray]) -> str:
    """The joint whose axis is closest to the sensor's axis ``axis``, as advice."""
    name, best = max(((n, abs(float(np.asarray(v)[axis]))) for n, v in joint_axes.items()), key=lambda item: item[1])
    angle = math.degrees(math.acos(min(best, 1.0)))
    return f"{_AXES[axis]}: rotate {name}" + ("" if angle < 5 else f", {angle:.0f}° off that axis at the motion's middle")


_LATENCY_TOLERANCE_S = 2e-5  # [s] a latency step below this ends the alternation (the estimate's own error: tests/test_latency.py)
_ROUNDS = 5  # fits at most


def aligned_joints(time: np.ndarray, joints: np.ndarray, latency_s: float, continuous: np.ndarray) -> np.ndarray:
    """The joints at each sample's time when the readings are ``latency_s`` late: read at ``t + latency_s``.

    Args:
        time: Sample times [s], non-decreasing. Shape (N,).
        joints: Joint readings [rad]. Shape (N, n_joints).
        latency_s: How late the readings are [s] (the row of time t holds the joints of t - latency_s).
        continuous: Which joints are continuous (unwrapped before interpolating). Shape (n_joints,).

    Returns:
        Shape (N, n_joints); rows whose ``t + latency_s`` is outside the recording take its end value.
    """
    joints = np.array(joints, dtype=float)
    if np.any(continuous) and len(joints) > 1:
        joints[:, continuous] = np.unwrap(joints[:, continuous], axis=0)
    if latency_s == 0.0:
        return joints
    return np.stack([np.interp(time + latency_s, time, joints[:, k]) for k in range(joints.shape[1])], axis=1)


def _regressor(time, g, omega, alpha, a, window_s: float, dt: float) -> np.ndarray:
    """The regressor seen through the joint-rate window: its terms in gravity and speed smoothed, (N, 6, 10).

    The regressor is linear in the accelerations: ``Y(g, omega, alpha, a) = Y(g, omega, 0, 0) +
    Y(0, 0, alpha, a)``. The accelerations from the joint-rate estimates are already smoothed
    by the window's kernel, and the measured wrench is smoothed by it
    (:func:`fts_calib.filters.joint_rates.smoothed_like_acceleration`); the terms in gravity and speed are smoothed here, so that
    every term of the model sees the same smoothing (in the simulation this takes the inertia's
    bias from about 1 % to 0.2 %).
    """
    zero = np.zeros_like(g)
    rest = inertial.body_regressor(g, omega, zero, zero)
    smoothed, _ = smoothed_like_acceleration(time, rest.reshape(len(time), -1), window_s, dt)
    return smoothed.reshape(rest.shape) + inertial.body_regressor(zero, zero, alpha, a)


def _latency_left(
    time: np.ndarray, measured: np.ndarray, regressor: np.ndarray, estimate: PayloadEstimate, block_samples: int
) -> tuple[float, float]:
    """How much later the joints still are than the fit assumed, from its residuals.

    The regression of :mod:`fts_calib.filters.latency` (``W_meas - W_pred ~ tau dW_pred/dt``,
    each axis weighted by its residual spread) on the fit's own residuals, which leave out the
    offsets' drift (``estimate_latency`` takes constant offsets: a sensor warming up moved its
    estimate by 0.15 ms); its standard error from the spread of the estimates of blocks of
    ``block_samples``.

    Args:
        time: Sample times [s]. Shape (N,).
        measured: Measured wrenches [N, N m]. Shape (N, 6).
        regressor: The fit's regressor. Shape (N, 6, 10).
        estimate: The fit.
        block_samples: Samples per block.

    Returns:
        ``(latency step [s], its standard error [s])`` (0 and inf when the motion shows none).
    """
    predicted = regressor @ estimate.parameters
    middle = (time[0] + time[-1]) / 2
    residual = measured - predicted - estimate.offsets - np.outer(time - middle, estimate.offset_rate)
    rate = wrench_rate(time, predicted)
    ok = np.all(np.isfinite(rate), axis=1)  # repeated time stamps: no slope there
    rs, ss = latency_sums(residual[ok], rate[ok], 1.0 / np.maximum(estimate.residual_rms, 1e-15) ** 2)
    blocks = max(len(ss) // max(block_samples, 1), 1)
    step = latency_regression(rs, ss, np.linspace(0, len(ss), blocks + 1).astype(int)[:-1])
    return (0.0, math.inf) if step is None else (step.latency_s, step.stderr_s)


def fit_motion_samples(
    samples: SampleBatch,
    kin: Kinematics,
    calibration: Calibration,
    window_s: float = 0.05,
    latency_s: float = 0.0,
    fit_latency: bool = True,
    where: str = "the motion",
) -> PayloadEstimate:
    """Identify mass, centre of mass, inertia and offsets from the samples of a continuous motion (module docstring).

    Args:
        samples: The samples that passed the checks (time [s], joints [rad], channels), in time order.
        kin: Kinematics of the robot (its model's gravity is used).
        calibration: The sensor's calibration.
        window_s: Window of the joint-rate estimates [s] (the filter chain's ``derivative_window_s``).
        latency_s: How late the joint readings still are [s]: the start.
        fit_latency: Estimate the remaining latency (else ``latency_s`` is used as is).
        where: What the samples are, for the messages (a path, ``udp://HOST:PORT``).

    Raises:
        PayloadError: Too few samples, or a motion that does not determine the payload.
    """
    if len(samples) < 3:
        raise PayloadError(f"{where}: {len(samples)} usable rows, too few for a motion")
    time = samples.time
    dt = sample_period(time)
    wrench, smooth = smoothed_like_acceleration(time, calibration.wrench(samples.channels), window_s, dt)
    left_out = _gaps_left_out(time, smooth, window_s, dt)
    if left_out and int(smooth.sum()) < _UNKNOWNS:
        raise PayloadError(f"{where}: no motion left to fit: {left_out}; record the motion again without gaps")
    g_world = kin.g_world()
    middle = len(time) // 2
    block = max(int(round(8 * window_s / dt)), 40)  # samples per block of the standard errors: eight joint-rate windows
    lag, stderr_lag = float(latency_s), math.inf
    final = not fit_latency
    for round_ in range(_ROUNDS):
        joints = aligned_joints(time, samples.joints, lag, kin.continuous)
        rates = joint_rates(time, joints, window_s, dt, kin.continuous, order=2)
        motion = kin.sensor_motion(joints, rates.velocity, rates.acceleration)
        R = motion.R_world_sensor
        g = np.einsum("nji,j->ni", R, g_world)
        keep = smooth.copy()
        keep &= (time + lag >= time[0]) & (time + lag <= time[-1])
        axes = {name: R[middle].T @ kin.joint_axis_world(joints[middle], name) for name in kin.joint_names}
        regressor = _regressor(time, g, motion.omega, motion.alpha, motion.a, window_s, dt)
        estimate = fit_payload_regressor(wrench[keep], regressor[keep], axes, where, final, block, time[keep])
        if final:
            break
        step, stderr_lag = _latency_left(time[keep], wrench[keep], regressor[keep], estimate, block)
        lag += step
        # the last fit is the one checked: with the joints aligned (what is left is below the tolerance)
        final = abs(step) < _LATENCY_TOLERANCE_S or round_ == _ROUNDS - 2
    used = time[keep]
    duration_s = float(used[-1] - used[0]) if len(used) else 0.0
    return dataclasses.replace(estimate, latency_s=lag, stderr_latency_s=stderr_lag, duration_s=duration_s, left_out=left_out)


#: Unknowns of the motion's fit: the ten parameters, the offsets and their drift.
_UNKNOWNS = 22


def _gaps_left_out(time: np.ndarray, whole: np.ndarray, window_s: float, dt: float) -> str:
    """The samples left out near gaps in ``time`` (s, (N,)), in words; '' when none.

    ``whole`` (N,) marks the samples whose joint-rate window is whole and even; those within half
    a window of either end are left out whatever the gaps, and are not counted here.
    """
    half = half_window(window_s, dt)
    gaps = np.flatnonzero(np.diff(time) > MISSING_PERIODS * dt)
    inner = np.zeros(len(time), dtype=bool)
    inner[half : len(time) - half] = True
    cut = int(np.count_nonzero(inner & ~whole))
    if not cut or not len(gaps):
        return ""
    where = ", ".join(f"{time[k]:.3f}" for k in gaps[:3]) + (", ..." if len(gaps) > 3 else "")
    return (
        f"{cut:,} of {len(time):,} samples left out, within {1e3 * half * dt:.0f} ms of {len(gaps):,} gap(s) in the samples "
        f"(rows refused or datagrams lost; their joint rates would come from uneven windows), after t = {where} s"
    )

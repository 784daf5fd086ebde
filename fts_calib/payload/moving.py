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
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..core.arrays import as_samples, frozen
from ..core.exceptions import PayloadError, ShapeError
from ..robot import inertial
from ..robot.tool import STANDARD_GRAVITY, Tool, ToolConfiguration

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
#: Names of the derived parameters, in the order of :attr:`MotionPayloadEstimate.stderr`.
NAMES = ("mass", "com x", "com y", "com z", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")
_PAIRS = ((0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2))


@dataclass(frozen=True)
class MotionPayloadEstimate:
    """A payload identified from a continuous motion.

    Attributes:
        mass: [kg].
        com: Centre of mass in the sensor frame [m]. Shape (3,).
        inertia_com: Inertia about the centre of mass, axes of S [kg m^2]. Shape (3, 3).
        stderr: Standard errors of :data:`NAMES` (mass [kg], com [m], inertia elements
            [kg m^2]). Shape (10,).
        offsets: Wrench offsets [N, N, N, N m, N m, N m] (at the middle of the motion when they
            drift). Shape (6,).
        stderr_offsets: Same units. Shape (6,).
        offset_rate: How fast the offsets drift [N/s, N m/s] (zeros when not estimated). Shape (6,).
        parameters: The ten inertial parameters (:mod:`fts_calib.robot.inertial`). Shape (10,).
        unconstrained: The unconstrained least-squares parameters. Shape (10,).
        constrained: Whether the consistency constraint moved the estimate.
        residual_rms: Per axis [N, N m]. Shape (6,).
        samples: Samples used.
        latency_s: Latency of the joint stream applied [s] (recordings; 0 for arrays).
        stderr_latency_s: Its standard error [s] (inf when not estimated).
    """

    mass: float
    com: np.ndarray
    inertia_com: np.ndarray
    stderr: np.ndarray
    offsets: np.ndarray
    stderr_offsets: np.ndarray
    offset_rate: np.ndarray
    parameters: np.ndarray
    unconstrained: np.ndarray
    constrained: bool
    residual_rms: np.ndarray
    samples: int
    latency_s: float = 0.0
    stderr_latency_s: float = math.inf

    def __post_init__(self):
        names = ("com", "inertia_com", "stderr", "offsets", "stderr_offsets", "offset_rate", "parameters", "unconstrained", "residual_rms")
        for name in names:
            object.__setattr__(self, name, frozen(getattr(self, name)))

    @property
    def stderr_mass(self) -> float:
        """[kg]."""
        return float(self.stderr[0])

    @property
    def stderr_com(self) -> np.ndarray:
        """[m], shape (3,)."""
        return self.stderr[1:4]

    @property
    def stderr_inertia(self) -> np.ndarray:
        """Standard errors of the inertia about the centre of mass [kg m^2], shape (3, 3)."""
        out = np.zeros((3, 3))
        for k, (i, j) in enumerate(_PAIRS):
            out[i, j] = out[j, i] = self.stderr[4 + k]
        return out

    def tool(self, name: str = "payload", gravity: float = STANDARD_GRAVITY) -> Tool:
        """The payload as a tool with one configuration, with its inertia (for :func:`fts_calib.robot.tool.save_tool`).

        A body on the consistency boundary (a principal moment of zero, or one equal to the sum
        of the other two) can miss it by rounding; its principal moments are put back on it.
        """
        values, vectors = np.linalg.eigh((self.inertia_com + self.inertia_com.T) / 2)
        values = np.maximum(values, 1e-9 * max(float(values[2]), 0.0))  # a moment of zero would come back as -1e-20
        values[2] = min(values[2], values[0] + values[1])
        inertia = (vectors * values) @ vectors.T
        return Tool(name=name, gravity=gravity, configurations=(ToolConfiguration(name, self.mass, self.com, inertia),))


def _derived(pi: np.ndarray) -> np.ndarray:
    """``[m, c (3), I_c elements (6)]`` of parameters ``pi`` (10,)."""
    mass, c, inertia = inertial.body(pi)
    return np.concatenate([[mass], c, [inertia[i, j] for i, j in _PAIRS]])


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
) -> MotionPayloadEstimate:
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
) -> MotionPayloadEstimate:
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
    return MotionPayloadEstimate(
        mass=mass,
        com=com,
        inertia_com=inertia,
        stderr=stderr,
        offsets=offsets[:6],
        stderr_offsets=np.sqrt(np.maximum(np.diag(full_cov)[10:16], 0.0)),
        offset_rate=rate,
        parameters=pi,
        unconstrained=pi_hat,
        constrained=constrained,
        residual_rms=np.sqrt(np.mean(residual**2, axis=0)),
        samples=len(W),
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
    for k, (i, j) in enumerate(_PAIRS):
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
            hint += " (held still, the payload's mass and centre of mass come from the still poses: leave out --motion)"
        advice.append(hint)
    raise PayloadError(
        f"{where} does not determine the payload: {'; '.join(parts)}. " + "; ".join(advice)[0].upper() + "; ".join(advice)[1:]
    )


def _joint_for(axis: int, joint_axes: Mapping[str, np.ndarray]) -> str:
    """The joint whose axis is closest to the sensor's axis ``axis``, as advice."""
    name, best = max(((n, abs(float(np.asarray(v)[axis]))) for n, v in joint_axes.items()), key=lambda item: item[1])
    angle = math.degrees(math.acos(min(best, 1.0)))
    return f"{_AXES[axis]}: rotate {name}" + ("" if angle < 5 else f", {angle:.0f}° off that axis at the motion's middle")

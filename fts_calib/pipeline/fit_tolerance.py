r"""What the tolerances declared in the tool and robot files leave in the fit check's residuals.

A tool is known to a tolerance (the tool file's ``tolerance: {mass, com}``) and the sensor's
mount and joint readings to the robot file's ``accuracy`` (``mount_rotation``,
``encoder_resolution``): the accuracy budget's own terms (:mod:`fts_calib.robot.sensitivities`).
An error within them changes the known wrench of every sample, and the part of that change the
fit cannot absorb into ``[C_bar, D]`` shows as residual. The fit check
(:mod:`fts_calib.pipeline.fit`) expects it, beside the strain noise:

- the errors are the budget's: one mass error, one centre-of-mass error (3 coordinates) and one
  mount rotation (3 axes) for the run, common to every configuration (the tool file's meaning:
  one body moved between configurations, :class:`fts_calib.robot.tool.ToolTolerance`), each
  independent and uniform within its bound (standard deviation bound / sqrt(3));
- they enter the known wrench linearly in gravity, so each is a change of every
  configuration's wrench matrix ``M_c`` (eqs 17-18) per unit error: the mass,
  ``dM_c = M_c / m_c``; a coordinate ``a`` of the centre of mass, ``dM_c = [0; m_c [e_a]x]``;
  the mount rotated about axis ``a`` of S, ``dM_c = M_c [e_a]x``;
- each is fitted on the same sums as the fit itself (``[C_bar, D]`` from ``sum_c dM_c S_gx,c``
  and ``S_XX``, the offset model's columns included), and what it leaves is its residual sum of
  squares per configuration and axis, ``RSS_p,c,j`` for a unit error p: the error projected off
  the fitted model's column space, exactly. The centre-of-mass error leaves nothing (a common
  lever is ``dW = A W``: C_bar absorbs it, it is a budget term, not a residual), nor does a mass
  error when the masses are equal (a scale); a rotated mount on centres of mass that differ
  leaves some. A centre of mass off in one configuration alone is not what the file declares:
  the budget does not cover it, and the check refuses it beyond the noise and this allowance.
  The tolerance part of configuration c, axis j, is the standard deviation of the residual the
  errors leave, ``sigma_T,c,j^2 = sum_p sigma_p^2 RSS_p,c,j / n_c``;
- a joint-reading error is a new draw at every stop (the budget's encoder term): the fit
  absorbs little of it, so it enters unprojected, as a rotation of gravity by
  ``sqrt(n_joints / 12)`` encoder steps: ``|row_j M_c| |g| resolution sqrt(n_joints / 12)``.
  Stream latency and jitter act on moving samples only, which the quasi-static filter keeps
  few of: they are not in the allowance.

Per axis the tolerance part is the largest over the configurations. The fit check adds it in
quadrature to the strain noise, ``sigma_j = sqrt(sigma_W,j^2 + sigma_T,j^2)``, and keeps its
limit of 3 such standard deviations: for one or a few dominant errors that covers the worst
corner of the declared box (sqrt(3) sigma for one), while an error 5 times a tolerance is
refused (5 sqrt(3) ~ 8.7 sigma; one configuration's centre of mass 5 tolerances off: 29-32 times,
tests/tolerance_sweep.py). Beside it, an absolute floor (the pipeline setting
``fit.floor``, 0.01 % of each axis's full scale by default): a residual RMS below it never
refuses. Units: N for forces, N m for moments, rad, m, kg.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..model.sensor import WRENCH_AXES, WRENCH_UNITS
from ..robot.definition import RobotAccuracy
from ..robot.tool import Tool
from .settings import DEFAULT_FLOOR_PERCENT

#: Largest accepted ratio of a configuration's residual RMS to the expected residual (noise and tolerances), per axis.
#: A consistent fit over hundreds of samples gives 1 +- a few %: 3 leaves room for the
#: unmodelled dynamics the filter lets through, wrong data give 1e3 to 1e7.
MAX_RATIO = 3.0
#: Floor of the expected residual, relative to the tool's weight (forces) and moment (moments).
RELATIVE_FLOOR = 1e-6


@dataclass(frozen=True)
class FitAllowance:
    """What the fit check allows beside the strain noise and the tool file's tolerance.

    Attributes:
        mount_rotation: Bound of the sensor mount's rotation error about each axis of S [rad]
            (the robot file's ``accuracy.mount_rotation``); 0 for none.
        encoder_resolution: Step of a joint reading [rad] (``accuracy.encoder_resolution``); 0 for none.
        n_joints: Joints whose readings place the sensor.
        floor: Absolute floor of the residual RMS per axis, [N, N, N, N m, N m, N m], shape (6,):
            below it a residual never refuses; None for none.
    """

    mount_rotation: float = 0.0
    encoder_resolution: float = 0.0
    n_joints: int = 0
    floor: np.ndarray | None = None


def robot_allowance(accuracy: RobotAccuracy, n_joints: int, full_scale, floor_percent: float = DEFAULT_FLOOR_PERCENT) -> FitAllowance:
    """The allowance of a robot file's accuracy and a sensor's full scale.

    Args:
        accuracy: The robot file's ``accuracy`` (mount tolerance [rad], encoder step [rad]).
        n_joints: Joints of the robot.
        full_scale: Full scale per axis [N, N, N, N m, N m, N m], shape (6,).
        floor_percent: The setting ``fit.floor``, in % of each axis's full scale.
    """
    floor = np.asarray(full_scale, dtype=float).reshape(6) * floor_percent / 100.0
    return FitAllowance(accuracy.mount_rotation, accuracy.encoder_resolution, int(n_joints), floor)


def _cross(axis: int) -> np.ndarray:
    """``[e_axis]x`` (3, 3)."""
    return np.cross(np.eye(3)[axis], np.eye(3)).T  # column i: e_axis x e_i


def unit_errors(tool: Tool, matrices: Sequence[np.ndarray], mount_rotation: float) -> tuple[np.ndarray, np.ndarray]:
    """The declared errors as changes of the wrench matrices (see the module docstring).

    Args:
        tool: The tool file (its ``tolerance``; none when None).
        matrices: The wrench matrices ``M_c`` judged, shape (6, 3) each (a hypothesis's: the mass is ``M_c[0, 0]``).
        mount_rotation: Bound of the mount's rotation about each axis [rad].

    Returns:
        ``(sigma (P,), dM (P, k, 6, 3))``: each error's standard deviation (uniform within its bound) and the change
        of every configuration's matrix per unit of it; P = 0 when nothing is declared.
    """
    k = len(matrices)
    sigmas: list[float] = []
    changes: list[np.ndarray] = []
    tolerance = tool.tolerance
    masses = [float(M[0, 0]) for M in matrices]
    if tolerance is not None and tolerance.mass > 0 and min(masses) > 0:  # one mass error, every configuration
        changes.append(np.stack([M / m for M, m in zip(matrices, masses, strict=True)]))
        sigmas.append(tolerance.mass / math.sqrt(3.0))
    for axis in range(3):
        if tolerance is not None and tolerance.com > 0:  # one centre-of-mass error, every configuration
            change = np.zeros((k, 6, 3))
            change[:, 3:] = np.multiply.outer(masses, _cross(axis))
            changes.append(change)
            sigmas.append(tolerance.com / math.sqrt(3.0))
        if mount_rotation > 0:  # one mount rotation, every configuration
            changes.append(np.stack([M @ _cross(axis) for M in matrices]))
            sigmas.append(mount_rotation / math.sqrt(3.0))
    return np.array(sigmas), np.array(changes).reshape(len(changes), k, 6, 3)


def projected_rss(changes: np.ndarray, sums: np.ndarray, embeddings: Sequence[np.ndarray]) -> np.ndarray:
    """What the fit leaves of each change of the wrench matrices: its residual sum of squares.

    Args:
        changes: ``dM`` per error and configuration, shape (P, k, 6, 3).
        sums: Per configuration the fit sums ``sum y y^T``, ``y = [g_sensor; P Delta; 1; drift]``, shape (k, q, q).
        embeddings: Per configuration the map of its ``[P Delta; 1; drift]`` into the joint regressor
            (:func:`fts_calib.pipeline.fit._embeddings`).

    Returns:
        Per error, configuration and axis, shape (P, k, 6), in [N^2, N^2 m^2 per unit error^2]; zeros when the
        regressors do not determine the fit.
    """
    P, k = changes.shape[:2]
    if P == 0:
        return np.zeros((0, k, 6))
    S_gg = np.stack([s[:3, :3] for s in sums])
    S_gx = np.stack([s[:3, 3:] @ e.T for s, e in zip(sums, embeddings, strict=True)])
    S_xx = np.stack([e @ s[3:, 3:] @ e.T for s, e in zip(sums, embeddings, strict=True)])
    S_XX = S_xx.sum(axis=0)
    S_WX = np.einsum("pcij,cjk->pik", changes, S_gx)  # (P, 6, r)
    scale = 1.0 / np.sqrt(np.maximum(np.diag(S_XX), 1e-300))
    try:
        inverse = np.linalg.inv(S_XX * scale[:, None] * scale[None, :]) * scale[:, None] * scale[None, :]
    except np.linalg.LinAlgError:
        return np.zeros((P, k, 6))
    theta = S_WX @ inverse  # (P, 6, r): [C_bar, D, ...] fitted to the change alone
    own = np.einsum("pcij,cjl,pcil->pci", changes, S_gg, changes)
    cross = np.einsum("pir,pcij,cjr->pci", theta, changes, S_gx)
    quad = np.einsum("pir,crs,pis->pci", theta, S_xx, theta)
    return np.maximum(own - 2.0 * cross + quad, 0.0)


def tolerance_residual(
    tool: Tool,
    matrices: Sequence[np.ndarray],
    sums: np.ndarray,
    embeddings: Sequence[np.ndarray],
    counts: np.ndarray,
    allowance: FitAllowance | None,
) -> np.ndarray:
    """The residual RMS the declared tolerances leave, per axis (see the module docstring).

    Args:
        tool: The tool file (its ``tolerance`` and ``gravity``).
        matrices: The wrench matrices judged, shape (6, 3) each.
        sums: Per configuration the fit sums, shape (k, q, q).
        embeddings: Per configuration the map into the joint regressor.
        counts: Samples per configuration, shape (k,).
        allowance: The robot's mount and encoders (None: the tool's tolerance alone).

    Returns:
        The standard deviation per axis, the largest over the configurations with samples,
        [N, N, N, N m, N m, N m], shape (6,).
    """
    allowance = allowance or FitAllowance()
    counts = np.asarray(counts, dtype=float)
    sigma, changes = unit_errors(tool, matrices, allowance.mount_rotation)
    rss = projected_rss(changes, sums, embeddings)
    variance = np.einsum("p,pcj->cj", sigma**2, rss) / np.maximum(counts, 1.0)[:, None]
    if allowance.encoder_resolution > 0 and allowance.n_joints > 0:
        angle = allowance.encoder_resolution * math.sqrt(allowance.n_joints / 12.0)
        rows = np.linalg.norm(np.stack([np.asarray(M, dtype=float) for M in matrices]), axis=2)  # |row_j M_c|, (k, 6)
        variance = variance + (rows * tool.gravity * angle) ** 2
    seen = counts > 0
    return np.sqrt(variance[seen].max(axis=0)) if seen.any() else np.zeros(6)


def noise_residual(C_bar: np.ndarray, noise_cov: np.ndarray) -> np.ndarray:
    """The residual the strain noise explains per axis, ``sqrt(diag(C_bar Sigma_P C_bar^T))``; shape (6,), [N, N m].

    Args:
        C_bar: Modified calibration matrix (a nonlinear model's slope), shape (6, 6).
        noise_cov: Covariance of ``P Delta`` of one sample, shape (6, 6).
    """
    return np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", C_bar, noise_cov, C_bar), 0.0))


def expected_residual(tool: Tool, C_bar: np.ndarray, noise_cov: np.ndarray, tolerance=None, floor=None) -> np.ndarray:
    """The residual expected per axis: noise and declared tolerances in quadrature, floored; shape (6,), [N, N m].

    ``max(sqrt(sigma_W^2 + sigma_T^2), RELATIVE_FLOOR x weight (moment), floor / MAX_RATIO)`` with
    ``sigma_W`` the noise (:func:`noise_residual`) and ``sigma_T`` the tolerance part: a residual RMS below
    ``floor`` never gives a ratio above :data:`MAX_RATIO`.

    Args:
        tool: The tool file (its weight and moment set the relative floor, :data:`RELATIVE_FLOOR`).
        C_bar: Modified calibration matrix (a nonlinear model's slope), shape (6, 6).
        noise_cov: Covariance of ``P Delta`` of one sample, shape (6, 6).
        tolerance: What the declared tolerances leave per axis
            (:func:`fts_calib.pipeline.fit_tolerance.tolerance_residual`), shape (6,); None for none.
        floor: The absolute floor ``fit.floor`` per axis [N, N m], shape (6,); None for none.
    """
    sigma = noise_residual(C_bar, noise_cov)
    if tolerance is not None:
        sigma = np.hypot(sigma, np.asarray(tolerance, dtype=float))
    weight = max(c.mass for c in tool.configurations) * tool.gravity
    moment = max(c.mass * float(np.linalg.norm(c.p_sensor_com)) for c in tool.configurations) * tool.gravity
    relative = RELATIVE_FLOOR * np.array([weight] * 3 + [max(moment, 1e-3 * weight)] * 3)
    absolute = np.zeros(6) if floor is None else np.asarray(floor, dtype=float) / MAX_RATIO
    return np.maximum.reduce([sigma, relative, absolute])


def expected_words(worst: str, expected: np.ndarray, noise, tolerance, floor) -> str:
    """What the expected residual of the worst axis is made of, when more than the noise; '' otherwise.

    Args:
        worst: Where the largest ratio is ('configuration B, Mx').
        expected: The expected residual per axis [N, N m], shape (6,).
        noise: Its noise part, shape (6,), or None.
        tolerance: Its tolerance part, shape (6,), or None.
        floor: The absolute floor ``fit.floor``, shape (6,), or None.

    Returns:
        E.g. ': noise 0.00023 N·m and declared tolerances 0.0011 N·m'.
    """
    axis = next((k for k, name in enumerate(WRENCH_AXES) if worst.endswith(f", {name}")), None)
    if axis is None or noise is None:
        return ""
    unit, sigma = WRENCH_UNITS[axis], float(noise[axis])
    parts = []
    if tolerance is not None and float(tolerance[axis]) > 0.1 * sigma:
        parts.append(f"noise {sigma:.2g} {unit} and declared tolerances {float(tolerance[axis]):.2g} {unit}")
    if floor is not None and MAX_RATIO * float(expected[axis]) <= float(floor[axis]) * (1.0 + 1e-9):
        parts.append(f"a residual below fit.floor, {float(floor[axis]):.2g} {unit}, never refuses")
    return ": " + "; ".join(parts) if parts else ""

r"""Payload identification from still poses: mass, centre of mass and offsets of an unknown tool.

From calibrated wrenches measured with the tool held still in several orientations, and the
gravity the sensor sees in each (from the kinematics), the model is linear in the unknowns
``m`` [kg], ``m c`` [kg m] (c: centre of mass in S) and the wrench offsets ``d`` [N, N m]:

.. math::

    F = m\,g_S + d_F, \qquad M = (m c) \times g_S + d_M = -[g_S]_\times (m c) + d_M

Least squares over every sample, weighted by the residual spread of each axis; the
standard errors come from the weighted normal matrix, and those of c = (m c) / m by first-
order propagation. With ``mount=True`` the small rotation ``delta`` [rad] between the sensor
frame the kinematics assume and the real one is estimated too (``g_real = g_S - delta x
g_S``), by Gauss-Newton from the linear solution.

The identification judges the whole set of orientations, not pairs of them: the RMS spread
of the unit gravity directions about their mean along the two principal axes of their
scatter (:func:`orientation_spread`). Gravity along one direction (spread below
``min_spread_deg`` on the first axis) cannot tell the mass from the force offsets; a swing
about one axis only (spread below it on the second) leaves the centre of mass along that
axis undetermined; each is refused with what is missing. Beyond that, the conditioning of
the fit refuses what the spread lets through, and the standard errors of mass and centre of
mass say how well the set determines them: 100 poses tilted within 25° of vertical work.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.arrays import as_samples
from ..core.exceptions import PayloadError, ShapeError
from .estimate import STILL, PayloadEstimate

_SAME_POSE_DEG = 5.0  # gravity directions closer than this are one orientation
#: Smallest RMS spread of the gravity directions along each of two axes [deg] (``--min-spread``).
MIN_SPREAD_DEG = 3.0
#: Unknowns of a still fit: mass, centre of mass (3) and offsets (6); a fit needs at least that many samples.
STILL_UNKNOWNS = 10
_MAX_CONDITION = 1e8  # scaled normal matrix above this: the payload is not determined


def group_orientations(g_sensor: np.ndarray, same_deg: float = _SAME_POSE_DEG) -> tuple[np.ndarray, np.ndarray]:
    """Group samples into orientations: gravity directions within ``same_deg`` of each other.

    Returns:
        ``(label of each sample (N,), mean unit direction of each orientation (K, 3))``, in
        order of first appearance.
    """
    unit = g_sensor / np.linalg.norm(g_sensor, axis=1, keepdims=True)
    labels = np.full(len(unit), -1)
    cos_same = math.cos(math.radians(same_deg))
    means: list[np.ndarray] = []
    while True:  # one pass per orientation: the first sample not yet grouped starts the next
        free = np.nonzero(labels < 0)[0]
        if not len(free):
            break
        members = free[unit[free] @ unit[free[0]] >= cos_same]
        labels[members] = len(means)
        mean = unit[members].mean(axis=0)
        means.append(mean / np.linalg.norm(mean))
    return labels, np.array(means).reshape(-1, 3)


def orientation_spread(g_sensor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The spread of the gravity directions: RMS angle about their mean along its two principal axes.

    The eigen-decomposition of the scatter of the unit directions ``u`` about their mean,
    ``S = mean((u - u_mean)(u - u_mean)^T)``: an eigenvalue ``lambda`` is an RMS swing of
    ``asin(sqrt(lambda))`` along its eigenvector, tangent to the sphere.

    Args:
        g_sensor: Gravity at each sample [m/s^2], shape (N, 3).

    Returns:
        ``(spread [deg], largest first, shape (2,); the two axes in the sensor frame (unit), shape (2, 3))``.
    """
    unit = g_sensor / np.linalg.norm(g_sensor, axis=1, keepdims=True)
    centred = unit - unit.mean(axis=0)
    values, vectors = np.linalg.eigh(centred.T @ centred / len(unit))
    order = np.argsort(values)[::-1][:2]
    spread = np.degrees(np.arcsin(np.sqrt(np.clip(values[order], 0.0, 1.0))))
    return spread, vectors[:, order].T


def _check_orientations(g: np.ndarray, poses: np.ndarray, min_spread_deg: float) -> np.ndarray:
    """Refuse a set of gravity directions that cannot determine the payload; return its spread [deg], (2,)."""
    spread, axes = orientation_spread(g)
    where = f"{len(g):,} samples in {len(poses)} orientation(s) (within {_SAME_POSE_DEG:.0f}° count as one)"
    if spread[0] < min_spread_deg:
        raise PayloadError(
            f"payload identification needs gravity seen from several directions, but the {where} see it along one "
            f"direction (RMS spread {spread[0]:.2f}°, below {min_spread_deg:g}°): the mass cannot be told from the "
            "force offsets, nor the centre of mass from the moment offsets. Add poses with the tool tilted by 20° or "
            "more about two different axes."
        )
    if spread[1] < min_spread_deg:
        axis = ", ".join(f"{v:+.2f}" for v in axes[0])
        raise PayloadError(
            f"the gravity directions of the {where} swing about one axis only (RMS spread {spread[0]:.1f}° along "
            f"({axis}) in the sensor frame, {spread[1]:.2f}° across, below {min_spread_deg:g}°): the centre of mass "
            "along that direction is undetermined. Add poses tilted about a second axis."
        )
    return spread


def _design(g: np.ndarray) -> np.ndarray:
    """Rows of the linear model for samples g (N, 3): shape (6N, 10), unknowns [m, mc, d]."""
    n = len(g)
    A = np.zeros((n, 6, 10))
    A[:, :3, 0] = g
    zero = np.zeros(n)
    # -[g]x (mc): rows of -skew(g)
    A[:, 3, 1:4] = np.stack([zero, g[:, 2], -g[:, 1]], axis=1)
    A[:, 4, 1:4] = np.stack([-g[:, 2], zero, g[:, 0]], axis=1)
    A[:, 5, 1:4] = np.stack([g[:, 1], -g[:, 0], zero], axis=1)
    A[:, np.arange(6), 4 + np.arange(6)] = 1.0
    return A


def _weighted_solve(A: np.ndarray, y: np.ndarray, sigma: np.ndarray):
    """Least squares of y (N, 6) on A (N, 6, p), rows weighted by 1/sigma per axis."""
    w = 1.0 / sigma
    Aw = (A * w[None, :, None]).reshape(-1, A.shape[2])
    yw = (y * w[None, :]).reshape(-1)
    N = Aw.T @ Aw
    scale = 1.0 / np.sqrt(np.diag(N))
    Ns = N * scale[:, None] * scale[None, :]
    condition = np.linalg.cond(Ns)
    x = scale * np.linalg.solve(Ns, scale * (Aw.T @ yw))
    cov = np.linalg.inv(Ns) * scale[:, None] * scale[None, :]
    return x, cov, condition


def fit_payload_still(w_measured, g_sensor, mount: bool = False, min_spread_deg: float = MIN_SPREAD_DEG) -> PayloadEstimate:
    """Identify a payload from still samples in several orientations (see the module docstring).

    The arrays' form (``fts_calib.identify_payload(w_measured, g_sensor)`` calls it); from a
    recording or a live feed: :func:`fts_calib.payload.identify.identify_payload`.

    Args:
        w_measured: Calibrated wrenches with the payload on [N, N m], shape (N, 6).
        g_sensor: Gravity in the sensor frame at each sample [m/s^2], shape (N, 3).
        mount: Also estimate the small rotation of the sensor mount.
        min_spread_deg: Smallest RMS spread of the gravity directions along each of two axes [deg].

    Raises:
        PayloadError: Fewer samples than :data:`STILL_UNKNOWNS` (with ``mount``, 3 more), gravity
            directions along one direction or one axis, or a fit too poorly conditioned; the
            message names what is missing.
        ShapeError: Wrong shapes.
    """
    W, _ = as_samples(w_measured, 6, "w_measured")
    g, _ = as_samples(g_sensor, 3, "g_sensor")
    if len(W) != len(g):
        raise ShapeError(f"w_measured has {len(W)} rows but g_sensor has {len(g)}: expected the same N")
    ok = np.all(np.isfinite(W), axis=1) & np.all(np.isfinite(g), axis=1)
    W, g = W[ok], g[ok]
    unknowns = STILL_UNKNOWNS + (3 if mount else 0)
    if len(W) < unknowns:  # none at all would be a mean of nothing and an eigen-decomposition of NaN
        raise PayloadError(
            f"{len(W)} still samples, but the payload and offsets are {unknowns} unknowns (each sample gives 6 "
            "equations, and the orientations must differ): record the payload held still in several orientations"
        )
    _, poses = group_orientations(g)
    spread = _check_orientations(g, poses, min_spread_deg)
    A = _design(g)
    sigma = np.ones(6)
    for _ in range(2):  # unweighted, then weighted by the residual spread of each axis
        x, cov, condition = _weighted_solve(A, W, sigma)
        residual = W - np.einsum("nij,j->ni", A, x)
        sigma = np.maximum(np.sqrt(np.mean(residual**2, axis=0)), 1e-12 * np.max(np.abs(W)) + 1e-15)
    if condition > _MAX_CONDITION:
        raise PayloadError(
            f"the {len(poses)} orientations do not determine the centre of mass (condition {condition:.1e}): "
            "they lie too close to one plane through gravity. Add a pose with the tool axis rotated by 90°."
        )
    delta = cov_delta = None
    if mount:
        x, cov, delta, cov_delta, residual = _with_mount(A, W, g, x, sigma)
    dof = max(W.size - len(x), 1)
    chi2 = float(np.sum((residual / sigma) ** 2)) / dof  # ~1 when sigma describes the noise
    cov = cov * chi2
    m, mc = x[0], x[1:4]
    com = mc / m
    # c = mc / m: dc/dmc = I / m, dc/dm = -mc / m^2
    J = np.hstack([-mc[:, None] / m**2, np.eye(3) / m])
    cov_c = J @ cov[:4, :4] @ J.T
    stderr = np.sqrt(np.maximum(np.diag(cov), 0.0))
    return PayloadEstimate(
        mass=float(m),
        stderr_mass=float(stderr[0]),
        com=com,
        stderr_com=np.sqrt(np.maximum(np.diag(cov_c), 0.0)),
        offsets=x[4:10],
        stderr_offsets=stderr[4:10],
        residual_rms=np.sqrt(np.mean(residual**2, axis=0)),
        samples=len(W),
        motion=STILL,
        mount_rotation=delta,
        stderr_mount_rotation=None if cov_delta is None else np.sqrt(np.maximum(np.diag(cov_delta) * chi2, 0.0)),
        poses=poses,
        spread_deg=spread,
        condition=float(condition),
        gravity=float(np.median(np.linalg.norm(g, axis=1))),  # the magnitude the mass was weighed against
    )


def _with_mount(A: np.ndarray, W: np.ndarray, g: np.ndarray, x: np.ndarray, sigma: np.ndarray):
    """Gauss-Newton on [m, mc, d, delta] with g_real = g - delta x g (small rotation)."""
    theta = np.concatenate([x, np.zeros(3)])
    for _ in range(20):
        delta = theta[10:]
        g_real = g - np.cross(delta, g)
        A_real = _design(g_real)
        predicted = np.einsum("nij,j->ni", A_real, theta[:10])
        # derivative of the prediction with respect to delta: d(g_real)/d(delta) = [g]x
        m, mc = theta[0], theta[1:4]
        skew_g = np.zeros((len(g), 3, 3))
        skew_g[:, 0, 1], skew_g[:, 0, 2] = -g[:, 2], g[:, 1]
        skew_g[:, 1, 0], skew_g[:, 1, 2] = g[:, 2], -g[:, 0]
        skew_g[:, 2, 0], skew_g[:, 2, 1] = -g[:, 1], g[:, 0]
        d_force = m * skew_g  # F = m g_real: dF/d(delta) = m [g]x
        # M = mc x g_real: dM/d(delta) = [mc]x [g]x
        skew_mc = np.array([[0, -mc[2], mc[1]], [mc[2], 0, -mc[0]], [-mc[1], mc[0], 0]])
        d_moment = skew_mc[None] @ skew_g
        J = np.concatenate([A_real, np.concatenate([d_force, d_moment], axis=1)], axis=2)
        step, cov, _ = _weighted_solve(J, W - predicted, sigma)
        theta = theta + step
        if np.max(np.abs(step[10:])) < 1e-12 and np.max(np.abs(step[:10])) < 1e-12 * (1 + np.max(np.abs(theta[:10]))):
            break
    delta = theta[10:]
    residual = W - np.einsum("nij,j->ni", _design(g - np.cross(delta, g)), theta[:10])
    return theta[:10], cov[:10, :10], delta.copy(), cov[10:, 10:], residual

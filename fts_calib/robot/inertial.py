r"""A rigid body's ten inertial parameters: the linear wrench regressor and physical consistency.

Frames and units: everything in the sensor frame S; the moment is about the origin of S; a
wrench is ``[Fx, Fy, Fz, Mx, My, Mz]`` in [N, N m]. The parameters are Pinocchio's dynamic
parameters (``pin.Inertia.toDynamicParameters``) of the body in S:

.. math::

    \pi = [m,\; h_x, h_y, h_z,\; I_{xx}, I_{xy}, I_{yy}, I_{xz}, I_{yz}, I_{zz}]

with ``h = m c`` [kg m] (c: centre of mass) and ``I_o = I_c + m ([c]_x^T [c]_x)`` the inertia
about the origin of S [kg m^2]. The wrench the moving body exerts on the sensor
(:func:`fts_calib.robot.tool.dynamic_wrench`, Newton-Euler about the origin of S) is linear
in them:

.. math::

    F = m\,(g - a) - \alpha \times h - \omega \times (\omega \times h), \qquad
    M = h \times (g - a) - I_o\,\alpha - \omega \times (I_o\,\omega)

(``omega``, ``alpha``: angular velocity and acceleration of S; ``a``: classical acceleration of
its origin; ``g``: gravity; all in S), i.e. ``W = Y(omega, alpha, a - g) pi``
(:func:`body_regressor`; it is minus Pinocchio's ``bodyRegressor``, which gives the wrench on
the body).

Physical consistency (Wensing, Kim and Slotine, "Linear matrix inequalities for physically
consistent inertial parameter identification", IEEE RA-L 2018): the parameters are those of a
real mass distribution (positive mass, positive-definite inertia about the centre of mass
whose principal moments satisfy the triangle inequalities) if and only if the pseudo-inertia
matrix

.. math::

    J = \begin{bmatrix} \Sigma & h \\ h^T & m \end{bmatrix}, \qquad
    \Sigma = \tfrac12 \operatorname{tr}(I_o)\,\mathbb 1 - I_o

is positive definite. The log-Cholesky parameters ``theta`` (Rucker and Wensing, "Smooth
parameterization of rigid-body inertia", IEEE RA-L 2022; ``pin.LogCholeskyParameters``)
write ``J = U U^T`` with ``U = e^alpha [[e^d1, s12, s13, t1], [0, e^d2, s23, t2], [0, 0,
e^d3, t3], [0, 0, 0, 1]]``: every real ``theta`` gives a consistent body and every
consistent body has one ``theta``, so a least squares over ``theta`` is constrained without
constraints (:func:`consistent_fit`).
"""

from __future__ import annotations

import numpy as np

from ..core.arrays import as_matrix, as_samples

#: Names of the ten parameters, in order (inertia about the origin of S).
PARAMETER_NAMES = ("m", "hx", "hy", "hz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")
_PAIRS = ((0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2))  # (row, column) of Ixx, Ixy, Iyy, Ixz, Iyz, Izz


def _cross_matrix(v: np.ndarray) -> np.ndarray:
    """``[v]x`` for a batch (N, 3): shape (N, 3, 3), column j = v x e_j."""
    return np.stack([np.cross(v, e) for e in np.eye(3)], axis=2)


def _inertia_map(w: np.ndarray) -> np.ndarray:
    """``L(w)`` with ``I w = L(w) [Ixx, Ixy, Iyy, Ixz, Iyz, Izz]``, for a batch (N, 3): shape (N, 3, 6)."""
    L = np.zeros((len(w), 3, 6))
    for k, (i, j) in enumerate(_PAIRS):
        L[:, i, k] += w[:, j]
        if i != j:
            L[:, j, k] += w[:, i]
    return L


def body_regressor(g_sensor, omega_sensor, alpha_sensor, a_sensor) -> np.ndarray:
    """The regressor ``Y`` with ``W = Y pi``: the wrench of a moving body on the sensor (module docstring).

    Args:
        g_sensor: Gravity in S [m/s^2]. Shape (N, 3).
        omega_sensor: Angular velocity of S in S [rad/s]. Shape (N, 3).
        alpha_sensor: Angular acceleration of S in S [rad/s^2]. Shape (N, 3).
        a_sensor: Classical acceleration of the origin of S in S [m/s^2]. Shape (N, 3).

    Returns:
        Shape (N, 6, 10): rows Fx..Mz, columns :data:`PARAMETER_NAMES`.
    """
    g, _ = as_samples(g_sensor, 3, "g_sensor")
    omega, _ = as_samples(omega_sensor, 3, "omega_sensor")
    alpha, _ = as_samples(alpha_sensor, 3, "alpha_sensor")
    a, _ = as_samples(a_sensor, 3, "a_sensor")
    free = g - a  # the apparent gravity at the origin of S
    skew_omega = _cross_matrix(omega)
    Y = np.zeros((len(g), 6, 10))
    Y[:, :3, 0] = free
    Y[:, :3, 1:4] = -(_cross_matrix(alpha) + skew_omega @ skew_omega)
    Y[:, 3:, 1:4] = -_cross_matrix(free)
    Y[:, 3:, 4:] = -(_inertia_map(alpha) + skew_omega @ _inertia_map(omega))
    return Y


def parameters(mass: float, p_sensor_com, inertia_com) -> np.ndarray:
    """The ten parameters of a body (module docstring), shape (10,).

    Args:
        mass: [kg].
        p_sensor_com: Centre of mass in S [m]. Shape (3,).
        inertia_com: Inertia about the centre of mass, axes of S [kg m^2]. Shape (3, 3).
    """
    c = as_matrix(p_sensor_com, (3,), "p_sensor_com")
    inertia = as_matrix(inertia_com, (3, 3), "inertia_com")
    origin = inertia + mass * (np.dot(c, c) * np.eye(3) - np.outer(c, c))
    return np.concatenate([[mass], mass * c, [origin[i, j] for i, j in _PAIRS]])


def body(pi) -> tuple[float, np.ndarray, np.ndarray]:
    """``(mass [kg], centre of mass in S [m] (3,), inertia about it [kg m^2] (3, 3))`` of parameters ``pi`` (10,)."""
    pi = as_matrix(pi, (10,), "pi")
    mass = float(pi[0])
    c = pi[1:4] / mass
    origin = np.zeros((3, 3))
    for k, (i, j) in enumerate(_PAIRS):
        origin[i, j] = origin[j, i] = pi[4 + k]
    return mass, c, origin - mass * (np.dot(c, c) * np.eye(3) - np.outer(c, c))


def pseudo_inertia(pi) -> np.ndarray:
    """The pseudo-inertia matrix ``J`` (4, 4) of parameters ``pi`` (10,): positive definite iff physical."""
    pi = as_matrix(pi, (10,), "pi")
    origin = np.zeros((3, 3))
    for k, (i, j) in enumerate(_PAIRS):
        origin[i, j] = origin[j, i] = pi[4 + k]
    J = np.empty((4, 4))
    J[:3, :3] = 0.5 * np.trace(origin) * np.eye(3) - origin
    J[:3, 3] = J[3, :3] = pi[1:4]
    J[3, 3] = pi[0]
    return J


def from_log_cholesky(theta) -> tuple[np.ndarray, np.ndarray]:
    """Parameters of log-Cholesky ``theta`` (10,) and their Jacobian ``d pi / d theta`` (10, 10) (Pinocchio's)."""
    import pinocchio as pin

    lc = pin.LogCholeskyParameters(np.asarray(theta, dtype=float))
    return np.asarray(lc.toDynamicParameters()), np.asarray(lc.calculateJacobian())


def to_log_cholesky(pi) -> np.ndarray:
    """Log-Cholesky parameters (10,) of physically consistent parameters ``pi`` (10,): ``J = U U^T``, U upper triangular.

    Raises:
        numpy.linalg.LinAlgError: ``pi`` is not physically consistent (J not positive definite).
    """
    J = pseudo_inertia(pi)
    flip = np.eye(4)[::-1]
    U = flip @ np.linalg.cholesky(flip @ J @ flip) @ flip  # the "UL" factor: Cholesky of J with its axes reversed
    scale = U[3, 3]
    V = U / scale
    return np.array([np.log(scale), *np.log(np.diag(V)[:3]), V[0, 1], V[1, 2], V[0, 2], V[0, 3], V[1, 3], V[2, 3]])


def nearest_consistent(pi, floor: float = 1e-2) -> np.ndarray:
    """Physically consistent parameters near ``pi`` (10,): the pseudo-inertia's eigenvalues raised to a floor.

    The floor is ``floor`` times the largest eigenvalue magnitude of the second-moment block
    ``Sigma`` (metres squared times kilograms: the mass would swamp it). A starting point for
    :func:`consistent_fit`, not its answer (it ignores how well the data determine each direction).
    """
    J = pseudo_inertia(pi)
    values, vectors = np.linalg.eigh(J)
    least = floor * max(float(np.max(np.abs(np.linalg.eigvalsh(J[:3, :3])))), 1e-12 * abs(float(J[3, 3])), 1e-300)
    J = (vectors * np.maximum(values, least)) @ vectors.T
    origin = np.trace(J[:3, :3]) * np.eye(3) - J[:3, :3]  # I_o = tr(Sigma) 1 - Sigma
    return np.concatenate([[J[3, 3]], J[:3, 3], [origin[i, j] for i, j in _PAIRS]])


def consistent_fit(pi_hat, normal, iterations: int = 200) -> tuple[np.ndarray, bool]:
    """The physically consistent parameters closest to ``pi_hat`` in the metric ``normal``.

    Minimises ``(pi(theta) - pi_hat)^T normal (pi(theta) - pi_hat)`` over the log-Cholesky
    parameters ``theta`` by Levenberg-Marquardt: with ``pi_hat`` the unconstrained least-squares
    solution and ``normal`` its normal matrix (offsets eliminated), this is the least squares of
    the data over the consistent bodies only. A consistent ``pi_hat`` is its own answer.

    Args:
        pi_hat: Unconstrained estimate (10,).
        normal: Symmetric positive-definite (10, 10) matrix (the inverse covariance of ``pi_hat``).
        iterations: Most Levenberg-Marquardt steps.

    Returns:
        ``(consistent parameters (10,), whether the constraint moved them)``.
    """
    pi_hat = as_matrix(pi_hat, (10,), "pi_hat")
    try:
        to_log_cholesky(pi_hat)
        return pi_hat.copy(), False
    except np.linalg.LinAlgError:
        pass  # not consistent: search the consistent set
    theta = to_log_cholesky(nearest_consistent(pi_hat))
    scale = 1.0 / np.sqrt(np.maximum(np.diag(normal), 1e-300))
    Ns = normal * scale[:, None] * scale[None, :]  # unit diagonal: the damping treats every parameter alike

    def cost(th: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        with np.errstate(over="ignore", invalid="ignore"):  # a wild trial step (exp overflow) is just rejected
            pi, jac = from_log_cholesky(th)
            r = (pi - pi_hat) / scale
            value = float(r @ Ns @ r)
            jac = jac / scale[:, None]
        return (value if np.isfinite(value) and np.all(np.isfinite(jac)) else np.inf), r, jac

    value, r, jac = cost(theta)
    damping = 1e-3
    for _ in range(iterations):
        H = jac.T @ Ns @ jac
        grad = jac.T @ Ns @ r
        step = np.linalg.solve(H + damping * np.diag(np.diag(H) + 1e-12), -grad)
        trial, r_new, jac_new = cost(theta + step)
        if trial < value:
            converged = value - trial <= 1e-12 * max(value, 1e-300)
            theta, value, r, jac = theta + step, trial, r_new, jac_new
            damping = max(damping / 3.0, 1e-12)
            if converged:
                break
        else:
            damping *= 4.0
            if damping > 1e12:
                break
    return from_log_cholesky(theta)[0], True

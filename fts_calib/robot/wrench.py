r"""Wrench that a rigid tool exerts on the sensor, static (paper eqs 17-18) and moving.

Everything is expressed in the sensor frame S; the moment is about the origin of S; a
wrench is ``[Fx, Fy, Fz, Mx, My, Mz]`` in [N] and [N m].

Static (eqs 17-18), with ``g_sensor = R_world_sensor.T @ g_world``:

.. math::

    F = m\,g_S, \qquad M = c \times F

Moving (Newton-Euler on the tool body): with ``omega`` and ``alpha`` the angular velocity
and acceleration of S in the world, expressed in S, ``a`` the classical linear
acceleration of the origin of S expressed in S, and ``I_c`` the inertia about the centre
of mass in S,

.. math::

    a_c = a + \alpha \times c + \omega \times (\omega \times c), \qquad
    F = m\,(g_S - a_c), \qquad M = c \times F - (I_c\,\alpha + \omega \times I_c\,\omega)

At rest (omega = alpha = a = 0) the moving wrench equals the static one.
"""

from __future__ import annotations

import numpy as np

from ..core.arrays import as_matrix, as_samples, cross


def wrench_matrix(mass: float, p_sensor_com) -> np.ndarray:
    """The (6, 3) matrix ``[m I; m [c]x]`` of eqs 17-18: ``W = wrench_matrix @ g_sensor``.

    Args:
        mass: Tool mass in [kg].
        p_sensor_com: Centre of mass of the tool in the sensor frame, in [m]. Shape (3,).
    """
    import pinocchio as pin  # here, not at the top: the in-controller path (service.reader) imports this module

    c = as_matrix(p_sensor_com, (3,), "p_sensor_com")
    return mass * np.vstack([np.eye(3), pin.skew(c)])


def apply_wrench_matrix(matrix: np.ndarray, g_sensor) -> np.ndarray:
    """``matrix @ g`` for one gravity vector (3,) or a batch (N, 3); shape (6,) or (N, 6)."""
    g = np.asarray(g_sensor, dtype=float)
    if g.shape == (3,):
        return matrix.dot(g)
    g, _ = as_samples(g, 3, "g_sensor")
    return g @ matrix.T


def static_wrench(mass: float, p_sensor_com, g_sensor) -> np.ndarray:
    """Wrench of a tool at rest on the sensor (paper eqs 17-18).

    Args:
        mass: Tool mass in [kg].
        p_sensor_com: Centre of mass of the tool in the sensor frame, in [m]. Shape (3,).
        g_sensor: Gravity in the sensor frame, in [m/s^2]. Shape (3,) or (N, 3).

    Returns:
        ``[F, c x F]`` in [N, N m]. Shape (6,) or (N, 6).
    """
    return apply_wrench_matrix(wrench_matrix(mass, p_sensor_com), g_sensor)


def dynamic_wrench(mass: float, p_sensor_com, inertia_com, g_sensor, omega_sensor, alpha_sensor, a_sensor) -> np.ndarray:
    """Wrench of a moving rigid tool on the sensor (Newton-Euler, see module docstring).

    Args:
        mass: Tool mass in [kg].
        p_sensor_com: Centre of mass in the sensor frame, in [m]. Shape (3,).
        inertia_com: Inertia about the centre of mass, axes of S, in [kg m^2]. Shape (3, 3).
        g_sensor: Gravity in S, in [m/s^2]. Shape (3,) or (N, 3).
        omega_sensor: Angular velocity of S, in S, in [rad/s]. Shape (3,) or (N, 3).
        alpha_sensor: Angular acceleration of S, in S, in [rad/s^2]. Shape (3,) or (N, 3).
        a_sensor: Classical linear acceleration of the origin of S, in S, in [m/s^2].
            Shape (3,) or (N, 3).

    Returns:
        ``[Fx, Fy, Fz, Mx, My, Mz]`` in [N, N m]. Shape (6,) or (N, 6).
    """
    c = as_matrix(p_sensor_com, (3,), "p_sensor_com")
    inertia = as_matrix(inertia_com, (3, 3), "inertia_com")
    g, single = as_samples(g_sensor, 3, "g_sensor")
    omega, _ = as_samples(omega_sensor, 3, "omega_sensor")
    al, _ = as_samples(alpha_sensor, 3, "alpha_sensor")
    a, _ = as_samples(a_sensor, 3, "a_sensor")
    a_com = a + cross(al, c) + cross(omega, cross(omega, c))
    force = mass * (g - a_com)
    torque = cross(c, force) - (al @ inertia.T + cross(omega, omega @ inertia.T))
    out = np.concatenate([force, torque], axis=1)
    return out[0] if single and out.shape[0] == 1 else out

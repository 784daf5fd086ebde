r"""The trust rule of the dynamic filter: the predicted error of each sample's expected wrench, against the noise.

A moving sample's expected wrench (Newton-Euler, :func:`fts_calib.robot.tool_wrench.tool_load`)
is as good as its inputs. Per sample, with the tool configuration's mass ``m``, lever
``r = |c|``, inertia norm ``|I|``, the sensor's angular velocity ``omega`` and each joint's
lever ``R_i`` (the distance from joint i to the sensor), the errors of the joint rates
``delta qdd_i`` and ``delta qd_i`` give

.. math::

    \delta\alpha = |\delta\ddot q| + 2|\omega|\,|\delta\dot q|, \quad
    \delta a = \Big(\sum_i (R_i\,\delta\ddot q_i)^2\Big)^{1/2} + 2|\omega| \Big(\sum_i (R_i\,\delta\dot q_i)^2\Big)^{1/2},

    \delta F = m\,(\delta a + r\,\delta\alpha), \qquad
    \delta M = r\,\delta F + |I|\,\delta\alpha

where ``delta qdd_i`` combines the acceleration noise of the derivative filter
(``gain_a sigma_q``, :func:`fts_calib.pipeline.derivatives.kernel_gains`, ``sigma_q`` the joint
noise) and its bias where the jerk changes (the larger of ``gain_s x snap``, the snap estimated
from the second difference of the filtered acceleration over half a window, and the difference
from the same polynomial over a window a third as wide beyond three of its noises), and
``delta qd_i = gain_v sigma_q``. Two more terms, per axis:

- latency: ``sigma_tau |dW/dt|``, the uncertainty of the latency applied (``sigma_tau``) times
  the rate of change of the expected wrench;
- inertia: ``epsilon_I |I alpha + omega x I omega|`` on the moments, ``epsilon_I`` the
  inertia's relative tolerance (``filter.inertia_tolerance``). The mass and centre of mass
  are not judged here: their tolerance reaches the static wrench of a still sample as much
  as the dynamic one (the budget's "tool mass" and "tool centre of mass" terms, common to
  every sample), and an inertia does not exist for a still sample.

The joint noise's part is random (it averages over samples like the strain noise); the
others are systematic (the filter's bias, the latency, the inertia). Each adds in quadrature per
wrench axis and is compared with the strain noise through C, ``sigma_W,j``:
``rho = max_j e_j / sigma_W,j`` of the total error, ``rho_sys`` of the systematic part. A
sample enters the estimator with the weight ``1 / (1 + rho^2)`` (its error taken as a noise of
its own: the inverse of its variance relative to the strain noise's) when ``rho_sys`` is at
most ``filter.max_error_ratio`` (default 3: a bias within three times the noise), and is dropped
otherwise. Units: N, N m, s, rad.
"""

from __future__ import annotations

import numpy as np

from ..core.arrays import cross
from ..robot.tool import Tool


def inertial_moment(tool: Tool, codes: np.ndarray, omega: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """``I alpha + omega x I omega`` per sample [N m], shape (N, 3) (zero for a tool without inertia)."""
    if len(codes) and codes[0] == codes[-1] and np.all(codes == codes[0]):  # one configuration (the usual block): no copies
        inertia_com = tool.configurations[int(codes[0])].inertia_com
        if inertia_com is None:
            return np.zeros((len(codes), 3))
        inertia = np.asarray(inertia_com)
        return alpha @ inertia.T + cross(omega, omega @ inertia.T)
    out = np.zeros((len(codes), 3))
    for k, configuration in enumerate(tool.configurations):
        mine = codes == k
        if configuration.inertia_com is not None and mine.any():
            inertia = np.asarray(configuration.inertia_com)
            out[mine] = alpha[mine] @ inertia.T + cross(omega[mine], omega[mine] @ inertia.T)
    return out


def snap_estimate(acceleration: np.ndarray, half: int, dt: float) -> np.ndarray:
    """|snap| per joint [rad/s^4]: the second difference of the filtered acceleration over ``half`` samples, shaped like it."""
    n = len(acceleration)
    out = np.zeros_like(acceleration)
    if n > 2 * half and half > 0:
        step = half * dt
        out[half : n - half] = np.abs(acceleration[2 * half :] - 2 * acceleration[half : n - half] + acceleration[: n - 2 * half]) / step**2
    return out


def acceleration_bias(acceleration: np.ndarray, check: np.ndarray, half: int, dt: float, gains, joint_noise: np.ndarray) -> np.ndarray:
    """The bias of the filtered acceleration per joint [rad/s^2] (see the module docstring), shape like ``acceleration``.

    The larger of ``gain_s x snap`` and the difference from the narrower window's estimate
    beyond three of its noises (``gain_c sigma_q``).
    """
    _, _, gain_s, gain_c = gains
    beyond = np.maximum(np.abs(acceleration - check) - 3.0 * gain_c * joint_noise, 0.0)
    return np.maximum(gain_s * snap_estimate(acceleration, half, dt), beyond)


def predicted_error(
    tool: Tool,
    codes: np.ndarray,
    omega: np.ndarray,
    bias: np.ndarray,
    rate: np.ndarray,
    inertial: np.ndarray,
    gains: tuple[float, float, float, float],
    joint_noise: np.ndarray,
    latency_sigma_s: float,
    levers: np.ndarray,
    inertia_tolerance: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The predicted error of each sample's expected wrench, per axis (see the module docstring).

    Args:
        tool: The tool.
        codes: Configuration index per sample, shape (N,).
        omega: Angular velocity of the sensor [rad/s], shape (N, 3).
        bias: The acceleration's bias per joint [rad/s^2], shape (N, n_joints) (:func:`acceleration_bias`); zeros for exact rates.
        rate: Rate of change of the expected wrench [N/s, N m/s], shape (N, 6).
        inertial: :func:`inertial_moment` [N m], shape (N, 3).
        gains: ``kernel_gains`` of the derivative filter (zeros for exact rates).
        joint_noise: Joint reading noise [rad], shape (n_joints,).
        latency_sigma_s: Uncertainty of the latency applied [s].
        levers: Distance from each joint to the sensor [m], shape (n_joints,).
        inertia_tolerance: The inertia's relative tolerance.

    Returns:
        ``(random, systematic)``: the error per axis [N, N, N, N m, N m, N m], each shape (N, 6);
        random: of the joint noise; systematic: the filter's bias where the jerk changes, the
        latency's uncertainty and the inertia's tolerance.
    """
    gain_v, gain_a = gains[0], gains[1]
    masses = np.array([c.mass for c in tool.configurations])[codes]
    radii = np.array([float(np.linalg.norm(c.p_sensor_com)) for c in tool.configurations])[codes]
    inertias = np.array([0.0 if c.inertia_com is None else float(np.linalg.norm(c.inertia_com, 2)) for c in tool.configurations])[codes]
    spin = 2.0 * np.linalg.norm(omega, axis=1)

    def norms(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # |d| and |R d| per row of joint-rate errors
        return np.linalg.norm(d, axis=1), np.linalg.norm(d * levers, axis=1)

    def through_tool(d_acc, d_vel) -> np.ndarray:  # the norms of joint-rate errors -> wrench error (N, 6)
        angular = d_acc[0] + spin * d_vel[0]
        linear = d_acc[1] + spin * d_vel[1]
        force = masses * (linear + radii * angular)
        moment = radii * force + inertias * angular
        return np.column_stack([np.repeat(force[:, None], 3, axis=1), np.repeat(moment[:, None], 3, axis=1)])

    n = len(codes)
    # the noise is the same for every sample: its norms once (one row), not per sample
    noise = through_tool(norms((gain_a * joint_noise)[None]), norms((gain_v * joint_noise)[None]))
    bias = through_tool(norms(bias), (0.0, 0.0))
    latency = latency_sigma_s * np.abs(rate)
    inertia = inertia_tolerance * np.column_stack([np.zeros((n, 3)), np.abs(inertial)])
    return noise, np.sqrt(bias**2 + latency**2 + inertia**2)


def trust_weights(random: np.ndarray, systematic: np.ndarray, sigma_w: np.ndarray, max_ratio: float) -> tuple[np.ndarray, np.ndarray]:
    """Weights ``1 / (1 + rho^2)`` and which samples are trusted (``rho_sys <= max_ratio``).

    Args:
        random: Predicted random error per axis, shape (N, 6).
        systematic: Predicted systematic error per axis, shape (N, 6).
        sigma_w: Strain noise through C per axis, shape (6,).
        max_ratio: Largest ``rho_sys`` kept.

    Returns:
        ``(weight (N,), trusted (N,) bool)``; a ratio is 0 where its error is 0.
    """

    def ratio(error: np.ndarray) -> np.ndarray:
        with np.errstate(divide="ignore", invalid="ignore"):
            out = np.where(error > 0, error / np.maximum(sigma_w, 1e-300), 0.0)
        return np.max(out, axis=1) if len(error) else np.zeros(0)

    rho = ratio(np.sqrt(random**2 + systematic**2))
    return 1.0 / (1.0 + rho * rho), ratio(systematic) <= max_ratio

r"""The accuracy budget of a calibration's samples: predicted from a plan, or measured from data.

Every error source of the budget (:mod:`fts_calib.budget.propagation`) is a perturbation of the
regression's inputs: the tool's mass and centre-of-mass tolerance, the sensor mount, the
joint encoders, the latency and jitter between the joint and channel streams
(:mod:`fts_calib.budget.sensitivities`), and strain noise, white on each channel, which reaches
wrench axis j with the standard deviation

.. math::

    \sigma_{W,j} = \sqrt{(C\,\mathrm{diag}(\sigma^2)\,C^T)_{jj}}.

The same function (:func:`fts_calib.budget.measured.sample_budget`) serves the ``trajectory``
job (here: the quasi-static samples a plan will give, with the sensor file's noise) and every
calibration (:mod:`fts_calib.budget.measured`: the samples kept, with the noise measured in
them). Units: N, N m, and % of each axis's full scale.

The predicted accuracy budget of a continuous plan: every sample moves, and every sample calibrates.

In the ``dynamic`` filter mode each sample enters the least squares with the Newton-Euler
wrench of the moving tool, so a continuous plan's budget is that of all its samples
(:func:`fts_calib.budget.measured.sample_budget`), the regressors from the moving wrench, with
the dynamic terms (:mod:`fts_calib.budget.sensitivities`: tool inertia, joint noise
through the velocity and acceleration estimates, what remains of the stream latency, timing
jitter) in place of the static latency and jitter terms. The static terms (tool mass and
centre of mass, sensor mount, encoders) keep their static sensitivities: the tool's
accelerations are a few % of gravity, so they change them by a few % of themselves.

With dynamics one centre of mass no longer limits the estimator to rank 4 (paper eqs 19-20):
the inertial torques ``-(I alpha + omega x I omega)`` are not ``c x F``. They are small (a few
mN m on the UR5 at its limits) and known only to the inertia's tolerance, which is what one
or two configurations then reach at best. Units: N, N m, % of each axis's full scale.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from ..filters.dynamic import acceleration_bias, inertial_moment, joint_levers, predicted_error, trust_weights
from ..filters.joint_rates import kernel_gains
from ..filters.latency import wrench_rate
from ..filters.quasi_static import held_still
from ..filters.settings import FilterConfig
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool, tool_load
from .measured import KeptSamples, measured_budget, sample_budget
from .propagation import AccuracyBudget, ErrorSource
from .sensitivities import MotionUncertainty, dynamic_error_sources, stops, wrench_derivatives


class Plan(Protocol):
    """What a budget reads of a planned motion (:class:`fts_calib.planning.motion.Plan` is one)."""

    @property
    def time(self) -> np.ndarray:
        """Sample times [s], shape (N,)."""

    @property
    def q(self) -> np.ndarray:
        """Joint positions [rad], shape (N, n_joints)."""

    @property
    def qd(self) -> np.ndarray:
        """Joint velocities [rad/s], shape (N, n_joints)."""

    @property
    def qdd(self) -> np.ndarray:
        """Joint accelerations [rad/s^2], shape (N, n_joints)."""

    @property
    def rate(self) -> float:
        """Sample rate [Hz]."""


__all__ = ["SYSTEMATIC", "KeptSamples", "measured_budget", "plan_budget", "predicted_still", "sample_budget"]

#: The terms no plan can shrink: they move C as a whole (a scale, a rotation, a lever).
SYSTEMATIC = ("tool mass", "tool centre of mass", "sensor mount")


def predicted_still(plan: Plan, filter_config: FilterConfig) -> np.ndarray:
    """Samples of a plan the quasi-static filter would keep, shape (N,) bool.

    The filter's joint rules held over the strain window (:func:`fts_calib.filters.quasi_static.held_still`)
    on the plan's exact rates: joints slow and steady at every sample within half a strain window
    (the stationarity test needs the whole window still).
    """
    speed_ok, accel_ok, _, _ = held_still(plan.time, plan.qd, plan.qdd, filter_config)
    return speed_ok & accel_ok


def plan_budget(
    kin: Kinematics, tool: Tool, plan: Plan, still: np.ndarray, C_bar, D, sigma_w, full_scale, sample_rate_hz: float | None = None
) -> AccuracyBudget:
    """The predicted budget of a plan: its quasi-static samples, the same motion for every configuration.

    Args:
        kin: Kinematics.
        tool: The tool.
        plan: The sampled motion.
        still: The samples the filter would keep. Shape (N,) bool.
        C_bar: Nominal modified calibration matrix. Shape (6, 6).
        D: Nominal offsets. Shape (6,).
        sigma_w: Strain noise through C, per axis [N, N m]. Shape (6,).
        full_scale: Full scale per axis. Shape (6,).
        sample_rate_hz: The channels' sample rate [Hz]: each planned sample stands for
            ``sample_rate_hz / plan.rate`` of them; the plan's rate when None.
    """
    index = np.nonzero(still)[0]
    n_conf = len(tool.configurations)
    joints = np.tile(plan.q[index], (n_conf, 1))
    rates = np.tile(plan.qd[index], (n_conf, 1))
    codes = np.repeat(np.arange(n_conf), len(index))
    per = stops(plan.time[index], np.zeros(len(index), dtype=np.int64), 1.5 / plan.rate)
    stop = np.concatenate([per + c * (int(per.max()) + 1 if len(per) else 0) for c in range(n_conf)])
    W = tool_load(kin, tool, joints, codes).static  # the one wrench model, static: the filter keeps still samples
    x = np.hstack([np.linalg.solve(C_bar, (W - D).T).T, np.ones((len(W), 1))])
    weight = (sample_rate_hz or plan.rate) / plan.rate
    return sample_budget(kin, tool, joints, codes, rates, stop, x, sigma_w, C_bar, D, full_scale, weight=weight)


def plan_jerk(plan: Plan) -> np.ndarray:
    """Joint jerks along a plan [rad/s^3], from its accelerations (central differences). Shape (N, n_joints)."""
    if len(plan.time) < 2:
        return np.zeros_like(plan.qdd)
    return np.gradient(plan.qdd, plan.time, axis=0)


def dynamic_plan_budget(
    kin: Kinematics,
    tool: Tool,
    plan: Plan,
    C_bar,
    D,
    sigma_w,
    full_scale,
    sample_rate_hz: float | None = None,
    uncertainty: MotionUncertainty | None = None,
    weighted: bool = True,
) -> AccuracyBudget:
    """The predicted budget of a continuous plan: all its samples, the moving wrench, the dynamic terms.

    Args:
        kin: Kinematics.
        tool: The tool (the same motion for each of its configurations).
        plan: The sampled motion.
        C_bar: Nominal modified calibration matrix. Shape (6, 6).
        D: Nominal offsets [N, N m]. Shape (6,).
        sigma_w: Strain noise through C, per axis [N, N m]. Shape (6,).
        full_scale: Full scale per axis [N, N m]. Shape (6,).
        sample_rate_hz: The channels' sample rate [Hz] (each planned sample stands for
            ``sample_rate_hz / plan.rate`` of them); the plan's rate when None.
        uncertainty: Inertia tolerance, joint noise, latency and jitter; the defaults of
            :class:`MotionUncertainty` when None.
        weighted: Weigh each sample as the dynamic filter's trust rule does (:func:`filter_weights`);
            False: every sample alike.
    """
    uncertainty = MotionUncertainty() if uncertainty is None else uncertainty
    n_conf, n = len(tool.configurations), len(plan.time)
    tile = lambda a: np.tile(a, (n_conf, 1))  # noqa: E731
    q, qd, qdd, jerk = tile(plan.q), tile(plan.qd), tile(plan.qdd), tile(plan_jerk(plan))
    codes = np.repeat(np.arange(n_conf), n)
    time = np.tile(plan.time, n_conf)
    W = tool_load(kin, tool, q, codes, qd, qdd).w_sensor
    x = np.hstack([np.linalg.solve(C_bar, (W - D).T).T, np.ones((len(W), 1))])
    extra = [*dynamic_error_sources(kin, tool, time, q, qd, qdd, jerk, codes, uncertainty), rate_bias_source(kin, tool, plan, uncertainty)]
    weight = (sample_rate_hz or plan.rate) / plan.rate
    row_weight = filter_weights(kin, tool, plan, sigma_w, uncertainty) if weighted else None
    return sample_budget(kin, tool, q, codes, qd, None, x, sigma_w, C_bar, D, full_scale, weight=weight, extra=extra, row_weight=row_weight)


def filter_weights(kin: Kinematics, tool: Tool, plan: Plan, sigma_w, uncertainty: MotionUncertainty) -> np.ndarray:
    """The weight the dynamic filter gives each sample of a plan, every configuration in turn, shape (n_conf N,).

    The trust rule of :mod:`fts_calib.filters.dynamic` on the planned motion: the predicted error
    of each sample's expected wrench (joint noise through the rate estimates, their bias where
    the jerk changes, the latency's and the inertia's uncertainty) against the strain noise
    ``sigma_w`` ([N, N m], shape (6,)); weight ``1 / (1 + rho^2)``, 0 where dropped, and 0
    within a window of either end of the motion (the filter's derivative and jerk windows are cut there).
    """
    n_conf = len(tool.configurations)
    codes = np.repeat(np.arange(n_conf), len(plan.time))
    q, qd, qdd = (np.tile(a, (n_conf, 1)) for a in (plan.q, plan.qd, plan.qdd))
    load = tool_load(kin, tool, q, codes, qd, qdd)
    motion = kin.sensor_motion(q, qd, qdd)
    omega, alpha = motion.omega.reshape(len(q), 3), motion.alpha.reshape(len(q), 3)
    half = max(1, int(round(uncertainty.window_s / 2 * plan.rate)))
    gains = kernel_gains(uncertainty.window_s, 1.0 / uncertainty.joint_rate_hz, uncertainty.order)
    noise = np.full(kin.n_joints, uncertainty.joint_noise)
    # the planned acceleration is exact: the narrower window's check adds nothing, the snap's term stays
    bias = np.vstack([acceleration_bias(plan.qdd, plan.qdd, half, 1.0 / plan.rate, gains, noise)] * n_conf)
    rate = np.vstack([wrench_rate(plan.time, load.w_sensor[codes == c]) for c in range(n_conf)])
    random, systematic = predicted_error(
        tool,
        codes,
        omega,
        bias,
        rate,
        inertial_moment(tool, codes, omega, alpha),
        gains,
        noise,
        uncertainty.latency_s,
        joint_levers(kin, plan.q[0]),
        uncertainty.inertia,
    )
    weight, trusted = trust_weights(random, systematic, np.asarray(sigma_w, dtype=float), uncertainty.max_error_ratio)
    # the filter drops a sample whose derivative window, or the jerk window about it, is cut: a window from each end
    whole = np.tile((plan.time >= plan.time[0] + uncertainty.window_s) & (plan.time <= plan.time[-1] - uncertainty.window_s), n_conf)
    return np.where(trusted & whole, weight, 0.0)


def rate_bias_source(kin: Kinematics, tool: Tool, plan: Plan, uncertainty: MotionUncertainty) -> ErrorSource:
    """The 'rate-estimate bias' term: the acceleration the filter's polynomial misses where the jerk changes.

    The bias of the acceleration estimate is about ``gain_s x snap`` (:func:`fts_calib.filters.joint_rates.kernel_gains`,
    the snap from the second difference of the planned acceleration over half a window, its sign
    kept): a known error along the motion, entered as one draw of unit variance of
    ``dW/dqddot x gain_s x snap`` (a deterministic error: its sign does not matter).
    """
    n_conf, n = len(tool.configurations), len(plan.time)
    codes = np.repeat(np.arange(n_conf), n)
    q, qd, qdd = (np.tile(a, (n_conf, 1)) for a in (plan.q, plan.qd, plan.qdd))
    moving = np.nonzero(np.ptp(plan.q, axis=0) > 0)[0]
    half = max(1, int(round(uncertainty.window_s / 2 * plan.rate)))
    snap = np.zeros_like(plan.qdd)
    if n > 2 * half:
        step = half / plan.rate
        snap[half : n - half] = (plan.qdd[2 * half :] - 2 * plan.qdd[half : n - half] + plan.qdd[: n - 2 * half]) / step**2
    gain = kernel_gains(uncertainty.window_s, 1.0 / uncertainty.joint_rate_hz, uncertainty.order)[2]
    derivative = wrench_derivatives(kin, tool, q, qd, qdd, codes, moving)[:, :, 2, :]  # dW/dqddot, (N, 6, J)
    bias = np.einsum("njk,nk->nj", derivative, gain * np.tile(snap, (n_conf, 1))[:, moving])
    return ErrorSource("rate-estimate bias", bias[:, :, None], np.ones((1, 1)), np.zeros(len(q), dtype=np.int64))

"""The dynamic terms of the accuracy budget against Monte Carlo: a continuous UR5 motion, every sample calibrating.

Each draw perturbs what the calibration believes about the moving tool (its inertia, the
latency, the joint readings), fits C_bar and D by least squares of the believed wrench on
the true strains, and measures the error over the range; the budget's linear prediction
must match the spread of the draws.
"""

import dataclasses
import itertools

import numpy as np
import pytest

from fts_calib.budget.predicted import dynamic_plan_budget
from fts_calib.budget.propagation import range_moments
from fts_calib.budget.sensitivities import MotionUncertainty
from fts_calib.core.resources import resolve
from fts_calib.planning.motion import plan_sweeps
from fts_calib.planning.sweeps import SweepPattern
from fts_calib.robot.tool import dynamic_wrench, load_tool

from .helpers import C_BAR_TRUE, D_TRUE

FULL_SCALE = np.array([50.0, 50.0, 50.0, 5.0, 5.0, 5.0])
SIGMA_W = np.array([2e-3, 2e-3, 2e-3, 4e-5, 4e-5, 4e-5])  # [N, N m] the shipped sensor's strain noise through C
HOME = np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0])
RANGES = np.array([[-np.pi, np.pi], [-np.pi, np.pi]])
RUNS = 60
# the RMS over 60 draws of errors that each sum several squared normal components: within about +-10 % (1 sigma)
RELATIVE = 0.3
PATTERN = SweepPattern(2, 1, 0.0, 0.02, 0.2, continuous=True)  # 4.7 s, both wrist joints at once


@pytest.fixture(scope="module")
def continuous(_kinematics_cache):
    """A continuous UR5 motion at 200 Hz (the budget's rows and the fits' samples)."""
    from .conftest import _kinematics

    kin = _kinematics(_kinematics_cache, "ur5")
    tool = load_tool(resolve("paper_tool", "configs"))
    return kin, tool, plan_sweeps(kin, HOME, RANGES, PATTERN, 200.0)


def tiled(plan, tool):
    n_conf = len(tool.configurations)
    codes = np.repeat(np.arange(n_conf), len(plan.time))
    return codes, *(np.tile(a, (n_conf, 1)) for a in (plan.q, plan.qd, plan.qdd))


def fitter(W_true):
    """C_bar, D from a believed wrench on the true strains (eq 22), minus the truth: a function of W_known -> (6, 7)."""
    x = np.hstack([np.linalg.solve(C_BAR_TRUE, (W_true - D_TRUE).T).T, np.ones((len(W_true), 1))])
    solve = np.linalg.pinv(x)  # (7, N): least squares, once for every draw
    truth = np.hstack([C_BAR_TRUE, D_TRUE[:, None]])
    return lambda W_known: (solve @ W_known).T - truth


def fit_error(W_true, W_known):
    """C_bar, D fitted minus the truth, (6, 7)."""
    return fitter(W_true)(W_known)


def spread(errors):
    M = range_moments(C_BAR_TRUE, D_TRUE, FULL_SCALE)
    return np.sqrt(np.mean([np.einsum("jk,kl,jl->j", e, M, e) for e in errors], axis=0))


def wrench(kin, tool, codes, q, qd, qdd, inertias=None, motion=None):
    """The moving tool's wrench (Newton-Euler), with other inertias when given, (N, 6)."""
    motion = kin.sensor_motion(q, qd, qdd) if motion is None else motion
    out = np.zeros((len(q), 6))
    g = np.einsum("nji,j->ni", motion.R_world_sensor.reshape(len(q), 3, 3), kin.g_world(tool.gravity))
    for k, c in enumerate(tool.configurations):
        rows = codes == k
        inertia = c.inertia_com if inertias is None else inertias[k]
        out[rows] = dynamic_wrench(c.mass, c.p_sensor_com, inertia, g[rows], motion.omega[rows], motion.alpha[rows], motion.a[rows])
    return out


def predicted(kin, tool, plan, uncertainty):
    budget = dynamic_plan_budget(kin, tool, plan, C_BAR_TRUE, D_TRUE, SIGMA_W, FULL_SCALE, None, uncertainty, weighted=False)
    return budget


def compare(name, measured, budget):
    expected = budget.terms[name]
    reached = expected > 1e-3 * expected.max()
    ratio = measured[reached] / expected[reached]
    assert reached.any() and np.all(np.abs(ratio - 1) <= RELATIVE), f"{name}: Monte Carlo / predicted {np.round(ratio, 3)}"


def test_tool_inertia_term_matches_monte_carlo(continuous, rng):
    kin, tool, plan = continuous
    uncertainty = MotionUncertainty(inertia=0.1, joint_noise=0.0, latency_s=0.0, jitter_s=0.0)
    budget = predicted(kin, tool, plan, uncertainty)
    codes, q, qd, qdd = tiled(plan, tool)
    motion = kin.sensor_motion(q, qd, qdd)
    known = wrench(kin, tool, codes, q, qd, qdd, motion=motion)
    e = np.eye(3)
    basis = [np.diag(v) for v in e] + [np.outer(e[i], e[j]) + np.outer(e[j], e[i]) for i, j in ((0, 1), (0, 2), (1, 2))]
    fit = fitter(known)
    errors = []
    for _ in range(2 * RUNS):
        inertias = []
        for c in tool.configurations:
            bound = 0.1 * np.linalg.eigvalsh(c.inertia_com).max()
            inertias.append(c.inertia_com + sum(u * E for u, E in zip(rng.uniform(-bound, bound, 6), basis, strict=True)))
        errors.append(fit(wrench(kin, tool, codes, q, qd, qdd, inertias, motion)))  # believed: the inertia off by the draw
    compare("tool inertia", spread(errors), budget)


def test_latency_term_matches_monte_carlo(continuous, rng):
    """The joints used are those of t - dtau: the plan interpolated at the shifted times (1 kHz, dtau ~ 1 ms)."""
    kin, tool, plan = continuous
    uncertainty = MotionUncertainty(inertia=0.0, joint_noise=0.0, latency_s=1e-3, jitter_s=0.0)
    budget = predicted(kin, tool, plan, uncertainty)
    codes, q, qd, qdd = tiled(plan, tool)
    true = wrench(kin, tool, codes, q, qd, qdd)
    errors = []
    fit = fitter(true)
    for _ in range(RUNS):
        t = np.clip(plan.time - rng.normal(0.0, 1e-3), 0.0, plan.time[-1])
        shifted = [np.column_stack([np.interp(t, plan.time, a[:, k]) for k in range(a.shape[1])]) for a in (plan.q, plan.qd, plan.qdd)]
        errors.append(fit(wrench(kin, tool, codes, *(np.tile(a, (len(tool.configurations), 1)) for a in shifted))))
    compare("stream latency", spread(errors), budget)


def cubic_kernels(half: int, dt: float) -> np.ndarray:
    """Position, velocity, acceleration kernels of a centred least-squares cubic (a Savitzky-Golay filter), (3, 2 half + 1)."""
    t = np.arange(-half, half + 1) * dt
    V = np.vander(t, 4, increasing=True)  # columns 1, t, t^2, t^3
    fit = np.linalg.solve(V.T @ V, V.T)  # coefficients from readings
    return np.stack([fit[0], fit[1], 2.0 * fit[2]])


def test_joint_noise_term_matches_monte_carlo(continuous, rng):
    """White noise on 1 kHz readings, rates from a 50 ms centred cubic: the differentiated noise averages out as predicted."""
    kin, tool, coarse = continuous
    sigma_q = 1e-3  # [rad] large: the term then dwarfs the linearisation's error
    uncertainty = MotionUncertainty(0.0, sigma_q, 1000.0, window_s=0.05, latency_s=0.0, jitter_s=0.0, order=3)
    budget = predicted(kin, tool, coarse, uncertainty)  # the budget from the 200 Hz rows
    plan = plan_sweeps(kin, HOME, RANGES, PATTERN, 1000.0)  # the fits from every reading
    codes, q, qd, qdd = tiled(plan, tool)
    fit = fitter(wrench(kin, tool, codes, q, qd, qdd))
    kernels = cubic_kernels(25, 1e-3)
    moving = [kin.joint_names.index(j) for j in kin.sweep_joints]
    n, n_conf = len(plan.time), len(tool.configurations)
    errors = []
    for _ in range(RUNS):
        estimates = [q.copy(), qd.copy(), qdd.copy()]
        for c, k in itertools.product(range(n_conf), moving):
            noise = rng.normal(0.0, sigma_q, n + 50)  # readings half a window beyond each end too
            for d in range(3):  # the noise through each filter, on the exact motion (the filter's own bias left out)
                estimates[d][c * n : (c + 1) * n, k] += np.convolve(noise, kernels[d][::-1], mode="valid")
        errors.append(fit(wrench(kin, tool, codes, *estimates)))
    compare("joint noise", spread(errors), budget)


def test_noiseless_and_exact_inertia_give_no_dynamic_error(continuous):
    """Nothing uncertain: every dynamic term is 0, and the fit on the moving wrench is exact."""
    kin, tool, plan = continuous
    uncertainty = MotionUncertainty(inertia=0.0, joint_noise=0.0, latency_s=0.0, jitter_s=0.0)
    budget = predicted(kin, tool, plan, uncertainty)
    for name in ("joint noise", "stream latency", "timing jitter"):
        assert np.all(budget.terms[name] == 0.0)
    assert "tool inertia" not in budget.terms
    codes, q, qd, qdd = tiled(plan, tool)
    W = wrench(kin, tool, codes, q, qd, qdd)
    assert np.max(np.abs(fit_error(W, W))) < 1e-9


def test_one_configuration_is_rank_7_only_through_the_inertial_torques(continuous):
    """One centre of mass: the static wrench leaves rank 4 (eqs 19-20); the moving one is finite, growing as the inertia is known worse."""
    kin, tool, _ = continuous
    plan = plan_sweeps(kin, HOME, RANGES, SweepPattern(3, 2, 0.0, 0.02, 0.5, continuous=True), 25.0)
    one = dataclasses.replace(tool, configurations=tool.configurations[:1])
    tight = predicted(kin, one, plan, MotionUncertainty(inertia=0.01))
    loose = predicted(kin, one, plan, MotionUncertainty(inertia=0.1))
    assert np.isfinite(tight.largest_percent)
    assert np.all(loose.terms["tool inertia"][:3] == 0.0)  # inertial torques: the force rows see none
    ratio = loose.terms["tool inertia"][3:] / tight.terms["tool inertia"][3:]
    assert np.allclose(ratio, 10.0, rtol=1e-6), ratio  # linear in the tolerance
    assert loose.dominant()[0] == "tool inertia"


@pytest.mark.parametrize("order", [3, 5])
def test_the_budget_filters_the_joints_as_the_dynamic_mode_does(order):
    """The joint-noise term's kernels are those of the dynamic filter's derivative estimate (its noise gains)."""
    from fts_calib.filters.joint_rates import kernel_gains

    uncertainty = MotionUncertainty(joint_noise=1.0, joint_rate_hz=1000.0, window_s=0.3, order=order)
    gain_v, gain_a = kernel_gains(0.3, 1e-3, order)[:2]
    assert np.sqrt(np.diag(uncertainty.estimate_covariance()))[1:] == pytest.approx([gain_v, gain_a], rel=1e-9)

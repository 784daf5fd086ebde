r"""The accuracy budget of a calibration's samples: predicted from a plan, or measured from data.

Every error source of the budget (:mod:`fts_calib.model.budget`) is a perturbation of the
regression's inputs: the tool's mass and centre-of-mass tolerance, the sensor mount, the
joint encoders, the latency and jitter between the joint and channel streams
(:mod:`fts_calib.robot.sensitivities`), and strain noise, white on each channel, which reaches
wrench axis j with the standard deviation

.. math::

    \sigma_{W,j} = \sqrt{(C\,\mathrm{diag}(\sigma^2)\,C^T)_{jj}}.

The same function (:func:`fts_calib.pipeline.budget.sample_budget`) serves the ``trajectory``
job (here: the quasi-static samples a plan will give, with the sensor file's noise) and every
calibration (:mod:`fts_calib.pipeline.budget`: the samples kept, with the noise measured in
them). Units: N, N m, and % of each axis's full scale.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

from ..model.budget import AccuracyBudget
from ..pipeline.budget import KeptSamples, measured_budget, sample_budget
from ..pipeline.settings import FilterConfig
from ..robot.kinematics import Kinematics
from ..robot.sensitivities import stops
from ..robot.tool import Tool
from ..robot.tool_wrench import tool_load


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

    def still(self, max_speed: float, max_acceleration: float) -> np.ndarray:
        """Samples where every joint is slow and steady, shape (N,) bool."""


__all__ = ["SYSTEMATIC", "KeptSamples", "measured_budget", "plan_budget", "predicted_still", "sample_budget"]

#: The terms no plan can shrink: they move C as a whole (a scale, a rotation, a lever).
SYSTEMATIC = ("tool mass", "tool centre of mass", "sensor mount")


def predicted_still(plan: Plan, filter_config: FilterConfig) -> np.ndarray:
    """Samples of a plan the quasi-static filter would keep, shape (N,) bool.

    Joints slow and steady, and at least half a strain window away from any motion (the
    stationarity test needs the whole window).
    """
    still = plan.still(filter_config.max_joint_speed, filter_config.max_joint_acceleration)
    half = int(math.ceil(filter_config.strain_window_s * plan.rate / 2))
    if half:
        moving = np.convolve((~still).astype(float), np.ones(2 * half + 1), mode="same") > 0
        still = still & ~moving
    return still


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

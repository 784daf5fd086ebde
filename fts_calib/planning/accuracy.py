r"""The accuracy budget of a calibration's samples: predicted from a plan, or measured from data.

Every error source of the budget (:mod:`fts_calib.model.budget`) is a perturbation of the
regression's inputs: the tool's mass and centre-of-mass tolerance, the sensor mount, the
joint encoders, the latency and jitter between the joint and channel streams
(:mod:`fts_calib.robot.load_errors`), and strain noise, white on each channel, which reaches
wrench axis j with the standard deviation

.. math::

    \sigma_{W,j} = \sqrt{(C\,\mathrm{diag}(\sigma^2)\,C^T)_{jj}}.

The same function serves the ``trajectory`` job (the quasi-static samples a plan will give,
with the sensor file's noise) and the ``calibrate`` job (the samples kept, with the noise
measured in them). Units: N, N m, and % of each axis's full scale.
"""

from __future__ import annotations

import math

import numpy as np

from ..model.budget import MODEL_ERROR, AccuracyBudget, ErrorSource, model_error, propagate, range_moments
from ..model.calibration import Calibration
from ..model.least_squares import information_rank
from ..pipeline.settings import FilterConfig
from ..robot.definition import RobotAccuracy
from ..robot.kinematics import Kinematics
from ..robot.load import tool_load
from ..robot.load_errors import SOURCE_NAMES, load_error_sources, stops
from ..robot.tool import Tool
from .motion import Plan

_STOP_GAP_S = 0.05  # [s] a gap this long between kept samples: the arm moved to another stop
_MAX_BUDGET_SAMPLES = 20_000  # samples the measured budget uses (every k-th beyond)

#: The terms no plan can shrink: they move C as a whole (a scale, a rotation, a lever).
SYSTEMATIC = ("tool mass", "tool centre of mass", "sensor mount")


def sample_budget(
    kin: Kinematics,
    tool: Tool,
    joints: np.ndarray,
    configuration: np.ndarray,
    joint_velocity: np.ndarray,
    stop: np.ndarray,
    x: np.ndarray,
    sigma_w: np.ndarray,
    C_bar: np.ndarray,
    D: np.ndarray,
    full_scale: np.ndarray,
    kind: str = "predicted",
    weight: float = 1.0,
    accuracy: RobotAccuracy | None = None,
    prior_weight: float | None = None,
) -> AccuracyBudget:
    """The budget of a calibration from its samples (every term inf when they do not determine C, rank < 7).

    Args:
        kin: Kinematics (its robot's ``accuracy``: encoders, timing, mount).
        tool: The tool (its ``tolerance``).
        joints: Joint readings of the samples [rad]. Shape (N, n_joints).
        configuration: Tool configuration index of each sample. Shape (N,) int.
        joint_velocity: Joint velocities at the samples [rad/s]. Shape (N, n_joints).
        stop: Still stretch of each sample. Shape (N,) int.
        x: Regressors ``[P Delta; 1]`` (``[C_bar^-1 (W - D); 1]``). Shape (N, 7).
        sigma_w: Strain noise through C, per axis [N, N m]. Shape (6,).
        C_bar: Modified calibration matrix (nominal, or the result). Shape (6, 6).
        D: Offsets [N, N, N, N m, N m, N m]. Shape (6,).
        full_scale: Full scale per axis, same units. Shape (6,).
        kind: 'predicted' or 'measured'.
        weight: Channel samples each row stands for (white terms average over them).
        accuracy: Encoder resolution, timing and mount tolerance; the robot definition's when None.
        prior_weight: The weight lambda of a prior C_bar was shrunk toward (:mod:`fts_calib.model.prior`): the
            errors propagate through the shrunk least squares, so every term is finite; None for none.
    """
    accuracy = kin.robot.accuracy if accuracy is None else accuracy
    n = len(joints)
    ridge = None
    if prior_weight is not None and n:
        ridge = np.zeros((7, 7))
        ridge[:6, :6] = prior_weight * np.diag(np.einsum("ni,ni->i", x[:, :6], x[:, :6]))
    if n == 0 or (ridge is None and information_rank(x.T @ x)[0] < 7):
        names = [name for name in ("strain noise", *SOURCE_NAMES) if tool.tolerance is not None or not name.startswith("tool")]
        return AccuracyBudget({name: np.full(6, np.inf) for name in names}, full_scale, kind=kind)
    sources = load_error_sources(kin, tool, joints, configuration, joint_velocity, stop, accuracy)
    noise = ErrorSource("strain noise", np.broadcast_to(np.eye(6), (n, 6, 6)), np.diag(np.asarray(sigma_w, dtype=float) ** 2))
    terms = propagate(x, [noise, *sources], range_moments(C_bar, D, full_scale), weight, ridge)
    return AccuracyBudget(terms, full_scale, kind=kind)


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


class KeptSamples:
    """The samples entering the least squares, collected for the measured budget.

    Pass it as the session's ``on_kept``: it is called with ``(time (k,), w_sensor (k, 6),
    channels (k, n), configuration (k,), joints (k, n_joints))``.
    """

    def __init__(self) -> None:
        self._parts: list[tuple[np.ndarray, ...]] = []

    def __call__(self, time, w_sensor, channels, configuration, joints) -> None:
        """Keep one batch of kept samples."""
        self._parts.append(tuple(np.array(a) for a in (time, w_sensor, channels, configuration, joints)))

    def __len__(self) -> int:
        return sum(len(part[0]) for part in self._parts)

    def arrays(self) -> tuple[np.ndarray, ...]:
        """``(time, w_sensor, channels, configuration, joints)``, every batch in order."""
        if not self._parts:
            return (np.zeros(0), np.zeros((0, 6)), np.zeros((0, 0)), np.zeros(0, dtype=np.int64), np.zeros((0, 0)))
        return tuple(np.concatenate(column) for column in zip(*self._parts, strict=True))


def measured_budget(
    kin: Kinematics,
    tool: Tool,
    kept: KeptSamples,
    calibration: Calibration,
    sigma_w,
    full_scale,
    gap_s: float = _STOP_GAP_S,
    residual_rms=None,
    prior_weight: float | None = None,
) -> AccuracyBudget:
    """The budget of a calibration from the samples it was solved from, with its model error.

    Args:
        kin: Kinematics.
        tool: The tool.
        kept: The samples that entered the least squares.
        calibration: The result (its C_bar, D and C).
        sigma_w: Strain noise measured in the data, through C (:func:`fts_calib.model.budget.wrench_noise` of the
            filter's noise floor), per axis [N, N m]. Shape (6,).
        full_scale: Full scale per axis [N, N m]. Shape (6,).
        gap_s: A gap between kept samples longer than this [s] starts a new stop.
        residual_rms: The calibration's residual RMS per axis on held-out samples (or its fit's), [N, N m], shape
            (6,): what exceeds ``sigma_w`` is the budget's "model error" term
            (:func:`fts_calib.model.budget.model_error`); None for no such term.
        prior_weight: The weight of the prior C_bar was shrunk toward, or None (see :func:`sample_budget`).
    """
    time, _, channels, codes, joints = kept.arrays()
    stride = max(1, int(math.ceil(len(time) / _MAX_BUDGET_SAMPLES)))  # bounded memory: white terms weigh the rest
    stop = stops(time, codes, gap_s)[::stride]
    time, channels, codes, joints = time[::stride], channels[::stride], codes[::stride], joints[::stride]
    same = np.diff(stop) == 0
    velocity = np.zeros_like(joints)
    if len(time) > 1:
        slope = np.diff(joints, axis=0) / np.maximum(np.diff(time), 1e-12)[:, None]
        velocity[1:][same] = slope[same]
    x_bar = np.linalg.solve(calibration.C_bar, (calibration.wrench(channels) - calibration.D).T).T
    x = np.hstack([x_bar, np.ones((len(x_bar), 1))])
    budget = sample_budget(
        kin,
        tool,
        joints,
        codes,
        velocity,
        stop,
        x,
        sigma_w,
        calibration.C_bar,
        calibration.D,
        full_scale,
        "measured",
        weight=stride,
        prior_weight=prior_weight,
    )
    if residual_rms is None:
        return budget
    terms = {**budget.terms, MODEL_ERROR: model_error(residual_rms, sigma_w)}
    return AccuracyBudget(terms, budget.full_scale, budget.coverage, budget.kind)

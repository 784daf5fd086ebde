r"""The dynamic sample filter (``filter.mode: dynamic``): moving samples calibrate.

The quasi-static filter (:mod:`fts_calib.pipeline.qsfilter`) keeps the samples where the
tool's wrench is its weight alone: a few % of a recording. This filter keeps every sample
whose *expected* wrench is trusted, with the tool's full Newton-Euler wrench
(:func:`fts_calib.robot.tool_wrench.tool_load`: mass, centre of mass, inertia):

1. joint positions, velocities and accelerations from the joint readings by a centred local
   polynomial (``dynamic_order``, 5) over ``dynamic_window_s`` (0.3 s) (no phase lag), evaluated ``latency_s`` later: the
   readings are that late (:mod:`fts_calib.pipeline.derivatives`); a sample whose window is
   cut (a stream's edge, a gap, a tool change) is dropped ("derivative window cut");
2. the sensor's motion and the tool's wrench at every remaining sample (vectorised over the
   batch, one forward kinematics);
3. the trust rule (:mod:`fts_calib.pipeline.trust`): each sample's predicted error of the
   expected wrench (acceleration noise, jerk, latency uncertainty, inertia tolerance) against
   the strain noise through C; weight ``1 / (1 + rho^2)``, dropped beyond
   ``max_error_ratio`` ("expected wrench not trusted").

Noise levels are measured from the stream itself, once, on its first
:data:`NOISE_SAMPLES` samples (they wait until then): the robust spread of the third
differences of each channel and each joint (a third difference removes any quadratic
motion; of white noise it has the variance ``20 sigma^2``), the channels' never below their
quantization step / sqrt(12). The strain noise through C uses the sensor file's nominal C
(``PipelineConfig.nominal_c``); without one, :data:`DEFAULT_NOISE_FS` of each axis's full
scale.

A controller that knows its joint rates exactly can give them
(:meth:`fts_calib.pipeline.session.CalibrationSession.add_samples`, ``rates``): they are then
used as they are (no latency shift, no derivative terms in the trust rule). Samples stream in
chunks; the filter keeps a window of context at the end of each and decides those samples
with the next, so the result does not depend on where chunks end.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core.exceptions import ShapeError
from ..feeds.batch import SampleBatch
from ..model.channel_limits import ChannelLimits, GridWatch
from ..model.channels import MALTESE_CROSS_8, ChannelLayout
from ..model.sensor_config import SensorSpec
from ..robot.definition import RobotAccuracy
from ..robot.kinematics import Kinematics
from ..robot.motion import SensorMotion
from ..robot.tool import Tool
from ..robot.tool_wrench import ToolLoad, tool_load
from .derivatives import JointMotion, joint_motion, kernel_gains
from .latency_fit import LatencyFit
from .qsfilter import PERIOD_SAMPLES, QuasiStaticFilter, sample_period
from .settings import DYNAMIC, FilterConfig, PipelineConfig
from .still import StillSamples, quasi_static
from .trust import acceleration_bias, inertial_moment, predicted_error, trust_weights

#: The rules of the dynamic filter, in the order they are reported.
DYNAMIC_RULES = ("derivative window cut", "expected wrench not trusted")
#: Samples whose third differences set the noise levels (the first of the stream).
NOISE_SAMPLES = 1000
#: Strain noise through C, per axis, in units of full scale, without a nominal C (the paper's sensor: 2 mN of 50 N).
DEFAULT_NOISE_FS = 4e-5
#: A significant latency for ``latency_s: auto`` [s] (``calibrate`` reads again beyond it and 3 standard errors).
LATENCY_SIGNIFICANT_S = 5e-5


def third_difference_noise(values: np.ndarray) -> np.ndarray:
    """White-noise standard deviation per column from the robust spread of third differences, shape (c,)."""
    if len(values) < 8:
        return np.zeros(values.shape[1])
    d3 = np.diff(values, n=3, axis=0)
    return 1.4826 * np.median(np.abs(d3 - np.median(d3, axis=0)), axis=0) / math.sqrt(20.0)


#: Samples whose tool load is computed at a time: their temporaries stay in the cache (a third of the time of 40,000 at once).
LOAD_BLOCK = 4096


def blocked_load(
    kin: Kinematics, tool: Tool, joints: np.ndarray, codes: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray
) -> ToolLoad:
    """:func:`fts_calib.robot.tool_wrench.tool_load` with joint rates, :data:`LOAD_BLOCK` samples at a time (the same result)."""
    parts = [
        tool_load(
            kin, tool, joints[i : i + LOAD_BLOCK], codes[i : i + LOAD_BLOCK], velocity[i : i + LOAD_BLOCK], acceleration[i : i + LOAD_BLOCK]
        )
        for i in range(0, len(joints), LOAD_BLOCK)
    ]
    if len(parts) == 1:
        return parts[0]
    motions = [p.motion for p in parts if p.motion is not None]
    motion = SensorMotion(*(np.concatenate([getattr(m, f) for m in motions]) for f in ("omega", "alpha", "v", "a", "R_world_sensor")))
    moving = np.concatenate([p.moving for p in parts if p.moving is not None])
    return ToolLoad(np.concatenate([p.g_sensor for p in parts]), np.concatenate([p.static for p in parts]), moving, motion)


def joint_levers(kin: Kinematics, joints: np.ndarray) -> np.ndarray:
    """The distance from each joint's origin to the sensor at ``joints`` [m], shape (n_joints,) (the levers of the trust rule)."""
    pose = kin.sensor_pose(joints)  # runs the forward kinematics: the joints' placements are in kin.data
    origins = np.array([kin.data.oMi[j].translation for j in range(1, kin.model.njoints)])
    return np.linalg.norm(origins - np.asarray(pose.translation), axis=1)[: kin.n_joints]


class DynamicFilter:
    """Stream filter of trusted moving samples (see the module docstring).

    Args:
        settings: The filter settings (mode ``dynamic``).
        continuous: Which joints are continuous, shape (n_joints,) bool.
        limits: The channels' declared resolution (None: learnt from the values).
        nominal_c: Nominal C (6 x n, raw channels to [N, N m]), or None.
        full_scale: Full scale per axis [N, N m], shape (6,).
        layout: The channel layout (``P Delta`` for the latency fit).
        n_configurations: The tool's configurations.

    Attributes:
        latency_fit: The latency left after :attr:`latency_s`, fitted with the calibration
            from the kept samples (:mod:`fts_calib.pipeline.latency_fit`).
    """

    def __init__(
        self,
        settings: FilterConfig,
        continuous,
        limits: ChannelLimits | None,
        nominal_c,
        full_scale,
        layout: ChannelLayout = MALTESE_CROSS_8,
        n_configurations: int = 3,
    ):
        self.layout = layout
        self.latency_fit = LatencyFit(n_configurations, full_scale)
        self.settings = settings
        self.rejected = dict.fromkeys(DYNAMIC_RULES, 0)
        self.grid = GridWatch(None if limits is None else limits.resolution)
        self.measured_floor: np.ndarray | None = None
        self.joint_noise: np.ndarray | None = None
        self.latency_s = 0.0 if settings.latency_s is None else settings.latency_s
        self._nominal = None if nominal_c is None else np.asarray(nominal_c, dtype=float)
        self._full_scale = np.asarray(full_scale, dtype=float)
        self._continuous = np.asarray(continuous, dtype=bool)
        self._half = settings.dynamic_window_s + abs(self.latency_s)  # context each side: the window, and the jerk's
        self._buffer: SampleBatch | None = None
        self._rates: tuple[np.ndarray, np.ndarray] | None = None
        self._context = 0
        self._dt: float | None = None
        self._levers: np.ndarray | None = None

    @property
    def noise_floor(self) -> np.ndarray | None:
        """The strain noise per channel, raw units, shape (n,), never below step / sqrt(12); None before it is measured."""
        return self.grid.floor(self.measured_floor)

    def sigma_w(self) -> np.ndarray:
        """The strain noise through C per axis [N, N m], shape (6,) (see the module docstring)."""
        floor = self.noise_floor
        if self._nominal is None or floor is None or self._nominal.shape[1] != len(floor):
            return DEFAULT_NOISE_FS * self._full_scale
        return np.sqrt((self._nominal**2) @ (floor**2))

    def state(self) -> dict:
        """What a checkpoint keeps of the filter."""
        return {
            "noise_floor": None if self.measured_floor is None else self.measured_floor.tolist(),
            "joint_noise": None if self.joint_noise is None else self.joint_noise.tolist(),
            "resolution": self.grid.state(),
            "rejected": dict(self.rejected),
            "latency_sums": self.latency_fit.sums.tolist(),
            "latency_counts": self.latency_fit.counts.tolist(),
        }

    def restore(self, state: dict) -> None:
        """Restore :meth:`state`."""
        for key in ("noise_floor", "joint_noise"):
            if state.get(key) is not None:
                setattr(self, "measured_floor" if key == "noise_floor" else key, np.asarray(state[key], dtype=float))
        if state.get("resolution") is not None:
            self.grid.restore(state["resolution"])
        self.rejected.update({k: int(v) for k, v in state.get("rejected", {}).items() if k in self.rejected})
        if state.get("latency_sums") is not None:
            sums = np.asarray(state["latency_sums"], dtype=float)
            counts = np.asarray(state.get("latency_counts", []), dtype=np.int64)
            if sums.shape == self.latency_fit.sums.shape and counts.shape == self.latency_fit.counts.shape:
                self.latency_fit.sums, self.latency_fit.counts = sums, counts

    def fit_residuals(self) -> tuple[dict[int, np.ndarray], np.ndarray] | None:
        """The kept samples' residual per configuration and C_bar, of the fit with the latency fitted (:meth:`LatencyFit.residuals`)."""
        fit = self.latency_fit.solve()
        return self.latency_fit.residuals(0.0 if fit is None else fit[0])

    def samples(self, kin: Kinematics, tool: Tool, batch: SampleBatch, final: bool = False, rates=None) -> StillSamples:
        """Feed ``batch`` and return the samples that can now be decided, with the moving wrench and the weight of the kept ones.

        Args:
            kin: Kinematics.
            tool: The tool (mass, centre of mass, inertia, tolerance).
            batch: New samples, in time order.
            final: No more samples will come.
            rates: Exact ``(velocity [rad/s], acceleration [rad/s^2])`` of the batch's joints,
                each (N, n_joints), or None: estimated from the readings.
        """
        self.grid.update(batch.channels)
        buf = batch if self._buffer is None else SampleBatch.concatenate([self._buffer, batch])
        exact = self._rates if rates is None and not len(batch) else None  # the final flush: the rates held
        if rates is not None:
            new = (np.asarray(rates[0], dtype=float), np.asarray(rates[1], dtype=float))
            held = self._rates
            exact = new if held is None else (np.concatenate([held[0], new[0]]), np.concatenate([held[1], new[1]]))
        time, n = buf.time, len(buf)
        if self._dt is None and n > PERIOD_SAMPLES:
            self._dt = sample_period(time)
        if self.measured_floor is None:
            if n < NOISE_SAMPLES and not final:
                self._buffer, self._rates = buf, exact  # nothing is decided before the noise is known
                return self._none(buf)
            self.measured_floor = third_difference_noise(buf.channels)
            self.joint_noise = third_difference_noise(buf.joints)
        start = self._context
        end = n if final else int(np.searchsorted(time, time[-1] - self._half, side="right")) if n else 0
        end = max(end, start)
        decided = self._decide(kin, tool, buf, exact, start, end)
        if final or end >= n:
            self._buffer, self._rates, self._context = None, None, 0
        else:
            first = min(int(np.searchsorted(time, time[end] - self._half, side="left")), end)
            self._buffer, self._context = buf.rows(first, n), end - first
            self._rates = None if exact is None else (exact[0][first:], exact[1][first:])
        return decided

    def _none(self, buf: SampleBatch) -> StillSamples:
        return StillSamples(buf.rows(0, 0), np.zeros(0, dtype=bool), np.zeros((0, 3)), np.zeros((0, 6)), np.zeros(0))

    def _decide(self, kin: Kinematics, tool: Tool, buf: SampleBatch, exact, start: int, end: int) -> StillSamples:
        settings = self.settings
        rows = buf.rows(start, end)
        if end <= start:
            return self._none(buf)
        window, dt = settings.dynamic_window_s, self._dt or 0.0
        if exact is None:
            # a sample without a whole window is dropped, and so is one whose jerk window reaches one: their rates are never used
            motion = joint_motion(buf.time, buf.joints, window, dt, self._continuous, self.latency_s, settings.dynamic_order, cut=False)
            half = max(1, int(round(window / 2 / dt))) if dt > 0 else 1
            gains = kernel_gains(window, dt, settings.dynamic_order) if dt > 0 else (0.0, 0.0, 0.0, 0.0)
            check = motion.acceleration if motion.check is None else motion.check
            bias = acceleration_bias(motion.acceleration, check, half, dt, gains, self._joint_noise(kin)) if dt > 0 else 0 * check
            bias = bias[start:end]
            full = motion.full[start:end] & _whole(motion.full, half)[start:end]
        else:
            motion = JointMotion(buf.joints, exact[0], exact[1], np.ones(len(buf), dtype=bool))
            bias, gains, full = np.zeros((end - start, buf.joints.shape[1])), (0.0, 0.0, 0.0, 0.0), np.ones(end - start, dtype=bool)
        keep = full.copy()
        self.rejected["derivative window cut"] += int((~full).sum())
        index = np.flatnonzero(full)
        weight = np.zeros(0)
        if not len(index):
            return StillSamples(rows, keep, np.zeros((0, 3)), np.zeros((0, 6)), weight)
        at = start + index
        codes = rows.configuration[index]
        load = blocked_load(kin, tool, motion.joints[at], codes, motion.velocity[at], motion.acceleration[at])
        if self._levers is None:
            self._levers = joint_levers(kin, motion.joints[at[0]])
        moving = load.w_sensor
        rate = np.gradient(moving, rows.time[index], axis=0) if len(index) > 1 else np.zeros_like(moving)
        rate = np.where(np.isfinite(rate), rate, np.inf)
        omega = load.motion.omega if load.motion is not None else np.zeros((len(index), 3))
        alpha = load.motion.alpha if load.motion is not None else np.zeros((len(index), 3))
        bias, noise, latency, sigma_w = bias[index], self._joint_noise(kin), self._latency_sigma(kin), self.sigma_w()
        weight, trusted = np.zeros(len(index)), np.zeros(len(index), dtype=bool)
        for b in (slice(i, i + LOAD_BLOCK) for i in range(0, len(index), LOAD_BLOCK)):  # in the cache, as the load
            inertial = inertial_moment(tool, codes[b], omega[b], alpha[b])
            errors = predicted_error(
                tool, codes[b], omega[b], bias[b], rate[b], inertial, gains, noise, latency, self._levers, settings.inertia_tolerance
            )
            weight[b], trusted[b] = trust_weights(*errors, sigma_w, settings.max_error_ratio)
        self.rejected["expected wrench not trusted"] += int((~trusted).sum())
        keep[index] = trusted
        mine = index[trusted]
        self.latency_fit.add(self.layout.project(rows.channels[mine]), codes[trusted], moving[trusted], rate[trusted], weight[trusted])
        static_model = np.all(np.abs(moving - load.static)[trusted] <= sigma_w, axis=1)  # the dynamic part below the noise
        return StillSamples(rows, keep, load.g_sensor[trusted], moving[trusted], weight[trusted], static_model)

    def _joint_noise(self, kin: Kinematics) -> np.ndarray:
        if self.settings.joint_noise is not None:
            return np.full(kin.n_joints, self.settings.joint_noise)
        measured = np.zeros(kin.n_joints) if self.joint_noise is None else self.joint_noise
        return np.maximum(measured, kin.robot.accuracy.encoder_resolution / math.sqrt(12.0))

    def budget_accuracy(self, kin: Kinematics) -> RobotAccuracy:
        """The robot's accuracy with the latency this filter leaves: the bound of the accuracy budget's latency term.

        The latency is fitted with the calibration and applied (:mod:`fts_calib.pipeline.latency_fit`): what is
        left is the fit's remaining latency and its standard error, ``sqrt(3) * hypot(tau, stderr)`` as the bound of
        a uniform error [s]; without a fit, the trust rule's latency uncertainty.
        """
        fit = self.latency_fit.solve()
        sigma = self._latency_sigma(kin) if fit is None else math.hypot(*fit)
        return dataclasses.replace(kin.robot.accuracy, latency_s=math.sqrt(3.0) * sigma)

    def _latency_sigma(self, kin: Kinematics) -> float:
        if self.settings.latency_uncertainty_s is not None:
            return self.settings.latency_uncertainty_s
        accuracy = kin.robot.accuracy
        return math.hypot(accuracy.latency_s / math.sqrt(3.0), accuracy.jitter_s)


def _whole(full: np.ndarray, half: int) -> np.ndarray:
    """Samples whose jerk window (``half`` each side) holds only whole derivative windows."""
    bad = np.concatenate([[0], np.cumsum(~full)])
    n = len(full)
    left, right = np.maximum(np.arange(n) - half, 0), np.minimum(np.arange(n) + half, n - 1)
    return bad[right + 1] == bad[left]


def nominal_c(spec: SensorSpec) -> np.ndarray | None:
    """A sensor file's nominal C (6 x n, raw channels to [N, N m]): its simulation section's, or None without one."""
    return None if spec.simulated is None else spec.layout.c_from_c_bar(spec.simulated.C_bar)


def sample_filter(
    settings: PipelineConfig, kin: Kinematics, use_filter: bool, full_scale, layout: ChannelLayout, n_configurations: int
) -> QuasiStaticFilter | DynamicFilter | None:
    """The session's sample filter of ``settings.filter.mode`` (None: every valid sample kept).

    Args:
        settings: Pipeline settings (the filter's, the channels' limits, the nominal C).
        kin: Kinematics (its continuous joints).
        use_filter: False: no filter.
        full_scale: Full scale per axis [N, N m], shape (6,).
        layout: The channel layout.
        n_configurations: The tool's configurations.
    """
    if not use_filter:
        return None
    if settings.filter.mode == DYNAMIC:
        limits = settings.checks.limits
        return DynamicFilter(settings.filter, kin.continuous, limits, settings.nominal_c, full_scale, layout, n_configurations)
    return QuasiStaticFilter(settings.filter, kin.continuous, settings.checks.limits)


def filtered(
    filter_: QuasiStaticFilter | DynamicFilter, kin: Kinematics, tool: Tool, batch: SampleBatch, final: bool, rates=None
) -> StillSamples:
    """The samples ``filter_`` decides now, with their wrench and weight (exact ``rates``: see :meth:`DynamicFilter.samples`).

    Raises:
        ShapeError: Exact rates given to the quasi-static filter (it estimates its own).
    """
    if isinstance(filter_, DynamicFilter):
        return filter_.samples(kin, tool, batch, final, rates)
    if rates is not None:
        raise ShapeError("exact joint rates are for filter.mode 'dynamic': the quasi-static filter estimates its own")
    return quasi_static(filter_, kin, tool, batch, final)


#: The smallest latency uncertainty the second read of ``latency_s: auto`` assumes [s].
MIN_LATENCY_SIGMA_S = 2e-5


def settings_for_first_read(settings: PipelineConfig, resume: bool) -> PipelineConfig:
    """The settings of a recording's first read: with ``latency_s: auto`` in dynamic mode, no latency and none of its uncertainty."""
    f = settings.filter
    if resume or f.mode != DYNAMIC or f.latency_s is not None:
        return settings
    return dataclasses.replace(settings, filter=dataclasses.replace(f, latency_s=0.0, latency_uncertainty_s=0.0))


def settings_with_latency(settings: PipelineConfig, filter_) -> PipelineConfig | None:
    """The settings of the second read: the latency fitted in the first applied (None: none was fitted)."""
    fit = None if not isinstance(filter_, DynamicFilter) else filter_.latency_fit.solve()
    if fit is None:
        return None
    tau, stderr = fit
    if abs(tau) <= max(3.0 * stderr, LATENCY_SIGNIFICANT_S):  # the first read stands: no latency to speak of
        return None
    f = dataclasses.replace(settings.filter, latency_s=filter_.latency_s + tau, latency_uncertainty_s=max(stderr, MIN_LATENCY_SIGMA_S))
    return dataclasses.replace(settings, filter=f)

r"""The trust rule of the dynamic filter: the predicted error of each sample's expected wrench, against the noise.

A moving sample's expected wrench (Newton-Euler, :func:`fts_calib.robot.tool.tool_load`)
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
(``gain_a sigma_q``, :func:`fts_calib.filters.joint_rates.kernel_gains`, ``sigma_q`` the joint
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

The dynamic sample filter (``filter.mode: dynamic``): moving samples calibrate.

The quasi-static filter (:mod:`fts_calib.filters.quasi_static`) keeps the samples where the
tool's wrench is its weight alone: a few % of a recording. This filter keeps every sample
whose *expected* wrench is trusted, with the tool's full Newton-Euler wrench
(:func:`fts_calib.robot.tool.tool_load`: mass, centre of mass, inertia):

1. joint positions, velocities and accelerations from the joint readings by a centred local
   polynomial (``dynamic_order``, 5) over ``dynamic_window_s`` (0.3 s) (no phase lag), evaluated ``latency_s`` later: the
   readings are that late (:mod:`fts_calib.filters.joint_rates`); a sample whose window is
   cut (a stream's edge, a gap, a tool change) is dropped ("derivative window cut");
2. the sensor's motion and the tool's wrench at every remaining sample (vectorised over the
   batch, one forward kinematics);
3. the trust rule (:mod:`fts_calib.filters.dynamic`): each sample's predicted error of the
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
(:meth:`fts_calib.session.session.CalibrationSession.add_samples`, ``rates``): they are then
used as they are (no latency shift, no derivative terms in the trust rule). Samples stream in
chunks; the filter keeps a window of context at the end of each and decides those samples
with the next, so the result does not depend on where chunks end.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core.arrays import cross
from ..model.channel_limits import ChannelLimits, GridWatch
from ..model.channels import MALTESE_CROSS_8, ChannelLayout
from ..model.sensor_config import SensorSpec
from ..robot.definition import RobotAccuracy
from ..robot.kinematics import Kinematics, SensorMotion
from ..robot.tool import Tool, ToolLoad, tool_load
from ..sources.batch import SampleBatch
from .joint_rates import JointMotion, joint_rates, kernel_gains
from .latency import LatencyFit, wrench_rate
from .quasi_static import PERIOD_SAMPLES, StillSamples, sample_period
from .settings import DYNAMIC, FilterConfig, PipelineConfig


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
    finite = np.isfinite(rate)  # a rate unbounded (a repeated time stamp): the latency's error unbounded, even when its sigma is 0
    latency = np.where(finite, latency_sigma_s * np.abs(np.where(finite, rate, 0.0)), np.inf)
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
    """:func:`fts_calib.robot.tool.tool_load` with joint rates, :data:`LOAD_BLOCK` samples at a time (the same result)."""
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
            from the kept samples (:mod:`fts_calib.filters.latency`).
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
        if self._dt is None and (n > PERIOD_SAMPLES or (final and n > 1)):
            self._dt = sample_period(time)
        # context each side: the window, and the jerk's
        half_s = self.settings.windows(self._dt or 0.0).dynamic_s + abs(self.latency_s) + (self._dt or 0.0)
        if self.measured_floor is None:
            if n < NOISE_SAMPLES and not final:
                self._buffer, self._rates = buf, exact  # nothing is decided before the noise is known
                return self._none(buf)
            self.measured_floor = third_difference_noise(buf.channels)
            self.joint_noise = third_difference_noise(buf.joints)
        start = self._context
        end = n if final else int(np.searchsorted(time, time[-1] - half_s, side="right")) if n else 0
        end = max(end, start)
        decided = self._decide(kin, tool, buf, exact, start, end)
        if final or end >= n:
            self._buffer, self._rates, self._context = None, None, 0
        else:
            first = min(int(np.searchsorted(time, time[end] - half_s, side="left")), end)
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
        dt = self._dt or 0.0
        window = settings.windows(dt).dynamic_s
        if exact is None:
            # a sample without a whole window is dropped, and so is one whose jerk window reaches one: their rates are never used
            motion = joint_rates(
                buf.time, buf.joints, window, dt, self._continuous, settings.dynamic_order, self.latency_s, cut=False, check=True
            )
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
        rate = wrench_rate(rows.time[index], moving)
        rate = np.where(np.isfinite(rate), rate, np.inf)  # a repeated time stamp: the latency's error unbounded there
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

        The latency is fitted with the calibration and applied (:mod:`fts_calib.filters.latency`): what is
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

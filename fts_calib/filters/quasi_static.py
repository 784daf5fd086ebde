"""The quasi-static sample filter: keep the samples where the tool's wrench is its weight alone.

A sample is kept when all four rules pass (thresholds in ``configs/pipeline.yaml``):

1. *joint speed*: every joint slower than ``max_joint_speed`` [rad/s];
2. *joint acceleration*: every joint accelerating less than ``max_joint_acceleration``
   [rad/s^2]; both estimated from the joint readings by a least-squares quadratic over
   ``derivative_window_s`` (at least ``derivative_min_samples`` samples:
   :meth:`fts_calib.filters.settings.FilterConfig.windows`) (:func:`fts_calib.filters.joint_rates.joint_rates`: the feeds carry
   no velocities), and both must hold at every
   sample of the strain window around the sample (the first milliseconds of a
   jerk-limited motion hardly show in a difference estimate);
3. *strain stationary*: the standard deviation of every bridge over ``strain_window_s``
   (centred on the sample; at least ``strain_min_samples`` samples) at most ``max_strain_std``, or, with ``auto``,
   ``strain_std_factor`` times the noise floor: the median of that deviation over the first
   200 samples the joint rules keep (vibration after a stop shows here; until those
   samples have come, nothing is decided), never below a channel's quantization noise step / sqrt(12)
   (:class:`fts_calib.model.channel_limits.GridWatch`); a window holding fewer than three quarters of
   half a window's samples (at least 3) shows nothing and fails: a lone sample beside a
   gap or at a stream's end (its deviation and joint rates would be zero by construction);
4. *dynamic wrench*: the dynamic part of the tool's wrench (Newton-Euler, from the
   kinematics and the estimated joint velocities and accelerations) at most
   ``max_dynamic_fraction`` of its weight, for the force and for the moment (relative to
   ``m g |c|``).

The filter never computes kinematics: :meth:`QuasiStaticFilter.process` applies rules 1-3
and returns the joint rates of the samples it decided; the caller computes the tool's load
along that motion (:func:`fts_calib.robot.tool.tool_load`) and
:meth:`QuasiStaticFilter.dynamic_rule` applies rule 4 to it
(:func:`fts_calib.filters.quasi_static.quasi_static` does both).

Samples stream in chunks; the filter keeps the last window of each chunk as context and
decides those samples with the next chunk, so that the result does not depend on where
chunks end. Samples must come in time order. Each rule counts what it rejects; a sample can
fail both joint rules, and the strain and dynamic rules count only samples whose joints
were still.

The windowed standard deviations use running sums restarted every block of samples, so
their rounding error stays at the level of one window whatever the length of the feed,
about values centred on their median, so that one wild reading spoils only the windows
near it. (Readings beyond the plausible range never get here: the session's checks skip
them.)

Quasi-static samples: the filter's decisions, the sensor motion and the tool's load, in that order.

The one place that joins the three: :class:`QuasiStaticFilter` decides from joint rates and
strain stationarity (rules 1-3), :func:`fts_calib.robot.tool.tool_load` computes the
tool's load along the motion of the still samples (the only kinematics), and the filter's
dynamic rule (4) judges that load. The calibration session, tare and payload
identification all take their samples from :func:`quasi_static`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.channel_limits import ChannelLimits, GridWatch
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool, ToolLoad, dynamic_fraction, tool_load
from ..sources.batch import SampleBatch
from .joint_rates import joint_rates, window_bounds
from .settings import FilterConfig

#: The rules, in the order they are reported.
RULES = ("joint speed", "joint acceleration", "strain not stationary", "dynamic wrench")

_FLOOR_SAMPLES = 200  # still samples whose strain deviation sets the noise floor (its median to a few %)
_FLOOR_WAIT_S = 120.0  # longest wait for them [s]; then the floor comes from what there is
PERIOD_SAMPLES = 100  # intervals that set the sample period


@dataclass(frozen=True)
class Decided:
    """Samples the filter has decided, in time order; every array has one row per sample.

    Attributes:
        samples: The decided samples. Length m.
        still: Joints and strain still (rules 1-3 passed): candidates for the dynamic rule.
            Shape (m,) bool.
        joint_velocity: Estimated joint velocities in [rad/s]. Shape (m, n_joints).
        joint_acceleration: Estimated joint accelerations in [rad/s^2]. Shape (m, n_joints).
    """

    samples: SampleBatch
    still: np.ndarray
    joint_velocity: np.ndarray
    joint_acceleration: np.ndarray


def windowed_std(values: np.ndarray, left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """Standard deviation of ``values[left:right+1]`` per column, for many windows.

    Args:
        values: Samples, shape (N, c).
        left: First index of each window, shape (m,).
        right: Last index of each window, shape (m,).

    Returns:
        Shape (m, c).
    """
    n, width = values.shape
    if n == 0 or len(left) == 0:
        return np.zeros((len(left), width))
    # centred on the median, not the mean: one wild value (1e8 among readings of 1) then spoils the
    # sums of its own block only, where a mean would carry it into every window's cancellation
    y = values - np.median(values, axis=0)
    block = int(max(1, np.max(right - left + 1)))  # a window spans at most two blocks
    padded = np.zeros((-(-n // block) * block, width))
    padded[:n] = y
    shape = (-1, block, width)
    s1 = np.cumsum(padded.reshape(shape), axis=1).reshape(-1, width)
    s2 = np.cumsum((padded * padded).reshape(shape), axis=1).reshape(-1, width)

    def window_sum(s: np.ndarray) -> np.ndarray:
        end = s[right]
        block_left, block_right = left // block, right // block
        before = np.where((left % block)[:, None] > 0, s[np.maximum(left - 1, 0)], 0.0)
        block_total = s[block_left * block + block - 1]
        return np.where((block_left == block_right)[:, None], end - before, block_total - before + end)

    count = (right - left + 1)[:, None].astype(float)
    mean = window_sum(s1) / count
    var = window_sum(s2) / count - mean * mean
    return np.sqrt(np.maximum(var, 0.0))


def held_still(
    time: np.ndarray,
    velocity: np.ndarray,
    acceleration: np.ndarray,
    settings: FilterConfig,
    index: np.ndarray | None = None,
    dt: float | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rules 1 and 2 held over the strain window around each sample: the joints slow and steady throughout it.

    The one form of the joint rules: the filter applies it to the rates it estimates, a plan's
    prediction (:func:`fts_calib.budget.predicted.predicted_still`) to its exact rates.

    Args:
        time: Sample times [s], in order. Shape (N,).
        velocity: Joint velocities [rad/s]. Shape (N, n_joints).
        acceleration: Joint accelerations [rad/s^2]. Shape (N, n_joints).
        settings: The thresholds (``max_joint_speed``, ``max_joint_acceleration``, ``strain_window_s``).
        index: The samples judged (their windows may reach the others), shape (m,); None: all.
        dt: The sample period [s] that sets the strain window (:meth:`FilterConfig.windows`); None: from ``time``.

    Returns:
        ``(speed ok (m,), acceleration ok (m,), first (m,), last (m,))``: whether every sample of
        the window passes rule 1, rule 2, and the window's first and last sample indices.
    """
    index = np.arange(len(time)) if index is None else index
    dt = sample_period(time) if dt is None else dt
    slow = np.max(np.abs(velocity), axis=1) <= settings.max_joint_speed
    steady = np.max(np.abs(acceleration), axis=1) <= settings.max_joint_acceleration
    left, right = window_bounds(time, index, settings.windows(dt).strain_s / 2)
    bad_speed = np.concatenate([[0], np.cumsum(~slow)])
    bad_accel = np.concatenate([[0], np.cumsum(~steady)])
    return bad_speed[right + 1] == bad_speed[left], bad_accel[right + 1] == bad_accel[left], left, right


def window_moves(time: np.ndarray, joints: np.ndarray, settings: FilterConfig) -> bool:
    """Rule 1 over a window of samples: does a joint travel farther than ``max_joint_speed`` allows in it?

    The window lasts as many sample periods as it holds samples (each stands for one period); a
    joint that travels more than ``max_joint_speed`` times that was faster than the rule allows
    at some sample. For the windows of a stream judged whole, not sample by sample (the offset
    watch in service: :mod:`fts_calib.monitor.offset_watch`).

    Args:
        time: Sample times of the window [s], in order. Shape (B,).
        joints: Joint readings [rad]. Shape (B, n_joints) (no column: nothing moves).
        settings: The thresholds (``max_joint_speed``).
    """
    n = len(time)
    if n < 2 or not joints.shape[1]:
        return False
    duration = (float(time[-1]) - float(time[0])) * n / (n - 1)
    return bool(np.any(np.ptp(joints, axis=0) > settings.max_joint_speed * duration))


def sample_period(time: np.ndarray) -> float:
    """A stream's sample period in [s], from its first intervals (the median of the first 100; 0 for fewer than 2 samples).

    Estimated once per stream, from its start (101 samples), so that chunking changes nothing;
    a stream of fewer samples has the median of what it has.

    Args:
        time: Sample times in [s]. Shape (N,).
    """
    steps = np.diff(np.asarray(time, dtype=float)[: PERIOD_SAMPLES + 1])
    return float(np.median(steps)) if len(steps) else 0.0


class QuasiStaticFilter:
    """Stream filter of quasi-static samples (see the module docstring).

    Args:
        settings: Thresholds.
        continuous: Which joints are continuous (unwrapped before differentiating), the
            robot's joint order. Shape (n_joints,) bool.
        limits: The channels' declared resolution (0 or None: learnt from the values, :attr:`grid`).
    """

    def __init__(self, settings: FilterConfig, continuous: np.ndarray, limits: ChannelLimits | None = None):
        self.settings = settings
        self.rejected = dict.fromkeys(RULES, 0)
        self.measured_floor: np.ndarray | None = None
        self.grid = GridWatch(None if limits is None else limits.resolution)
        self._context = 0
        self._buffer: SampleBatch | None = None
        self._continuous = np.asarray(continuous, dtype=bool)
        self._dt: float | None = None

    @property
    def dt(self) -> float:
        """The stream's sample period [s] (0 before it is known)."""
        return self._dt or 0.0

    def _half(self) -> float:
        """Context kept on each side of a decided sample [s]: its strain window, and the derivative window of every sample in it."""
        windows = self.settings.windows(self.dt)
        return (windows.derivative_s + windows.strain_s) / 2 + self.dt

    @property
    def noise_floor(self) -> np.ndarray | None:
        """The strain noise per channel, raw units, shape (n,): :attr:`measured_floor`, at least step / sqrt(12)."""
        return self.grid.floor(self.measured_floor)

    def state(self) -> dict:
        """What a checkpoint keeps of the filter (the noise floor measured, and the channels' resolution)."""
        floor = None if self.measured_floor is None else self.measured_floor.tolist()
        return {"noise_floor": floor, "resolution": self.grid.state(), "rejected": dict(self.rejected)}

    def restore(self, state: dict) -> None:
        """Restore :meth:`state`."""
        if state.get("noise_floor") is not None:
            self.measured_floor = np.asarray(state["noise_floor"], dtype=float)
        if state.get("resolution") is not None:
            self.grid.restore(state["resolution"])
        self.rejected.update({k: int(v) for k, v in state.get("rejected", {}).items() if k in self.rejected})

    def process(self, batch: SampleBatch, final: bool = False) -> Decided:
        """Add samples (in time order) and return those that can now be decided (rules 1-3).

        Args:
            batch: New samples, not before the previous ones.
            final: No more samples will come: decide everything.
        """
        self.grid.update(batch.channels)
        buf = batch if self._buffer is None else SampleBatch.concatenate([self._buffer, batch])
        time = buf.time
        n = len(time)
        start = self._context
        if self._dt is None and n > PERIOD_SAMPLES:
            self._dt = sample_period(time)
        if self._dt is None and not final:  # the windows need the sample period: the first 101 samples
            end = start
        else:
            if self._dt is None:  # a stream of 100 samples or fewer: the period of what there is
                self._dt = sample_period(time)
            end = n if final else int(np.searchsorted(time, time[-1] - self._half(), side="right")) if n else 0
        end = max(end, start)
        if self._waiting(buf, np.arange(start, end), final):
            self._buffer = buf  # nothing is decided before the noise floor is known
            none = np.zeros(0, dtype=bool)
            return Decided(buf.rows(0, 0), none, buf.joints[:0], buf.joints[:0])
        index = np.arange(start, end)
        still, velocity, acceleration = self._decide(buf, index)
        decided = Decided(buf.rows(start, end), still, velocity, acceleration)
        if final or end >= n:
            self._buffer, self._context = None, 0
        else:
            first = int(np.searchsorted(time, time[end] - self._half(), side="left"))
            first = min(first, end)
            self._buffer = buf.rows(first, n)
            self._context = end - first
        return decided

    def dynamic_rule(self, load: ToolLoad, configuration: np.ndarray, tool: Tool) -> np.ndarray:
        """Rule 4 on still samples: their dynamic wrench at most ``max_dynamic_fraction`` of the weight.

        Args:
            load: The tool's load at the samples, with the moving wrench. Length k.
            configuration: Configuration index of each sample. Shape (k,).
            tool: The tool (the weight and lever of each configuration).

        Returns:
            The samples that pass, shape (k,) bool (all of them without a moving wrench).
        """
        moving = load.moving is not None
        fraction = dynamic_fraction(tool, configuration, load.moving - load.static) if moving else np.zeros(len(configuration))
        ok = fraction <= self.settings.max_dynamic_fraction
        self.rejected["dynamic wrench"] += int((~ok).sum())
        return ok

    def _joint_rates(self, time, joints) -> tuple[np.ndarray, np.ndarray]:
        if self._dt is None and len(time) > PERIOD_SAMPLES:
            self._dt = sample_period(time)
        motion = joint_rates(time, joints, self.settings.windows(self.dt).derivative_s, self.dt, self._continuous, order=2)
        return motion.velocity, motion.acceleration

    def _still(self, buf: SampleBatch, index):
        """Joint rules at ``index``: (speed ok, acceleration ok, velocity, acceleration, window bounds).

        The rules hold over the whole strain window, not only at the sample: the first
        milliseconds of a jerk-limited motion hardly show in any estimate.
        """
        velocity_all, acceleration_all = self._joint_rates(buf.time, buf.joints)
        speed_ok, accel_ok, s_left, s_right = held_still(buf.time, velocity_all, acceleration_all, self.settings, index, self.dt)
        return speed_ok, accel_ok, velocity_all[index], acceleration_all[index], s_left, s_right

    def _judged(self, time: np.ndarray, s_left: np.ndarray, s_right: np.ndarray) -> np.ndarray:
        """Which strain windows hold samples enough to show stationarity (rule 3).

        At least three quarters of the samples of half a window, and 3: a sample at a
        stream's edge or beside a gap has its window on one side only (and passes), a lone
        one or two has nothing to show.
        """
        dt = self.dt or sample_period(time)
        need = max(3, int(np.ceil(0.75 * self.settings.windows(dt).strain_s / (2 * dt)))) if dt > 0 else 3
        return s_right - s_left + 1 >= need

    def _waiting(self, buf: SampleBatch, index, final: bool) -> bool:
        """In ``auto`` mode, set the noise floor from the first still samples of the stream.

        The floor is the median, per bridge, of the strain deviation over the first 200
        samples whose joints are still (in stream order, so it does not depend on how the
        stream is chunked); until they have come, samples wait. After 120 s of waiting, or
        at the end of the stream, what there is sets it.

        Returns:
            True while the samples must wait.
        """
        if self.settings.max_strain_std is not None or self.measured_floor is not None or len(index) == 0:
            return False
        speed_ok, accel_ok, _, _, s_left, s_right = self._still(buf, index)
        still = np.nonzero(speed_ok & accel_ok & self._judged(buf.time, s_left, s_right))[0][:_FLOOR_SAMPLES]
        give_up = final or buf.time[index[-1]] - buf.time[0] >= _FLOOR_WAIT_S
        if len(still) < _FLOOR_SAMPLES and not give_up:
            return True
        if len(still):
            self.measured_floor = np.median(windowed_std(buf.channels, s_left[still], s_right[still]), axis=0)
        return False

    def _decide(self, buf: SampleBatch, index) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Rules 1-3 at ``index``: (still (m,), joint velocity (m, n), joint acceleration (m, n))."""
        settings = self.settings
        channels = buf.channels
        if len(index) == 0:
            return np.zeros(0, dtype=bool), buf.joints[:0], buf.joints[:0]
        speed_ok, accel_ok, velocity, acceleration, s_left, s_right = self._still(buf, index)
        joints_ok = speed_ok & accel_ok
        # strain stationarity, computed where the joints are still (the others are rejected anyway)
        std = np.full((len(index), channels.shape[1]), np.inf)
        std[joints_ok] = windowed_std(channels, s_left[joints_ok], s_right[joints_ok])
        if settings.max_strain_std is not None:
            threshold = np.full(channels.shape[1], settings.max_strain_std)
        elif (floor := self.noise_floor) is None:
            threshold = np.full(channels.shape[1], -1.0)  # no still sample at all: nothing is known to be stationary
        else:
            # a tiny absolute floor keeps noiseless (simulated) data from failing on rounding; at the scale
            # of the typical reading (a median: one wild value must not loosen the threshold of all)
            scale = float(np.max(np.median(np.abs(channels), axis=0)))
            threshold = np.maximum(settings.strain_std_factor * floor, 1e-9 * scale)
        strain_ok = np.all(std <= threshold, axis=1) & self._judged(buf.time, s_left, s_right)
        # a moving sample is counted by the joint rules only: its strain was not looked at
        self.rejected["joint speed"] += int((~speed_ok).sum())
        self.rejected["joint acceleration"] += int((~accel_ok).sum())
        self.rejected["strain not stationary"] += int((joints_ok & ~strain_ok).sum())
        return joints_ok & strain_ok, velocity, acceleration


@dataclass(frozen=True)
class StillSamples:
    """The samples the filter decided, which of them are quasi-static, and the load of those.

    Attributes:
        decided: The samples decided by this call, in time order. Length m.
        keep: The quasi-static ones (all four rules passed). Shape (m,) bool, k of them true.
        g_sensor: Gravity in the sensor frame at each kept sample, in [m/s^2]. Shape (k, 3).
        w_sensor: The tool's static wrench at each kept sample (paper eqs 17-18), in
            [N, N m], shape (k, 6); None for an unknown payload (no tool). The dynamic filter's:
            the moving wrench (:mod:`fts_calib.filters.dynamic`).
        weight: The estimator's weight of each kept sample, shape (k,), or None: all 1.
        static_model: Which kept samples the fit check's static model (eqs 17-18) holds for,
            shape (k,) bool, or None: all (the quasi-static filter's).
        still: The quasi-static filter's rules 1-3 (joints and strain still), before the dynamic
            rule, shape (m,) bool; None for another filter.
    """

    decided: SampleBatch
    keep: np.ndarray
    g_sensor: np.ndarray
    w_sensor: np.ndarray | None
    weight: np.ndarray | None = None
    static_model: np.ndarray | None = None
    still: np.ndarray | None = None

    @property
    def samples(self) -> SampleBatch:
        """The kept samples, in time order. Length k."""
        return self.decided.select(self.keep)


def quasi_static(filter_: QuasiStaticFilter, kin: Kinematics, tool: Tool | None, batch: SampleBatch, final: bool = False) -> StillSamples:
    """Feed ``batch`` to the filter and return the samples it can now decide, with the load of the kept ones.

    Args:
        filter_: The stream's filter (it keeps context between calls).
        kin: Kinematics of the robot.
        tool: The mounted tool, or None for an unknown payload (gravity then has the robot
            model's magnitude, and the dynamic rule is skipped).
        batch: New samples, in time order, every configuration index valid.
        final: No more samples will come.
    """
    decided = filter_.process(batch, final=final)
    still = decided.samples.select(decided.still)
    keep = decided.still.copy()
    if tool is None:
        g = kin.g_sensor(still.joints, None).reshape(-1, 3) if len(still) else np.zeros((0, 3))
        return StillSamples(decided.samples, keep, g, None, still=decided.still)
    velocity, acceleration = decided.joint_velocity[decided.still], decided.joint_acceleration[decided.still]
    load = tool_load(kin, tool, still.joints, still.configuration, velocity, acceleration)
    ok = filter_.dynamic_rule(load, still.configuration, tool)
    keep[decided.still] = ok
    return StillSamples(decided.samples, keep, load.g_sensor[ok], load.static[ok], still=decided.still)

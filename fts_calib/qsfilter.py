r"""The quasi-static sample filter: keep the samples where the tool's wrench is its weight alone.

A sample is kept when all four rules pass (thresholds in ``configs/pipeline.yaml``):

1. *joint speed*: every joint slower than ``max_joint_speed`` [rad/s];
2. *joint acceleration*: every joint accelerating less than ``max_joint_acceleration``
   [rad/s^2]; both estimated from the joint readings by differences over
   ``derivative_window_s`` (the feeds carry no velocities), and both must hold at every
   sample of the strain window around the sample (the first milliseconds of a
   jerk-limited motion hardly show in a difference estimate);
3. *strain stationary*: the standard deviation of every bridge over ``strain_window_s``
   (centred on the sample) at most ``max_strain_std``, or, with ``auto``,
   ``strain_std_factor`` times the noise floor: the median of that deviation over the
   samples the joint rules keep (vibration after a stop shows here);
4. *dynamic wrench*: the dynamic part of the tool's wrench (Newton-Euler, from the
   kinematics and the estimated joint velocities and accelerations) at most
   ``max_dynamic_fraction`` of its weight, for the force and for the moment (relative to
   ``m g |c|``).

Samples stream in chunks; the filter keeps the last window of each chunk as context and
decides those samples with the next chunk, so that the result does not depend on where
chunks end. Samples must come in time order. Each rule counts what it rejects (a sample
can fail several).

The windowed standard deviations use running sums restarted every block of samples, so
their rounding error stays at the level of one window whatever the length of the feed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .kinematics import Kinematics
from .pipeline_config import FilterConfig
from .tool import Tool

#: The rules, in the order they are reported.
RULES = ("joint speed", "joint acceleration", "strain not stationary", "dynamic wrench")

_FLOOR_HISTORY = 200  # noise-floor estimates kept (one per chunk)


@dataclass(frozen=True)
class Decided:
    """Samples the filter has decided, in time order.

    Attributes:
        time: [s], shape (m,).
        readings: Joint readings [rad], shape (m, n_joints).
        strain: Raw strains, shape (m, 8).
        tool: Tool configuration indices, shape (m,).
        keep: Quasi-static samples, shape (m,) bool.
        g_sensor: Gravity in the sensor frame [m/s^2] of the kept samples, shape (k, 3).
    """

    time: np.ndarray
    readings: np.ndarray
    strain: np.ndarray
    tool: np.ndarray
    keep: np.ndarray
    g_sensor: np.ndarray


def window_bounds(time: np.ndarray, index: np.ndarray, half: float) -> tuple[np.ndarray, np.ndarray]:
    """First and last sample indices within ``half`` [s] of each sample ``index``."""
    left = np.searchsorted(time, time[index] - half, side="left")
    right = np.searchsorted(time, time[index] + half, side="right") - 1
    return left, right


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
    y = values - values.mean(axis=0)
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


class QuasiStaticFilter:
    """Stream filter of quasi-static samples (see the module docstring).

    Args:
        config: Thresholds.
        kin: Kinematics of the robot (for the dynamic rule and gravity).
        tool: The calibration tool (mass, centre of mass and inertia of each configuration).
    """

    def __init__(self, config: FilterConfig, kin: Kinematics, tool: Tool):
        self.config = config
        self.kin = kin
        self.tool = tool
        self.rejected = dict.fromkeys(RULES, 0)
        self.noise_floor: np.ndarray | None = None
        self._floors: list[np.ndarray] = []
        self._context = 0
        self._buffer: tuple[np.ndarray, ...] | None = None
        self._half = max(config.derivative_window_s, config.strain_window_s) / 2

    def state(self) -> dict:
        """What a checkpoint keeps of the filter (the noise floor)."""
        return {"noise_floor": None if self.noise_floor is None else self.noise_floor.tolist(),
                "rejected": dict(self.rejected)}

    def restore(self, state: dict) -> None:
        """Restore :meth:`state`."""
        if state.get("noise_floor") is not None:
            self.noise_floor = np.asarray(state["noise_floor"], dtype=float)
            self._floors = [self.noise_floor]
        self.rejected.update({k: int(v) for k, v in state.get("rejected", {}).items() if k in self.rejected})

    def process(self, time, readings, strain, tool, final: bool = False) -> Decided:
        """Add samples (in time order) and return those that can now be decided.

        Args:
            time: [s], shape (n,), not before the previous samples.
            readings: Joint readings [rad], shape (n, n_joints).
            strain: Raw strains, shape (n, 8).
            tool: Tool configuration indices, shape (n,).
            final: No more samples will come: decide everything.
        """
        new = (np.asarray(time, dtype=float), np.asarray(readings, dtype=float), np.asarray(strain, dtype=float),
               np.asarray(tool, dtype=np.int64))
        if self._buffer is None:
            buf = new
        else:
            buf = tuple(np.concatenate([old, part]) for old, part in zip(self._buffer, new, strict=True))
        T, theta, S, codes = buf
        n = len(T)
        start = self._context
        end = n if final else int(np.searchsorted(T, T[-1] - self._half, side="right")) if n else 0
        end = max(end, start)
        index = np.arange(start, end)
        keep, g = self._decide(T, theta, S, codes, index)
        decided = Decided(T[start:end], theta[start:end], S[start:end], codes[start:end], keep, g)
        if final or end >= n:
            self._buffer, self._context = None, 0
        else:
            first = int(np.searchsorted(T, T[end] - self._half, side="left"))
            first = min(first, end)
            self._buffer = tuple(a[first:] for a in buf)
            self._context = end - first
        return decided

    def _joint_rates(self, T, theta, index) -> tuple[np.ndarray, np.ndarray]:
        """Joint velocity and acceleration at ``index`` by differences over the derivative window."""
        left, right = window_bounds(T, index, self.config.derivative_window_s / 2)
        dt_total = T[right] - T[left]
        dt_left = T[index] - T[left]
        dt_right = T[right] - T[index]
        with np.errstate(divide="ignore", invalid="ignore"):
            velocity = np.where((dt_total > 0)[:, None], (theta[right] - theta[left]) / dt_total[:, None], 0.0)
            both = (dt_left > 0) & (dt_right > 0)
            slope_right = (theta[right] - theta[index]) / dt_right[:, None]
            slope_left = (theta[index] - theta[left]) / dt_left[:, None]
            acceleration = np.where(both[:, None], 2.0 * (slope_right - slope_left) / dt_total[:, None], 0.0)
        return velocity, acceleration

    def _decide(self, T, theta, S, codes, index) -> tuple[np.ndarray, np.ndarray]:
        cfg = self.config
        if len(index) == 0:
            return np.zeros(0, dtype=bool), np.zeros((0, 3))
        # the joint rules hold over the whole strain window, not only at the sample: the first
        # milliseconds of a jerk-limited motion hardly show in a difference estimate
        everywhere = np.arange(len(T))
        velocity_all, acceleration_all = self._joint_rates(T, theta, everywhere)
        slow = np.max(np.abs(velocity_all), axis=1) <= cfg.max_joint_speed
        steady = np.max(np.abs(acceleration_all), axis=1) <= cfg.max_joint_acceleration
        s_left, s_right = window_bounds(T, index, cfg.strain_window_s / 2)
        bad_speed = np.concatenate([[0], np.cumsum(~slow)])
        bad_accel = np.concatenate([[0], np.cumsum(~steady)])
        speed_ok = bad_speed[s_right + 1] == bad_speed[s_left]
        accel_ok = bad_accel[s_right + 1] == bad_accel[s_left]
        joints_ok = speed_ok & accel_ok
        velocity, acceleration = velocity_all[index], acceleration_all[index]
        # strain stationarity
        std = windowed_std(S, s_left, s_right)
        if cfg.max_strain_std is not None:
            threshold = np.full(S.shape[1], cfg.max_strain_std)
        else:
            if joints_ok.any():
                self._floors.append(np.median(std[joints_ok], axis=0))
                del self._floors[:-_FLOOR_HISTORY]
                self.noise_floor = np.median(np.array(self._floors), axis=0)
            if self.noise_floor is None:
                threshold = np.full(S.shape[1], -1.0)  # no still sample yet: nothing is known to be stationary
            else:
                # a tiny absolute floor keeps noiseless (simulated) data from failing on rounding
                threshold = np.maximum(cfg.strain_std_factor * self.noise_floor, 1e-9 * np.max(np.abs(S)))
        strain_ok = np.all(std <= threshold, axis=1)
        candidates = joints_ok & strain_ok
        keep = candidates.copy()
        g_kept = np.zeros((0, 3))
        rows = index[candidates]
        dynamic_rejected = 0
        if len(rows):
            motion = self.kin.sensor_motion(theta[rows], velocity[candidates], acceleration[candidates])
            g = np.einsum("nji,j->ni", motion.R_world_sensor, self.kin.g_world(self.tool.gravity))
            fraction = np.zeros(len(rows))
            for c, config in enumerate(self.tool.configurations):
                mine = codes[rows] == c
                if not mine.any():
                    continue
                static = config.static_wrench(g[mine])
                dynamic = config.dynamic_wrench(g[mine], motion.omega[mine], motion.alpha[mine], motion.a[mine])
                weight = config.mass * self.tool.gravity
                lever = max(float(np.linalg.norm(config.p_sensor_com)), 1e-3)
                delta = dynamic - static
                fraction[mine] = np.maximum(np.linalg.norm(delta[:, :3], axis=1) / weight,
                                            np.linalg.norm(delta[:, 3:], axis=1) / (weight * lever))
            dynamic_ok = fraction <= cfg.max_dynamic_fraction
            dynamic_rejected = int((~dynamic_ok).sum())
            keep[candidates] = dynamic_ok
            g_kept = g[dynamic_ok]
        self.rejected["joint speed"] += int((~speed_ok).sum())
        self.rejected["joint acceleration"] += int((~accel_ok).sum())
        self.rejected["strain not stationary"] += int((~strain_ok).sum())
        self.rejected["dynamic wrench"] += dynamic_rejected
        return keep, g_kept

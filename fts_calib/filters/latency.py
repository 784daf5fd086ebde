r"""The constant latency between the joint and channel streams: one regression, three uses.

When the joint readings are ``tau`` late (the row of time t holds the joints of t - tau), the
wrench predicted from them along a motion is late too: with ``W_meas`` the measured wrench
and ``W_pred`` the tool's (or payload's) wrench predicted from the readings,

.. math::

    W_{meas}(t) - W_{pred}(t) \approx \tau\, \dot W_{pred}(t), \qquad
    \hat\tau = \frac{\sum_{i,j} w_j r_{ij} s_{ij}}{\sum_{i,j} w_j s_{ij}^2},

the least squares of the residuals ``r`` on the predicted wrench's rate ``s``
(:func:`wrench_rate`), over samples i and axes j weighted by ``w_j``
(:func:`latency_regression`). Its standard error comes from groups of consecutive samples
when the errors correlate within them (the weighted spread of the groups' estimates over the
square root of their number less one), or, where only sums are kept, from the residual sum of
squares (the samples taken as independent):

- the measured stream latency of every calibration (:func:`estimate_latency`): the moving
  samples whose dynamic part is well predicted (every joint's rates from a whole window, a
  joint faster than ``min_speed``), the calibration's wrench against the tool's moving wrench
  (:func:`fts_calib.robot.tool.tool_load`, joint rates by the quasi-static filter's quadratic),
  each axis scaled by its full scale; a first fit, then the residuals beyond five robust spreads
  left out and one group per move (a stretch of moving samples), so correlated model errors
  within a move do not make it look better than it is;
- payload from motion (:func:`fts_calib.payload.samples.identify_payload_from_samples`): the
  residuals of the payload just identified (its offsets' drift left out), each axis weighted by
  its residual spread, groups of eight joint-rate windows; the joints are re-aligned by the
  step and the payload fitted again until the step is below 20 us;
- the dynamic filter (:class:`LatencyFit`): the latency fitted with the calibration, from sums.
  Fitting the calibration to ``W + tau dW/dt`` (axes scaled by their full scale ``FS``,
  regressors ``x = [P Delta; e_c]``, one offset per tool configuration) is the same regression
  on the parts of ``W`` and ``dW/dt`` the regressors do not explain: with ``S`` the weighted sums
  of ``z z^T``, ``z = [x; W / FS; dW/dt / FS]``,
  ``A = S_WW - S_Wx S_xx^+ S_xW``, ``B = S_WV - S_Wx S_xx^+ S_xV``, ``E = S_VV - S_Vx S_xx^+ S_xV``,

  .. math::

      \mathrm{RSS}(\tau) = \mathrm{tr} A + 2\tau\,\mathrm{tr} B + \tau^2\,\mathrm{tr} E, \qquad
      \hat\tau = -\mathrm{tr} B / \mathrm{tr} E, \qquad
      \sigma_\tau^2 = \frac{\mathrm{RSS}(\hat\tau)}{6 (n - p)\,\mathrm{tr} E}.

  ``tau`` is the latency *left* after the one the filter applied: ``calibrate`` with
  ``filter.latency_s: auto`` reads the recording again with it applied
  (:func:`fts_calib.session.calibration_run.calibrate_recording`). The standard error takes the
  samples as independent: optimistic where the errors correlate over the derivative window.
  Only sums are kept: memory does not grow with the stream.

Times in [s], rates in [rad/s], wrenches in [N, N m].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model.calibration import Calibration
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool, tool_load
from .joint_rates import joint_rates

_MIN_SPEED = 0.2  # [rad/s] a joint at least this fast: the wrench changes enough to show a lag
_MIN_MOVE_SAMPLES = 20  # a move shorter than this gives no estimate of its own
_OUTLIER = 5.0  # residuals beyond this many robust spreads are not "well predicted"


@dataclass(frozen=True)
class LatencyEstimate:
    """How late the joint readings are, relative to the channels.

    Attributes:
        latency_s: The estimate [s] (positive: the joints are late; add it to their times,
            ``live.latency_s``, to align them).
        stderr_s: Its standard error [s] (inf with fewer than two moves).
        moves: Moves that gave an estimate.
        samples: Moving samples used.
    """

    latency_s: float
    stderr_s: float
    moves: int
    samples: int

    def summary(self) -> str:
        """One line with units."""
        return (
            f"joint stream behind the channels by {1e3 * self.latency_s:.3f} ± {1e3 * self.stderr_s:.3f} ms "
            f"(from {self.moves} moves, {self.samples:,} moving samples)"
        )

    def as_dict(self) -> dict:
        """Plain data for a file, in [ms]."""
        return {
            "latency_ms": float(f"{1e3 * self.latency_s:.4g}"),
            "stderr_ms": float(f"{1e3 * self.stderr_s:.4g}") if math.isfinite(self.stderr_s) else None,
            "moves": self.moves,
            "samples": self.samples,
        }


@dataclass(frozen=True)
class LatencyStep:
    """A least-squares latency (:func:`latency_regression`).

    Attributes:
        latency_s: How much later the joints are than the prediction assumed [s].
        stderr_s: Its standard error [s] (inf when nothing gives one: fewer than two groups).
        groups: Groups that gave an estimate of their own (1 without groups).
    """

    latency_s: float
    stderr_s: float
    groups: int


def wrench_rate(time: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The time derivative of a wrench along samples, by central differences [N/s, N m/s], shaped like ``w`` (N, 6).

    Not finite where a time stamp repeats (a sample logged twice has no step); zeros with fewer than two samples.
    """
    if len(time) < 2:
        return np.zeros_like(w)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.gradient(w, time, axis=0)


def latency_sums(residual: np.ndarray, rate: np.ndarray, weight: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Each sample's terms of the regression: ``sum_j w_j r_j s_j`` and ``sum_j w_j s_j^2``.

    Args:
        residual: Measured less predicted wrench, shape (N, 6) (scaled as the caller weighs the axes).
        rate: The predicted wrench's time derivative (:func:`wrench_rate`), finite, shape (N, 6).
        weight: Weight of each axis, shape (6,); None: 1.

    Returns:
        ``(rs (N,), ss (N,))``.
    """
    if weight is None:
        return np.sum(residual * rate, axis=1), np.sum(rate * rate, axis=1)
    return np.sum(residual * rate * weight, axis=1), np.sum(rate**2 * weight, axis=1)


def latency_regression(
    rs: np.ndarray | float, ss: np.ndarray | float, starts: np.ndarray | None = None, rr: float | None = None, dof: int = 1
) -> LatencyStep | None:
    """The least-squares latency of ``W_meas - W_pred ~ tau dW_pred/dt`` and its standard error (module docstring).

    Args:
        rs: The samples' ``sum_j w_j r_j s_j`` (:func:`latency_sums`), shape (n,), or their sum.
        ss: The samples' ``sum_j w_j s_j^2``, shape (n,), or their sum.
        starts: The first sample of each group of consecutive samples (a move, a block), ascending,
            shape (K,): the standard error from the spread of the groups' estimates (weighted by
            their ``ss``), the groups without a rate left out.
        rr: Without groups: the weighted sum of the squared residuals, for the standard error of
            independent residuals ``sqrt(RSS(tau) / dof / ss)``, ``RSS(tau) = rr - 2 tau rs + tau^2 ss``.
        dof: The residuals' degrees of freedom (with ``rr``).

    Returns:
        The latency [s] with its standard error, or None when the predicted wrench does not change (``ss`` sums to 0).
    """
    total, cross = float(np.sum(ss)), float(np.sum(rs))
    if not total > 0:
        return None
    tau = cross / total
    if starts is not None:
        group_rs, group_ss = np.add.reduceat(rs, starts), np.add.reduceat(ss, starts)
        good = group_ss > 0
        k = int(good.sum())
        if k < 2:
            return LatencyStep(tau, math.inf, k)
        each, w = group_rs[good] / group_ss[good], group_ss[good]
        return LatencyStep(tau, math.sqrt(float(np.sum(w * (each - tau) ** 2) / np.sum(w)) / (k - 1)), k)
    if rr is None:
        return LatencyStep(tau, math.inf, 1)
    rss = max(rr - 2 * tau * cross + tau * tau * total, 0.0)
    return LatencyStep(tau, math.sqrt(rss / dof / total), 1)


def estimate_latency(
    kin: Kinematics,
    tool: Tool,
    calibration: Calibration,
    time: np.ndarray,
    joints: np.ndarray,
    channels: np.ndarray,
    configuration: np.ndarray,
    full_scale: np.ndarray,
    window_s: float = 0.05,
    min_speed: float = _MIN_SPEED,
) -> LatencyEstimate | None:
    """Estimate the latency of the joint stream from a recording's moving samples (see the module docstring).

    Args:
        kin: Kinematics.
        tool: The tool (mass, centre of mass and inertia of each configuration).
        calibration: The calibration (from the still samples) that turns channels into wrenches.
        time: Sample times [s], non-decreasing. Shape (N,).
        joints: Joint readings [rad]. Shape (N, n_joints).
        channels: Raw channels. Shape (N, n).
        configuration: Tool configuration index of each sample. Shape (N,) int.
        full_scale: Full scale per axis [N, N m] (scales the axes). Shape (6,).
        window_s: Window of the joint-rate estimates [s].
        min_speed: Slowest joint speed that counts as moving [rad/s].

    Returns:
        The estimate, or None when the recording has no usable move.
    """
    time, joints = np.asarray(time, dtype=float), np.asarray(joints, dtype=float)
    codes = np.asarray(configuration, dtype=np.int64)
    if len(time) < 3:
        return None
    steps = np.diff(time)
    steps = steps[steps > 0]  # repeated stamps (a sample logged twice) have no step: the period is that of the others
    if not len(steps):
        return None
    dt = float(np.median(steps))
    residual, rate, move = [], [], []
    new = np.concatenate([[True], np.diff(codes) != 0])
    bounds = [*np.nonzero(new)[0], len(time)]
    for start, stop in zip(bounds[:-1], bounds[1:], strict=True):
        part = slice(start, stop)
        rates = joint_rates(time[part], joints[part], window_s, dt, kin.continuous, order=2)
        velocity, acceleration = rates.velocity, rates.acceleration
        half = int(math.ceil(window_s / dt / 2)) + 1
        moving = np.max(np.abs(velocity), axis=1) >= min_speed
        moving[:half], moving[-half:] = False, False
        if not moving.any():
            continue
        predicted = tool_load(kin, tool, joints[part], codes[part], velocity, acceleration).w_sensor / full_scale
        measured = calibration.wrench(channels[part], region_check=False) / full_scale
        slope = wrench_rate(time[part], predicted)
        moving &= np.all(np.isfinite(slope), axis=1)  # repeated time stamps: no slope there
        label = np.cumsum(np.concatenate([[True], moving[1:] & ~moving[:-1]])) + start
        residual.append((measured - predicted)[moving])
        rate.append(slope[moving])
        move.append(label[moving])
    if not residual:
        return None
    r, s, m = np.concatenate(residual), np.concatenate(rate), np.concatenate(move)
    rs, ss = latency_sums(r, s)
    first = latency_regression(rs, ss)
    if first is None:
        return None
    spread = np.abs(r - first.latency_s * s)
    scale = 1.4826 * np.median(spread, axis=0) + 1e-15
    good = np.all(spread <= _OUTLIER * scale, axis=1)
    _, counts = np.unique(m[good], return_counts=True)  # the moves' good samples (labels ascend: each move is one run)
    counted = np.repeat(counts >= _MIN_MOVE_SAMPLES, counts)
    starts = np.concatenate([[0], np.cumsum(counts[counts >= _MIN_MOVE_SAMPLES])[:-1]]).astype(np.int64)
    step = latency_regression(rs[good][counted], ss[good][counted], starts) if counted.any() else None
    if step is None:
        return None
    return LatencyEstimate(step.latency_s, step.stderr_s, step.groups, int(good.sum()))


#: Fewest samples for a latency estimate.
MIN_SAMPLES = 200


class LatencyFit:
    """Sums for the latency fitted with the calibration (see the module docstring).

    Args:
        n_configurations: k, the tool's configurations (one offset column each).
        full_scale: Full scale per axis [N, N m], shape (6,).
    """

    def __init__(self, n_configurations: int, full_scale):
        self.k = int(n_configurations)
        self.full_scale = np.asarray(full_scale, dtype=float)
        width = 6 + self.k + 12
        self.sums = np.zeros((self.k, width, width))  # per configuration
        self.counts = np.zeros(self.k, dtype=np.int64)

    @property
    def count(self) -> int:
        """Samples added."""
        return int(self.counts.sum())

    def add(self, projected: np.ndarray, codes: np.ndarray, wrench: np.ndarray, rate: np.ndarray, weight: np.ndarray) -> None:
        """Add kept samples.

        Args:
            projected: ``P Delta`` of the samples, shape (N, 6).
            codes: Configuration index per sample, shape (N,).
            wrench: Expected wrench [N, N m], shape (N, 6).
            rate: Its rate of change [N/s, N m/s], shape (N, 6).
            weight: The samples' weights, shape (N,).
        """
        finite = np.all(np.isfinite(rate), axis=1)
        n = int(finite.sum())
        if not n:
            return
        z = np.zeros((n, self.sums.shape[1]))
        z[:, :6] = projected[finite]
        z[np.arange(n), 6 + codes[finite]] = 1.0
        z[:, 6 + self.k : 12 + self.k] = wrench[finite] / self.full_scale
        z[:, 12 + self.k :] = rate[finite] / self.full_scale
        codes, weight = codes[finite], weight[finite]
        single = bool(np.all(codes == codes[0]))
        for c in np.unique(codes):
            mine = slice(None) if single else codes == c  # one configuration (the usual chunk): no copies
            part = z[mine]
            self.sums[c] += (part * weight[mine, None]).T @ part
            self.counts[c] += len(part)

    def solve(self) -> tuple[float, float] | None:
        """``(tau [s], standard error [s])``, or None with too few samples or no change of the wrench."""
        if self.count < MIN_SAMPLES:
            return None
        p = 6 + self.k
        S = self.sums.sum(axis=0)
        x, w, v = slice(0, p), slice(p, p + 6), slice(p + 6, p + 12)
        inverse = np.linalg.pinv(S[x, x])

        def part(a: slice, b: slice) -> float:
            return float(np.trace(S[a, b] - S[a, x] @ inverse @ S[x, b]))

        # the regression on what the calibration's regressors leave of W and dW/dt: residual -W, rate dW/dt
        step = latency_regression(-part(w, v), part(v, v), rr=part(w, w), dof=6 * max(self.count - p, 1))
        return None if step is None else (step.latency_s, step.stderr_s)

    def residuals(self, tau: float) -> tuple[dict[int, np.ndarray], np.ndarray] | None:
        """The fit's residual per configuration at the latency ``tau`` [s] (the dynamic fit check), and its C_bar.

        Returns:
            ``({configuration index: weighted residual RMS per axis [N, N m], scaled by
            sqrt(sum of weights / samples) so that samples of weight 1 / (1 + rho^2) show the strain
            noise alone}, C_bar (6, 6))``, or None with too few samples.
        """
        if self.count < MIN_SAMPLES:
            return None
        p = 6 + self.k
        S = self.sums.sum(axis=0)
        x = slice(0, p)
        target = S[p : p + 6, x] + tau * S[p + 6 : p + 12, x]
        theta = target @ np.linalg.pinv(S[x, x])  # (6, p): scaled wrench from [P Delta; e_c]
        L = np.hstack([-theta, np.eye(6), tau * np.eye(6)])
        out = {}
        for c in range(self.k):
            weight = self.sums[c, 6 + c, 6 + c]  # the sum of the weights: the one-hot column's
            if self.counts[c] and weight > 0:
                rss = np.maximum(np.diag(L @ self.sums[c] @ L.T), 0.0)
                out[c] = self.full_scale * np.sqrt(rss / weight) * math.sqrt(weight / self.counts[c])
        return out, theta[:, :6] * self.full_scale[:, None]

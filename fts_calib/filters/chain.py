"""The filter chain: every sample a job selects goes through the checks, then the quasi-static filter, the dynamic one or none.

One chain per stream, built in one place (:func:`filter_chain`) from the pipeline settings
(``filter``: its mode and thresholds; ``checks``: ``max_abs_channel`` and the channels'
limits), the kinematics and the sensor (its channel layout and full scale) with the tool's
number of configurations:

1. the checks (:class:`fts_calib.filters.sample_checks.SampleChecks`): valid values, rails,
   time order, a known configuration, joint limits; what fails is skipped and counted;
2. the filter of the mode: ``quasi-static`` (:class:`fts_calib.filters.quasi_static.QuasiStaticFilter`:
   rules 1-4), ``dynamic`` (:class:`fts_calib.filters.dynamic.DynamicFilter`: the trust rule)
   or ``none`` (:data:`NO_FILTER`: every checked sample kept);
3. the known load of the kept samples: the tool's wrench (:func:`fts_calib.robot.tool.tool_load`),
   or for an unknown payload (no tool) gravity in the sensor frame alone.

:meth:`FilterChain.samples` runs a batch through it and returns the samples that passed the
checks and those the filter kept, with their load (:class:`Filtered`). The calibration session,
tare and payload identification take their samples from it; a job that needs a part of it
takes that part from here, never a rule of its own:

- the checks alone (:meth:`FilterChain.accept`): ``validate`` compares every valid sample, and
  a payload's motion is fitted from every valid sample;
- the joint-rate window's duration (:meth:`FilterChain.motion_window`, at the stream's sample
  period: the duration, or the 3 samples of a quadratic if longer): ``validate``'s expected wrench
  and a payload's motion see the rates of the filter's polynomial over the filter's duration (not
  its 7 samples at a low rate, :meth:`FilterChain.derivative_window`: a moving sample's rates
  want the shortest window, a still one's the quietest);
- the quasi-static joint rules held over the strain window, from exact joint rates
  (:func:`fts_calib.filters.quasi_static.held_still`): the samples of a planned motion the
  filter will keep (:func:`fts_calib.budget.predicted.predicted_still`);
- the joint-speed rule over a window of samples (:func:`fts_calib.filters.quasi_static.window_moves`):
  the offset watch's windows without motion (:mod:`fts_calib.monitor.offset_watch`).

Without kinematics (a tare window without a robot) the checks leave out the joint limits, the
joint rules take the stream's joint columns as they are (none continuous; a stream of the
strains alone has none: the strain rule alone decides), and no load is known (gravity NaN). Units: time [s], joints [rad], wrenches
[N, N, N, N m, N m, N m], gravity [m/s^2].
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..core.exceptions import ConfigError, ShapeError
from ..model.channels import MALTESE_CROSS_8, ChannelLayout
from ..model.sensor_config import DEFAULT_FULL_SCALE
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool, tool_load
from ..sources.batch import SampleBatch
from .dynamic import DynamicFilter
from .quasi_static import QuasiStaticFilter, StillSamples, quasi_static
from .sample_checks import SampleChecks
from .settings import AUTO_FILTER, DYNAMIC, FILTER_CHOICES, NO_FILTER, QUASI_STATIC, PipelineConfig, window_span

#: The chain's modes: the pipeline's filter modes, and none (every sample that passes the checks is kept).
CHAIN_MODES = FILTER_CHOICES


@dataclass(frozen=True)
class Filtered:
    """One batch through the chain.

    Attributes:
        checked: The samples of the batch that passed the checks, in time order.
        still: What the filter decided by this call (it holds a window of context back), which
            samples it kept and their known load (:class:`fts_calib.filters.quasi_static.StillSamples`).
    """

    checked: SampleBatch
    still: StillSamples

    @property
    def kept(self) -> SampleBatch:
        """The kept samples, in time order."""
        return self.still.samples


class FilterChain:
    """The checks and the filter of one stream (see the module docstring); built by :func:`filter_chain`.

    Args:
        kin: Kinematics of the robot, or None for a stream without joints.
        checks: The stream's checks.
        filter_: The stream's filter, or None (:data:`NO_FILTER`).
        derivative_window_s: The joint-rate window of the still rules [s] (``filter.derivative_window_s``).
        n_channels: The sensor's channels.
        n_joints: Without kinematics: the stream's joint columns.
        derivative_min_samples: The fewest samples the joint-rate window holds (``filter.derivative_min_samples``).

    Attributes:
        kin: The kinematics (None: no joints).
        checks: The checks, with what they skipped.
        filter: The filter (None without one), with what it rejected by rule and its noise floor.
        derivative_window_s: The joint-rate window's duration [s] (``filter.derivative_window_s``);
            at a sample period, :meth:`derivative_window`.
        derivative_min_samples: The fewest samples that window holds (``filter.derivative_min_samples``).
    """

    def __init__(
        self,
        kin: Kinematics | None,
        checks: SampleChecks,
        filter_: QuasiStaticFilter | DynamicFilter | None,
        derivative_window_s: float,
        n_channels: int,
        n_joints: int = 0,
        derivative_min_samples: int = 3,
    ):
        self.kin = kin
        self.checks = checks
        self.filter = filter_
        self.derivative_window_s = derivative_window_s
        self.derivative_min_samples = derivative_min_samples
        self.n_channels = n_channels
        self.n_joints = n_joints

    def derivative_window(self, dt: float) -> float:
        """The joint-rate window of the still rules at the sample period ``dt`` [s], in [s]: the rates the filter judges."""
        return window_span(self.derivative_window_s, self.derivative_min_samples, dt)

    def motion_window(self, dt: float) -> float:
        """The joint-rate window of moving samples at the sample period ``dt`` [s], in [s]: the filter's duration, at least 3 samples."""
        return window_span(self.derivative_window_s, 3, dt)

    @property
    def mode(self) -> str:
        """``quasi-static``, ``dynamic`` or ``none``."""
        return NO_FILTER if self.filter is None else DYNAMIC if isinstance(self.filter, DynamicFilter) else QUASI_STATIC

    @property
    def noise_floor(self) -> np.ndarray | None:
        """The strain noise per channel the filter measured, raw units, shape (n,); None without a filter or before it is known."""
        return None if self.filter is None else self.filter.noise_floor

    def accept(self, batch: SampleBatch) -> np.ndarray:
        """The checks alone: the samples of ``batch`` that pass them, shape (N,) bool; the others are counted."""
        return self.checks.accept(batch)

    def samples(self, batch: SampleBatch, tool: Tool | None = None, final: bool = False, rates=None) -> Filtered:
        """Run ``batch`` through the checks and the filter: the checked samples, and the kept ones with their load.

        Args:
            batch: New samples of the stream, in time order.
            tool: The mounted tool (its load: static, or moving for the dynamic filter), or None
                for an unknown payload (gravity in the sensor frame alone; the dynamic rule skipped).
            final: No more samples will come: the filter decides all it holds.
            rates: The joints' exact ``(velocity [rad/s], acceleration [rad/s^2])``, each
                (N, n_joints), for the dynamic filter; None: estimated from the readings.

        Raises:
            ShapeError: Exact rates given to a chain whose filter is not the dynamic one.
        """
        ok = self.checks.accept(batch)
        checked = batch.select(ok)
        if not len(checked) and not final:  # nothing new: the filter has nothing more to decide
            return Filtered(checked, StillSamples(checked, np.zeros(0, dtype=bool), np.zeros((0, 3)), None))
        if rates is not None:
            rates = (np.asarray(rates[0])[ok], np.asarray(rates[1])[ok])
        return Filtered(checked, self.decide(checked, tool, final, rates))

    def decide(self, checked: SampleBatch, tool: Tool | None = None, final: bool = False, rates=None) -> StillSamples:
        """The filter's part alone, on samples that passed the checks (see :meth:`samples`)."""
        filter_ = self.filter
        if isinstance(filter_, DynamicFilter):
            if tool is None:
                raise ConfigError("tool", None, "a tool", message="the dynamic filter judges a known tool's wrench: give the tool")
            if self.kin is None:
                raise ConfigError("kin", None, "the robot's kinematics", message="the dynamic filter needs the kinematics")
            return filter_.samples(self.kin, tool, checked, final, rates)
        if rates is not None:
            raise ShapeError("exact joint rates are for filter.mode 'dynamic': the quasi-static filter estimates its own")
        if filter_ is None:
            return self._all(checked, tool)
        if self.kin is None:  # the joint columns as they are (none: a column at rest), no load known
            if not checked.joints.shape[1]:
                checked = dataclasses.replace(checked, joints=np.zeros((len(checked), 1)))
            decided = filter_.process(checked, final=final)
            still = decided.still.copy()
            return StillSamples(decided.samples, still, np.full((int(still.sum()), 3), np.nan), None, still=decided.still)
        return quasi_static(filter_, self.kin, tool, checked, final)

    def flush(self, tool: Tool | None = None) -> StillSamples:
        """Decide the samples the filter still holds (the stream has ended)."""
        n_joints = self.n_joints if self.kin is None else self.kin.n_joints
        return self.decide(SampleBatch.empty(n_joints, self.n_channels), tool, final=True)

    def skipped(self) -> dict[str, int]:
        """Samples not kept, by reason: the checks', then the filter's rules (``filter: joint speed``, ...)."""
        out = dict(self.checks.skipped)
        if self.filter is not None:
            out.update({f"filter: {rule}": n for rule, n in self.filter.rejected.items() if n})
        return out

    def _all(self, checked: SampleBatch, tool: Tool | None) -> StillSamples:
        """Every checked sample kept, with its static load (gravity alone for an unknown payload)."""
        keep = np.ones(len(checked), dtype=bool)
        if self.kin is None:
            return StillSamples(checked, keep, np.full((len(checked), 3), np.nan), None)
        if tool is None:
            g = self.kin.g_sensor(checked.joints, None).reshape(-1, 3) if len(checked) else np.zeros((0, 3))
            return StillSamples(checked, keep, g, None)
        load = tool_load(self.kin, tool, checked.joints, checked.configuration)
        return StillSamples(checked, keep, load.g_sensor, load.static)


def filter_chain(
    settings: PipelineConfig,
    kin: Kinematics | None,
    mode: str | None = None,
    layout: ChannelLayout = MALTESE_CROSS_8,
    full_scale=None,
    n_configurations: int = 1,
    n_joints: int = 0,
) -> FilterChain:
    """The filter chain of one stream (see the module docstring).

    Args:
        settings: Pipeline settings: the filter's mode and thresholds, ``checks.max_abs_channel``,
            the channels' declared (or detected) limits ``checks.limits``, the nominal C.
        kin: Kinematics of the robot (joint limits, continuous joints, gravity), or None for a
            stream without joints (the strain rule alone).
        mode: ``quasi-static``, ``dynamic``, ``none``, or ``auto`` (one read of a stream: the
            quasi-static filter; ``calibrate`` alone reads a recording again with the dynamic one);
            None: ``settings.filter.mode``.
        layout: The sensor's channel layout.
        full_scale: The sensor's full scale per axis [N, N, N, N m, N m, N m], shape (6,) (the
            dynamic filter's noise without a nominal C); the sensor file's default when None.
        n_configurations: The tool's configurations (the dynamic filter's latency fit).
        n_joints: Without kinematics: the joint columns of the stream (none continuous); 0 for the strains alone.

    Raises:
        ConfigError: An unknown mode, or the dynamic filter without kinematics.
    """
    mode = settings.filter.mode if mode is None else mode
    if mode not in CHAIN_MODES:
        raise ConfigError("mode", mode, " or ".join(CHAIN_MODES))
    if mode == AUTO_FILTER:
        mode = QUASI_STATIC
    limits = settings.checks.limits
    checks = SampleChecks(kin, settings.checks.max_abs_channel, limits)
    continuous = np.zeros(max(n_joints, 1), dtype=bool) if kin is None else kin.continuous
    filter_: QuasiStaticFilter | DynamicFilter | None = None
    if mode == DYNAMIC:
        if kin is None:
            raise ConfigError("kin", None, "the robot's kinematics", message="the dynamic filter needs the robot's kinematics")
        scale = DEFAULT_FULL_SCALE if full_scale is None else np.asarray(full_scale, dtype=float)
        filter_ = DynamicFilter(settings.filter, continuous, limits, settings.nominal_c, scale, layout, n_configurations)
    elif mode == QUASI_STATIC:
        filter_ = QuasiStaticFilter(settings.filter, continuous, limits)
    derivative = settings.filter.derivative_window_s
    return FilterChain(kin, checks, filter_, derivative, layout.n_channels, n_joints, settings.filter.derivative_min_samples)

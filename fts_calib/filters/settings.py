"""Pipeline settings (``configs/pipeline.yaml``): the quasi-static filter and the live path.

``filter``: a sample is kept when the joint speeds stay below ``max_joint_speed`` [rad/s]
and the joint accelerations below ``max_joint_acceleration`` [rad/s^2] (estimated by a least-squares quadratic over
``derivative_window_s`` [s]: the feeds carry no velocities), when the strains are
stationary over ``strain_window_s`` [s] (standard deviation of every bridge at most
``max_strain_std`` raw units, or ``auto``: ``strain_std_factor`` times the noise floor
measured on still samples), and when the dynamic part of the tool's wrench is at most
``max_dynamic_fraction`` of its weight (force) and of weight times lever (moment).

Windows at any sample rate: each window lasts its duration (``derivative_window_s``,
``strain_window_s``, ``dynamic_window_s``) AND holds a minimum number of samples
(``derivative_min_samples``, 7; ``strain_min_samples``, 5; the dynamic filter's polynomial:
its degree + 2), whichever is longer at the stream's sample period ``dt``
(:meth:`FilterConfig.windows`): at 1 kHz the durations rule (0.05 s: 51 samples; 0.1 s: 101),
at 100 Hz the derivative window stretches to 0.06 s (7 samples: a quadratic through 5
readings of a joint with 1e-5 rad of noise has 0.05 rad/s^2 of acceleration noise, half the
``max_joint_acceleration``), at 10 Hz to 0.6 s and 0.4 s. A motion seen at 10 Hz, 100 Hz and
1 kHz is then judged alike, within the noise; a stop shorter than the still rules' span (the
strain window and a derivative window on each side: 1.0 s at 10 Hz) has no still sample at
that rate, which the commands say (:meth:`Windows.text`).

``filter.mode``: ``auto`` (default: the rules above, ``quasi-static``; a recording that moves
without stops, too few of whose samples are still for them, is read again with ``dynamic``:
:func:`fts_calib.session.calibration_run.calibrate_recording`; a live feed, read once, stays
quasi-static), ``quasi-static`` or ``dynamic``
(:mod:`fts_calib.filters.dynamic`): every sample whose expected wrench is trusted enters the
estimator with the tool's Newton-Euler wrench, joint rates from a centred local polynomial of degree
``dynamic_order`` (3 or 5) over ``dynamic_window_s`` [s] evaluated ``latency_s`` [s] later (how late the joint readings are in
the samples the session receives; ``auto``: 0, and ``calibrate`` reads the recording again with
the latency it estimates when that is significant), weighted by the trust rule
(:mod:`fts_calib.filters.dynamic`) with ``joint_noise`` [rad] (``auto``: measured),
``latency_uncertainty_s`` [s] (``auto``: the robot file's ``accuracy.latency_s`` / sqrt(3) and
``jitter_s``), ``inertia_tolerance`` (relative, of the tool's inertia) and
``max_error_ratio`` (the largest predicted error of a kept sample, in units of the noise).

``live``: ``max_gap_s`` [s], the longest gap of the joint stream the synchronizer
interpolates across; ``latency_s`` [s], added to joint times to align them with strain
times; ``checkpoint_interval_s`` [s], how often the session's accumulators are saved.

``checks``: ``max_abs_channel`` [raw units], the largest plausible magnitude of a channel
reading (default 1e9, above the counts of a 24-bit ADC): a sample with a channel beyond it
is a bad sample, skipped and counted as "channel out of range" by the sample checks, so
that one corrupt value never reaches the filter's stationarity windows. Lower it to the
sensor's range to catch smaller glitches; raise it for a sensor that delivers larger raw
numbers (e.g. 32-bit ADC counts).

``design``: ``noise_std``, the strain noise per bridge [raw units] assumed by the
excitation report of planned trajectories (default: the sensor file's).

``offsets``: how the offsets may move during the run (:mod:`fts_calib.model.offset_models`):
``model`` is ``auto`` (default: the simplest model the data support, by BIC),
``constant`` (the paper), ``per-configuration`` or ``drift``; ``drift_degree`` the highest
power of time in the drift model (default 2); ``time_scale_s`` [s] the unit of time of
its basis (default 600, conditioning only).

``fit``: ``floor``, in % of each axis's full scale (the sensor file's), the residual RMS below
which the fit check never refuses (default 0.01: a misfit that small is below what any use
of the sensor notices; :mod:`fts_calib.session.fit`).

An unknown section or key (a typo) is refused with the known ones listed.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..core import arrays as validation
from ..core.exceptions import ConfigError, FileFormatError
from ..core.files import check_keys, fields_of, load_yaml, read_number
from ..model.channel_limits import ChannelLimits
from ..model.offset_models import AUTO, OffsetBasis, offset_setting

#: Default of ``checks.max_abs_channel`` [raw units]: larger than any reading of a sensor
#: delivering mV/V, N or 24-bit ADC counts (2^23 = 8.4e6), far below a corrupt cell (1e160).
DEFAULT_MAX_ABS_CHANNEL = 1e9

#: The sample filter's modes (``filter.mode``): still samples only, every trusted moving one, or
#: auto: still samples, moving ones for a recording without stops (see the module docstring).
AUTO_FILTER, QUASI_STATIC, DYNAMIC = "auto", "quasi-static", "dynamic"
FILTER_MODES = (AUTO_FILTER, QUASI_STATIC, DYNAMIC)
#: What ``--filter`` takes: a mode, or ``none`` (every valid sample kept, no filter).
NO_FILTER = "none"
FILTER_CHOICES = (*FILTER_MODES, NO_FILTER)
#: Filter keys that take ``auto`` (None).
_AUTO_KEYS = ("max_strain_std", "latency_s", "joint_noise", "latency_uncertainty_s")

#: The sections of a pipeline settings file.
SECTIONS = ("filter", "live", "checks", "design", "offsets", "fit")


def window_span(duration_s: float, min_samples: int, dt: float) -> float:
    """A window's span [s]: ``duration_s``, or longer when that holds fewer than ``min_samples`` samples at the period ``dt`` [s].

    ``min_samples`` samples centred on one span ``(min_samples - 1) dt`` (a millionth more: the end samples of a
    stamped clock fall inside whatever their rounding); ``dt`` 0 (unknown): ``duration_s``.
    """
    return max(float(duration_s), (int(min_samples) - 1) * float(dt) * (1 + 1e-6)) if dt > 0 else float(duration_s)


@dataclass(frozen=True)
class Windows:
    """The filter's windows at one sample period (:meth:`FilterConfig.windows`), in [s].

    Attributes:
        dt: The sample period [s] (0: unknown; the durations then).
        derivative_s: The joint-rate window of the still rules.
        strain_s: The strain-stationarity window.
        dynamic_s: The dynamic filter's joint-rate window.
    """

    dt: float
    derivative_s: float
    strain_s: float
    dynamic_s: float

    @property
    def still_span_s(self) -> float:
        """The shortest stop with a still sample [s]: the strain window and a derivative window on each side."""
        return self.strain_s + self.derivative_s

    def text(self) -> str:
        """The windows in words, with the rate: 'at 10 Hz the filter's windows hold ...'."""
        rate = f"{1 / self.dt:.3g} Hz ({self.dt:g} s between samples)" if self.dt > 0 else "an unknown rate"

        def one(name: str, span: float) -> str:
            samples = f", {int(round(span / self.dt)) + 1} samples" if self.dt > 0 else ""
            return f"{name} {span:.3g} s{samples}"

        return (
            f"at {rate} the filter's windows are {one('derivative', self.derivative_s)}, {one('strain', self.strain_s)}: "
            f"a still sample needs the arm held still for {self.still_span_s:.3g} s or more"
        )


@dataclass(frozen=True)
class FilterConfig:
    """Quasi-static sample filter thresholds (see the module docstring)."""

    max_joint_speed: float = 0.01  # [rad/s]
    max_joint_acceleration: float = 0.1  # [rad/s^2]
    derivative_window_s: float = 0.05  # [s]
    strain_window_s: float = 0.1  # [s]
    max_strain_std: float | None = None  # [raw units]; None = auto
    strain_std_factor: float = 4.0
    max_dynamic_fraction: float = 1e-3
    mode: str = AUTO_FILTER
    latency_s: float | None = None  # [s]; None = auto
    joint_noise: float | None = None  # [rad]; None = auto (measured)
    latency_uncertainty_s: float | None = None  # [s]; None = auto (the robot file's accuracy)
    dynamic_window_s: float = 0.3  # [s]
    dynamic_order: int = 5
    inertia_tolerance: float = 0.01  # relative
    max_error_ratio: float = 3.0
    derivative_min_samples: int = 7
    strain_min_samples: int = 5

    def windows(self, dt: float) -> Windows:
        """The windows at the sample period ``dt`` [s]: each its duration, or its minimum number of samples if longer.

        Args:
            dt: The stream's sample period [s]; 0 (unknown): the durations.
        """
        return Windows(
            dt,
            window_span(self.derivative_window_s, self.derivative_min_samples, dt),
            window_span(self.strain_window_s, self.strain_min_samples, dt),
            window_span(self.dynamic_window_s, self.dynamic_order + 2, dt),
        )

    def low_rate_text(self, dt: float) -> str:
        """:meth:`Windows.text` at the period ``dt`` [s] when a window holds its minimum of samples, not its duration; else ''."""
        windows = self.windows(dt)
        stretched = windows.derivative_s > self.derivative_window_s or windows.strain_s > self.strain_window_s
        return windows.text() if stretched else ""

    def __post_init__(self):
        if self.mode not in FILTER_MODES:
            raise ConfigError("filter.mode", self.mode, " or ".join(FILTER_MODES))
        if self.latency_s is not None:
            object.__setattr__(self, "latency_s", validation.number("filter.latency_s", self.latency_s, "s"))
        for name in ("joint_noise", "latency_uncertainty_s", "inertia_tolerance"):
            if getattr(self, name) is not None:
                object.__setattr__(self, name, validation.non_negative(f"filter.{name}", getattr(self, name)))
        for name in ("derivative_min_samples", "strain_min_samples"):
            count = validation.number(f"filter.{name}", getattr(self, name))
            if not (count.is_integer() and count >= 3):
                raise ConfigError(f"filter.{name}", getattr(self, name), "an integer >= 3 (samples in the window)")
            object.__setattr__(self, name, int(count))
        if self.dynamic_order not in (3, 5):
            raise ConfigError("filter.dynamic_order", self.dynamic_order, "3 or 5 (the degree of the local polynomial)")
        object.__setattr__(self, "dynamic_order", int(self.dynamic_order))
        for name in ("max_error_ratio", "dynamic_window_s"):
            object.__setattr__(self, name, validation.positive(f"filter.{name}", getattr(self, name)))
        for name in (
            "max_joint_speed",
            "max_joint_acceleration",
            "derivative_window_s",
            "strain_window_s",
            "strain_std_factor",
            "max_dynamic_fraction",
        ):
            object.__setattr__(self, name, validation.positive(f"filter.{name}", getattr(self, name)))
        if self.max_strain_std is not None:
            std = validation.number("filter.max_strain_std", self.max_strain_std)
            if not std > 0:
                raise ConfigError("filter.max_strain_std", std, "a value > 0 or 'auto'")
            object.__setattr__(self, "max_strain_std", std)


@dataclass(frozen=True)
class LiveConfig:
    """Live-feed settings (see the module docstring)."""

    max_gap_s: float = 0.05
    latency_s: float = 0.0
    checkpoint_interval_s: float = 5.0

    def __post_init__(self):
        object.__setattr__(self, "max_gap_s", validation.positive("live.max_gap_s", self.max_gap_s, "s"))
        object.__setattr__(self, "latency_s", validation.number("live.latency_s", self.latency_s, "s"))
        object.__setattr__(
            self, "checkpoint_interval_s", validation.positive("live.checkpoint_interval_s", self.checkpoint_interval_s, "s")
        )


@dataclass(frozen=True)
class ChecksConfig:
    """Sample-check settings (see the module docstring)."""

    max_abs_channel: float = DEFAULT_MAX_ABS_CHANNEL  # [raw units]
    limits: ChannelLimits | None = None  # the channels' resolution and rails: the sensor file's, not this file's

    def __post_init__(self):
        object.__setattr__(self, "max_abs_channel", validation.positive("checks.max_abs_channel", self.max_abs_channel))
        if self.limits is not None and not isinstance(self.limits, ChannelLimits):  # a pipeline file's 'limits:'
            raise ConfigError("checks.limits", self.limits, "nothing here: a channel's resolution and range are the sensor file's")


@dataclass(frozen=True)
class OffsetConfig:
    """Offset-model settings (see the module docstring)."""

    model: str = AUTO
    drift_degree: int = 2
    time_scale_s: float = 600.0  # [s]

    def __post_init__(self):
        object.__setattr__(self, "model", offset_setting(self.model))
        degree = validation.number("offsets.drift_degree", self.drift_degree)
        if not (degree.is_integer() and 0 <= degree <= 4):
            raise ConfigError("offsets.drift_degree", self.drift_degree, "an integer from 0 to 4")
        object.__setattr__(self, "drift_degree", int(degree))
        object.__setattr__(self, "time_scale_s", validation.positive("offsets.time_scale_s", self.time_scale_s, "s"))

    def basis(self, n_configurations: int) -> OffsetBasis:
        """The estimator's full offset basis for a tool of ``n_configurations``."""
        return OffsetBasis(n_configurations, self.drift_degree, self.time_scale_s, temperature=True)


#: Default of the pipeline setting ``fit.floor``: a residual RMS below this, in % of each axis's
#: full scale, never refuses a fit.
DEFAULT_FLOOR_PERCENT = 0.01


@dataclass(frozen=True)
class FitConfig:
    """Fit-check settings (see the module docstring)."""

    floor: float = DEFAULT_FLOOR_PERCENT  # [% of full scale]

    def __post_init__(self):
        object.__setattr__(self, "floor", validation.non_negative("fit.floor", self.floor, "% of full scale"))


@dataclass(frozen=True)
class PipelineConfig:
    """All pipeline settings.

    Attributes:
        filter: Quasi-static filter.
        live: Live feeds.
        checks: Sample checks (plausible channel range).
        offsets: The offset model of the estimator.
        fit: The fit check (its absolute floor).
        noise_std: Strain noise per bridge for experiment design [raw units], or None for
            the sensor file's.
        nominal_c: The sensor file's nominal C (6 x n, raw channels to [N, N m]) as rows, or
            None: the dynamic filter's noise through C (:mod:`fts_calib.filters.dynamic`).
        repeatability: The sensor file's ``repeatability`` per axis [N, N, N, N m, N m, N m], or None:
            what the fit check expects and the budget holds of a sensor that does not repeat from pose to pose.
    """

    filter: FilterConfig = field(default_factory=FilterConfig)
    live: LiveConfig = field(default_factory=LiveConfig)
    noise_std: float | None = None
    checks: ChecksConfig = field(default_factory=ChecksConfig)
    offsets: OffsetConfig = field(default_factory=OffsetConfig)
    fit: FitConfig = field(default_factory=FitConfig)
    nominal_c: tuple[tuple[float, ...], ...] | None = None
    repeatability: tuple[float, ...] | None = None

    def with_filter_mode(self, mode: str | None) -> PipelineConfig:
        """These settings with another filter mode ('quasi-static', 'dynamic'); unchanged for None."""
        return self if mode is None else replace(self, filter=replace(self.filter, mode=mode))

    def with_nominal_c(self, C) -> PipelineConfig:
        """These settings with a nominal C (6 x n, raw channels to [N, N m]; None: none)."""
        return replace(self, nominal_c=None if C is None else tuple(tuple(float(v) for v in row) for row in np.asarray(C, dtype=float)))

    def with_limits(self, limits: ChannelLimits | None) -> PipelineConfig:
        """These settings with the channels' declared resolution and rails (:attr:`SensorSpec.limits`; None: none)."""
        return replace(self, checks=replace(self.checks, limits=limits))

    def with_repeatability(self, repeatability) -> PipelineConfig:
        """These settings with the sensor's repeatability per axis (:attr:`SensorSpec.repeatability`, shape (6,); None: none)."""
        values = None if repeatability is None else tuple(float(v) for v in np.asarray(repeatability, dtype=float).reshape(6))
        return replace(self, repeatability=values)

    def with_offsets(self, model: str | None) -> PipelineConfig:
        """These settings with another offset model ('auto', 'constant', 'per-configuration', 'drift'); unchanged for None."""
        return self if model is None else replace(self, offsets=replace(self.offsets, model=model))

    def __post_init__(self):
        if self.noise_std is not None:
            object.__setattr__(self, "noise_std", validation.positive("design.noise_std", self.noise_std))


def load_pipeline_config(path: str | Path) -> PipelineConfig:
    """Read a pipeline configuration file; absent keys take the defaults.

    Raises:
        FileFormatError: An unknown key or a bad value; the message names the field.
    """
    path = Path(path)
    data = load_yaml(path)
    check_keys(data, SECTIONS, path)

    def section(name: str, cls):
        raw = data.get(name) or {}
        if not isinstance(raw, dict):
            raise FileFormatError(path, name, "expected a mapping")
        check_keys(raw, cls.__dataclass_fields__, path, name)
        values: dict[str, float | str | None] = {}
        for key, value in raw.items():
            auto = name == "filter" and key in _AUTO_KEYS and value == "auto"
            if key in ("model", "mode"):  # the text values: offsets.model, filter.mode
                values[key] = str(value)
                continue
            values[key] = None if auto else read_number(value, path, f"{name}.{key}", "s" if key.endswith("_s") else "")
        with fields_of(path):  # the dataclasses name their fields as the file does ('filter.max_joint_speed')
            return cls(**values)

    design = data.get("design") or {}
    if not isinstance(design, dict):
        raise FileFormatError(path, "design", "expected a mapping")
    check_keys(design, ("noise_std",), path, "design")
    noise = design.get("noise_std")
    filter_config, live, checks = section("filter", FilterConfig), section("live", LiveConfig), section("checks", ChecksConfig)
    offsets, fit = section("offsets", OffsetConfig), section("fit", FitConfig)
    with fields_of(path):
        return PipelineConfig(
            filter=filter_config,
            live=live,
            noise_std=None if noise is None else read_number(noise, path, "design.noise_std"),
            checks=checks,
            offsets=offsets,
            fit=fit,
        )

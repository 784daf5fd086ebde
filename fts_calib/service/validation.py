"""The offsets ``validate`` adds to each calibration's wrench: its own offset model where it applies.

A calibration's ``D`` is the offset at the end of its run. On the calibration's own
recording, a per-configuration or drift model knows better: each configuration's offset (by
name: the validation tool's configuration ``B`` takes the calibration's offset of ``B``) and
the drift at each sample's time and temperature
(:func:`fts_calib.model.offset_models.evaluate_offsets`). The model applies only where it was
fitted: a configuration the calibration never saw, or a sample outside the time span of its
run (another recording, another day), takes ``D``. Constant models, and files written before
offset models existed, use ``D`` everywhere. :attr:`ValidationOffsets.words` says which.

The ``validate`` job: measured against expected wrench over a recording (the paper's third stage).

The recording should come from another motion and another tool than the calibration. For
every sample, the *expected* wrench is the tool's, from the kinematics: by default the
Newton-Euler wrench of the moving tool, with joint velocities and accelerations estimated
from the readings as the quasi-static filter does (:func:`fts_calib.filters.joint_rates.joint_rates`
over the filter chain's ``derivative_window_s``);
with ``dynamic=False`` the static weight alone (paper eqs 17-18: what the paper compared, its
error then includes the uncompensated dynamics). The *measured* wrench is ``C strain + D``
with each calibration, ``D`` being its offset model's where it applies (each
configuration's offset, the drift at each sample's time on the calibration's own recording:
:mod:`fts_calib.service.validation`). Errors per axis, in [N] or [N m] and in % of the sensor's full
scale (the paper's sensor: 50 N, 5 N m), and, with two calibrations, the same between them
(the paper's Table 1 against Table 2).

A calibration that records its load region (:mod:`fts_calib.model.region`) also has its errors
split into the samples whose *expected* wrench lies inside that region and those outside it
(:class:`RegionErrors`): a model is determined only on the loads it was fitted on, and the
region is a box with magnitude caps, so the split says where the errors were measured, not more.

Every sample goes through the checks of the filter chain (:mod:`fts_calib.filters.chain`:
bad values, rails, time order, joint limits; skipped and counted) and no filter: every valid
sample is compared. The recording streams in chunks; statistics are accumulated and the series for the plot are
thinned as they grow, so memory does not grow with the recording's length.
"""

from __future__ import annotations

import dataclasses
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core.arrays import frozen
from ..core.exceptions import ConfigError
from ..filters.chain import NO_FILTER, filter_chain
from ..filters.joint_rates import half_window, joint_rates
from ..filters.quasi_static import PERIOD_SAMPLES, sample_period
from ..filters.settings import PipelineConfig
from ..model.calibration import Calibration
from ..model.channel_limits import ChannelLimits
from ..model.channels import CALIBRATION_HINT, WRENCH_AXES, check_channels
from ..model.offset_models import evaluate_offsets
from ..model.region import LoadRegion
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool, tool_load
from ..sources.bag import BagTopics
from ..sources.source import open_recording

#: Slack on the calibration run's time span [s]: samples this far outside still use the
#: drift model (the trace's first and last points are samples, not the run's exact ends).
TIME_SLACK_S = 1.0


class ValidationOffsets:
    """The offsets of one calibration at the samples of a validation recording.

    Args:
        calibration: The calibration.
        tool_names: The validation tool's configuration names, its order (the recording's
            configuration indices).
    """

    def __init__(self, calibration: Calibration, tool_names: Sequence[str]):
        self.D = np.asarray(calibration.D, dtype=float)
        model: Mapping = calibration.offset_model or {}
        self.model = str(model.get("model", "constant")) if "basis" in model else "constant"
        self.description = model
        names = _configuration_names(calibration)
        fitted = _fitted_configurations(model, names)
        # validation tool index -> calibration index, -1 where the calibration has no offset of it
        self.codes = np.array([names.index(n) if n in fitted else -1 for n in tool_names], dtype=np.int64)
        self.matched = [n for n in tool_names if n in fitted]
        trajectory = model.get("trajectory") or []
        times = [float(p["time_s"]) for p in trajectory if "time_s" in p]
        start = float(model.get("time_origin_s", 0.0))
        # the run's span; unknown (every time) when the file traced none of its samples
        self.span = (min([start, *times]) - TIME_SLACK_S, max([start, *times]) + TIME_SLACK_S) if times else (-np.inf, np.inf)
        self.modelled = 0  # samples given the model's offset
        self.samples = 0

    def offsets(self, time: np.ndarray, configuration: np.ndarray, temperature: np.ndarray | None) -> np.ndarray:
        """The offset of each sample, [N, N, N, N m, N m, N m], shape (N, 6).

        Args:
            time: Sample times [s], shape (N,).
            configuration: The validation tool's configuration index per sample, shape (N,).
            temperature: Sensor temperatures [°C], shape (N,), or None.
        """
        n = len(time)
        out = np.broadcast_to(self.D, (n, 6)).copy()
        self.samples += n
        if self.model == "constant" or n == 0:
            return out
        configuration = np.asarray(configuration, dtype=np.int64)
        known = (configuration >= 0) & (configuration < len(self.codes))  # an unknown configuration takes D
        codes = np.where(known, self.codes[np.clip(configuration, 0, max(len(self.codes) - 1, 0))], -1)
        use = codes >= 0
        if self.model == "drift":
            use &= (time >= self.span[0]) & (time <= self.span[1])
        if use.any():
            heat = None if temperature is None else temperature[use]
            out[use] = evaluate_offsets(self.description, time[use], codes[use], heat)
            self.modelled += int(use.sum())
        return out

    @property
    def words(self) -> str:
        """Which offsets were used, for the printout."""
        if self.model == "constant":
            return "constant D (the calibration's offset model is constant)"
        share = f"{self.modelled:,} of {self.samples:,} samples"
        if self.model == "per-configuration":
            how = f"each configuration's offset by name ({', '.join(self.matched) or 'none matched'})"
        else:
            matched = ", ".join(self.matched) or "none"
            how = f"the drift at each sample's time and temperature (within the calibration run, configurations {matched})"
        return f"{self.model} model: {how} on {share}; D at the end of the run on the others"


def _configuration_names(calibration: Calibration) -> list[str]:
    """The calibration tool's configuration names, its order (the offset basis's columns)."""
    tools = (calibration.provenance or {}).get("tools") or {}
    names = [str(c.get("name")) for c in tools.get("configurations") or [] if isinstance(c, Mapping)]
    if names:
        return names
    size = int(((calibration.offset_model or {}).get("basis") or {}).get("n_configurations", 1))
    return [str(c) for c in range(size)]


def _fitted_configurations(model: Mapping, names: Sequence[str]) -> set[str]:
    """The configurations whose offset column the model fitted ('offset A' in its columns)."""
    columns = [str(c) for c in model.get("columns") or []]
    return {n for n in names if f"offset {n}" in columns}


_PLOT_POINTS = 20_000  # samples kept for the plot, at most twice this


@dataclass(frozen=True)
class AxisErrors:
    """Errors of a wrench against a reference, per axis ``[Fx, Fy, Fz, Mx, My, Mz]``.

    Attributes:
        max_abs: Largest absolute error [N, N, N, N m, N m, N m]. Shape (6,).
        rms: Root mean square error, same units. Shape (6,).
        full_scale: Full scale per axis, same units. Shape (6,).
    """

    max_abs: np.ndarray
    rms: np.ndarray
    full_scale: np.ndarray

    def __post_init__(self):
        for name in ("max_abs", "rms", "full_scale"):
            object.__setattr__(self, name, frozen(getattr(self, name)))

    @property
    def max_percent(self) -> np.ndarray:
        """Largest absolute error in % of full scale, shape (6,)."""
        return 100.0 * self.max_abs / self.full_scale

    @property
    def rms_percent(self) -> np.ndarray:
        """RMS error in % of full scale, shape (6,)."""
        return 100.0 * self.rms / self.full_scale


@dataclass(frozen=True)
class RegionErrors:
    """Errors of one calibration inside and outside its load region, the samples classified by their expected wrench.

    Attributes:
        inside: Errors of the samples whose expected wrench lies inside the region (zeros when there is none).
        outside: Errors of the samples outside it (zeros when there is none).
        inside_samples: Samples inside.
        outside_samples: Samples outside (the two add up to :attr:`ValidationResult.samples`).
        region: The calibration's region.
    """

    inside: AxisErrors
    outside: AxisErrors
    inside_samples: int
    outside_samples: int
    region: LoadRegion

    def as_json(self) -> dict:
        """``{"inside": {"samples": n, "axes": {...}}, "outside": {...}}``; ``axes`` null for a part without a sample (N, N·m)."""
        parts = (("inside", self.inside, self.inside_samples), ("outside", self.outside, self.outside_samples))
        return {name: {"samples": int(n), "axes": axes_json(errors) if n else None} for name, errors, n in parts}


def axes_json(errors: AxisErrors) -> dict[str, dict[str, float]]:
    """The errors per axis for scripts: ``{"Fx": {"rms": ..., "max": ...}, ...}`` in N and N·m."""
    return {axis: {"rms": float(errors.rms[i]), "max": float(errors.max_abs[i])} for i, axis in enumerate(WRENCH_AXES)}


@dataclass(frozen=True)
class ValidationResult:
    """What ``validate`` measured.

    Attributes:
        samples: Samples compared (0: the errors are zeros and mean nothing).
        skipped: Rows or samples not compared, by reason.
        errors: Per calibration, its errors against the expected wrench.
        between: The first calibration against the second, or None.
        dynamic: Whether the expected wrench includes the tool's dynamics.
        time: Times of the plotted samples [s], shape (M,).
        expected: Expected wrench at those samples, shape (M, 6).
        measured: Per calibration, the measured wrench at those samples, (M, 6) each.
        problems: The first problems of the recording, with their line and column.
        rows_read: Channel samples read from the recording (compared or skipped).
        rails: One line per channel whose samples were skipped at its rail
            (:meth:`fts_calib.filters.sample_checks.RailTally.lines`).
        offsets: Per calibration, which offsets were used (:attr:`ValidationOffsets.words`).
        regions: Per calibration, its errors inside and outside its load region, or None for
            a calibration that records none.
        configuration: The tool configuration of each plotted sample, an index into the
            tool's names, shape (M,) (None: not recorded).
    """

    samples: int
    skipped: dict[str, int]
    errors: list[AxisErrors]
    between: AxisErrors | None
    dynamic: bool
    time: np.ndarray
    expected: np.ndarray
    measured: list[np.ndarray]
    problems: list[str] = field(default_factory=list)
    rows_read: int = 0

    @property
    def coverage(self) -> float:
        """The share of the recording's channel samples compared, in [0, 1] (0 for an empty recording)."""
        return self.samples / self.rows_read if self.rows_read else 0.0

    rails: list[str] = field(default_factory=list)
    offsets: list[str] = field(default_factory=list)
    regions: list[RegionErrors | None] = field(default_factory=list)
    configuration: np.ndarray | None = None

    def as_json(self, index: int = 0) -> dict:
        """The errors of calibration ``index`` for scripts: ``{"axes": {"Fx": {"rms": ..., "max": ...}, ...}, "samples": N}``.

        With a load region, a ``"region"`` key: :meth:`RegionErrors.as_json`; without one, no
        such key. Units: N for the forces, N·m for the moments.
        """
        out = {"axes": axes_json(self.errors[index]), "samples": int(self.samples)}
        region = self.regions[index] if index < len(self.regions) else None
        if region is not None:
            out["region"] = region.as_json()
        return out


class _Errors:
    def __init__(self):
        self.sum_sq = np.zeros(6)
        self.max_abs = np.zeros(6)

    def add(self, difference: np.ndarray) -> None:
        if len(difference):
            self.sum_sq += np.sum(difference * difference, axis=0)
            self.max_abs = np.maximum(self.max_abs, np.max(np.abs(difference), axis=0))

    def result(self, n: int, full_scale: np.ndarray) -> AxisErrors:
        return AxisErrors(self.max_abs.copy(), np.sqrt(self.sum_sq / max(n, 1)), full_scale)


class _RegionSplit:
    """The errors of one calibration inside and outside its load region, by the expected wrench."""

    def __init__(self, region: LoadRegion):
        self.region = region
        self.inside, self.outside = _Errors(), _Errors()
        self.counts = [0, 0]

    def add(self, expected: np.ndarray, difference: np.ndarray) -> None:
        inside = self.region.contains(expected)
        self.inside.add(difference[inside])
        self.outside.add(difference[~inside])
        self.counts[0] += int(inside.sum())
        self.counts[1] += int((~inside).sum())

    def result(self, full_scale: np.ndarray) -> RegionErrors:
        inside, outside = self.counts
        return RegionErrors(self.inside.result(inside, full_scale), self.outside.result(outside, full_scale), inside, outside, self.region)


class _Thinner:
    """Keeps at most twice ``limit`` rows of a stream, evenly spaced (every ``stride``-th)."""

    def __init__(self, limit: int):
        self.limit, self.stride, self.seen = limit, 1, 0
        self.rows: list[tuple[np.ndarray, ...]] = []

    def add(self, *columns: np.ndarray) -> None:
        n = len(columns[0])
        take = (np.arange(self.seen, self.seen + n) % self.stride) == 0
        self.seen += n
        self.rows.append(tuple(c[take] for c in columns))
        if sum(len(r[0]) for r in self.rows) > 2 * self.limit:
            merged = [np.concatenate(parts) for parts in zip(*self.rows, strict=True)]
            self.rows = [tuple(m[::2] for m in merged)]
            self.stride *= 2

    def arrays(self, width: int) -> list[np.ndarray]:
        if not self.rows:
            return [np.zeros((0,) + ((width,) if k else ())) for k in range(width)]
        return [np.concatenate(parts) for parts in zip(*self.rows, strict=True)]


def expected_wrench(
    kin: Kinematics,
    tool: Tool,
    time: np.ndarray,
    readings: np.ndarray,
    codes: np.ndarray,
    dt: float,
    dynamic: bool,
    window_s: float,
) -> np.ndarray:
    """The tool's wrench on the sensor at each sample, from the joint readings alone.

    Args:
        kin: Kinematics.
        tool: The tool.
        time: [s], shape (N,).
        readings: Joint readings [rad], shape (N, n_joints).
        codes: Configuration index of each sample, shape (N,).
        dt: The stream's sample period [s], for the joint-rate estimates.
        dynamic: Newton-Euler wrench of the moving tool (True) or its weight alone (False).
        window_s: The joint-rate window [s]: the filter chain's at ``dt`` (:meth:`fts_calib.filters.chain.FilterChain.motion_window`),
            so that the expected wrench sees the rates the filter sees.

    Returns:
        Shape (N, 6), [N, N m].
    """
    if not dynamic:
        return tool_load(kin, tool, readings, codes).static
    rates = joint_rates(time, readings, window_s, dt, kin.continuous, order=2)
    return tool_load(kin, tool, readings, codes, rates.velocity, rates.acceleration).w_sensor


def validate_recording(
    path: str | Path | Sequence[str | Path],
    kin: Kinematics,
    tool: Tool,
    calibrations: Sequence[Calibration],
    full_scale: np.ndarray,
    dynamic: bool = True,
    max_abs_channel: float | None = None,
    topics: BagTopics | None = None,
    limits: ChannelLimits | None = None,
    settings: PipelineConfig | None = None,
) -> ValidationResult:
    """Compare measured and expected wrenches over a recording (see the module docstring).

    Args:
        path: Recording (CSV or CSV.gz) made with ``tool``, or ROS 2 bags (each optionally
            ``BAG:CONFIGURATION``, :mod:`fts_calib.sources.source`).
        kin: Kinematics of the robot that made it.
        tool: The tool mounted during the recording.
        calibrations: One or two calibrations.
        full_scale: Full scale per axis [N, N, N, N m, N m, N m], shape (6,).
        dynamic: Include the moving tool's dynamics in the expected wrench.
        max_abs_channel: Largest plausible magnitude of a channel, in raw units: a sample
            beyond it is skipped as a bad sample; None: the settings' ``checks.max_abs_channel``.
        topics: Topic names of a bag; the defaults when None.
        limits: The channels' range (the sensor file's): a sample with a channel at its rail
            is skipped and counted; None: the settings' ``checks.limits``.
        settings: Pipeline settings: the checks' and the joint-rate window; the defaults when None.
            Every sample goes through the checks of the filter chain
            (:meth:`fts_calib.filters.chain.FilterChain.accept`), no filter: every valid sample is compared.

    Raises:
        RecordingError: The recording cannot be read (missing, empty, a missing column).
        ConfigError: Not one or two calibrations.
        ShapeError: The recording has another number of channels than a calibration's layout.
    """
    if not 1 <= len(calibrations) <= 2:
        message = f"{len(calibrations)} calibrations given but expected one or two"
        raise ConfigError("calibrations", len(calibrations), "one or two calibrations", message=message)
    full_scale = np.asarray(full_scale, dtype=float)
    settings = settings or PipelineConfig()
    if limits is not None:
        settings = settings.with_limits(limits)
    if max_abs_channel is not None:
        settings = dataclasses.replace(settings, checks=dataclasses.replace(settings.checks, max_abs_channel=max_abs_channel))
    chain = filter_chain(settings, kin, NO_FILTER, calibrations[0].layout)
    window_s = chain.motion_window(0.0)
    errors = [_Errors() for _ in calibrations]
    splits = [None if cal.region is None else _RegionSplit(cal.region) for cal in calibrations]
    between = _Errors()
    plot = _Thinner(_PLOT_POINTS)
    offsets = [ValidationOffsets(cal, tool.names) for cal in calibrations]
    samples = 0
    dt, half = 0.0, 0
    # rows already compared that the next rows' rate windows need, and rows not compared yet
    context: tuple[np.ndarray, ...] | None = None
    waiting: tuple[np.ndarray, ...] | None = None

    def compare(rows: tuple[np.ndarray, ...], first: int, last: int) -> None:
        """Compare rows ``first:last``; the rows around them serve the rate estimates."""
        nonlocal samples
        t, q, s, k, T = rows
        W = expected_wrench(kin, tool, t, q, k, dt, dynamic, window_s)[first:last]
        heat = None if np.isnan(T[first:last]).all() else T[first:last]
        measured = [  # the region is reported below, split by the expected wrench: no warning per chunk
            cal.wrench(s[first:last], region_check=False) - cal.D + off.offsets(t[first:last], k[first:last], heat)
            for cal, off in zip(calibrations, offsets, strict=True)
        ]
        for errs, split, m in zip(errors, splits, measured, strict=True):
            errs.add(m - W)
            if split is not None:
                split.add(W, m - W)
        if len(measured) == 2:
            between.add(measured[0] - measured[1])
        samples += len(W)
        plot.add(t[first:last], W, *measured, k[first:last])

    def join(*parts):
        parts = [p for p in parts if p is not None]
        return tuple(np.concatenate(columns) for columns in zip(*parts, strict=True))

    with open_recording(path, kin.joint_names, tool.names, settings.checks.max_abs_channel, topics, kin.continuous) as reader:
        for chunk in reader:
            t, q, s, k = chunk.time, chunk.joints, chunk.channels, chunk.configuration
            T = np.full(len(t), np.nan) if chunk.temperature is None else chunk.temperature
            for cal in calibrations:  # each calibration reads the channels of its own layout
                check_channels(cal.layout, s.shape[1], str(reader.path), CALIBRATION_HINT)
            forward = chain.accept(chunk)  # the chain's checks: bad values, rails, time order, joint limits
            if not forward.any():
                continue
            new = (t[forward], q[forward], s[forward], k[forward], T[forward])
            if dt == 0.0 and len(new[0]) > PERIOD_SAMPLES:
                dt = sample_period(new[0])
                window_s = chain.motion_window(dt)
                half = half_window(window_s, dt)
            rows = join(context, waiting, new)
            first = 0 if context is None else len(context[0])
            last = len(rows[0]) - half  # the last rows wait for their right-hand window
            if last > first:
                compare(rows, first, last)
                context = tuple(a[max(last - half, 0) : last] for a in rows)
                waiting = tuple(a[last:] for a in rows)
            else:
                waiting = join(waiting, new)
        skipped = Counter(chain.checks.skipped)
        for reason, count in reader.skipped.items():
            if count:
                skipped[reason] += count
        problems = reader.notes()
        rows_read = reader.rows_read
    if waiting is not None and len(waiting[0]):
        rows = join(context, waiting)
        compare(rows, 0 if context is None else len(context[0]), len(rows[0]))
    time, expected, *measured, codes = plot.arrays(3 + len(calibrations))
    return ValidationResult(
        samples=samples,
        skipped=dict(skipped),
        errors=[e.result(samples, full_scale) for e in errors],
        between=between.result(samples, full_scale) if len(calibrations) == 2 else None,
        dynamic=dynamic,
        time=time,
        expected=expected,
        measured=measured,
        problems=problems,
        rows_read=rows_read,
        rails=[] if chain.checks.rails is None else chain.checks.rails.lines(tool.names),
        offsets=[off.words for off in offsets],
        regions=[None if split is None else split.result(full_scale) for split in splits],
        configuration=np.asarray(codes, dtype=int).reshape(-1),
    )

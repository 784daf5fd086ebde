"""Where a calibration session stands: counts, rank and what is still missing.

Where a session's calibration came from: robot, sensor frame, tools, source and filter (the file's ``provenance``).

A calibration tool whose weight the sensor cannot carry: a mass in grams, or another sensor's full scale.

A mass written in g instead of kg scales every known wrench by 1000, and with it C and D:
the data still fit the model exactly, so no fit check can see it. What can: the tool hangs
on the sensor during the calibration, so its weight lies within the sensor's range. Far
beyond it (:data:`MAX_LOAD_RATIO` times the full scale) the tool file or the sensor file is
wrong, and the calibration is refused before any sample is read.

A calibration session: samples in, a calibration out, for recordings, live feeds and controllers.

Data flow, one way, one :class:`SampleBatch` at a time: checks (finite values in range, rails, time
order, known tool configuration, joint limits; :mod:`fts_calib.filters.sample_checks`) -> quasi-static
filter decisions from joint rates and strain stationarity -> the sensor motion and the
tool's load (:func:`fts_calib.robot.tool.tool_load`, the only kinematics) -> the filter's
dynamic rule -> online least squares on the static wrench (paper eqs 12-18).

From a controller's own loop::

    session = CalibrationSession(kin, tool)
    session.add(t, joints, channels, "A")    # [s], joint readings [rad], raw channels, configuration
    print(session.progress().missing)        # e.g. "centres of mass on one line (configurations A and B); mount one more ..."
    calibration = session.solve()

With a checkpoint path the session saves its sums atomically every
``live.checkpoint_interval_s`` seconds of wall-clock time and when it stops;
:meth:`CalibrationSession.resume` continues from the file, skipping samples it already
holds, so a crash loses at most that interval.

What a calibration session keeps of its kept samples per tool configuration, and what it tells.

Per configuration ``c`` the session (:class:`fts_calib.session.session.CalibrationSession`)
keeps the sum of ``[u; 1][u; 1]^T`` with ``u = g / |g|`` (4 x 4: the gravity directions the
sensor saw, for the advice on what is missing) and the sum of ``y y^T`` with
``y = [g_sensor; P Delta; 1; drift]`` ((10 + m) x (10 + m), :func:`fts_calib.session.fit.fit_rows`,
for the fit check); over all of them, the load region of the known wrenches
(:class:`fts_calib.model.region.RegionBuilder`). From them: the progress in words, the fit
check of the model in use, and the error raised when a solve lacks rank. Units: gravity in
[m/s^2], channels raw, wrenches [N, N, N, N m, N m, N m].

The calibration's parity model (:mod:`fts_calib.model.parity`), from what a session kept.
"""

from __future__ import annotations

import math
import time as _time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..budget.measured import KeptSamples, MovingSamples, with_measured_budget
from ..budget.propagation import AccuracyBudget
from ..budget.sensitivities import stops
from ..core.arrays import as_matrix
from ..core.deprecation import renamed
from ..core.exceptions import FileFormatError, FtsCalibError, InsufficientExcitation, ModelNotDetermined, PoorFit, ShapeError
from ..filters.chain import NO_FILTER, FilterChain, filter_chain
from ..filters.dynamic import DynamicFilter
from ..filters.latency import LatencyEstimate
from ..filters.quasi_static import QuasiStaticFilter, StillSamples
from ..filters.sample_checks import BACKWARDS, BEFORE_CHECKPOINT, NON_FINITE, OUTSIDE_LIMITS, UNKNOWN_TOOL, SampleChecks
from ..filters.settings import AUTO_FILTER, DYNAMIC, QUASI_STATIC, PipelineConfig
from ..model.calibration import Calibration
from ..model.channels import MALTESE_CROSS_8, ChannelLayout, channel_layout, check_channels
from ..model.estimator import OnlineEstimator
from ..model.least_squares import unexplained_strain
from ..model.parity import CodeDwell, code_dwell, fit_parity
from ..model.prior import Prior
from ..model.region import RegionBuilder
from ..model.sensor_config import DEFAULT_FULL_SCALE
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool, check_tool_load, weight_wrench
from ..sources.batch import SampleBatch, configuration_codes
from ..sources.source import array_batch
from .checkpoint import read_checkpoint, write_checkpoint
from .diagnosis import (
    MOVING_ADVICE,
    RECORDING_KINDS,
    Cause,
    cause,
    missing_centres,
    missing_words,
    moving_words,
    refused_words,
    session_allowance,
    weak_excitation,
)
from .fit import MAX_RATIO, UNEXPLAINED, FitCheck, check_fit, check_model_fit, fit_rows, model_fit_sums
from .held_out import UNIT_GAP_S, held_out_units
from .provenance import session_provenance


@dataclass(frozen=True)
class Progress:
    """Where a session stands.

    Attributes:
        seen: Samples offered.
        kept: Samples that entered the least squares.
        kept_by_configuration: Kept samples per tool configuration name.
        rank: Rank of S_XX of the offset model in use (``full_rank`` determines every coefficient).
        condition_number: Of the scaled S_XX (inf below full rank).
        missing: What is still missing, in words ('' at full rank).
        skipped: Samples not kept, by reason (checks and filter rules).
        last_time: Time of the last sample [s], or None.
        full_rank: 6 + the offset model's columns (7 for constant offsets).
    """

    seen: int
    kept: int
    kept_by_configuration: dict[str, int]
    rank: int
    condition_number: float
    missing: str
    skipped: dict[str, int]
    last_time: float | None
    full_rank: int = 7

    @property
    def kept_fraction(self) -> float:
        """Kept samples over seen samples (0 when none seen)."""
        return self.kept / self.seen if self.seen else 0.0


__all__ = ["BACKWARDS", "BEFORE_CHECKPOINT", "NON_FINITE", "OUTSIDE_LIMITS", "UNKNOWN_TOOL", "CalibrationSession", "Progress"]

_STAGE = 256  # single samples from add() are processed in groups of this size


class CalibrationSession:
    """Turns a stream of samples into a calibration (see the module docstring).

    Args:
        kin: Kinematics of the robot.
        tool: The calibration tool.
        settings: Pipeline settings (filter thresholds, checkpoint interval).
        checkpoint: File for checkpoints, or None for none.
        use_filter: Keep every valid sample instead of the quasi-static ones (for comparison).
        source: What the samples come from, for the calibration's provenance.
        clock: Wall-clock function in [s] (for checkpoint timing).
        on_kept: Called with ``(time (k,), w_sensor (k, 6), channels (k, n), configuration
            indices (k,), joints (k, n_joints), temperature (k,) [°C] or None)`` for the samples entering the least squares,
            in order (e.g. to plot the convergence, or for the accuracy budget); None for nothing.
        source_record: What the checkpoint records of the source, to resume only with it
            (:func:`fts_calib.session.checkpoint.recording_source`, ``live_source``), or None.
        layout: The sensor's channel layout (n channels); the paper's 8 bridges by default.
            Samples of another number of channels are refused (ShapeError naming both).
        model: The sensor model setting ('linear', 'quadratic', 'cubic' or 'auto':
            :mod:`fts_calib.model.features`); with any but 'linear' the kept samples are also
            grouped into held-out units (:mod:`fts_calib.session.held_out`) for the choice.
        full_channels: Regress on the raw channels (a free 6 x n C; ``channels: full``).
        full_scale: Full scale per wrench axis [N, N, N, N m, N m, N m], shape (6,), scaling the
            held-out errors and the measured accuracy budget in % (:mod:`fts_calib.budget.measured`);
            a sensor file's default (50 N, 5 N m) when None.

    Raises:
        ConfigError: A tool far heavier than the sensor's full scale (grams: :mod:`fts_calib.session.session`).

    Attributes:
        budget: The measured accuracy budget of the last :meth:`solve`, or None.
        latency: The stream-latency estimate of the last :meth:`solve`, or None.
        kept_region: The load region of the wrenches kept so far (:class:`~fts_calib.model.region.RegionBuilder`), for :meth:`solve`.
    """

    def __init__(
        self,
        kin: Kinematics,
        tool: Tool,
        settings: PipelineConfig | None = None,
        checkpoint: str | Path | None = None,
        use_filter: bool = True,
        source: str = "",
        clock: Callable[[], float] = _time.monotonic,
        on_kept: Callable[..., None] | None = None,
        source_record: dict | None = None,
        layout: ChannelLayout = MALTESE_CROSS_8,
        model: str = "linear",
        full_channels: bool = False,
        full_scale=None,
    ):
        self.kin = kin
        self.full_scale = as_matrix(DEFAULT_FULL_SCALE if full_scale is None else full_scale, (6,), "full_scale")
        check_tool_load(tool, self.full_scale)  # a mass in grams fits the data exactly: only the sensor's range tells
        self.budget: AccuracyBudget | None = None
        self.latency: LatencyEstimate | None = None
        self.kept_samples, self._moving = KeptSamples(), MovingSamples()  # for the measured budget and the latency
        self.layout = channel_layout(layout)
        self.tool = tool
        self.settings = settings or PipelineConfig()
        if self.settings.filter.mode == AUTO_FILTER:  # a session reads each sample once: still samples (a recording may be read again)
            self.settings = self.settings.with_filter_mode(QUASI_STATIC)
        self.checkpoint_path = Path(checkpoint) if checkpoint else None
        self.source = source
        self.source_record = source_record
        self.joints_in_degrees = False  # the joints were converted from degrees (the fit's diagnosis tries rad)
        self.orientation_source: str | None = None  # what gives the orientation, for a mount's diagnosis (feeds.source)
        n = len(tool.configurations)
        self.estimator = OnlineEstimator(
            layout=self.layout,
            offsets=self.settings.offsets.model,
            basis=self.settings.offsets.basis(n),
            model=model,
            full_channels=full_channels,
            full_scale=full_scale,
        )
        # the checks, then filter.mode's filter (quasi-static or dynamic) or none
        mode = None if use_filter else NO_FILTER
        self.chain: FilterChain = filter_chain(self.settings, kin, mode, self.layout, self.full_scale, n)
        self.kept = np.zeros(n, dtype=np.int64)
        self.seen = 0
        self.directions, self.fit_sums, self.kept_region = empty_sums(n, self.estimator.basis.n_drift, self.full_scale)  # kept_sums
        self._staged: list[tuple] = []
        self._last: tuple[float, int, float | None] | None = None  # time, configuration, temperature of the last valid sample
        self._clock = clock
        self._last_checkpoint = clock()
        self._on_kept = on_kept

    @property
    def checks(self) -> SampleChecks:
        """The chain's checks, with what they skipped."""
        return self.chain.checks

    @property
    def filter(self) -> QuasiStaticFilter | DynamicFilter | None:
        """The chain's filter (None: every valid sample kept)."""
        return self.chain.filter

    @property
    def skipped(self) -> Counter[str]:
        """Samples skipped by the checks (and before reaching the session), by reason."""
        return self.checks.skipped

    # -- input --------------------------------------------------------------------------

    @renamed(strain="channels")
    def add(self, t: float, joints, channels, configuration: str, temperature: float | None = None) -> None:
        """Add one sample.

        Args:
            t: Time [s].
            joints: Joint readings [rad], (n_joints,) or a mapping joint name -> value.
            channels: Raw channels, (n,), n = ``layout.n_channels``.
            configuration: Tool configuration name.
            temperature: Sensor temperature [°C] (for the drift offset model), or None.
        """
        readings, _ = self.kin.joint_array(joints)
        channels = np.array(channels, dtype=float)  # a copy: a controller may refill its buffer for the next tick
        if channels.shape != (self.layout.n_channels,):
            raise ShapeError(f"channels.shape={channels.shape} but expected ({self.layout.n_channels},), the {self.layout.name} layout")
        code = int(configuration_codes(configuration, 1, self.tool.names)[0])
        self._staged.append((float(t), readings[0].copy(), channels, code, math.nan if temperature is None else float(temperature)))
        if len(self._staged) >= _STAGE:
            self._flush_staged()

    @renamed(strain="channels")
    def add_batch(self, t, joints, channels, configuration, temperature=None) -> None:
        """Add many samples, in time order.

        Args:
            t: Times [s], shape (n,).
            joints: Joint readings [rad], shape (n, n_joints) or a mapping of (n,) arrays.
            channels: Raw channels, shape (n, n_channels).
            configuration: Configuration names (one, or one per sample) or indices in the
                tool's order.
            temperature: Sensor temperatures [°C], shape (n,), or None.

        Raises:
            ShapeError: The arrays do not have one row per time, or not ``n_channels`` channels.
            UnknownToolConfiguration: A configuration that is not in the tool file.
        """
        batch, _ = array_batch(t, joints, channels, configuration, temperature, self.kin.joint_names, self.tool.names, "add_batch")
        self.add_samples(batch)

    def add_samples(self, batch: SampleBatch, rates=None) -> None:
        """Add a batch from a feed (configuration indices in the tool's order), in time order.

        ``rates``: the joints' exact ``(velocity [rad/s], acceleration [rad/s^2])``, each (N, n_joints), for
        ``filter.mode: dynamic`` (a controller that has them); None: estimated from the readings.
        """
        self._flush_staged()
        self._process(batch, rates)

    def note_skipped(self, reason: str, count: int) -> None:
        """Count samples skipped before reaching the session (e.g. malformed lines of a file)."""
        if count:
            self.seen += count
            self.checks.skipped[reason] += count

    def _flush_staged(self) -> None:
        if self._staged:
            t, joints, strain, codes, heat = zip(*self._staged, strict=True)
            self._staged = []
            temperature = None if np.all(np.isnan(heat)) else np.array(heat)  # some missing: NaN, skipped by the checks
            self._process(SampleBatch(np.array(t), np.array(joints), np.array(strain), np.array(codes, dtype=np.int64), temperature))

    def _process(self, batch: SampleBatch, rates=None) -> None:
        check_channels(self.layout, batch.channels.shape[1], self.source or "the samples")
        self.seen += len(batch)
        step = self.chain.samples(batch, self.tool, rates=rates)
        valid = step.checked
        if len(valid):
            self._last = (  # the end of the run so far: where the calibration's D belongs
                float(valid.time[-1]),
                int(valid.configuration[-1]),
                None if valid.temperature is None else float(valid.temperature[-1]),
            )
            self._moving.add(valid.time, valid.joints, valid.channels, valid.configuration)
            self._accumulate(step.still)
        self._maybe_checkpoint()

    def _accumulate(self, still: StillSamples) -> None:
        kept, g, W, weight = still.samples, still.g_sensor, still.w_sensor, still.weight
        fit = still.static_model  # the dynamic filter's: the samples the fit check's static model holds for
        if not len(kept) or W is None:
            return
        codes = kept.configuration
        units = static = None
        if self.estimator.units is not None:  # the held-out units, and the weight alone: what the jig gave there
            units, static = held_out_units(codes, g), weight_wrench(self.tool, g, codes)
        columns = {"time": kept.time, "configuration": codes, "temperature": kept.temperature, "unit": units, "w_static": static}
        self.estimator.update_batch(W, kept.channels, weight, **columns, precision=True)  # the filters' weights: 1 / variance
        self.kept_samples(kept.time, W, kept.channels, codes, kept.joints)
        if self._on_kept is not None:
            self._on_kept(kept.time, W, kept.channels, codes, kept.joints, kept.temperature)
        add_kept(self, g, W, kept.channels, codes, kept.time, kept.temperature, fit)

    def flush(self) -> None:
        """Decide the samples the filter still holds (call when the stream ends)."""
        self._flush_staged()
        if self.filter is not None:
            self._accumulate(self.chain.flush(self.tool))

    # -- output -------------------------------------------------------------------------

    def all_skipped(self) -> dict[str, int]:
        """Samples not kept, by reason: the session's checks and the filter's rules."""
        return self.chain.skipped()

    def progress(self) -> Progress:
        """Counts, rank and what is missing, in words."""
        return session_progress(self)

    def fit_check(self, hint: str = "") -> FitCheck:
        """Whether the kept samples fit the tool's model at the noise level of the data.

        The noise is the filter's noise floor (the strain scatter of the still windows);
        without the filter, or with a fixed strain threshold, none is measured and the
        verdict is 'unchecked'. See :mod:`fts_calib.session.fit`.

        Args:
            hint: Words added to a poor fit's diagnosis when no alternative explains it.
        """
        return session_fit_check(self, hint)

    def solve(self, accept_poor_fit: bool = False, hint: str = "", prior: Prior | None = None) -> Calibration:
        """The calibration from everything kept so far, with its fit check, measured budget and latency in the quality, and its load region.

        The measured accuracy budget and the stream-latency estimate
        (:func:`fts_calib.budget.measured.with_measured_budget`) are left out only for a
        session resumed from a checkpoint (the samples before it are not at hand).

        Args:
            accept_poor_fit: Return a calibration whose fit is poor (its quality records the
                verdict) instead of raising :class:`PoorFit`.
            hint: See :meth:`fit_check`.
            prior: Shrink C_bar toward a known calibration (:mod:`fts_calib.model.prior`).

        Raises:
            InsufficientExcitation: Rank below full (7, or 6 + the offset columns); the message says what is missing.
            PoorFit: The data do not fit the model (and ``accept_poor_fit`` is False); it
                carries the check and the refused calibration (None when the loads also
                leave a direction undetermined, as a wrong tool file or joint unit can).
        """
        self._flush_staged()
        if self.settings.repeatability is not None:  # the samples of a still pose share its offset: the offsets' BIC counts poses
            self.estimator.samples_per_draw = self.kept_samples.samples_per_stop()
        try:
            calibration = self.estimator.solve(configurations=self.tool.names, at=self._last, prior=prior)
        except InsufficientExcitation as exc:  # a wrong tool file or joint unit, not a short sweep: the fit names it
            raise refusal(self, exc, hint, accept_poor_fit) from None
        if calibration.quality is None:  # the estimator always measures the fit
            raise FtsCalibError("the estimator returned a calibration without its quality")
        check = self.fit_check(hint)
        quality = replace(calibration.quality, samples_seen=self.seen, skipped=self.all_skipped(), fit=check.as_dict())
        provenance = {**calibration.provenance, **self._provenance}
        calibration = replace(calibration, quality=quality, provenance=provenance, region=self.kept_region.region())
        if not check.ok and not accept_poor_fit:
            raise PoorFit(check, calibration)
        noise_floor = None if self.filter is None else self.filter.noise_floor
        accuracy = self.filter.budget_accuracy(self.kin) if isinstance(self.filter, DynamicFilter) else None  # the latency it fitted
        kept, n_kept, scatter = self.kept_samples, int(self.kept.sum()), self.settings.repeatability
        calibration, self.budget, self.latency = with_measured_budget(
            calibration, self.kin, self.tool, kept, n_kept, noise_floor, self._moving, self.full_scale, accuracy, scatter
        )
        return with_health(self, calibration, noise_floor)

    @property
    def _provenance(self) -> dict:
        return session_provenance(self.kin, self.tool, self.kept, self.source, None if self.filter is None else self.settings.filter)

    # -- checkpoints --------------------------------------------------------------------

    def _maybe_checkpoint(self) -> None:
        if self.checkpoint_path is not None and self._clock() - self._last_checkpoint >= self.settings.live.checkpoint_interval_s:
            self.checkpoint()

    def checkpoint(self) -> Path | None:
        """Write the checkpoint now (atomically); None without a checkpoint path."""
        if self.checkpoint_path is None:
            return None
        state = self.state()
        self._last_checkpoint = self._clock()
        return write_checkpoint(self.checkpoint_path, state)

    def state(self) -> dict[str, Any]:
        """What a checkpoint holds of a session: plain types, safe to write as JSON."""
        last = self.checks.last_time
        return {
            "robot": self.kin.robot.name,
            "tool": self.tool.name,
            "source": self.source_record,
            "configurations": self.tool.names,
            "estimator": self.estimator.state(),
            "kept": self.kept.tolist(),
            "seen": self.seen,
            **self.checks.state(),  # skipped, by reason, and at the rails
            "directions": self.directions.tolist(),
            "fit_sums": self.fit_sums.tolist(),
            "last_time": None if last == -math.inf else last,
            "filter": None if self.filter is None else self.filter.state(),
            "region": self.kept_region.state(),
        }

    def _restore(self, state: dict[str, Any], path: Path, models: tuple[str, bool, Any]) -> None:
        """Load a checkpoint's state into a new session (see the module docstring).

        Args:
            state: The checkpoint's content.
            path: The checkpoint file, for messages.
            models: ``(model setting, full_channels, full_scale)`` of the run.

        Raises:
            FileFormatError: A damaged checkpoint, or one of another channel layout or sensor model.
        """
        model, full_channels, full_scale = models
        try:
            self.estimator = estimator = OnlineEstimator.from_state(state["estimator"])
            estimator.full_scale = None if full_scale is None else np.asarray(full_scale, dtype=float)
            if "basis" in state["estimator"]:  # a checkpoint of an older version has constant offsets only
                estimator.offsets = self.settings.offsets.model
            m = 10 + estimator.basis.n_drift
            self.fit_sums = np.zeros((len(self.tool.configurations), m, m))
            self.kept = np.array(state["kept"], dtype=np.int64)
            self.seen = int(state["seen"])
            self.checks.restore(state)
            self.directions = np.array(state["directions"], dtype=float)
            if "fit_sums" in state:
                self.fit_sums = np.array(state["fit_sums"], dtype=float).reshape(self.fit_sums.shape)
            # a checkpoint of an older version holds no region: the calibration's is then that of the resumed part only
            self.kept_region.restore(state.get("region"))
        except (KeyError, TypeError, ValueError) as exc:
            raise FileFormatError(path, None, f"damaged checkpoint: {exc}") from None
        saved = (self.estimator.model, self.estimator.full_channels)
        if "model" in state["estimator"] and saved != (model, full_channels):  # older checkpoints: the linear model
            raise FileFormatError(path, "estimator.model", f"is {saved[0]} but the run asks for {model}: resume with the same --model")
        if self.estimator.layout != self.layout:
            found, expected = self.estimator.layout.name, self.layout.name
            raise FileFormatError(path, "estimator.channels", f"is of a {found} sensor but the sensor is {expected}: give its --sensor")
        if state.get("last_time") is not None:
            self.checks.last_time = self.checks.resume_time = float(state["last_time"])
        if self.filter is not None and state.get("filter"):
            self.filter.restore(state["filter"])

    @classmethod
    def resume(
        cls,
        checkpoint: str | Path,
        kin: Kinematics,
        tool: Tool,
        settings: PipelineConfig | None = None,
        source: str = "",
        clock: Callable[[], float] = _time.monotonic,
        source_record: dict | None = None,
        layout: ChannelLayout = MALTESE_CROSS_8,
        model: str = "linear",
        full_channels: bool = False,
        full_scale=None,
    ) -> CalibrationSession:
        """A session continuing from a checkpoint; samples up to its last time are skipped.

        The arguments are those of :class:`CalibrationSession`; the checkpoint must be of
        ``source_record`` (None: not checked).

        Raises:
            FileFormatError: Not a checkpoint, or one of another robot, tool, source or
                channel layout.
        """
        path = Path(checkpoint)
        state = read_checkpoint(path, kin.robot.name, tool, source_record)
        record = source_record if source_record is not None else state.get("source")
        use_filter = state.get("filter") is not None
        session = cls(
            kin,
            tool,
            settings,
            path,
            use_filter,
            source,
            clock,
            source_record=record,
            layout=layout,
            model=model,
            full_channels=full_channels,
            full_scale=full_scale,
        )
        session._restore(state, path, (model, full_channels, full_scale))
        return session


def empty_sums(n_configurations: int, n_drift: int, full_scale) -> tuple[np.ndarray, np.ndarray, RegionBuilder]:
    """The empty sums of a new session: gravity directions and fit rows, per configuration, and its load region.

    Args:
        n_configurations: k, the tool's configurations.
        n_drift: m, the drift columns of the estimator's offset basis.
        full_scale: The sensor's full scale [N, N, N, N m, N m, N m], shape (6,): the region's margin is 1 % of it.

    Returns:
        ``(directions (k, 4, 4), fit sums (k, 10 + m, 10 + m), region)``, zeros and an empty region.
    """
    m = 10 + n_drift  # sum of y y^T per configuration, y = [g; P Delta; 1; drift] (fit checks)
    directions = np.zeros((n_configurations, 4, 4))  # sum of [u; 1][u; 1]^T, u = g / |g|
    return directions, np.zeros((n_configurations, m, m)), RegionBuilder(full_scale)


def add_kept(
    session: CalibrationSession,
    g: np.ndarray,
    w_sensor: np.ndarray,
    channels: np.ndarray,
    codes: np.ndarray,
    time,
    temperature,
    fit: np.ndarray | None = None,
) -> None:
    """Add kept samples to the session's counts, gravity directions and fit sums, per configuration, and to its load region.

    Args:
        session: The session (its ``kept``, directions, fit sums and ``kept_region`` are updated in place).
        g: Gravity in the sensor frame [m/s^2], shape (N, 3).
        w_sensor: The known wrench the least squares took [N, N, N, N m, N m, N m], shape (N, 6).
        channels: Raw channels, shape (N, n).
        codes: Configuration indices in the tool's order, shape (N,).
        time: Times [s], shape (N,) (the estimator's drift columns).
        temperature: Sensor temperatures [°C], shape (N,), or None.
        fit: Which samples enter the fit sums (whose wrench is the weight alone: the fit check's
            model), shape (N,) bool; None: all.
    """
    session.kept += np.bincount(codes, minlength=len(session.kept))
    session.kept_region.add(w_sensor)
    unit = np.hstack([g / np.linalg.norm(g, axis=1, keepdims=True), np.ones((len(g), 1))])
    rows = fit_rows(g, channels, session.layout, session.estimator.drift_rows(time, temperature))
    for c in np.unique(codes):
        mine = codes == c
        u = unit[mine]
        session.directions[c] += u.T @ u
        mine_fit = mine if fit is None else mine & fit
        session.fit_sums[c] += rows[mine_fit].T @ rows[mine_fit]


def session_progress(session: CalibrationSession) -> Progress:
    """Counts, rank and what is missing, in words (:meth:`CalibrationSession.progress`).

    Args:
        session: The session.

    Returns:
        The progress; ``missing`` is '' at full rank.
    """
    rank, condition = session.estimator.rank()
    full, last = session.estimator.full_rank(), session.checks.last_time
    return Progress(
        seen=session.seen,
        kept=int(session.kept.sum()),
        kept_by_configuration={name: int(n) for name, n in zip(session.tool.names, session.kept, strict=True)},
        rank=rank,
        condition_number=condition,
        missing="" if rank == full else missing_words(session.tool, session.kept, session.directions, dynamic=_moving(session)),
        skipped=session.all_skipped(),
        last_time=None if last == -math.inf else last,
        full_rank=full,
    )


def session_fit_check(session: CalibrationSession, hint: str = "") -> FitCheck:
    """Whether the session's kept samples fit the tool's model at the noise level of the data.

    The noise is the filter's noise floor (the strain scatter of the still windows, raw units,
    shape (n,)); without the filter, or with a fixed strain threshold, none is measured and
    the verdict is 'unchecked'. The tool file's tolerance, the robot file's mount and encoders and the
    setting ``fit.floor`` (of the session's full scale) widen what is expected
    (:mod:`fts_calib.session.fit`). See :mod:`fts_calib.session.fit`; a poor fit's diagnosis is
    the first cause the data support (:mod:`fts_calib.session.diagnosis`).

    Args:
        session: The session.
        hint: Words added to a poor fit's diagnosis when no alternative explains it.

    Returns:
        The check of the model in use (a nonlinear model's by its residual per configuration).
    """
    return _checked(session, hint)[0]


def _checked(session: CalibrationSession, hint: str) -> tuple[FitCheck, Cause | None]:
    """The fit check of :func:`session_fit_check`, and the cause of a poor linear fit (None otherwise)."""
    noise = None if session.filter is None else session.filter.noise_floor
    in_sums = session.fit_sums[:, 9, 9]  # samples the sums hold (the last entry of y is 1)
    missing = int(session.kept.sum() - round(float(in_sums.sum())))
    # resumed from a checkpoint of a version without fit sums: a part is not judged (dynamic: only near-still samples are in them)
    if missing > 0 and session.settings.filter.mode != DYNAMIC:
        reason = f"{missing:,} kept samples came from a checkpoint without fit sums: run again with --restart to check the fit"
        return FitCheck("unchecked", math.nan, {}, np.full(6, math.nan), reason), None
    chosen = session.estimator.model_in_use()[0]
    sums, per_configuration = model_fit_sums(session.fit_sums, chosen.model, chosen.columns, session.estimator.basis.n_configurations)
    allowance = session_allowance(session)
    linear = check_fit(session.tool, sums, in_sums, noise, hint, session.layout, per_configuration, allowance)  # noise: >= step/sqrt(12)
    dynamic = session.filter.fit_residuals() if isinstance(session.filter, DynamicFilter) else None
    if dynamic is not None:  # the moving samples' residual, of the dynamic wrench (the static model's check gives the diagnosis)
        named = {name: dynamic[0][k] for k, name in enumerate(session.tool.names) if k in dynamic[0]}
        return check_model_fit(session.tool, named, dynamic[1], noise, session.layout, linear), None
    residuals = session.estimator.model_residuals()
    final = linear  # the linear model on P Delta: the check above is the model's
    if residuals is not None:
        rms, C_bar = residuals
        named = {name: rms[k] for k, name in enumerate(session.tool.names) if k in rms}
        final = check_model_fit(session.tool, named, C_bar, noise, session.layout, linear)
    if final.verdict != "poor" or linear.verdict != "poor":
        return final, None
    # a quadratic model is named only when the linear one is in use
    found = cause(session, linear, per_configuration, hint or UNEXPLAINED, session.joints_in_degrees, residuals is None)
    return replace(final, diagnosis=found.text), found


def _moving(session: CalibrationSession) -> bool:
    """Whether the session's samples are the dynamic filter's (moving ones)."""
    return isinstance(session.filter, DynamicFilter)


def without_stops(session: CalibrationSession) -> str:
    """That the quasi-static filter's recording moves without stops, in words ('' otherwise: :func:`~.diagnosis.moving_words`)."""
    still, kept = session.filter, int(session.kept.sum())
    if still is None or isinstance(still, DynamicFilter):
        return ""
    time, _, _, codes, _ = session.kept_samples.arrays()
    if len(time) != kept:  # resumed: the kept samples are not all at hand
        return ""
    starts = 1 + int(np.count_nonzero((np.diff(codes) != 0) | (np.diff(time) > UNIT_GAP_S))) if kept else 0
    per_configuration = starts / max(len(np.unique(codes)), 1)
    low_rate = still.settings.low_rate_text(still.dt)  # its stops may be shorter than the windows at its rate
    words = moving_words(still.rejected, session.seen, kept, per_configuration)
    return f"{words} ({low_rate})" if words and low_rate else words


def strains_unexplained(session: CalibrationSession) -> bool:
    """Whether the strains carry a signal the tool file's loads cannot produce (:func:`unexplained_strain`).

    Args:
        session: The session (its filter's noise floor; False without one).
    """
    if session.filter is None or session.filter.noise_floor is None:
        return False
    estimator = session.estimator
    sums, noise = estimator.model_sums(estimator.model_in_use()[0]), session.layout.projected_noise(session.filter.noise_floor)
    return unexplained_strain(sums, noise, estimator.weight_sum) > MAX_RATIO**2


def refusal(session: CalibrationSession, exc: InsufficientExcitation, hint: str, accept_poor_fit: bool) -> PoorFit | InsufficientExcitation:
    """The error for a solve the estimator refused for rank: what the recording lacks, unless the strains show a wrong file.

    In the order of :mod:`fts_calib.session.diagnosis`: configurations recorded that lack a
    centre of mass of the tool file are named first, whatever the fit; then, when the strains
    carry a signal the loads cannot produce, a cause the data support (joint units, the tool
    file's alternatives, a collinear tool file) is a poor fit; a weak excitation or no cause
    at all leaves the missing rank, with the weakly excited axis named.

    Args:
        session: The session.
        exc: The estimator's refusal (its rank, missing directions and full rank).
        hint: See :func:`session_fit_check`.
        accept_poor_fit: Do not turn the refusal into a :class:`PoorFit`.

    Returns:
        :class:`PoorFit` (no calibration) when a wrong tool file or joint unit, not the
        recording, explains the missing rank; otherwise :class:`InsufficientExcitation` in words.
    """
    if isinstance(exc, ModelNotDetermined):  # a model the jig cannot fix, whatever the samples: its words say what the jig lacks
        return exc
    short = missing_centres(session)
    if not short and not accept_poor_fit and strains_unexplained(session):
        check, found = _checked(session, hint)
        if not check.ok and (found is None or found.kind not in RECORDING_KINDS):  # a wrong file or unit, not a short sweep
            return PoorFit(check, None)
    weak = None if short else weak_excitation(session)
    refused = refused_words(session.checks.skipped, session.seen, int(session.kept.sum()))
    undetermined = session.estimator.undetermined(session.tool.names)
    moving = without_stops(session)
    said = "; ".join(w for w in (hint, f"{moving}: {MOVING_ADVICE}" if moving else "", "" if weak is None else weak.text) if w)
    words = missing_words(session.tool, session.kept, session.directions, undetermined, said, refused, _moving(session))
    return InsufficientExcitation(exc.rank, exc.missing, words, exc.full)


def still_dwell(session: CalibrationSession, time: np.ndarray, channels: np.ndarray, codes: np.ndarray) -> CodeDwell | None:
    """The channels' stays in one ADC code over the kept samples of the still stops (:func:`fts_calib.model.parity.code_dwell`).

    Learnt only from the quasi-static filter's samples (the sensor still at each stop: a
    moving calibration's codes follow the load) of a quantized sensor. A stop is a run of kept
    samples without a gap of more than 1.5 sample periods or a tool change.

    Args:
        session: The session (its filter and the channels' resolution).
        time: The kept samples' times [s], shape (K,).
        channels: Their raw readings, shape (K, n).
        codes: Their tool configuration index, shape (K,).

    Returns:
        The dwell, or None (another filter, no resolution, fewer than two samples).
    """
    resolution = None if session.filter is None else session.filter.grid.resolution
    if not isinstance(session.filter, QuasiStaticFilter) or resolution is None or not np.any(resolution > 0) or len(time) < 2:
        return None
    steps = np.diff(time)
    steps = steps[steps > 0]
    if not len(steps):
        return None
    period = float(np.median(steps))
    return code_dwell(channels, stops(time, codes, 1.5 * period), 1.0 / period)


def with_health(session: CalibrationSession, calibration: Calibration, noise_floor: np.ndarray | None) -> Calibration:
    """The calibration with its ``health`` section, learnt from the session's kept samples, when the layout has one.

    Args:
        session: The session the calibration was solved from (its kept channels, full scale,
            the channels' resolution and rails, declared or detected).
        calibration: The calibration solved.
        noise_floor: The channels' noise per sample, raw units, shape (n,), or None (measured from the fit).
    """
    resolution = None if session.filter is None else session.filter.grid.resolution
    limits = session.checks.detected_limits(resolution) or session.settings.checks.limits
    time, _, channels, codes, _ = session.kept_samples.arrays()
    parity = fit_parity(
        session.layout,
        calibration.C,
        calibration.D,
        channels,
        session.full_scale,
        noise_floor,
        resolution,
        None if limits is None else limits.low,
        None if limits is None else limits.high,
        still_dwell(session, time, channels, codes),
    )
    return calibration if parity is None else replace(calibration, health=parity.to_dict())

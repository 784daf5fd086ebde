"""A calibration session: samples in, a calibration out, for recordings, live feeds and controllers.

Data flow, one way, one :class:`SampleBatch` at a time: checks (finite values in range, rails, time
order, known tool configuration, joint limits; :mod:`fts_calib.pipeline.checks`) -> quasi-static
filter decisions from joint rates and strain stationarity -> the sensor motion and the
tool's load (:func:`fts_calib.robot.tool_wrench.tool_load`, the only kinematics) -> the filter's
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
"""

from __future__ import annotations

import math
import time as _time
from collections import Counter
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..core.arrays import as_floats, as_matrix, as_rows
from ..core.deprecation import renamed
from ..core.exceptions import FtsCalibError, InsufficientExcitation, PoorFit, ShapeError
from ..feeds.batch import SampleBatch, configuration_codes
from ..model.budget import AccuracyBudget
from ..model.calibration import Calibration
from ..model.channels import MALTESE_CROSS_8, ChannelLayout, channel_layout, check_channels
from ..model.estimator import OnlineEstimator
from ..model.prior import Prior
from ..model.sensor_config import DEFAULT_FULL_SCALE
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool
from ..robot.tool_wrench import tool_load, weight_wrench
from .budget import KeptSamples, MovingSamples, with_measured_budget
from .checkpoint import read_checkpoint, write_checkpoint
from .checks import BACKWARDS, BEFORE_CHECKPOINT, NON_FINITE, OUTSIDE_LIMITS, UNKNOWN_TOOL, SampleChecks
from .dynamic import DynamicFilter, filtered, sample_filter
from .fit import FitCheck
from .health import with_health
from .kept_sums import add_kept, empty_sums, refusal, session_fit_check, session_progress
from .latency import LatencyEstimate
from .progress import Progress
from .provenance import session_provenance
from .resume import restore_session, session_state
from .settings import PipelineConfig
from .tool_load import check_tool_load
from .units import held_out_units

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
            (:func:`fts_calib.pipeline.checkpoint.recording_source`, ``live_source``), or None.
        layout: The sensor's channel layout (n channels); the paper's 8 bridges by default.
            Samples of another number of channels are refused (ShapeError naming both).
        model: The sensor model setting ('linear', 'quadratic', 'cubic' or 'auto':
            :mod:`fts_calib.model.features`); with any but 'linear' the kept samples are also
            grouped into held-out units (:mod:`fts_calib.pipeline.units`) for the choice.
        full_channels: Regress on the raw channels (a free 6 x n C; ``channels: full``).
        full_scale: Full scale per wrench axis [N, N, N, N m, N m, N m], shape (6,), scaling the
            held-out errors and the measured accuracy budget in % (:mod:`fts_calib.pipeline.budget`);
            a sensor file's default (50 N, 5 N m) when None.

    Raises:
        ConfigError: A tool far heavier than the sensor's full scale (grams: :mod:`fts_calib.pipeline.tool_load`).

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
        self._kept_samples, self._moving = KeptSamples(), MovingSamples()  # for the measured budget and the latency
        self.layout = channel_layout(layout)
        self.tool = tool
        self.settings = settings or PipelineConfig()
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
        self.filter = sample_filter(self.settings, kin, use_filter, self.full_scale, self.layout, n)  # filter.mode: quasi-static or dynamic
        self.checks = SampleChecks(kin, self.settings.checks.max_abs_channel, self.settings.checks.limits)
        self.kept = np.zeros(n, dtype=np.int64)
        self.seen = 0
        self._directions, self._fit_sums, self.kept_region = empty_sums(n, self.estimator.basis.n_drift, self.full_scale)  # kept_sums
        self._staged: list[tuple] = []
        self._last: tuple[float, int, float | None] | None = None  # time, configuration, temperature of the last valid sample
        self._clock = clock
        self._last_checkpoint = clock()
        self._on_kept = on_kept

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
        readings, _ = self.kin.joint_array(joints)
        t = as_floats(t, "t").reshape(-1)
        codes = configuration_codes(configuration, len(t), self.tool.names)
        channels = as_rows(channels, len(t), "channels")  # its width is check_channels' to name, with the sensor
        if not (len(readings) == len(t) == len(channels) == len(codes)):
            counts = f"{len(t)} times, {len(readings)} joint readings, {len(channels)} rows of channels and {len(codes)} configurations"
            raise ShapeError(f"add_batch: {counts}: expected one of each per sample")
        self.add_samples(SampleBatch(t, readings, channels, codes, temperature))

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
        ok = self.checks.accept(batch)
        if ok.any():
            i = int(np.flatnonzero(ok)[-1])  # the end of the run so far: where the calibration's D belongs
            self._last = (
                float(batch.time[i]),
                int(batch.configuration[i]),
                None if batch.temperature is None else float(batch.temperature[i]),
            )
            valid = batch.select(ok)
            self._moving.add(valid.time, valid.joints, valid.channels, valid.configuration)
            self._accumulate(valid, False, None if rates is None else (np.asarray(rates[0])[ok], np.asarray(rates[1])[ok]))
        self._maybe_checkpoint()

    def _accumulate(self, batch: SampleBatch, final: bool, rates=None) -> None:
        weight = fit = None
        if self.filter is not None:
            still = filtered(self.filter, self.kin, self.tool, batch, final, rates)
            kept, g, W, weight = still.samples, still.g_sensor, still.w_sensor, still.weight
            fit = still.static_model  # the dynamic filter's: the samples the fit check's static model holds for
        else:
            load = tool_load(self.kin, self.tool, batch.joints, batch.configuration)
            kept, g, W = batch, load.g_sensor, load.static
        if not len(kept) or W is None:
            return
        codes = kept.configuration
        units = static = None
        if self.estimator.units is not None:  # the held-out units, and the weight alone: what the jig gave there
            units, static = held_out_units(codes, g), weight_wrench(self.tool, g, codes)
        columns = {"time": kept.time, "configuration": codes, "temperature": kept.temperature, "unit": units, "w_static": static}
        self.estimator.update_batch(W, kept.channels, weight, **columns)
        self._kept_samples(kept.time, W, kept.channels, codes, kept.joints)
        if self._on_kept is not None:
            self._on_kept(kept.time, W, kept.channels, codes, kept.joints, kept.temperature)
        add_kept(self, g, W, kept.channels, codes, kept.time, kept.temperature, fit)

    def flush(self) -> None:
        """Decide the samples the filter still holds (call when the stream ends)."""
        self._flush_staged()
        if self.filter is not None:
            self._accumulate(SampleBatch.empty(self.kin.n_joints, self.layout.n_channels), final=True)

    # -- output -------------------------------------------------------------------------

    def all_skipped(self) -> dict[str, int]:
        """Samples not kept, by reason: the session's checks and the filter's rules."""
        out = dict(self.checks.skipped)
        if self.filter is not None:
            out.update({f"filter: {rule}": n for rule, n in self.filter.rejected.items() if n})
        return out

    def progress(self) -> Progress:
        """Counts, rank and what is missing, in words."""
        return session_progress(self)

    def fit_check(self, hint: str = "") -> FitCheck:
        """Whether the kept samples fit the tool's model at the noise level of the data.

        The noise is the filter's noise floor (the strain scatter of the still windows);
        without the filter, or with a fixed strain threshold, none is measured and the
        verdict is 'unchecked'. See :mod:`fts_calib.pipeline.fit`.

        Args:
            hint: Words added to a poor fit's diagnosis when no alternative explains it.
        """
        return session_fit_check(self, hint)

    def solve(self, accept_poor_fit: bool = False, hint: str = "", prior: Prior | None = None) -> Calibration:
        """The calibration from everything kept so far, with its fit check, measured budget and latency in the quality, and its load region.

        The measured accuracy budget and the stream-latency estimate
        (:func:`fts_calib.pipeline.budget.with_measured_budget`) are left out only for a
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
        kept, n_kept = self._kept_samples, int(self.kept.sum())
        calibration, self.budget, self.latency = with_measured_budget(
            calibration, self.kin, self.tool, kept, n_kept, noise_floor, self._moving, self.full_scale, accuracy
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
        state = session_state(self)
        self._last_checkpoint = self._clock()
        return write_checkpoint(self.checkpoint_path, state)

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
        restore_session(session, state, path, (model, full_channels, full_scale))
        return session

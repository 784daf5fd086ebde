"""A calibration session: samples in, a calibration out, for recordings, live feeds and controllers.

Data flow, one way, one :class:`SampleBatch` at a time: checks (time order, finite values,
known tool configuration, joint limits; :mod:`fts_calib.pipeline.checks`) -> quasi-static
filter decisions from joint rates and strain stationarity -> the sensor motion and the
tool's load (:func:`fts_calib.robot.load.tool_load`, the only kinematics) -> the filter's
dynamic rule -> online least squares on the static wrench (paper eqs 12-18).

From a controller's own loop::

    session = CalibrationSession(kin, tool)
    session.add(t, joints, strain, "A")      # [s], joint readings [rad], raw strains, configuration
    print(session.progress().missing)        # e.g. "need a third centre of mass not on the line through A and B"
    calibration = session.solve()

With a checkpoint path the session saves its sums atomically every
``live.checkpoint_interval_s`` seconds of wall-clock time and when it stops;
:meth:`CalibrationSession.resume` continues from the file, skipping samples it already
holds, so a crash loses at most that interval.
"""

from __future__ import annotations

import dataclasses
import math
import time as _time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..core.exceptions import FileFormatError, FtsCalibError, InsufficientExcitation, ShapeError
from ..feeds.batch import SampleBatch
from ..model.calibration import Calibration
from ..model.estimator import OnlineEstimator
from ..robot.kinematics import Kinematics
from ..robot.load import tool_load
from ..robot.tool import Tool
from .advice import missing_words
from .checkpoint import read_checkpoint, write_checkpoint
from .checks import BACKWARDS, BEFORE_CHECKPOINT, NON_FINITE, OUTSIDE_LIMITS, UNKNOWN_TOOL, SampleChecks
from .qsfilter import QuasiStaticFilter
from .settings import PipelineConfig
from .still import quasi_static

__all__ = [
    "BACKWARDS",
    "BEFORE_CHECKPOINT",
    "NON_FINITE",
    "OUTSIDE_LIMITS",
    "UNKNOWN_TOOL",
    "CalibrationSession",
    "Progress",
]

_STAGE = 256  # single samples from add() are processed in groups of this size


@dataclass(frozen=True)
class Progress:
    """Where a session stands.

    Attributes:
        seen: Samples offered.
        kept: Samples that entered the least squares.
        kept_by_configuration: Kept samples per tool configuration name.
        rank: Rank of S_XX (7 determines every coefficient).
        condition_number: Of the scaled S_XX (inf below rank 7).
        missing: What is still missing, in words ('' at rank 7).
        skipped: Samples not kept, by reason (checks and filter rules).
        last_time: Time of the last sample [s], or None.
    """

    seen: int
    kept: int
    kept_by_configuration: dict[str, int]
    rank: int
    condition_number: float
    missing: str
    skipped: dict[str, int]
    last_time: float | None

    @property
    def kept_fraction(self) -> float:
        """Kept samples over seen samples (0 when none seen)."""
        return self.kept / self.seen if self.seen else 0.0


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
        on_kept: Called with ``(time (k,), w_sensor (k, 6), strain (k, 8), configuration
            indices (k,))`` for the samples entering the least squares, in order (e.g. to plot
            the convergence); None for nothing.
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
        on_kept: Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], None] | None = None,
    ):
        self.kin = kin
        self.tool = tool
        self.settings = settings or PipelineConfig()
        self.checkpoint_path = Path(checkpoint) if checkpoint else None
        self.source = source
        self.estimator = OnlineEstimator()
        self.filter = QuasiStaticFilter(self.settings.filter, kin.continuous, tool) if use_filter else None
        self.checks = SampleChecks(kin)
        n = len(tool.configurations)
        self.kept = np.zeros(n, dtype=np.int64)
        self.seen = 0
        self._directions = np.zeros((n, 4, 4))  # sum of [u; 1][u; 1]^T per configuration, u = g / |g|
        self._codes = {name: k for k, name in enumerate(tool.names)}
        self._staged: list[tuple] = []
        self._clock = clock
        self._last_checkpoint = clock()
        self._on_kept = on_kept

    @property
    def skipped(self) -> Counter[str]:
        """Samples skipped by the checks (and before reaching the session), by reason."""
        return self.checks.skipped

    # -- input --------------------------------------------------------------------------

    def add(self, t: float, joints, strain, configuration: str) -> None:
        """Add one sample.

        Args:
            t: Time [s].
            joints: Joint readings [rad], (n_joints,) or a mapping joint name -> value.
            strain: Raw strains, (8,).
            configuration: Tool configuration name.
        """
        readings, _ = self.kin.readings(joints)
        code = self._codes.get(configuration, -1)
        self._staged.append((float(t), readings[0], np.asarray(strain, dtype=float).reshape(-1), code))
        if len(self._staged) >= _STAGE:
            self._flush_staged()

    def add_batch(self, t, joints, strain, configuration) -> None:
        """Add many samples, in time order.

        Args:
            t: Times [s], shape (n,).
            joints: Joint readings [rad], shape (n, n_joints) or a mapping of (n,) arrays.
            strain: Raw strains, shape (n, 8).
            configuration: Configuration names (one, or one per sample) or indices in the
                tool's order.

        Raises:
            ShapeError: The arrays do not have one row per time.
        """
        readings, _ = self.kin.readings(joints)
        t = np.asarray(t, dtype=float).reshape(-1)
        if isinstance(configuration, str):
            codes = np.full(len(t), self._codes.get(configuration, -1), dtype=np.int64)
        else:
            given = np.asarray(configuration)
            if given.dtype.kind in "iu":
                codes = given.astype(np.int64)
            else:
                codes = np.array([self._codes.get(str(x), -1) for x in given], dtype=np.int64)
        strain = np.asarray(strain, dtype=float)
        if not (len(readings) == len(t) == len(strain) == len(codes)):
            raise ShapeError(f"add_batch: {len(t)} times, {len(readings)} readings, {len(strain)} strains and {len(codes)} tools")
        self.add_samples(SampleBatch(t, readings, strain.reshape(len(t), -1), codes))

    def add_samples(self, batch: SampleBatch) -> None:
        """Add a batch from a feed (configuration indices in the tool's order), in time order."""
        self._flush_staged()
        self._process(batch)

    def note_skipped(self, reason: str, count: int) -> None:
        """Count samples skipped before reaching the session (e.g. malformed lines of a file)."""
        if count:
            self.seen += count
            self.checks.skipped[reason] += count

    def _flush_staged(self) -> None:
        if self._staged:
            t, joints, strain, codes = zip(*self._staged, strict=True)
            self._staged = []
            self._process(SampleBatch(np.array(t), np.array(joints), np.array(strain), np.array(codes, dtype=np.int64)))

    def _process(self, batch: SampleBatch) -> None:
        self.seen += len(batch)
        ok = self.checks.accept(batch)
        if ok.any():
            self._accumulate(batch.select(ok), final=False)
        self._maybe_checkpoint()

    def _accumulate(self, batch: SampleBatch, final: bool) -> None:
        if self.filter is not None:
            still = quasi_static(self.filter, self.kin, self.tool, batch, final=final)
            kept, g, W = still.samples, still.g_sensor, still.w_sensor
        else:
            load = tool_load(self.kin, self.tool, batch.joints, batch.configuration)
            kept, g, W = batch, load.g_sensor, load.static
        if not len(kept) or W is None:
            return
        codes = kept.configuration
        self.estimator.update_batch(W, kept.channels)
        if self._on_kept is not None:
            self._on_kept(kept.time, W, kept.channels, codes)
        self.kept += np.bincount(codes, minlength=len(self.kept))
        unit = np.hstack([g / np.linalg.norm(g, axis=1, keepdims=True), np.ones((len(g), 1))])
        for c in np.unique(codes):
            u = unit[codes == c]
            self._directions[c] += u.T @ u

    def flush(self) -> None:
        """Decide the samples the filter still holds (call when the stream ends)."""
        self._flush_staged()
        if self.filter is not None:
            self._accumulate(SampleBatch.empty(self.kin.n_joints, 8), final=True)

    # -- output -------------------------------------------------------------------------

    def all_skipped(self) -> dict[str, int]:
        """Samples not kept, by reason: the session's checks and the filter's rules."""
        out = dict(self.checks.skipped)
        if self.filter is not None:
            out.update({f"filter: {rule}": n for rule, n in self.filter.rejected.items() if n})
        return out

    def progress(self) -> Progress:
        """Counts, rank and what is missing, in words."""
        rank, condition = self.estimator.rank()
        last = self.checks.last_time
        return Progress(
            seen=self.seen,
            kept=int(self.kept.sum()),
            kept_by_configuration={name: int(n) for name, n in zip(self.tool.names, self.kept, strict=True)},
            rank=rank,
            condition_number=condition,
            missing="" if rank == 7 else missing_words(self.tool, self.kept, self._directions),
            skipped=self.all_skipped(),
            last_time=None if last == -math.inf else last,
        )

    def solve(self) -> Calibration:
        """The calibration from everything kept so far.

        Raises:
            InsufficientExcitation: Rank below 7; the message says what is missing, in words.
        """
        self._flush_staged()
        try:
            calibration = self.estimator.solve()
        except InsufficientExcitation as exc:
            raise InsufficientExcitation(exc.rank, exc.missing, missing_words(self.tool, self.kept, self._directions)) from None
        if calibration.quality is None:  # the estimator always measures the fit
            raise FtsCalibError("the estimator returned a calibration without its quality")
        quality = replace(calibration.quality, samples_seen=self.seen, skipped=self.all_skipped())
        return replace(calibration, quality=quality, provenance={**calibration.provenance, **self._provenance()})

    def _provenance(self) -> dict:
        robot, mount = self.kin.robot, self.kin.robot.sensor
        return {
            "robot": {"name": robot.name, "urdf": robot.urdf_spec or str(robot.urdf)},
            "sensor_frame": {"name": mount.name, "parent_frame": mount.parent_frame, "xyz": mount.xyz.tolist(), "rpy": mount.rpy.tolist()},
            "tools": {
                "name": self.tool.name,
                "file": str(self.tool.source) if self.tool.source else None,
                "gravity": self.tool.gravity,
                "configurations": [
                    {"name": c.name, "mass": c.mass, "com": c.p_sensor_com.tolist(), "samples": int(n)}
                    for c, n in zip(self.tool.configurations, self.kept, strict=True)
                ],
            },
            "source": self.source,
            "filter": None if self.filter is None else dataclasses.asdict(self.settings.filter),
        }

    # -- checkpoints --------------------------------------------------------------------

    def _maybe_checkpoint(self) -> None:
        if self.checkpoint_path is not None and self._clock() - self._last_checkpoint >= self.settings.live.checkpoint_interval_s:
            self.checkpoint()

    def checkpoint(self) -> Path | None:
        """Write the checkpoint now (atomically); None without a checkpoint path."""
        if self.checkpoint_path is None:
            return None
        last = self.checks.last_time
        state = {
            "robot": self.kin.robot.name,
            "tool": self.tool.name,
            "configurations": self.tool.names,
            "estimator": self.estimator.state(),
            "kept": self.kept.tolist(),
            "seen": self.seen,
            "skipped": dict(self.checks.skipped),
            "directions": self._directions.tolist(),
            "last_time": None if last == -math.inf else last,
            "filter": None if self.filter is None else self.filter.state(),
        }
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
    ) -> CalibrationSession:
        """A session continuing from a checkpoint; samples up to its last time are skipped.

        Raises:
            FileFormatError: Not a checkpoint, or one of another robot or tool.
        """
        path = Path(checkpoint)
        state = read_checkpoint(path, kin.robot.name, tool)
        session = cls(kin, tool, settings, checkpoint=path, use_filter=state.get("filter") is not None, source=source, clock=clock)
        try:
            session.estimator = OnlineEstimator.from_state(state["estimator"])
            session.kept = np.array(state["kept"], dtype=np.int64)
            session.seen = int(state["seen"])
            session.checks.skipped = Counter({str(k): int(v) for k, v in state["skipped"].items()})
            session._directions = np.array(state["directions"], dtype=float)
        except (KeyError, TypeError, ValueError) as exc:
            raise FileFormatError(path, None, f"damaged checkpoint: {exc}") from None
        if state.get("last_time") is not None:
            session.checks.last_time = session.checks.resume_time = float(state["last_time"])
        if session.filter is not None and state.get("filter"):
            session.filter.restore(state["filter"])
        return session

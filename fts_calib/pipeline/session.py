"""A calibration session: samples in, a calibration out, for recordings, live feeds and controllers.

Data flow, one way: joint readings and raw strains -> checks (time order, finite values,
known tool configuration, joint limits) -> quasi-static filter -> gravity in the sensor
frame (kinematics) -> the tool configuration's static wrench (paper eqs 17-18) -> online
least squares (eqs 12-16).

From a controller's own loop::

    session = CalibrationSession(kin, tool)
    session.add(t, q, strain, "A")           # [s], joint readings [rad], raw strains, configuration
    print(session.progress().missing)        # e.g. "need a third centre of mass not on the line through A and B"
    calibration = session.solve()

With a checkpoint path the session saves its sums atomically every
``live.checkpoint_interval_s`` seconds of wall-clock time and when it stops;
:meth:`CalibrationSession.resume` continues from the file, skipping samples it already
holds, so a crash loses at most that interval.
"""

from __future__ import annotations

import json
import math
import time as _time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from .._version import __version__
from ..core.exceptions import FileFormatError, FtsCalibError, FtsCalibWarning, InsufficientExcitation
from ..core.fileio import atomic_write_text
from ..model.calibration import Calibration, now_iso
from ..model.estimator import OnlineEstimator
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool
from .qsfilter import QuasiStaticFilter
from .settings import PipelineConfig

CHECKPOINT_FORMAT = "fts-calib-checkpoint/1"

#: Skip reasons counted by the session.
BEFORE_CHECKPOINT = "before the checkpoint (already counted)"
BACKWARDS = "time going backwards"
NON_FINITE = "non-finite value"
UNKNOWN_TOOL = "unknown tool configuration"
OUTSIDE_LIMITS = "outside joint limits"

_STAGE = 256  # single samples from add() are processed in groups of this size
_MIN_SAMPLES = 10  # samples of a configuration before it counts in the progress words


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
        config: Pipeline settings (filter thresholds, checkpoint interval).
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
        config: PipelineConfig | None = None,
        checkpoint: str | Path | None = None,
        use_filter: bool = True,
        source: str = "",
        clock: Callable[[], float] = _time.monotonic,
        on_kept: Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], None] | None = None,
    ):
        self.kin = kin
        self.tool = tool
        self.config = config or PipelineConfig()
        self.checkpoint_path = Path(checkpoint) if checkpoint else None
        self.source = source
        self.estimator = OnlineEstimator()
        self.filter = QuasiStaticFilter(self.config.filter, kin, tool) if use_filter else None
        n = len(tool.configurations)
        self.kept = np.zeros(n, dtype=np.int64)
        self.seen = 0
        self.skipped: dict[str, int] = {}
        self._directions = np.zeros((n, 4, 4))  # sum of [g; 1][g; 1]^T per configuration
        self._codes = {c.name: k for k, c in enumerate(tool.configurations)}
        self._last_time = -math.inf
        self._resume_time = -math.inf
        self._staged: list[tuple] = []
        self._clock = clock
        self._last_checkpoint = clock()
        self._warned_degrees = False
        self._wrench = np.stack([c.wrench_matrix for c in tool.configurations])
        self._on_kept = on_kept

    # -- input --------------------------------------------------------------------------

    def add(self, t: float, q, strain, tool: str) -> None:
        """Add one sample.

        Args:
            t: Time [s].
            q: Joint readings [rad], (n_joints,) or a mapping joint name -> value.
            strain: Raw strains, (8,).
            tool: Tool configuration name.
        """
        theta, _ = self.kin.readings(q)
        self._staged.append((float(t), theta[0], np.asarray(strain, dtype=float).reshape(8), self._codes.get(tool, -1)))
        if len(self._staged) >= _STAGE:
            self._flush_staged()

    def add_batch(self, t, readings, strain, tool) -> None:
        """Add many samples, in time order.

        Args:
            t: Times [s], shape (n,).
            readings: Joint readings [rad], shape (n, n_joints) or a mapping of (n,) arrays.
            strain: Raw strains, shape (n, 8).
            tool: Configuration names (one, or one per sample) or indices in the tool's order.
        """
        self._flush_staged()
        theta, _ = self.kin.readings(readings)
        t = np.asarray(t, dtype=float).reshape(-1)
        strain = np.asarray(strain, dtype=float).reshape(-1, 8)
        if isinstance(tool, str):
            codes = np.full(len(t), self._codes.get(tool, -1), dtype=np.int64)
        else:
            tool = np.asarray(tool)
            codes = tool.astype(np.int64) if tool.dtype.kind in "iu" else np.array([self._codes.get(str(x), -1) for x in tool])
        if not (len(theta) == len(t) == len(strain) == len(codes)):
            raise ValueError(f"add_batch: {len(t)} times, {len(theta)} readings, {len(strain)} strains and {len(codes)} tools")
        self._process(t, theta, strain, codes)

    def note_skipped(self, reason: str, count: int) -> None:
        """Count samples skipped before reaching the session (e.g. malformed lines of a file)."""
        if count:
            self.seen += count
            self.skipped[reason] = self.skipped.get(reason, 0) + count

    def _flush_staged(self) -> None:
        if self._staged:
            t, theta, strain, codes = zip(*self._staged, strict=True)
            self._staged = []
            self._process(np.array(t), np.array(theta), np.array(strain), np.array(codes, dtype=np.int64))

    def _skip(self, reason: str, mask: np.ndarray) -> None:
        count = int(mask.sum())
        if count:
            self.skipped[reason] = self.skipped.get(reason, 0) + count

    def _process(self, t, theta, strain, codes) -> None:
        self.seen += len(t)
        ok = t > self._resume_time
        self._skip(BEFORE_CHECKPOINT, ~ok)
        finite = np.isfinite(t) & np.all(np.isfinite(theta), axis=1) & np.all(np.isfinite(strain), axis=1)
        self._skip(NON_FINITE, ok & ~finite)
        ok &= finite
        # time order: a sample earlier than one already accepted is dropped
        previous = np.maximum.accumulate(np.concatenate([[self._last_time], np.where(ok, t, -np.inf)]))[:-1]
        forward = t >= previous
        self._skip(BACKWARDS, ok & ~forward)
        ok &= forward
        known = codes >= 0
        self._skip(UNKNOWN_TOOL, ok & ~known)
        ok &= known
        _, outside, degrees = self.kin.reading_problems(theta)
        self._skip(OUTSIDE_LIMITS, ok & outside)
        ok &= ~outside
        if degrees and not self._warned_degrees:
            self._warned_degrees = True
            warnings.warn(
                f"joint readings look like degrees ({', '.join(degrees)} far beyond 2π): readings must be in rad; "
                "these samples are skipped as outside the joint limits",
                FtsCalibWarning,
                stacklevel=3,
            )
        if ok.any():
            self._last_time = float(t[ok][-1])
            self._accumulate(t[ok], theta[ok], strain[ok], codes[ok], final=False)
        self._maybe_checkpoint()

    def _accumulate(self, t, theta, strain, codes, final: bool) -> None:
        if self.filter is not None:
            decided = self.filter.process(t, theta, strain, codes, final=final)
            t, strain, codes, g = (decided.time[decided.keep], decided.strain[decided.keep], decided.tool[decided.keep], decided.g_sensor)
        else:
            g = self.kin.g_sensor(theta, self.tool.gravity) if len(theta) else np.zeros((0, 3))
        if not len(g):
            return
        W = np.einsum("nij,nj->ni", self._wrench[codes], g)  # eqs 17-18 per sample's configuration
        self.estimator.update_batch(W, strain)
        if self._on_kept is not None:
            self._on_kept(t, W, strain, codes)
        self.kept += np.bincount(codes, minlength=len(self.kept))
        unit = np.hstack([g / np.linalg.norm(g, axis=1, keepdims=True), np.ones((len(g), 1))])
        for c in np.unique(codes):
            u = unit[codes == c]
            self._directions[c] += u.T @ u

    def flush(self) -> None:
        """Decide the samples the filter still holds (call when the stream ends)."""
        self._flush_staged()
        if self.filter is not None:
            self._accumulate(np.zeros(0), np.zeros((0, self.kin.n_joints)), np.zeros((0, 8)), np.zeros(0, dtype=np.int64), final=True)

    # -- output -------------------------------------------------------------------------

    def all_skipped(self) -> dict[str, int]:
        """Samples not kept, by reason: the session's checks and the filter's rules."""
        out = dict(self.skipped)
        if self.filter is not None:
            out.update({f"filter: {rule}": n for rule, n in self.filter.rejected.items() if n})
        return out

    def progress(self) -> Progress:
        """Counts, rank and what is missing, in words."""
        rank, condition = self.estimator.rank()
        return Progress(
            seen=self.seen,
            kept=int(self.kept.sum()),
            kept_by_configuration={c.name: int(n) for c, n in zip(self.tool.configurations, self.kept, strict=True)},
            rank=rank,
            condition_number=condition,
            missing="" if rank == 7 else self._missing(),
            skipped=self.all_skipped(),
            last_time=None if self._last_time == -math.inf else self._last_time,
        )

    def _missing(self) -> str:
        names = [c.name for c in self.tool.configurations]
        seen = [k for k in range(len(names)) if self.kept[k] >= _MIN_SAMPLES]
        if not seen:
            return "no quasi-static sample yet: hold the arm still at the stops of the sweep"
        few = [names[k] for k in seen if np.linalg.matrix_rank(self._directions[k], tol=1e-6 * max(1.0, self.kept[k])) < 4]
        words = []
        if few:
            words.append(f"configuration {', '.join(few)}: gravity seen from too few directions so far (keep sweeping)")
        coms = np.array([c.p_sensor_com for c in self.tool.configurations])
        others = [k for k in range(len(names)) if k not in seen]
        if len(seen) == 1:
            words.append(f"need a second centre of mass: mount configuration {' or '.join(names[k] for k in others) or '(none left)'}")
        elif len(seen) >= 2:
            base = coms[seen[0]]
            span = np.linalg.matrix_rank(coms[seen] - base, tol=1e-6)
            if span < 2:
                label = " and ".join(names[k] for k in seen)
                off = [names[k] for k in others if np.linalg.matrix_rank(np.vstack([coms[seen] - base, coms[k] - base]), tol=1e-6) == 2]
                if off:
                    words.append(f"need a third centre of mass not on the line through {label}: mount configuration {' or '.join(off)}")
                else:
                    words.append(
                        f"the centres of mass of {label} and every other configuration lie on one line: the tool "
                        "needs a configuration off that line (paper eqs 19-20)"
                    )
        return "; ".join(words) or "more quasi-static samples"

    def solve(self) -> Calibration:
        """The calibration from everything kept so far.

        Raises:
            InsufficientExcitation: Rank below 7; the message says what is missing, in words.
        """
        self._flush_staged()
        try:
            calibration = self.estimator.solve()
        except InsufficientExcitation as exc:
            raise InsufficientExcitation(exc.rank, exc.missing, self._missing()) from None
        if calibration.quality is None:
            raise FtsCalibError("internal error: the estimator returned a calibration without its fit quality")
        quality = replace(calibration.quality, samples_seen=self.seen, skipped=self.all_skipped())
        mount = self.kin.robot.sensor
        provenance = {
            **calibration.provenance,
            "robot": {"name": self.kin.robot.name, "urdf": self.kin.robot.urdf_spec or str(self.kin.robot.urdf)},
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
            "filter": None if self.filter is None else {k: getattr(self.config.filter, k) for k in self.config.filter.__dataclass_fields__},
        }
        return replace(calibration, quality=quality, provenance=provenance)

    # -- checkpoints --------------------------------------------------------------------

    def _maybe_checkpoint(self) -> None:
        if self.checkpoint_path is not None and self._clock() - self._last_checkpoint >= self.config.live.checkpoint_interval_s:
            self.checkpoint()

    def checkpoint(self) -> Path | None:
        """Write the checkpoint now (atomically); None without a checkpoint path."""
        if self.checkpoint_path is None:
            return None
        state = {
            "format": CHECKPOINT_FORMAT,
            "robot": self.kin.robot.name,
            "tool": self.tool.name,
            "configurations": [c.name for c in self.tool.configurations],
            "estimator": self.estimator.state(),
            "kept": self.kept.tolist(),
            "seen": self.seen,
            "skipped": self.skipped,
            "directions": self._directions.tolist(),
            "last_time": None if self._last_time == -math.inf else self._last_time,
            "filter": None if self.filter is None else self.filter.state(),
            "written": now_iso(),
            "software_version": __version__,
        }
        self._last_checkpoint = self._clock()
        return atomic_write_text(self.checkpoint_path, json.dumps(state))

    @classmethod
    def resume(
        cls,
        checkpoint: str | Path,
        kin: Kinematics,
        tool: Tool,
        config: PipelineConfig | None = None,
        source: str = "",
        clock: Callable[[], float] = _time.monotonic,
    ) -> CalibrationSession:
        """A session continuing from a checkpoint; samples up to its last time are skipped.

        Raises:
            FileFormatError: Not a checkpoint, or one of another robot or tool.
        """
        path = Path(checkpoint)
        try:
            state = json.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise FileFormatError(path, None, "checkpoint not found") from None
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise FileFormatError(path, None, f"not a checkpoint: {exc}") from None
        if not isinstance(state, dict) or state.get("format") != CHECKPOINT_FORMAT:
            raise FileFormatError(path, "format", f"expected {CHECKPOINT_FORMAT!r}")
        names = [c.name for c in tool.configurations]
        if state.get("robot") != kin.robot.name or state.get("tool") != tool.name or state.get("configurations") != names:
            raise FileFormatError(
                path,
                None,
                f"checkpoint of robot {state.get('robot')!r} with tool {state.get('tool')!r} "
                f"{state.get('configurations')}, not of {kin.robot.name!r} with {tool.name!r} {names}",
            )
        session = cls(kin, tool, config, checkpoint=path, use_filter=state.get("filter") is not None, source=source, clock=clock)
        session.estimator = OnlineEstimator.from_state(state["estimator"])
        session.kept = np.array(state["kept"], dtype=np.int64)
        session.seen = int(state["seen"])
        session.skipped = {str(k): int(v) for k, v in state["skipped"].items()}
        session._directions = np.array(state["directions"], dtype=float)
        if state.get("last_time") is not None:
            session._last_time = session._resume_time = float(state["last_time"])
        if session.filter is not None and state.get("filter"):
            session.filter.restore(state["filter"])
        return session

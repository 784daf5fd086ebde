"""The quality of a calibration (:class:`Quality`) and its ``quality`` section of the calibration file.

Units: residual RMS and the standard errors of D in [N, N, N, N m, N m, N m]; the standard
errors of C_bar and C in [N or N m per strain unit]. The file form keeps the fields a newer
version wrote (``Quality.extra``) and writes them back unchanged
(:mod:`fts_calib.model.calibration` reads and writes the whole file).

The calibration result: C, C_bar, D and their quality, and its YAML file (``fts-calib/1``).

Units: C and C_bar in [N or N m per strain unit] (rows Fx, Fy, Fz in N, rows Mx, My, Mz
in N m), D in [N, N, N, N m, N m, N m]. C is always derived from C_bar (``C = C_bar P``,
paper eq 7, with P the sensor's channel layout, :mod:`fts_calib.model.channels`), so the
two can never disagree; a file whose C does not match its C_bar is refused.

The file is written atomically: a crash never leaves half a file. The quality and its
section of the file are :mod:`fts_calib.model.calibration`'s (:class:`Quality` is re-exported here);
the load region the calibration was fitted on and its ``region`` section are
:mod:`fts_calib.model.region`'s.
"""

from __future__ import annotations

import datetime as _dt
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..core import arrays as validation
from ..core.arrays import as_matrix, frozen
from ..core.bounded import MAX_TEXT_BYTES, parse_yaml
from ..core.deprecation import renamed
from ..core.exceptions import ConfigError, FileFormatError, FtsCalibError, FtsCalibWarning, ShapeError
from ..core.files import atomic_write_text, dump_yaml, fields_of, load_yaml, read_array, require
from ..core.resources import locate
from .channels import MALTESE_CROSS_8, WRENCH_AXES, WRENCH_UNITS, ChannelLayout, channel_layout, wrench_from_strain
from .features import SensorModel
from .parity import ParityModel
from .region import LoadRegion, region_from_dict


@dataclass(frozen=True)
class Quality:
    """How good a calibration is.

    Attributes:
        samples_used: Samples that entered the least squares.
        samples_seen: Samples offered, including those skipped.
        rank: Numerical rank of the 7x7 matrix S_XX (7 when every coefficient is determined).
        condition_number: Condition number of S_XX after scaling its diagonal to 1.
        residual_rms: RMS of the fit residual per wrench axis, in [N, N, N, N m, N m, N m].
            Shape (6,).
        stderr_C_bar: Standard error of every coefficient of C_bar. Shape (6, 6).
        stderr_D: Standard error of every offset, in [N, N, N, N m, N m, N m]. Shape (6,).
        stderr_C: Standard error of every coefficient of C. Shape (6, n), n channels.
        skipped: Samples skipped, by reason (e.g. ``{"non-finite strain": 3}``).
        fit: The fit check's verdict as plain data (verdict, residual RMS per
            configuration and axis, the expected noise, the diagnosis), or None when the
            fit was not checked (see :mod:`fts_calib.session.fit`).
        budget: The measured accuracy budget as plain data (per term and axis in % of full
            scale, the total; :meth:`fts_calib.budget.propagation.AccuracyBudget.to_dict`), or None.
        full_rank: The rank that determines every coefficient: 6 + the offset model's
            columns (7 for the paper's constant offsets, 6 for a jig).
        prior: The prior C_bar was shrunk toward, as plain data (source, weight, effective
            parameters, shrinkage: :mod:`fts_calib.model.prior`), or None for none.
        held_directions: How many directions of the model no load excited, and the rule
            that held them (``{count, rule}``, :mod:`fts_calib.model.model_choice`), or None
            when the model was not chosen by held-out error.
        extra: Fields of the file's ``quality`` that this version does not know (written by
            a newer one), kept as read and written back unchanged.
    """

    samples_used: int
    samples_seen: int
    rank: int
    condition_number: float
    residual_rms: np.ndarray
    stderr_C_bar: np.ndarray
    stderr_D: np.ndarray
    stderr_C: np.ndarray
    skipped: Mapping[str, int] = field(default_factory=dict)
    fit: Mapping[str, Any] | None = None
    budget: Mapping[str, Any] | None = None
    full_rank: int = 7
    prior: Mapping[str, Any] | None = None
    held_directions: Mapping[str, Any] | None = None
    extra: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self):
        object.__setattr__(self, "extra", dict(self.extra))
        n = np.shape(self.stderr_C)[-1] if np.ndim(self.stderr_C) == 2 else -1
        for name, shape in (("residual_rms", (6,)), ("stderr_C_bar", (6, 6)), ("stderr_D", (6,)), ("stderr_C", (6, n))):
            object.__setattr__(self, name, frozen(as_matrix(getattr(self, name), shape, name)))
        object.__setattr__(self, "skipped", dict(self.skipped))

    def relative_stderr_C(self, C: np.ndarray) -> np.ndarray:
        """Standard error of each coefficient of C relative to the largest |coefficient| of its row.

        Args:
            C: The calibration matrix the errors belong to. Shape (6, n).

        Returns:
            Dimensionless ratios, shape (6, n).
        """
        return self.stderr_C / np.max(np.abs(C), axis=1, keepdims=True)


#: The fields of ``quality`` this version reads; others are kept in ``Quality.extra``.
QUALITY_FIELDS = (
    "samples_used",
    "samples_seen",
    "skipped",
    "rank",
    "condition_number",
    "residual_rms",
    "stderr_C_bar",
    "stderr_D",
    "stderr_C",
    "fit",
    "accuracy_budget",
    "full_rank",
    "prior",
    "held_directions",
)


def quality_to_dict(quality: Quality) -> dict[str, Any]:
    """The ``quality`` section of a calibration file: plain data, unknown fields written back.

    Args:
        quality: The fit statistics (residual RMS per axis (6,) in [N, N, N, N m, N m, N m],
            standard errors of C_bar (6, 6), D (6,) and C (6, n)).

    Returns:
        A mapping for the YAML file; arrays are left as numpy arrays for the writer.
    """
    return {
        "samples_used": quality.samples_used,
        "samples_seen": quality.samples_seen,
        "skipped": dict(quality.skipped),
        "rank": quality.rank,
        "condition_number": quality.condition_number,
        "residual_rms": dict(zip(WRENCH_AXES, quality.residual_rms.tolist(), strict=True)),
        "stderr_C_bar": quality.stderr_C_bar,
        "stderr_D": quality.stderr_D,
        "stderr_C": quality.stderr_C,
        **({"fit": dict(quality.fit)} if quality.fit is not None else {}),
        **({"accuracy_budget": dict(quality.budget)} if quality.budget is not None else {}),
        "full_rank": quality.full_rank,
        **({"prior": dict(quality.prior)} if quality.prior is not None else {}),
        **({"held_directions": dict(quality.held_directions)} if quality.held_directions is not None else {}),
        **{key: value for key, value in quality.extra.items() if key not in QUALITY_FIELDS},
    }


def quality_from_dict(raw: Any, path: Path, n: int) -> Quality:
    """Read the ``quality`` section of a calibration file.

    Args:
        raw: The section as read from YAML (a mapping).
        path: The file, for messages.
        n: Channels of the sensor's layout: the width of ``stderr_C``, shape (6, n).

    Returns:
        The fit statistics; fields this version does not know are kept in ``extra``.

    Raises:
        FileFormatError: Not a mapping, a missing field or axis, a wrong shape or type.
    """
    if not isinstance(raw, Mapping):
        raise FileFormatError(path, "quality", "expected a mapping")
    rms = require(raw, "residual_rms", path, "quality.")
    if isinstance(rms, Mapping):
        missing = [axis for axis in WRENCH_AXES if axis not in rms]
        if missing:
            raise FileFormatError(path, "quality.residual_rms", f"missing axes {missing}")
        rms = [rms[axis] for axis in WRENCH_AXES]
    try:
        return Quality(
            samples_used=int(require(raw, "samples_used", path, "quality.")),
            samples_seen=int(require(raw, "samples_seen", path, "quality.")),
            rank=int(require(raw, "rank", path, "quality.")),
            condition_number=float(require(raw, "condition_number", path, "quality.")),
            residual_rms=read_array(rms, (6,), path, "quality.residual_rms"),
            stderr_C_bar=read_array(require(raw, "stderr_C_bar", path, "quality."), (6, 6), path, "quality.stderr_C_bar"),
            stderr_D=read_array(require(raw, "stderr_D", path, "quality."), (6,), path, "quality.stderr_D"),
            stderr_C=read_array(require(raw, "stderr_C", path, "quality."), (6, n), path, "quality.stderr_C"),
            skipped={str(k): int(v) for k, v in (raw.get("skipped") or {}).items()},
            fit=dict(raw["fit"]) if isinstance(raw.get("fit"), Mapping) else None,
            budget=dict(raw["accuracy_budget"]) if isinstance(raw.get("accuracy_budget"), Mapping) else None,
            full_rank=int(raw.get("full_rank", 7)),
            prior=dict(raw["prior"]) if isinstance(raw.get("prior"), Mapping) else None,
            held_directions=dict(raw["held_directions"]) if isinstance(raw.get("held_directions"), Mapping) else None,
            extra={key: value for key, value in raw.items() if key not in QUALITY_FIELDS},
        )
    except (TypeError, ValueError) as exc:
        raise FileFormatError(path, "quality", str(exc)) from None


#: Value of the ``format`` field of a calibration file.
FORMAT = "fts-calib/1"

_UNITS = {
    "wrench": list(WRENCH_UNITS),
    "C": "N or N·m per strain unit (rows Fx Fy Fz in N, Mx My Mz in N·m)",
    "D": "N, N, N, N·m, N·m, N·m",
    "strain": "raw bridge reading",
}


def now_iso() -> str:
    """Current UTC time as an ISO 8601 string with seconds, e.g. '2026-11-22T10:00:00Z'."""
    return _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat().replace("+00:00", "Z")


@dataclass(frozen=True)
class Calibration:
    """A sensor calibration: ``W = C Delta + D`` with ``C = C_bar P``.

    Attributes:
        C_bar: Modified calibration matrix, shape (6, 6).
        D: Wrench offsets in [N, N, N, N m, N m, N m], shape (6,).
        quality: Fit statistics, or None for a calibration typed in by hand.
        provenance: Where it came from: robot, sensor frame, tools, time, software version.
        offset_history: Earlier offsets, oldest first, each ``{"D": [...], "replaced": time,
            "reason": text}``.
        layout: The sensor's channel layout (its projection P, 6 x n); the paper's 8-bridge
            sensor when not given.
        model: The sensor model when it is not the linear ``C Delta`` (a quadratic or cubic
            family, or a free C over the raw channels: :class:`fts_calib.model.features.SensorModel`);
            None for the linear model. With a model, C_bar and C are the model linearised at the
            centre of the calibration data (for ``channels: full`` projected onto the layout),
            for what needs one matrix; :meth:`wrench` evaluates the model.
        model_selection: The held-out choice of the model as plain data (the table of
            candidates, :meth:`fts_calib.model.model_choice.Selection.as_dict`), or None.
        offset_model: How the offsets moved during the calibration run, as plain data
            (:func:`fts_calib.model.offset_models.describe`: the model chosen and why, its
            basis and coefficients, the offset trajectory); None for constant offsets of
            a file written before offset models existed. ``D`` is the offset at the end of
            the run.
        health: The parity model of the channels (the ``health`` section,
            :class:`fts_calib.model.parity.ParityModel` as plain data), or None (a layout
            with no more channels than axes, or a file written before it existed).
        region: The load region the calibration was fitted on (:class:`fts_calib.model.region.LoadRegion`:
            the known wrenches of the samples that entered the least squares), or None (a
            calibration typed in by hand, or a file written before regions were recorded).
        extra: Top-level fields of the file that this version does not know (written by a
            newer one), kept as read: a rewrite (``tare``) writes them back unchanged.
        C: Calibration matrix ``C_bar @ P``, shape (6, n) (derived, not an argument).
    """

    C_bar: np.ndarray
    D: np.ndarray
    quality: Quality | None = None
    provenance: Mapping[str, Any] = field(default_factory=dict)
    offset_history: tuple[Mapping[str, Any], ...] = ()
    layout: ChannelLayout = MALTESE_CROSS_8
    offset_model: Mapping[str, Any] | None = None
    model: SensorModel | None = None
    model_selection: Mapping[str, Any] | None = None
    extra: Mapping[str, Any] = field(default_factory=dict)
    health: Mapping[str, Any] | None = None
    region: LoadRegion | None = None
    C: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        C_bar = frozen(validation.finite_array("C_bar", as_matrix(self.C_bar, (6, 6), "C_bar")))
        object.__setattr__(self, "C_bar", C_bar)
        object.__setattr__(self, "D", frozen(validation.finite_array("D", as_matrix(self.D, (6,), "D"))))
        layout = channel_layout(self.layout)
        object.__setattr__(self, "layout", layout)
        object.__setattr__(self, "C", frozen(C_bar @ layout.projection))
        if self.quality is not None and self.quality.stderr_C.shape != self.C.shape:
            raise ShapeError(f"quality.stderr_C.shape={self.quality.stderr_C.shape} but expected {self.C.shape}, the shape of C")
        object.__setattr__(self, "provenance", dict(self.provenance))
        object.__setattr__(self, "offset_history", tuple(dict(h) for h in self.offset_history))
        object.__setattr__(self, "extra", dict(self.extra))
        if self.offset_model is not None:
            object.__setattr__(self, "offset_model", dict(self.offset_model))
        if self.health is not None:
            object.__setattr__(self, "health", dict(self.health))
        if self.model is not None and self.model.n_channels != layout.n_channels:
            raise ShapeError(f"model.n_channels={self.model.n_channels} but expected {layout.n_channels}, the layout's")
        if self.model_selection is not None:
            object.__setattr__(self, "model_selection", dict(self.model_selection))
        if self.region is not None and not isinstance(self.region, LoadRegion):
            raise ConfigError("region", type(self.region).__name__, "a LoadRegion (fts_calib.model.region) or None")

    @property
    def family(self) -> str:
        """The sensor model's family: 'linear', 'quadratic' or 'cubic'."""
        return "linear" if self.model is None else self.model.family

    @property
    def nonlinear(self) -> bool:
        """Whether the wrench is not ``C Delta + D`` (a nonlinear family or a free C over the raw channels)."""
        return self.model is not None

    @renamed(strain="channels")
    def wrench(self, channels, region_check: bool = True) -> np.ndarray:
        """Wrench on the sensor from raw channels: ``C Delta + D``, or the model's ``Theta phi(u) + D``.

        The one evaluator of a calibration (reader, validate, tare, payload, live, the budget).
        A nonlinear model (quadratic, cubic) is determined only on the loads it was fitted on:
        when any wrench lies outside the calibration's :attr:`region`, one
        :class:`FtsCalibWarning` per call says how many. The in-controller
        :class:`fts_calib.service.reader.WrenchReader` never checks per sample; its
        ``outside_region`` is there for a caller that wants to.

        Args:
            channels: Raw channel readings. Shape (n,) or (N, n), n = ``layout.n_channels``.
            region_check: Warn about wrenches outside the region (nonlinear models only);
                False for a caller that reports the region itself (``validate``, ``monitor``).

        Returns:
            ``[Fx, Fy, Fz, Mx, My, Mz]`` in S, in [N] and [N m]. Shape (6,) or (N, 6).
        """
        if self.model is None:
            return wrench_from_strain(self.C, channels, self.D)
        w_sensor = self.model.wrench(channels) + self.D
        if region_check and self.region is not None and self.model.family != "linear":
            outside = int(np.count_nonzero(~self.region.contains(w_sensor)))
            if outside:
                total = len(w_sensor) if w_sensor.ndim == 2 else 1
                warnings.warn(
                    f"{outside:,} of {total:,} wrenches lie outside the load region the {self.model.family} model was fitted on "
                    f"({self.region.describe()}): it is not determined there",
                    FtsCalibWarning,
                    stacklevel=3,  # the caller's line: this method is wrapped by @renamed
                )
        return w_sensor

    def save(self, path: str | Path) -> Path:
        """Write this calibration to a YAML file of format ``fts-calib/1``, atomically (:func:`save_calibration`).

        Args:
            path: Destination; its folder is created when missing.

        Returns:
            The path written.
        """
        return save_calibration(self, path)

    def require_linear(self, what: str) -> None:
        """Refuse a model other than ``C Delta + D`` for a format that holds one matrix.

        Args:
            what: The format, for the message (e.g. 'the ros2 export').

        Raises:
            ConfigError: The calibration's model is nonlinear or a free C over the raw channels.
        """
        if self.model is not None:
            kind = f"a {self.model.family} model" + (" of the raw channels" if self.model.full else "")
            # a linear model of the raw channels is a free C, not C_bar P: the layout, not the model, is what to change
            again = (
                "with the sensor's channel layout (the sensor file's channels: maltese-cross-8, wrench-6 or a projection, not full)"
                if self.model.family == "linear"
                else "with --model linear"
            )
            message = (
                f"{what} holds one matrix C (wrench = C strain + D) but this calibration is {kind} "
                f"({len(self.model.names)} features per axis): use the c-header or json export, or calibrate {again}"
            )
            raise ConfigError("model", self.model.family, "linear", message=message)

    def with_offsets(self, D, reason: str, time: str | None = None) -> Calibration:
        """Copy with new offsets; the current ones go to ``offset_history`` with the time.

        The history keeps at most :data:`MAX_OFFSET_HISTORY` entries: the first (the offsets the
        calibration run ended with, what a tare's drift is measured from) and the latest ones.

        Args:
            D: New wrench offsets in [N, N, N, N m, N m, N m]. Shape (6,).
            reason: Why they were replaced (e.g. 're-tare from tare.csv, nothing mounted').
            time: ISO time of the replacement; now when None.
        """
        entry = {"D": self.D.tolist(), "replaced": time or now_iso(), "reason": reason}
        history = (*self.offset_history, entry)
        if len(history) > MAX_OFFSET_HISTORY:  # the calibration's own offsets, then the latest ones: a bounded file
            history = (history[0], *history[len(history) - MAX_OFFSET_HISTORY + 1 :])
        return replace(self, D=D, offset_history=history)


#: Entries ``offset_history`` keeps: the first and the latest (an automatic re-tare every second must not grow the file
#: past its read limit; 100 entries are ~30 kB).
MAX_OFFSET_HISTORY = 100


#: The top-level fields of a calibration file this version reads; others are kept in ``Calibration.extra``.
FIELDS = (
    "format",
    "units",
    "channels",
    "C",
    "C_bar",
    "D",
    "quality",
    "provenance",
    "offset_history",
    "offset_model",
    "model",
    "model_selection",
    "health",
    "region",
)


def save_calibration(calibration: Calibration, path: str | Path) -> Path:
    """Write a calibration to a YAML file of format ``fts-calib/1``, atomically.

    Args:
        calibration: The calibration to write.
        path: Destination; its folder is created when missing.

    Returns:
        The path written.
    """
    data: dict[str, Any] = {
        "format": FORMAT,
        "units": _UNITS,
        "channels": calibration.layout.to_config(),
        "C": calibration.C,
        "C_bar": calibration.C_bar,
        "D": calibration.D,
    }
    if calibration.quality is not None:
        data["quality"] = quality_to_dict(calibration.quality)
    data["provenance"] = dict(calibration.provenance)
    data["offset_history"] = list(calibration.offset_history)
    if calibration.offset_model is not None:
        data["offset_model"] = dict(calibration.offset_model)
    data["model"] = "linear" if calibration.model is None else calibration.model.to_config()
    if calibration.model_selection is not None:
        data["model_selection"] = dict(calibration.model_selection)
    if calibration.health is not None:
        data["health"] = dict(calibration.health)
    if calibration.region is not None:
        data["region"] = calibration.region.as_dict()
    data.update({key: value for key, value in calibration.extra.items() if key not in FIELDS})  # a newer version's fields, kept
    header = "# fts-calib calibration: W = C @ strain + D (wrench [Fx Fy Fz Mx My Mz] in N and N·m, sensor frame)\n"
    text = header + dump_yaml(data)
    check_loadable(text, path)
    return atomic_write_text(path, text)


def check_loadable(text: str, path: str | Path) -> None:
    """Refuse to write a calibration file that :func:`load_calibration` would refuse: its rules, on the text to write.

    The text is parsed and read by :func:`calibration_from_data` (the loader's one reader) and
    checked against the loader's size limit, before any file is touched.

    Args:
        text: The file's YAML text.
        path: Where it would be written, for the message.

    Raises:
        FtsCalibError: An internal error naming the field the loader would refuse (a
            standard error that is NaN or inf, a wrong shape); nothing is written.
    """
    size = len(text.encode("utf-8"))
    try:
        if size > MAX_TEXT_BYTES:
            raise FileFormatError(path, None, f"{size:,} bytes, above the limit of {MAX_TEXT_BYTES:,} bytes the loader reads")
        data = parse_yaml(text, path)
        if not isinstance(data, dict):
            raise FileFormatError(path, None, "expected a mapping at the top level")
        calibration_from_data(data, Path(path))
    except FtsCalibError as error:  # whatever the loader would raise
        raise FtsCalibError(f"internal error: the calibration for {path} would not load back ({error}); nothing written") from error


def load_calibration(path: str | Path, rtol: float = 1e-9) -> Calibration:
    """Read a calibration file of format ``fts-calib/1``.

    Args:
        path: The YAML file, or the name of a shipped one (``"paper_table1_calibration"``).
        rtol: Accepted mismatch between the file's C and ``C_bar @ P``, relative to max|C|.
            P is the projection of the file's ``channels`` layout (the paper's 8-bridge one
            when the field is absent, as in files written before layouts existed).

    Raises:
        FileFormatError: Another format, a missing field, a wrong shape, a non-finite
            number, or a C that does not equal ``C_bar @ P``; the message names the field.

    Fields this version does not know (a newer version's) are kept in ``extra`` (top level)
    and ``quality.extra``, and :func:`save_calibration` writes them back; a
    :class:`FtsCalibWarning` names them and the file: nothing else uses them.
    """
    path = locate(path, "configs", "calibration")
    calibration = calibration_from_data(load_yaml(path), path, rtol)
    quality = calibration.quality
    unknown = [*calibration.extra, *(f"quality.{key}" for key in (quality.extra if quality is not None else {}))]
    if unknown:
        warnings.warn(unknown_fields(path, unknown), FtsCalibWarning, stacklevel=2)
    return calibration


def calibration_from_data(data: Mapping[str, Any], path: Path, rtol: float = 1e-9) -> Calibration:
    """The calibration of a file's parsed YAML: every rule of :func:`load_calibration` (which warns of unknown fields).

    :func:`save_calibration` reads what it is about to write with it, so a written file always loads.

    Args:
        data: The file's top-level mapping.
        path: The file, for messages.
        rtol: Accepted mismatch between C and ``C_bar @ P``, relative to max|C|.

    Raises:
        FileFormatError: Another format, a missing field, a wrong shape, a non-finite
            number, or a C that does not equal ``C_bar @ P``; the message names the field.
    """
    fmt = data.get("format")
    if fmt != FORMAT:
        raise FileFormatError(path, "format", f"is {fmt!r} but expected {FORMAT!r}: not a calibration file of this version")
    C_bar = read_array(require(data, "C_bar", path), (6, 6), path, "C_bar")
    D = read_array(require(data, "D", path), (6,), path, "D")
    with fields_of(path):
        layout = channel_layout(data.get("channels"))
    C = read_array(require(data, "C", path), (6, layout.n_channels), path, "C")
    mismatch = float(np.max(np.abs(C - C_bar @ layout.projection)))
    if mismatch > rtol * max(float(np.max(np.abs(C))), 1e-300):
        raise FileFormatError(
            path, "C", f"does not equal C_bar @ P (largest difference {mismatch:.3g}); the file was edited inconsistently"
        )
    quality = quality_from_dict(data["quality"], path, layout.n_channels) if data.get("quality") is not None else None
    provenance = data.get("provenance") or {}
    if not isinstance(provenance, Mapping):
        raise FileFormatError(path, "provenance", "expected a mapping")
    history = data.get("offset_history") or []
    if not isinstance(history, list) or not all(isinstance(h, Mapping) for h in history):
        raise FileFormatError(path, "offset_history", "expected a list of mappings")
    offset_model = data.get("offset_model")
    if offset_model is not None and not isinstance(offset_model, Mapping):
        raise FileFormatError(path, "offset_model", "expected a mapping")
    model = _model_from(data.get("model"), path, layout)
    selection = data.get("model_selection")
    if selection is not None and not isinstance(selection, Mapping):
        raise FileFormatError(path, "model_selection", "expected a mapping")
    health = data.get("health")
    if health is not None and not isinstance(health, Mapping):
        raise FileFormatError(path, "health", "expected a mapping (the parity model)")
    with fields_of(path):
        if health is not None:
            ParityModel.from_dict(health)  # refused here, naming the field, rather than in service
    region = region_from_dict(data["region"], path) if data.get("region") is not None else None  # older files: none
    extra = {key: value for key, value in data.items() if key not in FIELDS}
    with fields_of(path):
        return Calibration(
            C_bar=C_bar,
            D=D,
            quality=quality,
            provenance=provenance,
            offset_history=tuple(history),
            layout=layout,
            offset_model=offset_model,
            model=model,
            model_selection=selection,
            health=health,
            region=region,
            extra=extra,
        )


def unknown_fields(path: str | Path, names: list[str]) -> str:
    """The warning of a calibration file's fields this version does not know (``names``, dotted): ignored, kept on a rewrite."""
    from .._version import __version__

    listed = ", ".join(f"'{name}'" for name in names)
    return (
        f"{path}: field{'s' if len(names) > 1 else ''} {listed} not known to fts-calib {__version__} (a newer version's?): "
        "ignored here (no computation and no export uses it), kept as it is when fts-calib rewrites the file (tare)"
    )


def _model_from(raw: Any, path: Path, layout: ChannelLayout) -> SensorModel | None:
    """The ``model`` field: absent or 'linear' (files of older versions: linear), or a model's mapping."""
    if raw is None or raw == "linear":
        return None
    if not isinstance(raw, Mapping):
        raise FileFormatError(path, "model", f"is {raw!r} but expected 'linear' or a mapping {{family, coefficients, ...}}")
    n = len(raw.get("features") or [])
    with fields_of(path, "model."):
        model = SensorModel.from_config(raw, layout.projection)
    if n and n != len(model.names):
        raise FileFormatError(path, "model.features", f"has {n} names but the {model.family} family has {len(model.names)}")
    return model

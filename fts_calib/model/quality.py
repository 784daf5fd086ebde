"""The quality of a calibration (:class:`Quality`) and its ``quality`` section of the calibration file.

Units: residual RMS and the standard errors of D in [N, N, N, N m, N m, N m]; the standard
errors of C_bar and C in [N or N m per strain unit]. The file form keeps the fields a newer
version wrote (``Quality.extra``) and writes them back unchanged
(:mod:`fts_calib.model.calibration` reads and writes the whole file).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..core.arrays import as_matrix, frozen
from ..core.exceptions import FileFormatError
from ..core.fileio import read_array, require
from .sensor import WRENCH_AXES


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
            fit was not checked (see :mod:`fts_calib.pipeline.fit`).
        budget: The measured accuracy budget as plain data (per term and axis in % of full
            scale, the total; :meth:`fts_calib.model.budget.AccuracyBudget.to_dict`), or None.
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

"""A calibration session's checkpoint state: what it holds (sums, counts, filter state) and its restoration.

:meth:`fts_calib.pipeline.session.CalibrationSession.resume` reads the checkpoint
(:mod:`fts_calib.pipeline.checkpoint`) and builds the session; this restores what the file
holds into it and refuses a checkpoint of another channel layout or sensor model.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.exceptions import FileFormatError
from ..model.estimator import OnlineEstimator

if TYPE_CHECKING:
    from .session import CalibrationSession


def restore_session(session: CalibrationSession, state: dict[str, Any], path: Path, models: tuple[str, bool, Any]) -> None:
    """Load a checkpoint's state into a new session (see the module docstring).

    Args:
        session: The session, built with the run's settings.
        state: The checkpoint's content.
        path: The checkpoint file, for messages.
        models: ``(model setting, full_channels, full_scale)`` of the run.

    Raises:
        FileFormatError: A damaged checkpoint, or one of another channel layout or sensor model.
    """
    model, full_channels, full_scale = models
    try:
        session.estimator = estimator = OnlineEstimator.from_state(state["estimator"])
        estimator.full_scale = None if full_scale is None else np.asarray(full_scale, dtype=float)
        if "basis" in state["estimator"]:  # a checkpoint of an older version has constant offsets only
            estimator.offsets = session.settings.offsets.model
        m = 10 + estimator.basis.n_drift
        session._fit_sums = np.zeros((len(session.tool.configurations), m, m))
        session.kept = np.array(state["kept"], dtype=np.int64)
        session.seen = int(state["seen"])
        session.checks.restore(state)
        session._directions = np.array(state["directions"], dtype=float)
        if "fit_sums" in state:
            session._fit_sums = np.array(state["fit_sums"], dtype=float).reshape(session._fit_sums.shape)
        # a checkpoint of an older version holds no region: the calibration's is then that of the resumed part only
        session.kept_region.restore(state.get("region"))
    except (KeyError, TypeError, ValueError) as exc:
        raise FileFormatError(path, None, f"damaged checkpoint: {exc}") from None
    saved = (session.estimator.model, session.estimator.full_channels)
    if "model" in state["estimator"] and saved != (model, full_channels):  # older checkpoints: the linear model
        raise FileFormatError(path, "estimator.model", f"is {saved[0]} but the run asks for {model}: resume with the same --model")
    if session.estimator.layout != session.layout:
        found, expected = session.estimator.layout.name, session.layout.name
        raise FileFormatError(path, "estimator.channels", f"is of a {found} sensor but the sensor is {expected}: give its --sensor")
    if state.get("last_time") is not None:
        session.checks.last_time = session.checks.resume_time = float(state["last_time"])
    if session.filter is not None and state.get("filter"):
        session.filter.restore(state["filter"])


def session_state(session: CalibrationSession) -> dict[str, Any]:
    """What a checkpoint holds of a session: plain types, safe to write as JSON."""
    last = session.checks.last_time
    return {
        "robot": session.kin.robot.name,
        "tool": session.tool.name,
        "source": session.source_record,
        "configurations": session.tool.names,
        "estimator": session.estimator.state(),
        "kept": session.kept.tolist(),
        "seen": session.seen,
        **session.checks.state(),  # skipped, by reason, and at the rails
        "directions": session._directions.tolist(),
        "fit_sums": session._fit_sums.tolist(),
        "last_time": None if last == -math.inf else last,
        "filter": None if session.filter is None else session.filter.state(),
        "region": session.kept_region.state(),
    }

"""The calibration's parity model (:mod:`fts_calib.model.health`), from what a session kept."""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from ..model.calibration import Calibration
from ..model.health import fit_parity

if TYPE_CHECKING:
    from .session import CalibrationSession


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
    parity = fit_parity(
        session.layout,
        calibration.C,
        calibration.D,
        session._kept_samples.arrays()[2],
        session.full_scale,
        noise_floor,
        resolution,
        None if limits is None else limits.low,
        None if limits is None else limits.high,
    )
    return calibration if parity is None else replace(calibration, health=parity.to_dict())

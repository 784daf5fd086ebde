"""Deprecated module path, kept for one release: the budget's sensitivities live in :mod:`fts_calib.robot.sensitivities`."""

import warnings

from .sensitivities import SOURCE_NAMES, load_error_sources, stops

__all__ = ["SOURCE_NAMES", "load_error_sources", "stops"]

warnings.warn(
    "fts_calib.robot.load_errors is now fts_calib.robot.sensitivities; the old path goes in fts-calib 0.2", DeprecationWarning, stacklevel=2
)

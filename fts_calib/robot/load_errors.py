"""Deprecated module path, kept for one release: the budget's sensitivities live in :mod:`fts_calib.robot.sensitivities`."""

from .sensitivities import SOURCE_NAMES, load_error_sources, stops

__all__ = ["SOURCE_NAMES", "load_error_sources", "stops"]

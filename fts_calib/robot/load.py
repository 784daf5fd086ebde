"""Deprecated module path, kept for one release: the tool's wrench lives in :mod:`fts_calib.robot.tool_wrench`."""

import warnings

from .tool_wrench import ToolLoad, tool_load

__all__ = ["ToolLoad", "tool_load"]

warnings.warn(
    "fts_calib.robot.load is now fts_calib.robot.tool_wrench; the old path goes in fts-calib 0.2", DeprecationWarning, stacklevel=2
)

"""Deprecated module path, kept for one release: the tool's wrench lives in :mod:`fts_calib.robot.tool_wrench`."""

from .tool_wrench import ToolLoad, tool_load

__all__ = ["ToolLoad", "tool_load"]

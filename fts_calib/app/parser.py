"""The command line's parser class: help opens with the purpose and an example; a missing ``--tool`` names the shipped tools."""

from __future__ import annotations

import argparse


class Parser(argparse.ArgumentParser):
    """An argument parser whose error for a missing ``--tool`` names the shipped tools (no tool is assumed)."""

    def error(self, message: str):
        """Print the usage and the message (with the shipped tools when ``--tool`` is missing), exit 2."""
        if "required" in message and "--tool" in message:
            from ..core.resources import shipped

            tools = shipped("configs", "tool")
            message += (
                f"; name the calibration tool mounted: a shipped one ({', '.join(f'--tool {t}' for t in tools)}) "
                "or your tool YAML (--tool my_tool.yaml): a wrong tool gives a wrong calibration"
            )
        super().error(message)

    def format_help(self) -> str:
        """The help with the description (purpose, example) before the usage: argparse's sections, reordered."""
        formatter = self._get_formatter()
        formatter.add_text(self.description)
        formatter.add_usage(self.usage, self._actions, self._mutually_exclusive_groups)
        for group in self._action_groups:
            formatter.start_section(group.title)
            formatter.add_text(group.description)
            formatter.add_arguments(group._group_actions)
            formatter.end_section()
        formatter.add_text(self.epilog)
        return formatter.format_help()

"""The parser class of the command line (help opens with purpose and example; a missing ``--tool`` names the tools) and option types."""

from __future__ import annotations

import argparse
import textwrap
from pathlib import Path

#: Image formats a plot may be written in (matplotlib's Agg backend; no suffix: PNG).
PLOT_SUFFIXES = (".png", ".pdf", ".svg", ".jpg", ".jpeg", ".eps", ".ps", ".tif", ".tiff", ".webp")


def plot_path(text: str) -> str:
    """The type of a plot option: its suffix must name an image format (checked before the job, not by matplotlib after it)."""
    suffix = Path(text).suffix.lower()
    if suffix and suffix not in PLOT_SUFFIXES:
        raise argparse.ArgumentTypeError(f"{text!r} is not an image file: expected a name ending in {', '.join(PLOT_SUFFIXES)}")
    return text


class Parser(argparse.ArgumentParser):
    """An argument parser whose errors explain: a missing ``--tool`` names the shipped tools, a bare ``--mount`` its values."""

    def error(self, message: str):
        """Print the usage and the message (with the shipped tools when ``--tool`` is missing), exit 2."""
        if "required" in message and "--tool" in message:
            from ..core.resources import shipped

            tools = shipped("configs", "tool")
            message += (
                f"; name the calibration tool mounted: a shipped one ({', '.join(f'--tool {t}' for t in tools)}) "
                "or your tool YAML (--tool my_tool.yaml): a wrong tool gives a wrong calibration"
            )
        elif "argument --mount: expected 3 arguments" in message:
            message += (
                ": roll, pitch, yaw in rad from the frame the feed gives to the sensor, e.g. --mount 0 0 1.5708 "
                "(payload's flag that estimates a small mount rotation is now --estimate-mount)"
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


def add_command(commands, name: str, help_text: str, description: str, example: str) -> argparse.ArgumentParser:
    """A sub-command whose help starts with its purpose in one line and an example, then the details."""
    first = example.splitlines()[0].split("  #")[0].strip()
    head = f"{help_text[0].upper()}{help_text[1:]}.\nexample: {first}\n\n{textwrap.fill(description, 110)}"
    return commands.add_parser(
        name,
        help=help_text,
        description=head,
        epilog=f"examples:\n  {example}",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )


def add_address(text: str) -> tuple[str, int]:
    """Argument type of a UDP address ``HOST:PORT`` (an empty host is 127.0.0.1; port 0: any free port)."""
    host, _, port = text.rpartition(":")
    try:
        number = int(port)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected HOST:PORT, e.g. 127.0.0.1:5005, got {text!r}") from None
    if not 0 <= number <= 65535:
        raise argparse.ArgumentTypeError(f"port {number} in {text!r} but expected 0 to 65535 (0: any free port)")
    return (host or "127.0.0.1"), number

"""The command-line reference, ``docs/cli.md``, generated from the argument parser itself.

Every command, option, default and example comes from :func:`fts_calib.app.parser.build_parser`
and the exit codes from :data:`fts_calib.app.exit_codes.EXIT_CODES`, so the page cannot
disagree with ``fts-calib --help``. The text does not depend on the terminal width or on the
Python version's help formatter: the parser's actions are read, not its formatted help.

Run ``python -m fts_calib.app.cli_docs docs/cli.md`` to write the page (without a path it is
printed); ``tests/test_docs.py`` fails when the committed page differs from it.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

from .exit_codes import EXIT_CODES
from .parser import build_parser, old_spellings

#: How the page says where it comes from (and how to write it again).
GENERATED_BY = "python -m fts_calib.app.cli_docs docs/cli.md"


def _cell(text: str) -> str:
    """Text for one Markdown table cell: one line, ``|`` escaped."""
    return " ".join(text.split()).replace("|", "\\|")


def _help(parser: argparse.ArgumentParser, action: argparse.Action) -> str:
    """The action's help with argparse's ``%`` expansions applied (``%%`` -> ``%``)."""
    if not action.help:
        return ""
    return parser._get_formatter()._expand_help(action)  # the same expansion --help applies


def _value(action: argparse.Action) -> str:
    """What the option takes: its choices, metavar or destination in capitals; empty for a flag."""
    if action.nargs == 0:
        return ""
    if action.choices is not None:
        return " \\| ".join(f"`{choice}`" for choice in action.choices)
    metavar = action.metavar if isinstance(action.metavar, str) else action.dest.upper()
    if action.nargs in ("+", "*"):
        return f"`{metavar} ...`"
    return f"`{metavar}`"


def _default(action: argparse.Action) -> str:
    """The default in words: ``required``, off for a flag, its value, or nothing."""
    if action.required:
        return "required"
    if action.nargs == 0:
        return "off"
    if action.default is None or action.default is argparse.SUPPRESS:
        return ""
    if isinstance(action.default, tuple):  # HOST:PORT
        return f"`{':'.join(str(part) for part in action.default)}`"
    return f"`{action.default}`"


def _options(parser: argparse.ArgumentParser) -> list[argparse.Action]:
    """The documented actions of a parser (its help option left out), positionals first."""
    actions = [
        a
        for a in parser._actions
        if not isinstance(a, argparse._HelpAction | argparse._SubParsersAction) and a.help != argparse.SUPPRESS  # old spellings apart
    ]
    return [a for a in actions if not a.option_strings] + [a for a in actions if a.option_strings]


def _synopsis(name: str, parser: argparse.ArgumentParser) -> str:
    """``fts-calib NAME`` with its required options and positionals; ``[options]`` for the rest."""
    words = [f"fts-calib {name}"]
    for action in _options(parser):
        if action.option_strings and action.required:
            words.append(f"{action.option_strings[-1]} {_value(action).strip('`')}")
    words.append("[options]")
    for action in _options(parser):
        if not action.option_strings:
            value = _value(action).strip("`")
            words.append(value if action.nargs not in ("?", "*") else f"[{value}]")
    return " ".join(words)


def _description(text: str, summary: str) -> list[str]:
    """The description's paragraphs on one line each, without the summary and example lines the page shows apart."""
    paragraphs = []
    for block in re.split(r"\n\s*\n", text):
        kept = [
            line
            for line in block.splitlines()
            if not line.strip().lower().startswith(("example:", "examples:"))
            and line.strip().rstrip(".").lower() != summary.strip().rstrip(".").lower()
        ]
        if " ".join(kept).strip():
            paragraphs.append(" ".join(" ".join(kept).split()))
    return paragraphs


def _command_section(name: str, parser: argparse.ArgumentParser, summary: str) -> list[str]:
    lines = [f"## `fts-calib {name}`", "", f"{summary[:1].upper()}{summary[1:]}.", "", "```sh", _synopsis(name, parser), "```", ""]
    lines += [f"{paragraph}\n" for paragraph in _description(parser.description or "", summary)]
    lines += ["| option | value | default | what it does |", "|---|---|---|---|"]
    for action in _options(parser):
        names = ", ".join(f"`{s}`" for s in action.option_strings) or f"`{_value(action).strip('`')}`"
        value = _value(action) if action.option_strings else ""
        lines.append(f"| {names} | {value} | {_default(action)} | {_cell(_help(parser, action))} |")
    lines.append("")
    old = old_spellings(parser)
    if old:
        listed = "; ".join(f"`{flag}` (now {_code(new)})" for flag, new in sorted(old.items()))
        lines += [f"Old spellings, read for this release with a warning naming the new one: {listed}.", ""]
    if parser.epilog:
        examples = [line.strip() for line in parser.epilog.splitlines()[1:] if line.strip()]
        lines += ["Example:" if len(examples) == 1 else "Examples:", "", "```sh", *examples, "```", ""]
    return lines


def _code(words: str) -> str:
    """A new spelling as code: ``--filter none``, or the source's name in ``the source udp://HOST:PORT``."""
    head, _, name = words.rpartition("the source ")
    return f"{head}the source `{name}`" if _ else f"`{words}`"


def exit_code_table() -> list[str]:
    """The exit-code table, every row of :data:`EXIT_CODES` in the order errors are looked up."""
    lines = ["| code | name | errors | meaning |", "|---|---|---|---|"]
    for entry in EXIT_CODES:
        errors = ", ".join(f"`{error.__name__}`" for error in entry.errors) or "—"
        lines.append(f"| {int(entry.code)} | `{entry.code.name}` | {errors} | {_cell(entry.meaning)} |")
    return lines


def cli_reference() -> str:
    """The text of ``docs/cli.md``: every command and option of ``fts-calib``, and the exit codes."""
    parser = build_parser()
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    summaries = {choice.dest: choice.help or "" for choice in commands._choices_actions}
    lines = [
        "# Command line",
        "",
        f"<!-- Generated by `{GENERATED_BY}` from the argument parser; do not edit by hand. -->",
        "",
        "`fts-calib COMMAND --help` prints the same options and an example of each command, the",
        "options a person needs first and the rest in groups titled `advanced`; `fts-calib --version`",
        "prints the version. Every option is declared once (`fts_calib/app/options.py`) and means the",
        "same in every command: `--sensor` is the sensor file, `--tool` the tool mounted during the",
        "recording, `-o/--output` what the command writes. In Python it is a keyword argument of",
        "`fts_calib.app.COMMAND.run(...)` or a field of the `Setup`, `SourceOptions` or `OutputOptions`",
        "(`fts_calib/app/setup.py`) that `run` takes, by the same name and with the same default. Shipped",
        "names (`ur5`, `paper_tool`, `sensor`, `pipeline`) and file paths are accepted wherever a robot,",
        "tool, sensor or pipeline file is asked for.",
        "",
        "| command | what it does |",
        "|---|---|",
    ]
    lines += [f"| [`{name}`](#fts-calib-{name}) | {_cell(summaries[name])} |" for name in commands.choices]
    lines.append("")
    for name, sub in commands.choices.items():
        lines += _command_section(name, sub, summaries[name])
    lines += [
        "## Exit codes",
        "",
        "A user error is answered in one line on standard error (`fts-calib COMMAND: error: ...`,",
        "no traceback) and an exit code per family of errors (`fts_calib/app/exit_codes.py`). An",
        "error takes the code of the first row below whose classes it belongs to, so the catch-alls",
        "(any other `FtsCalibError`, then `OSError`) come last.",
        "",
        *exit_code_table(),
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Write the reference to the path given (``docs/cli.md``), or print it; returns 0."""
    args = sys.argv[1:] if argv is None else argv
    text = cli_reference()
    if args:
        Path(args[0]).write_text(text, encoding="utf-8")
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())

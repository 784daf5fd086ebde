"""Command-line interface: ``fts-calib <command> --help`` shows each command with an example."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .exceptions import FtsCalibError


def _demo(args: argparse.Namespace) -> int:
    from . import demo

    return demo.main(Path(args.out), samples=args.samples, seed=args.seed)


def _robots(args: argparse.Namespace) -> int:
    from . import report

    print(report.robot_details(args.name) if args.name else report.robots_list())
    return 0


def _add(commands, name: str, help_text: str, description: str, example: str) -> argparse.ArgumentParser:
    return commands.add_parser(
        name, help=help_text, description=description, epilog=f"example:\n  {example}",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``fts-calib`` with all its sub-commands."""
    parser = argparse.ArgumentParser(
        prog="fts-calib",
        description="In-situ calibration of six-axis strain-gauge force/torque sensors.",
        epilog="Run 'fts-calib COMMAND --help' for the options and an example of each command.",
    )
    from ._version import __version__

    parser.add_argument("--version", action="version", version=f"fts-calib {__version__}")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND")

    demo = _add(commands, "demo", "the whole loop in simulation, with printed results",
                "Simulate the paper's validation on the shipped sensor and tool and calibrate.", "fts-calib demo --out out/")
    demo.add_argument("--out", default="out", help="folder for the results (default: out/)")
    demo.add_argument("--samples", type=int, default=2000, help="samples per tool configuration (default: 2000)")
    demo.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
    demo.set_defaults(handler=_demo)

    robots = _add(commands, "robots", "list the shipped robots, or show one",
                  "Without NAME: the shipped robot definitions. With NAME (a shipped name or a YAML path): its joints, "
                  "limits, frames and sensor mount.", "fts-calib robots ur5")
    robots.add_argument("name", nargs="?", help="shipped robot name (e.g. ur5) or path to a robot YAML file")
    robots.set_defaults(handler=_robots)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``fts-calib`` command; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "handler", None):
        parser.print_help()
        return 2
    try:
        return int(args.handler(args) or 0)
    except FtsCalibError as exc:
        print(f"fts-calib {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"fts-calib {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into `head` and the like: stop quietly
        sys.stderr.close()
        return 0


if __name__ == "__main__":
    sys.exit(main())

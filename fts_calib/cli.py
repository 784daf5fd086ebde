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


def _trajectory(args: argparse.Namespace) -> int:
    from .pipeline_config import load_pipeline_config
    from .planner import SweepPattern
    from .resources import resolve
    from .sensor_config import load_sensor_config
    from .tool import ToolShape, load_tool
    from .trajectory import format_report, plan_trajectories, write_run

    robot_path, tool_path = resolve(args.robot, "robots"), resolve(args.tool, "configs")
    tool = load_tool(tool_path)
    if args.tool_radius is not None or args.tool_length is not None:
        import dataclasses

        shape = ToolShape(args.tool_radius or tool.shape.radius, args.tool_length or tool.shape.length)
        tool = dataclasses.replace(tool, shape=shape)
    sensor = load_sensor_config(resolve(args.sensor, "configs"))
    pipeline = load_pipeline_config(resolve(args.pipeline, "configs"))
    noise = args.noise if args.noise is not None else pipeline.noise_std
    if noise is None:
        noise = sensor.simulated.noise_std if sensor.simulated is not None else 0.0
    pattern = SweepPattern(levels=args.levels, stops=args.stops, dwell=args.dwell, margin=args.margin)
    print(f"planning {robot_path.stem} sweeps for '{tool.name}' ({len(tool.configurations)} configurations)...", flush=True)
    run = plan_trajectories(robot_path, tool, sensor, pipeline.filter, noise, pattern, args.rate, args.min_clearance)
    run = write_run(run, args.out, compress=args.compress, plot=not args.no_plot)
    print(format_report(run, robot_path, tool_path))
    return 1 if run.problems else 0


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

    traj = _add(commands, "trajectory", "plan and check calibration sweeps for a robot and a tool",
                "Plan jerk-limited sweeps of the last two joints (ruckig), once per tool configuration; check limits, "
                "clearance and the predicted excitation before anything moves; write one CSV per configuration, plan.yaml "
                "and plan.png. Exits 1 when a check fails (the CSVs are then not written).",
                "fts-calib trajectory --robot robots/ur5.yaml --tool configs/paper_tool.yaml -o out/trajectories --rate 500")
    traj.add_argument("--robot", required=True, help="robot definition: a shipped name (ur5) or a YAML path")
    traj.add_argument("--tool", default="paper_tool", help="tool file: a shipped name or a YAML path (default: paper_tool)")
    traj.add_argument("-o", "--out", required=True, help="output folder")
    traj.add_argument("--rate", type=float, default=500.0, help="sample rate of the files in Hz (default: 500)")
    traj.add_argument("--levels", type=int, default=4, help="positions of the first sweep joint (default: 4)")
    traj.add_argument("--stops", type=int, default=6, help="positions of the second sweep joint per level (default: 6)")
    traj.add_argument("--dwell", type=float, default=0.5, help="time still at each stop in s (default: 0.5)")
    traj.add_argument("--margin", type=float, default=0.02, help="distance kept from position limits in rad (default: 0.02)")
    traj.add_argument("--min-clearance", type=float, default=0.02, help="smallest distance allowed in m (default: 0.02)")
    traj.add_argument("--tool-radius", type=float, help="override the tool envelope's radius in m")
    traj.add_argument("--tool-length", type=float, help="override the tool envelope's length in m")
    traj.add_argument("--sensor", default="sensor", help="sensor configuration (nominal model for the excitation report)")
    traj.add_argument("--pipeline", default="pipeline", help="pipeline configuration (quasi-static filter thresholds)")
    traj.add_argument("--noise", type=float, help="strain noise per bridge for the excitation report (default: the pipeline's)")
    traj.add_argument("--compress", action="store_true", help="write .csv.gz files")
    traj.add_argument("--no-plot", action="store_true", help="do not write plan.png")
    traj.set_defaults(handler=_trajectory)
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

"""Command-line interface: ``fts-calib <command> --help`` shows each command with an example."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from ..core.exceptions import FileFormatError, FtsCalibError


def _demo(args: argparse.Namespace) -> int:
    from . import demo

    return demo.main(Path(args.out), seed=args.seed, quick=args.quick)


def _robots(args: argparse.Namespace) -> int:
    from . import report

    print(report.robot_details(args.name) if args.name else report.robots_list())
    return 0


def _trajectory(args: argparse.Namespace) -> int:
    from ..core.resources import resolve
    from ..model.sensor_config import load_sensor_config
    from ..pipeline.settings import load_pipeline_config
    from ..planning.planner import SweepPattern
    from ..planning.trajectory import format_report, plan_trajectories, write_run
    from ..robot.tool import ToolShape, load_tool

    robot_path, tool_path = resolve(args.robot, "robots"), resolve(args.tool, "configs")
    tool = load_tool(tool_path)
    if args.tool_radius is not None or args.tool_length is not None:
        import dataclasses

        if tool.shape is None:  # never: Tool.__post_init__ fills in the default envelope
            raise FtsCalibError(f"tool '{tool.name}' has no shape for the collision checks")
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


def _setup(args: argparse.Namespace):
    """The robot's kinematics, the tool and the pipeline settings named on the command line."""
    from ..core.resources import resolve
    from ..pipeline.settings import load_pipeline_config
    from ..robot.definition import load_robot
    from ..robot.kinematics import Kinematics
    from ..robot.tool import load_tool

    return (
        Kinematics(load_robot(resolve(args.robot, "robots"))),
        load_tool(resolve(args.tool, "configs")),
        load_pipeline_config(resolve(getattr(args, "pipeline", "pipeline"), "configs")),
    )


def _calibrate(args: argparse.Namespace) -> int:
    from ..model.calibration import save_calibration
    from ..pipeline.calibrate import ProgressBar, calibrate_recording, format_summary

    kin, tool, config = _setup(args)
    recording = Path(args.recording)
    size = recording.stat().st_size if recording.exists() else 1
    bar = None if args.quiet else ProgressBar(size, "rows")
    result = calibrate_recording(
        recording,
        kin,
        tool,
        config,
        use_filter=not args.no_filter,
        checkpoint=args.checkpoint,
        resume=args.resume,
        joints_in_degrees=args.joints_in_degrees,
        progress=bar,
    )
    output = None
    if result.calibration is not None:
        output = save_calibration(result.calibration, args.output)
    print(format_summary(result, recording, output))
    return 0 if result.calibration is not None else 1


def _address(text: str) -> tuple[str, int]:
    host, _, port = text.rpartition(":")
    try:
        return (host or "127.0.0.1"), int(port)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected HOST:PORT, e.g. 127.0.0.1:5005, got {text!r}") from None


def _live(args: argparse.Namespace) -> int:
    from ..core.exceptions import InsufficientExcitation
    from ..feeds.sync import Synchronizer
    from ..model.calibration import save_calibration
    from ..pipeline.live import LiveRunner, UdpReceiver, format_stats
    from ..pipeline.session import CalibrationSession

    kin, tool, config = _setup(args)
    checkpoint = Path(args.checkpoint or f"{args.output}.checkpoint.json")
    host, port = args.listen
    source = f"live udp://{host}:{port}"
    if args.resume:
        session = CalibrationSession.resume(checkpoint, kin, tool, config, source=source)
        print(f"resumed from {checkpoint}: {session.progress().kept:,} samples kept so far", flush=True)
    else:
        session = CalibrationSession(kin, tool, config, checkpoint=checkpoint, source=source)
    latency = config.live.latency_s if args.latency is None else args.latency
    max_gap = config.live.max_gap_s if args.max_gap is None else args.max_gap
    sync = Synchronizer(kin.joint_names, [j.kind == "continuous" for j in kin.joints], max_gap, latency)
    receiver = UdpReceiver(host, port)
    print(
        f"listening on udp://{receiver.address[0]}:{receiver.address[1]} for {kin.robot.name} with '{tool.name}'; "
        "Ctrl-C or an 'end' message writes the calibration",
        flush=True,
    )
    try:
        runner = LiveRunner(session, receiver, sync, status=None if args.quiet else sys.stderr)
        stats = runner.run(idle_timeout_s=args.idle_timeout)
    finally:
        receiver.close()
    print(format_stats(stats, sync))
    from ..pipeline.calibrate import format_counts

    print("\n".join(format_counts(session)))
    try:
        calibration = session.solve()
    except InsufficientExcitation as exc:
        print(f"NO CALIBRATION: {exc}\ncheckpoint kept in {checkpoint}: run again with --resume to continue")
        return 1
    path = save_calibration(calibration, args.output)
    q = calibration.quality
    if q is None:  # CalibrationSession.solve always measures the fit
        raise FtsCalibError("internal error: the calibration has no fit quality")
    print(f"rank {q.rank} of 7, condition number {q.condition_number:.1f}; wrote {path}")
    return 0


def _replay(args: argparse.Namespace) -> int:
    from ..feeds.replay import ReplayOptions, replay

    options = ReplayOptions(
        speed=args.speed, joint_rate_hz=args.joint_rate, latency_s=args.latency, loss=args.loss, reorder=args.reorder, seed=args.seed
    )
    host, port = args.to
    print(f"replaying {args.recording} to udp://{host}:{port} at speed {args.speed:g}...", flush=True)
    stats = replay(args.recording, host, port, options)
    print(
        f"sent {stats.sent:,} datagrams in {stats.seconds:.1f} s ({stats.dropped:,} dropped and {stats.reordered:,} reordered on purpose)"
    )
    return 0


def _simulate(args: argparse.Namespace) -> int:
    import dataclasses

    import numpy as np

    from ..core.resources import resolve
    from ..model.sensor_config import load_sensor_config
    from ..planning.trajectory_io import TrajectoryFile, read_trajectory
    from ..sim.recording import simulate_recording

    kin, tool, _ = _setup(args)
    sensor_path = resolve(args.sensor, "configs")
    spec = load_sensor_config(sensor_path)
    if spec.simulated is None:
        raise FileFormatError(sensor_path, "simulation", "missing: this sensor file defines no simulated sensor")
    sensor = spec.simulated
    if args.noise is not None:
        sensor = dataclasses.replace(sensor, noise_std=np.full(8, args.noise))
    if args.drift is not None:
        sensor = dataclasses.replace(sensor, drift_rate=np.full(8, args.drift))
    folder = Path(args.trajectory)
    files = sorted(folder.glob("*.csv")) + sorted(folder.glob("*.csv.gz")) if folder.is_dir() else [folder]
    if not files:
        raise FileFormatError(folder, None, "no trajectory file (*.csv, *.csv.gz) in this folder")
    found: dict[str, TrajectoryFile] = {}
    for path in files:
        traj = read_trajectory(path)
        if traj.tool in tool.names:
            found.setdefault(traj.tool, traj)
    missing = [name for name in tool.names if name not in found]
    if not found:
        raise FileFormatError(folder, None, f"no trajectory for the configurations {tool.names} of '{tool.name}'")
    trajectories = [found[name] for name in tool.names if name in found]
    rng = None if args.noiseless else np.random.default_rng(args.seed)
    path = simulate_recording(args.output, kin, tool, trajectories, sensor, rng, tool_change_s=args.tool_change, dynamic=not args.static)
    rows = sum(len(t.time) for t in trajectories)
    noise = "none" if rng is None else f"{sensor.noise_std.max():.2g} {spec.strain_unit} per bridge (seed {args.seed})"
    wrench = "static" if args.static else "moving (Newton-Euler)"
    print(
        f"wrote {path}: {rows:,} rows, configurations {', '.join(t.tool for t in trajectories)}"
        + (f" (no trajectory for {missing})" if missing else "")
        + f"; tool wrench {wrench}, noise {noise}, "
        f"{sensor.adc_bits}-bit ADC"
    )
    return 0


def _validate(args: argparse.Namespace) -> int:
    import numpy as np

    from ..core.resources import resolve
    from ..model.calibration import load_calibration
    from ..model.sensor import WRENCH_AXES, WRENCH_UNITS
    from ..model.sensor_config import load_sensor_config
    from ..service.validate import validate_recording
    from .report import table

    kin, tool, _ = _setup(args)
    calibrations = [load_calibration(p) for p in args.calibration]
    full_scale = load_sensor_config(resolve(args.sensor, "configs")).full_scale.copy()
    if args.full_scale_force is not None:
        full_scale[:3] = args.full_scale_force
    if args.full_scale_moment is not None:
        full_scale[3:] = args.full_scale_moment
    result = validate_recording(args.recording, kin, tool, calibrations, full_scale, dynamic=not args.static)
    print(
        f"validation of {len(calibrations)} calibration(s) over {result.samples:,} samples of {args.recording} with "
        f"'{tool.name}' (expected wrench: {'moving tool, Newton-Euler' if result.dynamic else 'static weight'}; full scale "
        f"{full_scale[0]:g} N, {full_scale[3]:g} N·m)"
    )
    if result.skipped:
        print("skipped: " + ", ".join(f"{r}: {n:,}" for r, n in result.skipped.items()))
    sets = [(str(p), e) for p, e in zip(args.calibration, result.errors, strict=True)]
    if result.between is not None:
        sets.append((f"{args.calibration[0]} against {args.calibration[1]}", result.between))
    for label, errors in sets:
        print(label + ":")
        rows = [
            [
                axis,
                f"{errors.max_abs[i]:.4g} {u}",
                f"{errors.max_percent[i]:.4f} %",
                f"{errors.rms[i]:.4g} {u}",
                f"{errors.rms_percent[i]:.4f} %",
            ]
            for i, (axis, u) in enumerate(zip(WRENCH_AXES, WRENCH_UNITS, strict=True))
        ]
        print(table(["axis", "max error", "max, % FS", "RMS error", "RMS, % FS"], rows, "  "))
    if args.plot:
        from .plots import plot_validation

        labels = [Path(p).name for p in args.calibration]
        path = plot_validation(
            args.plot,
            result.time,
            result.expected[:, 0],
            [m[:, 0] for m in result.measured],
            labels,
            float(full_scale[0]),
            f"validation over {Path(args.recording).name}",
        )
        print(f"wrote {path}")
    worst = float(np.max([e.max_percent.max() for e in result.errors]))
    if args.max_error is not None and worst > args.max_error:
        print(f"FAILED: largest error {worst:.4f} % of full scale, above --max-error {args.max_error} %")
        return 1
    return 0


def _tare(args: argparse.Namespace) -> int:
    from ..core.resources import resolve
    from ..model.calibration import load_calibration, save_calibration
    from ..model.sensor import WRENCH_AXES, WRENCH_UNITS
    from ..pipeline.settings import load_pipeline_config
    from ..service.tare import tare_live, tare_recording

    calibration = load_calibration(args.calibration)
    kin = tool = None
    if args.configuration is not None:
        if args.robot is None:
            raise FileFormatError(args.calibration, None, "a mounted configuration needs --robot (its orientation matters)")
        kin, tool, _ = _setup(argparse.Namespace(robot=args.robot, tool=args.tool))
        tool.configuration(args.configuration)  # a clear error for an unknown name
    config = load_pipeline_config(resolve(args.pipeline, "configs"))
    if args.recording:
        result = tare_recording(calibration, args.recording, kin, tool, args.configuration, config)
    elif args.listen:

        def listening(address: tuple[str, int]) -> None:  # the bound port, also when --listen gave port 0
            print(f"listening on udp://{address[0]}:{address[1]} for {args.seconds:g} s: hold the sensor still...", flush=True)

        result = tare_live(calibration, args.listen[0], args.listen[1], args.seconds, kin, tool, args.configuration, config, listening)
    else:
        raise FileFormatError(args.calibration, None, "give a recording or --listen HOST:PORT to re-tare from")
    output = save_calibration(result.calibration, args.output or args.calibration)
    est = result.estimate
    print(f"re-tare from {est.samples_used:,} samples ({est.samples_skipped:,} skipped):")
    rows = [
        [a, f"{old:+.5f}", f"{new:+.5f}", f"{new - old:+.5f}", f"{se:.1g}", u]
        for a, old, new, se, u in zip(WRENCH_AXES, result.previous, est.D, est.stderr_D, WRENCH_UNITS, strict=True)
    ]
    from .report import table

    print(table(["axis", "old D", "new D", "change", "stderr", "unit"], rows, "  "))
    print(f"wrote {output} (previous offsets kept in offset_history: {len(result.calibration.offset_history)} entries)")
    return 0


def _payload(args: argparse.Namespace) -> int:
    from ..feeds.recording import RecordingReader
    from ..model.calibration import load_calibration
    from ..pipeline.qsfilter import QuasiStaticFilter
    from ..robot.tool import save_tool
    from ..service.payload import identify_payload

    kin, _, config = _setup(argparse.Namespace(robot=args.robot, tool="paper_tool", pipeline=args.pipeline))
    calibration = load_calibration(args.calibration)
    with RecordingReader(args.recording, kin.joint_names, None) as reader:
        chunks = list(reader)
    if not chunks:
        raise FileFormatError(args.recording, None, "no usable row")
    t, q, s = (np.concatenate([getattr(c, f) for c in chunks]) for f in ("time", "readings", "strain"))
    decided = QuasiStaticFilter(config.filter, kin, None).process(t, q, s, np.zeros(len(t), dtype=np.int64), final=True)
    strain = decided.strain[decided.keep]
    estimate = identify_payload(calibration.wrench(strain), decided.g_sensor, mount=args.mount, min_separation_deg=args.min_separation)
    print(
        f"payload from {estimate.samples:,} still samples ({len(t) - estimate.samples:,} moving or unsettled skipped) in "
        f"{len(estimate.poses)} orientations:"
    )
    print(f"  mass {estimate.mass:.4f} ± {estimate.stderr_mass:.1g} kg")
    print(
        "  centre of mass in the sensor frame "
        + ", ".join(f"{a} {v:+.5f} ± {e:.1g}" for a, v, e in zip("xyz", estimate.com, estimate.stderr_com, strict=True))
        + " m"
    )
    print("  offsets " + ", ".join(f"{v:+.4f}" for v in estimate.offsets) + " [N, N, N, N·m, N·m, N·m] (add to D to re-tare)")
    # the two are estimated together: both arrays or both None
    if estimate.mount_rotation is not None and estimate.stderr_mount_rotation is not None:
        print(
            "  mount rotation "
            + ", ".join(
                f"{np.degrees(v):+.3f} ± {np.degrees(e):.1g}"
                for v, e in zip(estimate.mount_rotation, estimate.stderr_mount_rotation, strict=True)
            )
            + " deg"
        )
    print("  residual RMS " + ", ".join(f"{v:.2g}" for v in estimate.residual_rms) + " [N, N·m]")
    header = (
        f"payload identified by fts-calib from {args.recording} ({estimate.samples} samples, {len(estimate.poses)} "
        f"orientations)\nmass {estimate.mass:.6g} ± {estimate.stderr_mass:.2g} kg; com ± "
        f"{', '.join(f'{e:.2g}' for e in estimate.stderr_com)} m"
    )
    path = save_tool(estimate.tool(args.name, float(np.linalg.norm(kin.g_world()))), args.output, header)
    print(f"wrote {path}")
    return 0


def _export(args: argparse.Namespace) -> int:
    from ..core.fileio import atomic_write_text
    from ..core.resources import resolve
    from ..model.calibration import load_calibration
    from ..robot.tool import load_tool
    from ..service.export import export

    calibration = load_calibration(args.calibration)
    payload, gravity = None, 9.81
    if args.payload:
        tool = load_tool(resolve(args.payload, "configs"))
        payload = tool.configuration(args.configuration) if args.configuration else tool.configurations[0]
        gravity = tool.gravity
    try:
        text = export(calibration, args.format, payload, gravity, args.name, args.sensor_frame, args.world_frame)
    except ValueError as exc:
        raise FileFormatError(args.calibration, None, str(exc)) from None
    path = atomic_write_text(args.output, text)
    print(f"wrote {path} ({args.format})")
    return 0


def _add(commands, name: str, help_text: str, description: str, example: str) -> argparse.ArgumentParser:
    return commands.add_parser(
        name,
        help=help_text,
        description=description,
        epilog=f"example:\n  {example}",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )


def _robot_and_tool(parser: argparse.ArgumentParser, pipeline: bool = True) -> None:
    parser.add_argument("--robot", required=True, help="robot definition: a shipped name (ur5) or a YAML path")
    parser.add_argument("--tool", default="paper_tool", help="tool file: a shipped name or a YAML path (default: paper_tool)")
    if pipeline:
        parser.add_argument("--pipeline", default="pipeline", help="pipeline configuration: filter thresholds, live settings")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``fts-calib`` with all its sub-commands."""
    parser = argparse.ArgumentParser(
        prog="fts-calib",
        description="In-situ calibration of six-axis strain-gauge force/torque sensors.",
        epilog="Run 'fts-calib COMMAND --help' for the options and an example of each command.",
    )
    from .._version import __version__

    parser.add_argument("--version", action="version", version=f"fts-calib {__version__}")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND")

    demo = _add(
        commands,
        "demo",
        "the whole loop in simulation on the built-in UR5, with plots",
        "Plan the sweeps, simulate the recording (true C = Table 1 of the paper), calibrate with the quasi-static "
        "filter, follow C_bar_11 sample by sample (paper Fig. 7) and validate on another motion with another tool; "
        "print the results beside the truth and the targets, and write everything with PNG plots into one folder.",
        "fts-calib demo --out out/",
    )
    demo.add_argument("--out", default="out", help="folder for the results (default: out/)")
    demo.add_argument("--seed", type=int, default=0, help="seed of the sensor noise and the validation motion (default: 0)")
    demo.add_argument("--quick", action="store_true", help="a smaller run: 3 levels x 4 stops at 100 Hz")
    demo.set_defaults(handler=_demo)

    robots = _add(
        commands,
        "robots",
        "list the shipped robots, or show one",
        "Without NAME: the shipped robot definitions. With NAME (a shipped name or a YAML path): its joints, "
        "limits, frames and sensor mount.",
        "fts-calib robots ur5",
    )
    robots.add_argument("name", nargs="?", help="shipped robot name (e.g. ur5) or path to a robot YAML file")
    robots.set_defaults(handler=_robots)

    traj = _add(
        commands,
        "trajectory",
        "plan and check calibration sweeps for a robot and a tool",
        "Plan jerk-limited sweeps of the last two joints (ruckig), once per tool configuration; check limits, "
        "clearance and the predicted excitation before anything moves; write one CSV per configuration, plan.yaml "
        "and plan.png. Exits 1 when a check fails (the CSVs are then not written).",
        "fts-calib trajectory --robot robots/ur5.yaml --tool configs/paper_tool.yaml -o out/trajectories --rate 500",
    )
    _robot_and_tool(traj)
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
    traj.add_argument("--noise", type=float, help="strain noise per bridge for the excitation report (default: the pipeline's)")
    traj.add_argument("--compress", action="store_true", help="write .csv.gz files")
    traj.add_argument("--no-plot", action="store_true", help="do not write plan.png")
    traj.set_defaults(handler=_trajectory)

    cal = _add(
        commands,
        "calibrate",
        "calibrate from a recording",
        "Read a recording (CSV: time, joints, strain_1..8, tool), keep the quasi-static samples, accumulate the "
        "least squares and write the calibration. Prints a progress bar, then a summary: samples kept and why the "
        "rest were dropped, rank, condition, residuals, standard errors. Exits 1 when the data cannot determine C.",
        "fts-calib calibrate --robot ur5 --tool configs/paper_tool.yaml recording.csv -o calibration.yaml",
    )
    cal.add_argument("recording", help="recording CSV (or .csv.gz)")
    _robot_and_tool(cal)
    cal.add_argument("-o", "--output", default="calibration.yaml", help="calibration file to write (default: calibration.yaml)")
    cal.add_argument("--no-filter", action="store_true", help="keep every valid sample, moving or not (for comparison)")
    cal.add_argument("--checkpoint", help="checkpoint file, written every few seconds")
    cal.add_argument("--resume", action="store_true", help="continue from --checkpoint")
    cal.add_argument("--joints-in-degrees", action="store_true", help="the joint columns are in degrees")
    cal.add_argument("--quiet", action="store_true", help="no progress bar")
    cal.set_defaults(handler=_calibrate)

    live = _add(
        commands,
        "live",
        "calibrate from live UDP feeds of joints and strains",
        "Listen for the JSON datagrams of the live protocol (joints, strain, tool, end), pair the two streams, keep "
        "the quasi-static samples and show a status line; write the calibration on 'end' or Ctrl-C. Checkpoints "
        "every few seconds; --resume continues after a crash.",
        "fts-calib live --robot ur5 --tool configs/paper_tool.yaml --listen 127.0.0.1:5005 -o calibration.yaml",
    )
    _robot_and_tool(live)
    live.add_argument("--listen", type=_address, default=("127.0.0.1", 5005), help="HOST:PORT to bind (default 127.0.0.1:5005)")
    live.add_argument("-o", "--output", default="calibration.yaml", help="calibration file to write")
    live.add_argument("--checkpoint", help="checkpoint file (default: OUTPUT.checkpoint.json)")
    live.add_argument("--resume", action="store_true", help="continue from the checkpoint")
    live.add_argument("--latency", type=float, help="how late the joint stamps are, in s (default: the pipeline's)")
    live.add_argument("--max-gap", type=float, help="longest joint gap interpolated across, in s (default: the pipeline's)")
    live.add_argument("--idle-timeout", type=float, help="stop after this many seconds without data")
    live.add_argument("--quiet", action="store_true", help="no status line")
    live.set_defaults(handler=_live)

    rep = _add(
        commands,
        "replay",
        "send a recording as the live protocol",
        "Send a recording's rows as live datagrams (joints, strain, tool, end), with options for a slower joint "
        "rate, added latency, loss and reordering, to test and show the live path without a robot.",
        "fts-calib replay recording.csv --to 127.0.0.1:5005 --speed 1.0",
    )
    rep.add_argument("recording", help="recording CSV (or .csv.gz)")
    rep.add_argument("--to", type=_address, default=("127.0.0.1", 5005), help="HOST:PORT (default 127.0.0.1:5005)")
    rep.add_argument("--speed", type=float, default=1.0, help="time scale: 1 real time, 10 ten times faster, 0 no pacing")
    rep.add_argument("--joint-rate", type=float, help="joint messages per second (default: one per row)")
    rep.add_argument("--latency", type=float, default=0.0, help="joint stamps late by this many s (default 0)")
    rep.add_argument("--loss", type=float, default=0.0, help="fraction of joint and strain messages dropped (default 0)")
    rep.add_argument("--reorder", type=float, default=0.0, help="fraction of messages delayed by 1-5 places (default 0)")
    rep.add_argument("--seed", type=int, default=0, help="seed of loss and reordering (default 0)")
    rep.set_defaults(handler=_replay)

    sim = _add(
        commands,
        "simulate",
        "simulate a recording from planned trajectories",
        "Play planned trajectories (one CSV per tool configuration) through the kinematics with the tool's full "
        "dynamic wrench (mass, centre of mass, inertia) and the simulated sensor of the sensor file (true C, offsets, "
        "noise, 24-bit ADC, null content, drift); write a recording in exactly the format a robot produces.",
        "fts-calib simulate --robot ur5 --tool configs/paper_tool.yaml --trajectory out/trajectories -o recording.csv",
    )
    _robot_and_tool(sim, pipeline=False)
    sim.add_argument("--trajectory", required=True, help="folder of trajectory CSVs (one per configuration), or one file")
    sim.add_argument("-o", "--output", required=True, help="recording to write (.csv or .csv.gz)")
    sim.add_argument("--sensor", default="sensor", help="sensor configuration with a 'simulation' section (default: sensor)")
    sim.add_argument("--noise", type=float, help="strain noise per bridge, raw units (default: the sensor file's)")
    sim.add_argument("--noiseless", action="store_true", help="no noise at all")
    sim.add_argument("--drift", type=float, help="offset drift of every bridge, raw units per s (default: the sensor file's)")
    sim.add_argument("--seed", type=int, default=0, help="seed of the noise (default 0)")
    sim.add_argument("--tool-change", type=float, default=2.0, help="pause between configurations in s (default 2)")
    sim.add_argument("--static", action="store_true", help="the tool's static wrench only (no dynamics)")
    sim.set_defaults(handler=_simulate)

    val = _add(
        commands,
        "validate",
        "compare measured and expected wrenches over a recording",
        "Over a recording made with another motion and another tool (the paper's third stage): the wrench measured "
        "with the calibration against the tool's wrench from the kinematics (moving tool, Newton-Euler; --static for "
        "its weight alone). Error per axis in N or N·m and in % of full scale; with two calibrations, the same "
        "between them (paper: Table 1 against Table 2); --plot writes Fx and its error (paper Figs 9-10).",
        "fts-calib validate --calibration calibration.yaml --robot ur5 --tool configs/validation_tool.yaml "
        "validation.csv --plot validation.png",
    )
    val.add_argument("recording", help="recording CSV (or .csv.gz)")
    val.add_argument("--calibration", action="append", required=True, help="calibration file (give two to compare them)")
    _robot_and_tool(val, pipeline=False)
    val.add_argument("--sensor", default="sensor", help="sensor configuration: full scale (default: sensor)")
    val.add_argument("--full-scale-force", type=float, help="full scale of the forces in N (default: the sensor file's)")
    val.add_argument("--full-scale-moment", type=float, help="full scale of the moments in N·m (default: the sensor file's)")
    val.add_argument("--static", action="store_true", help="expect the tool's weight alone (no dynamics)")
    val.add_argument("--plot", help="PNG of Fx and its error")
    val.add_argument("--max-error", type=float, help="exit 1 when an error exceeds this %% of full scale")
    val.set_defaults(handler=_validate)

    tare = _add(
        commands,
        "tare",
        "new offsets D for a calibration file, from a short still window",
        "Estimate the offsets D again with C_bar kept, from a recording or a live window with the sensor still, "
        "with nothing mounted or with a known tool configuration (then --robot gives its orientation). The file "
        "keeps the previous offsets and when they were replaced.",
        "fts-calib tare --calibration calibration.yaml tare.csv",
    )
    tare.add_argument("recording", nargs="?", help="recording with the sensor still")
    tare.add_argument("--calibration", required=True, help="calibration file to update")
    tare.add_argument("-o", "--output", help="where to write (default: update the calibration file)")
    tare.add_argument("--listen", type=_address, help="HOST:PORT: re-tare from a live window instead of a recording")
    tare.add_argument("--seconds", type=float, default=2.0, help="length of the live window in s (default 2)")
    tare.add_argument("--robot", help="robot definition (needed with a mounted configuration)")
    tare.add_argument("--tool", default="paper_tool", help="tool file of the mounted configuration (default: paper_tool)")
    tare.add_argument("--configuration", help="the mounted configuration (default: nothing mounted)")
    tare.add_argument("--pipeline", default="pipeline", help="pipeline configuration (filter thresholds)")
    tare.set_defaults(handler=_tare)

    pay = _add(
        commands,
        "payload",
        "identify an unknown payload: mass, centre of mass, offsets",
        "From a recording of the payload held still in at least three well-spread orientations: its mass, centre "
        "of mass (in the sensor frame) and the offsets, with standard errors, written as a tool file for gravity "
        "compensation. Refuses orientations that are too few or too close, and says which.",
        "fts-calib payload --calibration calibration.yaml --robot ur5 gripper.csv -o configs/gripper.yaml",
    )
    pay.add_argument("recording", help="recording of the payload in several still orientations")
    pay.add_argument("--calibration", required=True, help="the sensor's calibration file")
    pay.add_argument("--robot", required=True, help="robot definition: a shipped name (ur5) or a YAML path")
    pay.add_argument("-o", "--output", required=True, help="tool file to write")
    pay.add_argument("--name", default="payload", help="name of the payload (default: payload)")
    pay.add_argument("--mount", action="store_true", help="also estimate a small rotation of the sensor mount")
    pay.add_argument("--min-separation", type=float, default=15.0, help="smallest angle between orientations in deg (default 15)")
    pay.add_argument("--pipeline", default="pipeline", help="pipeline configuration (filter thresholds)")
    pay.set_defaults(handler=_payload)

    exp = _add(
        commands,
        "export",
        "export a calibration as a C header, JSON or ROS 2 parameters",
        "c-header: C and D as arrays and an inline wrench function for firmware; json: C, C_bar, D, quality, "
        "provenance; ros2: the parameters of control_toolbox's GravityCompensationWrench filter for a payload.",
        "fts-calib export --format c-header --calibration calibration.yaml -o fts_calib.h",
    )
    exp.add_argument("--format", required=True, choices=["c-header", "json", "ros2"], help="what to write")
    exp.add_argument("--calibration", required=True, help="calibration file")
    exp.add_argument("-o", "--output", required=True, help="file to write")
    exp.add_argument("--name", default="fts_calib", help="prefix of the C identifiers (default fts_calib)")
    exp.add_argument("--payload", help="tool file of the payload (ros2)")
    exp.add_argument("--configuration", help="configuration of the payload's tool file (default: the first)")
    exp.add_argument("--sensor-frame", default="ft_sensor", help="TF frame of the sensor (ros2, default ft_sensor)")
    exp.add_argument("--world-frame", default="world", help="TF frame with z up (ros2, default world)")
    exp.set_defaults(handler=_export)
    return parser


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    print(f"fts-calib: warning: {message}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``fts-calib`` command; returns the exit status."""
    import warnings

    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "handler", None):
        parser.print_help()
        return 2
    try:
        with warnings.catch_warnings():  # warnings as 'fts-calib: warning: ...', for this command only
            warnings.simplefilter("default")
            warnings.showwarning = _show_warning
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

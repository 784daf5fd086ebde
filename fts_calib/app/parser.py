"""The parser class of the command line (help opens with purpose and example; a missing ``--tool`` names the tools) and option types.

The ``monitor`` command's options (its own module: the parser module stays under its size).

The command line's service commands: tare, payload and export (what runs after a calibration).

The argument parser of ``fts-calib``: one function per sub-command, each with an example.

An option's destination is the parameter of the same name of ``fts_calib.app.NAME.run``,
and its default is that parameter's default: the command line and Python take the same
arguments (``tests/test_app.py`` checks it).
"""

from __future__ import annotations

import argparse
import textwrap
from collections.abc import Callable
from pathlib import Path

from ..sources.source import MIN_COVERAGE
from .exit_codes import EXIT_CODES
from .options import (
    add_drift_demo,
    add_filter_mode,
    add_offsets,
    add_prior,
    add_recording,
    add_report,
    add_report_option,
    add_return_pass,
    add_robot_or_orientation,
    add_sensor,
    add_ur,
)

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


def add_monitor(commands, add: Callable[..., argparse.ArgumentParser], address: Callable[[str], tuple[str, int]]) -> None:
    """The ``monitor`` sub-command; ``add`` makes a sub-command's parser, ``address`` parses HOST:PORT (the parser module's)."""
    mon = add(
        commands,
        "monitor",
        "watch the sensor's health over a recording: faulty bridges, named",
        "With the parity model the calibration learnt (the channels' combinations that carry no load, docs/health.md): "
        "a bridge whose gain changed, a jump, a frozen channel, a channel at its rail or beyond any load's reading; "
        "each with its time and the channel it points to. Exits 1 when a fault is found.",
        "fts-calib monitor --calibration calibration.yaml service.csv --json health.json",
    )
    mon.add_argument("recording", nargs="*", metavar="RECORDING", help="recording (CSV or CSV.gz) or ROS 2 bags of the sensor in service")
    mon.add_argument("--calibration", required=True, help="calibration file with its health section (fts-calib YAML)")
    mon.add_argument(
        "--json", dest="json_path", metavar="FILE", help='write the events as JSON: {"events": [{"time_s", "kind", "channel", "detail"}]}'
    )
    mon.add_argument(
        "--false-alarms",
        dest="false_alarms_per_hour",
        type=float,
        default=1e-3,
        help="false-alarm budget per hour of service (default 1e-3)",
    )
    mon.add_argument(
        "--listen",
        type=address,
        nargs="?",
        const=("127.0.0.1", 5005),
        metavar="HOST:PORT",
        help="watch the live UDP feed instead of a recording (default 127.0.0.1:5005, loopback)",
    )
    mon.add_argument("--listen-any", action="store_true", help="bind every network interface on the --listen port (warned about)")
    mon.add_argument("--rate", dest="rate_hz", type=float, default=1000.0, help="sample rate of the live feed in Hz (default 1000)")
    mon.add_argument("--idle-timeout", dest="idle_timeout_s", type=float, help="stop listening after this many seconds without data")
    mon.add_argument("--quiet", action="store_true", help="no status line while listening")
    offsets = mon.add_argument_group("offsets that stay right (a known payload and the joints)")
    offsets.add_argument("--robot", help="robot definition: the payload's wrench from the joints; the offset tracked without contact")
    offsets.add_argument("--tool", default="paper_tool", help="the payload's tool file (default paper_tool)")
    offsets.add_argument("--configuration", help="the payload's configuration (default: each sample's, the recording's tool column)")
    offsets.add_argument("--sensor", default="sensor", help="sensor configuration: its full scale (default: sensor)")
    offsets.add_argument(
        "--auto-tare", action="store_true", help="re-tare into the calibration file when the offset error exceeds the threshold"
    )
    offsets.add_argument(
        "--tare-threshold",
        dest="tare_threshold_percent",
        type=float,
        default=0.05,
        metavar="PERCENT",
        help="offset error tolerated, in %% of full scale (default 0.05)",
    )


#: fts_calib.payload.still.MIN_SPREAD_DEG [deg], written here: importing it would load the
#: kinematics into the parser (tests/test_app.py checks the two defaults agree).
MIN_SPREAD_DEG = 3.0
#: fts_calib.payload.samples.IDLE_TIMEOUT_S [s], written here for the same reason (checked alike).
IDLE_TIMEOUT_S = 10.0
#: fts_calib.payload.identify.MOTIONS, written here for the same reason (checked alike).
MOTIONS = ("auto", "still", "moving")


class PayloadMotion(argparse.Action):
    """``payload --motion {auto,still,moving}``; a bare ``--motion`` (the flag of the release before) is True.

    The command warns about a bare one and takes it for ``moving``. A recording right after a bare
    ``--motion`` is the SOURCE (``--motion rec.csv`` read as before).
    """

    def __call__(self, parser, namespace, values, option_string=None):
        """Store the choice, True for a bare ``--motion``; a recording after it becomes the SOURCE."""
        if values is not None and values not in MOTIONS:
            if getattr(namespace, "source", None) is not None:
                parser.error(f"argument --motion: invalid choice: {values!r} (choose from {', '.join(MOTIONS)})")
            namespace.source, values = values, None
        setattr(namespace, self.dest, True if values is None else values)


class PayloadSource(argparse.Action):
    """``payload``'s SOURCE: kept when a bare ``--motion`` took it already; two are refused."""

    def __call__(self, parser, namespace, values, option_string=None):
        """Store the SOURCE unless ``--motion`` stored it (two sources: an error)."""
        given = getattr(namespace, self.dest, None)
        if values is None or values == given:
            return
        if given is not None:
            parser.error(f"two sources, {given} and {values}: give one (--motion takes {', '.join(MOTIONS)})")
        setattr(namespace, self.dest, values)


def add_tare(commands) -> None:
    """``tare``: re-estimate the offsets D from a still window (a recording or a live feed)."""
    tare = add_command(
        commands,
        "tare",
        "new offsets D for a calibration file, from a short still window",
        "Estimate the offsets D again with C_bar kept, from a recording or a live window with the sensor still, "
        "with nothing mounted or with a known tool configuration (then --robot gives its orientation, or without it "
        "the recording or feed gives the sensor's). The file keeps the previous offsets and when they were replaced.",
        "fts-calib tare --calibration calibration.yaml tare.csv\n"
        "  fts-calib tare --calibration calibration.yaml --tool paper_tool --configuration A still_A.csv   # qw,qx,qy,qz columns",
    )
    tare.add_argument("recording", nargs="?", help="recording with the sensor still")
    tare.add_argument("--calibration", required=True, help="calibration file to update")
    tare.add_argument("-o", "--output", help="where to write (default: update the calibration file)")
    tare.add_argument("--listen", type=add_address, metavar="HOST:PORT", help="re-tare from a live window on this address instead")
    tare.add_argument("--seconds", dest="window_s", type=float, default=2.0, help="length of the live window in s (default 2)")
    add_robot_or_orientation(tare, "the recording or feed", "used with a mounted configuration")
    tare.add_argument("--tool", default="paper_tool", help="tool file of the mounted configuration (default: paper_tool)")
    tare.add_argument("--configuration", help="the mounted configuration (default: nothing mounted)")
    tare.add_argument("--pipeline", default="pipeline", help="pipeline configuration (filter thresholds)")


def add_payload(commands) -> None:
    """``payload``: identify an unknown payload's mass and centre of mass (and inertia, moving) from a source."""
    pay = add_command(
        commands,
        "payload",
        "identify an unknown payload: mass, centre of mass, offsets",
        "From a recording (or the live feed of udp://HOST:PORT) of the payload held still in orientations that tilt "
        "gravity about two axes: its mass, centre of mass (in the sensor frame) and the offsets, with standard errors, "
        "written as a tool file for gravity compensation. Judges the whole set (the spread of the gravity directions, "
        "the fit's conditioning) and refuses one that cannot determine the payload, saying what is missing. From a short "
        "continuous motion instead: the inertia too (physically consistent), the joint stream's latency estimated. "
        "Which of the two the data are is decided from them and said (--motion still or moving forces it); a live feed "
        "is collected until the sender's end, --seconds or Ctrl-C.",
        "fts-calib payload --calibration calibration.yaml --robot ur5 gripper.csv -o configs/gripper.yaml\n"
        "  fts-calib payload --calibration calibration.yaml gripper_tcp.csv --mount 0 0 0.785 -o gripper.yaml   # tcp_rx,tcp_ry,tcp_rz\n"
        "  fts-calib payload udp://127.0.0.1:5005 --seconds 10 --calibration calibration.yaml --robot ur5 -o gripper.yaml",
    )
    pay.add_argument(
        "source",
        nargs="?",
        action=PayloadSource,
        metavar="SOURCE",
        help="recording of the payload (still in several orientations, or moving), or udp://HOST:PORT for a live feed",
    )
    pay.add_argument("--calibration", required=True, help="the sensor's calibration file")
    add_robot_or_orientation(pay, note="; to estimate a small mount rotation: --estimate-mount")
    pay.add_argument("-o", "--output", required=True, help="tool file to write")
    pay.add_argument("--name", default="payload", help="name of the payload (default: payload)")
    pay.add_argument(
        "--estimate-mount", dest="mount", action="store_true", help="also estimate a small rotation of the sensor mount (beyond --mount's)"
    )
    pay.add_argument(
        "--motion",
        nargs="?",
        action=PayloadMotion,
        default="auto",
        metavar="{auto,still,moving}",
        help="still poses, or a continuous motion (the inertia too, physically consistent); default auto: decided from the "
        "data, and said (a bare --motion, the flag of the release before: moving)",
    )
    pay.add_argument(
        "--listen", type=add_address, metavar="HOST:PORT", help="the release before's live source: now the SOURCE udp://HOST:PORT"
    )
    pay.add_argument(
        "--seconds", type=float, help="with a live SOURCE: end after this many seconds of motion (default: the sender's end or Ctrl-C)"
    )
    pay.add_argument(
        "--idle-timeout",
        dest="idle_timeout_s",
        type=float,
        default=IDLE_TIMEOUT_S,
        help=f"with a live SOURCE: the longest wait for a datagram in s; none at all is a timeout (default {IDLE_TIMEOUT_S:g})",
    )
    pay.add_argument(
        "--min-spread",
        dest="min_spread_deg",
        type=float,
        default=MIN_SPREAD_DEG,
        help=f"smallest RMS spread of the gravity directions about each of two axes, in deg (default {MIN_SPREAD_DEG:g})",
    )
    pay.add_argument("--pipeline", default="pipeline", help="pipeline configuration (filter thresholds)")


def add_export(commands) -> None:
    """``export``: a calibration as constants for firmware, ROS 2 or an ATI file."""
    exp = add_command(
        commands,
        "export",
        "export a calibration as a C header, JSON, ROS 2 parameters or an ATI file",
        "c-header: C and D as arrays and an inline wrench function for firmware; json: C, C_bar, D, quality, "
        "provenance; ros2: ros2_controllers' force_torque_sensor_broadcaster parameters (its offset, added to the "
        "reading, and multiplier) with control_toolbox's GravityCompensationWrench filter for a payload; ati: C as the "
        "UserAxis rows of an ATI calibration file (N and N-m per channel unit).",
        "fts-calib export --format c-header --calibration calibration.yaml -o fts_calib.h\n"
        "  fts-calib export --format ros2 --calibration calibration.yaml --payload paper_tool --configuration A -o ft.yaml\n"
        "  fts-calib export --format ati --calibration calibration.yaml --sensor FT12345.cal -o FT12345_insitu.cal",
    )
    exp.add_argument("--format", dest="fmt", required=True, choices=["c-header", "json", "ros2", "ati"], help="what to write")
    exp.add_argument("--calibration", required=True, help="calibration file: fts-calib YAML or an ATI .cal")
    exp.add_argument("--sensor", default="sensor", help="sensor configuration or ATI .cal: the full scale an ati file states as max")
    exp.add_argument("-o", "--output", required=True, help="file to write ('-': standard output; a device or FIFO is written in place)")
    exp.add_argument("--name", default="fts_calib", help="prefix of the C identifiers (default fts_calib)")
    exp.add_argument("--payload", help="tool file of the payload (ros2); its gravity is the one exported")
    exp.add_argument("--configuration", help="configuration of the payload's tool file (default: the first)")
    exp.add_argument("--sensor-frame", default="ft_sensor", help="TF frame of the sensor (ros2, default ft_sensor)")
    exp.add_argument("--world-frame", default="world", help="TF frame with z up (ros2, default world)")


def _robot_and_tool(parser: argparse.ArgumentParser, pipeline: bool = True, tool_required: bool = True, orientations: str = "") -> None:
    if orientations:  # the recording or feed (this text) may give the sensor's orientation instead of joints
        add_robot_or_orientation(parser, orientations)
    else:
        parser.add_argument("--robot", required=True, help="robot definition: a shipped name (ur5) or a YAML path")
    if tool_required:
        parser.add_argument(
            "--tool", required=True, help="the calibration tool mounted (required): a shipped name (paper_tool) or a YAML path"
        )
    else:
        parser.add_argument("--tool", default="paper_tool", help="tool file: a shipped name or a YAML path (default: paper_tool)")
    if pipeline:
        parser.add_argument("--pipeline", default="pipeline", help="pipeline configuration: filter thresholds, live settings")


def _add_demo(commands) -> None:
    demo = add_command(
        commands,
        "demo",
        "the whole loop in simulation on the built-in UR5, with plots",
        "Plan the sweeps, simulate the recording (true C = Table 1 of the paper), calibrate with the quasi-static "
        "filter, follow C_bar_11 sample by sample (paper Fig. 7) and validate on another motion with another tool; "
        "print the results beside the truth and the targets, and write everything with PNG plots into one folder.",
        "fts-calib demo --out out/\n  fts-calib demo --drift --out out_drift/   # offsets that move, calibrated right",
    )
    demo.add_argument("--out", default="out", help="folder for the results (default: out/)")
    demo.add_argument("--seed", type=int, default=0, help="seed of the sensor noise and the validation motion (default: 0)")
    demo.add_argument("--quick", action="store_true", help="a smaller run: 3 levels x 4 stops at 100 Hz")
    add_drift_demo(demo)


def _add_robots(commands) -> None:
    robots = add_command(
        commands,
        "robots",
        "list the shipped robots, or show one",
        "Without NAME: the shipped robot definitions. With NAME (a shipped name or a YAML path): its joints, "
        "limits, frames and sensor mount.",
        "fts-calib robots ur5",
    )
    robots.add_argument("name", nargs="?", help="shipped robot name (e.g. ur5) or path to a robot YAML file")


def _add_trajectory(commands) -> None:
    traj = add_command(
        commands,
        "trajectory",
        "plan and check calibration sweeps for a robot and a tool",
        "Plan jerk-limited sweeps of the last two joints (ruckig), once per tool configuration; check limits, "
        "clearance and the predicted excitation before anything moves; write one CSV per configuration, plan.yaml "
        "and plan.png, with the predicted accuracy budget (strain noise, tool tolerance, encoders, stream timing, mount) "
        "in % of full scale. By default the raster is the shortest whose budget meets --target-error. Exits 1 when a "
        "check fails (the CSVs are then not written).",
        "fts-calib trajectory --robot ur5 --tool paper_tool -o out/trajectories --rate 500 --target-error 0.05",
    )
    _robot_and_tool(traj)
    traj.add_argument("-o", "--out", required=True, help="output folder")
    traj.add_argument("--rate", dest="rate_hz", type=float, default=500.0, help="sample rate of the files in Hz (default: 500)")
    traj.add_argument(
        "--target-error",
        dest="target_error_percent",
        type=float,
        help="size the plan: the shortest raster whose predicted accuracy budget is within this on every axis, "
        "in %% of full scale (default: 0.05; with a fixed raster only compared)",
    )
    traj.add_argument("--levels", type=int, help="positions of the first sweep joint (fixes the raster; default: 4)")
    traj.add_argument("--stops", type=int, help="positions of the second sweep joint per level (fixes the raster; default: 6)")
    traj.add_argument("--dwell", dest="dwell_s", type=float, help="time still at each stop in s (fixes the raster; default: 0.5)")
    traj.add_argument(
        "--span", type=float, help="fraction of the second sweep joint's range the stops cover (fixes the raster; default: 1)"
    )
    traj.add_argument("--margin", type=float, default=0.02, help="distance kept from position limits in rad (default: 0.02)")
    traj.add_argument("--min-clearance", type=float, default=0.02, help="smallest distance allowed in m (default: 0.02)")
    traj.add_argument("--tool-radius", type=float, help="override the tool envelope's radius in m")
    traj.add_argument("--tool-length", type=float, help="override the tool envelope's length in m")
    traj.add_argument("--sensor", default="sensor", help="sensor configuration (nominal model for the excitation report)")
    traj.add_argument(
        "--noise",
        dest="noise_std",
        type=float,
        help="noise per channel for the excitation report, in the channels' raw unit (default: the sensor file's, else the pipeline's)",
    )
    add_return_pass(traj)
    traj.add_argument(
        "--motion",
        choices=("stop", "continuous", "smooth"),
        default="stop",
        help="stop: dwell at each stop (quasi-static samples); continuous: no dwell, every sample calibrates in the "
        "dynamic filter mode, the budget with its dynamic terms; smooth: continuous, every joint on a sinusoid ramped in and "
        "out at home, sized by --target-error (the raster options unused): the dynamic filter trusts most of its samples (default: stop)",
    )
    traj.add_argument(
        "--configurations",
        type=int,
        help="plan for the tool's first N configurations (1, 2, ...; continuous only): refused, naming what each number "
        "reaches, when the target is out of reach (default: all)",
    )
    traj.add_argument(
        "--inertia-tolerance",
        type=float,
        help="continuous: each inertia element known to this fraction of the largest principal moment "
        "(default: the pipeline's filter.inertia_tolerance)",
    )
    traj.add_argument(
        "--joint-noise", type=float, help="continuous: noise of the joint readings in rad (default: filter.joint_noise, auto: 1e-5)"
    )
    traj.add_argument(
        "--latency-uncertainty",
        dest="latency_uncertainty_s",
        type=float,
        help="continuous: standard deviation of the stream-latency estimate in s (default: filter.latency_uncertainty_s, auto: 1e-4)",
    )
    traj.add_argument(
        "--model",
        choices=("linear", "quadratic", "cubic"),
        default="linear",
        help="the sensor model the plan must determine: quadratic or cubic need loads of more masses and centres of mass "
        "than the paper's jig; when the tool's configurations cannot determine it, nothing is planned, the jig that would "
        "is named and written to OUT/suggested_tool.yaml, exit 9 (default: linear)",
    )
    traj.add_argument("--compress", action="store_true", help="write .csv.gz files")
    traj.add_argument("--no-plot", dest="plot", action="store_false", help="do not write plan.png")


def _add_calibrate(commands) -> None:
    cal = add_command(
        commands,
        "calibrate",
        "calibrate from a recording (CSV or ROS 2 bag)",
        "Read a recording (CSV: time, joints, strain_1..n, tool; or a ROS 2 bag of joint states and channels), "
        "keep the quasi-static samples, accumulate the least squares and write the calibration. Prints a progress bar, "
        "then a summary: samples kept and why the rest were dropped, rank, condition, residuals, standard errors, and "
        "the fit check: the residual of each axis in each tool configuration against the strain noise of the data. "
        "A poor fit is refused (exit 15, no file) with its likely cause (labels permuted, centre of mass in mm or cm, "
        "a mistyped mass, a collinear tool file). Then the measured accuracy budget (noise in the data, tool tolerance, "
        "encoders, timing, mount; in % of full scale and N or N·m) and the joint stream's latency from the moving samples "
        "(ms), both written into the file. Exits 1 when the data cannot determine C.",
        "fts-calib calibrate --robot ur5 --tool paper_tool recording.csv -o calibration.yaml\n"
        "  fts-calib calibrate --robot ur5 --tool paper_tool --filter dynamic sweep.csv   # moving samples calibrate too\n"
        "  fts-calib calibrate --robot ur5 --tool paper_tool run_bag/ -o calibration.yaml   # a ROS 2 bag (MCAP or sqlite3)\n"
        "  fts-calib calibrate --robot ur5 --tool paper_tool --sensor factory_sensor wrench_run.csv   # a 6-axis wrench, strain_1..6",
    )
    add_recording(cal, pose=True)
    _robot_and_tool(cal, orientations="the recording")
    add_sensor(cal)
    cal.add_argument("-o", "--output", default="calibration.yaml", help="calibration file to write (default: calibration.yaml)")
    cal.add_argument("--no-filter", dest="use_filter", action="store_false", help="keep every valid sample, moving or not (for comparison)")
    add_filter_mode(cal)
    cal.add_argument("--checkpoint", help="checkpoint file, written every few seconds")
    _resume_or_restart(cal, "continue from --checkpoint (it must be of this recording)")
    cal.add_argument("--joints-in-degrees", action="store_true", help="the joint columns are in degrees")
    _accept_poor_fit(cal)
    add_prior(cal)
    add_offsets(cal)
    add_report_option(cal, "the calibration, also when it is refused (the diagnosis first)")
    cal.add_argument("--quiet", action="store_true", help="no progress bar")


def _resume_or_restart(parser: argparse.ArgumentParser, resume_help: str) -> None:
    """--resume and --restart: what to do with an existing checkpoint (never overwritten silently)."""
    parser.add_argument("--resume", action="store_true", help=resume_help)
    parser.add_argument("--restart", action="store_true", help="start afresh, overwriting an existing checkpoint")


def _accept_poor_fit(parser: argparse.ArgumentParser) -> None:
    """--accept-poor-fit: write a calibration whose fit check is poor (calibrate, live)."""
    parser.add_argument(
        "--accept-poor-fit", action="store_true", help="write the calibration even when its fit check is poor (the file says so)"
    )


def _add_live(commands) -> None:
    live = add_command(
        commands,
        "live",
        "calibrate from live UDP feeds of joints and strains, or a UR arm (RTDE)",
        "Listen for the JSON datagrams of the live protocol (joints, strain, tool, end), pair the two streams, keep "
        "the quasi-static samples and show a status line; write the calibration on 'end' or Ctrl-C. Checkpoints "
        "every few seconds; --resume continues after a crash. With --ur HOST the joints come from a UR controller "
        "through RTDE (with --ur-wrench also the channels: the built-in sensor's wrench); --configuration names the "
        "tool configuration mounted, so that one run per configuration (--resume) needs no tool datagram.",
        "fts-calib live --robot ur5 --tool paper_tool --listen 127.0.0.1:5005 -o calibration.yaml\n"
        "  fts-calib live --robot ur5 --tool paper_tool --ur 192.168.1.10 --ur-wrench --sensor factory_sensor --configuration A -o ur.yaml"
        "\n"
        "  fts-calib live --tool paper_tool --listen 127.0.0.1:5005 -o calibration.yaml   # datagrams with R or quat, no joints",
    )
    _robot_and_tool(live, orientations="the feed")
    add_sensor(live)
    add_filter_mode(live)
    add_prior(live)
    live.add_argument(
        "--plan", help="plan.yaml of the sized trajectories being run: the status line shows the motion left and the next configuration"
    )
    live.add_argument(
        "--listen",
        type=add_address,
        default=("127.0.0.1", 5005),
        metavar="HOST:PORT",
        help="address to bind (default 127.0.0.1:5005, loopback); a network address is warned about; 0:PORT needs --listen-any",
    )
    live.add_argument(
        "--listen-any",
        action="store_true",
        help="bind every network interface on the --listen port (any host that reaches this one can feed the run; warned about)",
    )
    live.add_argument("-o", "--output", default="calibration.yaml", help="calibration file to write")
    live.add_argument("--checkpoint", help="checkpoint file (default: OUTPUT.checkpoint.json)")
    _resume_or_restart(live, "continue from the checkpoint")
    live.add_argument("--latency", dest="latency_s", type=float, help="how late the joint stamps are, in s (default: the pipeline's)")
    live.add_argument(
        "--max-gap", dest="max_gap_s", type=float, help="longest joint gap interpolated across, in s (default: the pipeline's)"
    )
    live.add_argument("--idle-timeout", dest="idle_timeout_s", type=float, help="stop after this many seconds without data")
    live.add_argument("--configuration", help="tool configuration mounted from the start (default: wait for a tool datagram)")
    add_ur(live)
    _accept_poor_fit(live)
    add_offsets(live)
    add_report_option(live, "the calibration, also when it is refused (the diagnosis first)")
    live.add_argument("--quiet", action="store_true", help="no status line")


def _add_replay(commands) -> None:
    rep = add_command(
        commands,
        "replay",
        "send a recording as the live protocol",
        "Send a recording's rows as live datagrams (joints, strain, tool, end), with options for a slower joint "
        "rate, added latency, loss and reordering, to test and show the live path without a robot.",
        "fts-calib replay recording.csv --to 127.0.0.1:5005 --speed 1.0",
    )
    add_recording(rep)
    rep.add_argument("--to", type=add_address, default=("127.0.0.1", 5005), metavar="HOST:PORT", help="address (default 127.0.0.1:5005)")
    rep.add_argument("--speed", type=float, default=1.0, help="time scale: 1 real time, 10 ten times faster, 0 no pacing")
    rep.add_argument("--joint-rate", dest="joint_rate_hz", type=float, help="joint messages per second (default: one per row)")
    rep.add_argument("--latency", dest="latency_s", type=float, default=0.0, help="joint stamps late by this many s (default 0)")
    rep.add_argument("--loss", type=float, default=0.0, help="fraction of joint and strain messages dropped (default 0)")
    rep.add_argument("--reorder", type=float, default=0.0, help="fraction of messages delayed by 1-5 places (default 0)")
    rep.add_argument("--seed", type=int, default=0, help="seed of loss and reordering (default 0)")


def _add_simulate(commands) -> None:
    sim = add_command(
        commands,
        "simulate",
        "simulate a recording from planned trajectories",
        "Play planned trajectories (one CSV per tool configuration) through the kinematics with the tool's full "
        "dynamic wrench (mass, centre of mass, inertia) and the simulated sensor of the sensor file (true C, offsets, "
        "noise, ADC quantization and rails, null content, drift, nonlinearity); write a recording in exactly the format a robot produces.",
        "fts-calib simulate --robot ur5 --tool paper_tool --trajectory out/trajectories -o recording.csv",
    )
    _robot_and_tool(sim, pipeline=False)
    sim.add_argument("--trajectory", required=True, help="folder of trajectory CSVs (one per configuration), or one file")
    sim.add_argument("-o", "--output", required=True, help="recording to write (.csv or .csv.gz); with --pose-files, a folder")
    sim.add_argument("--sensor", default="sensor", help="sensor configuration with a 'simulation' section (default: sensor)")
    sim.add_argument("--noise", dest="noise_std", type=float, help="noise per channel, raw units (default: the sensor file's)")
    sim.add_argument("--noiseless", action="store_true", help="no noise at all")
    sim.add_argument(
        "--drift", dest="drift_rate", type=float, help="offset drift of every bridge, raw units per s (default: the sensor file's)"
    )
    sim.add_argument("--seed", type=int, default=0, help="seed of the noise (default 0)")
    sim.add_argument("--tool-change", dest="tool_change_s", type=float, default=2.0, help="pause between configurations in s (default 2)")
    sim.add_argument("--static", dest="dynamic", action="store_false", help="the tool's static wrench only (no dynamics)")
    sim.add_argument(
        "--poses-only",
        action="store_true",
        help="record only the samples where the arm holds still at a stop: a static-pose recording (poses separated by gaps)",
    )
    sim.add_argument(
        "--pose-files",
        action="store_true",
        help="as --poses-only, but one file per pose: -o is then a folder that receives pose_01.csv, pose_02.csv, ..., "
        "each from time 0 (calibrate them with 'FOLDER/*.csv'); poses and seconds per pose: trajectory --levels --stops --dwell",
    )


def _add_validate(commands) -> None:
    val = add_command(
        commands,
        "validate",
        "compare measured and expected wrenches over a recording",
        "Over a recording made with another motion and another tool (the paper's third stage): the wrench measured "
        "with the calibration against the tool's wrench from the kinematics (moving tool, Newton-Euler; --static for "
        "its weight alone). Error per axis in N or N·m and in % of full scale; with two calibrations, the same "
        "between them (paper: Table 1 against Table 2); --plot writes Fx and its error (paper Figs 9-10). "
        "Exits 1 when an error exceeds --max-error, or when less than --min-coverage of the samples could be compared.",
        "fts-calib validate --calibration calibration.yaml --robot ur5 --tool validation_tool validation.csv --plot validation.png",
    )
    add_recording(val, pose=True)
    val.add_argument(
        "--calibration",
        dest="calibrations",
        action="append",
        required=True,
        metavar="CALIBRATION",
        help="calibration file: fts-calib YAML or an ATI .cal (give two to compare them)",
    )
    val.add_argument(
        "--reference",
        metavar="CALIBRATION",
        help="a reference calibration compared too, e.g. the sensor's factory ATI .cal (the same as a second --calibration)",
    )
    _robot_and_tool(val, pipeline=False, tool_required=False, orientations="the recording")
    val.add_argument("--sensor", default="sensor", help="sensor configuration or ATI .cal: its full scale (default: sensor)")
    val.add_argument("--full-scale-force", type=float, help="full scale of the forces in N (default: the sensor file's)")
    val.add_argument("--full-scale-moment", type=float, help="full scale of the moments in N·m (default: the sensor file's)")
    val.add_argument("--static", dest="dynamic", action="store_false", help="expect the tool's weight alone (no dynamics)")
    val.add_argument("--plot", dest="plot_path", type=plot_path, metavar="PNG", help="PNG (or .pdf, .svg) of Fx and its error")
    val.add_argument(
        "--json",
        dest="json_path",
        metavar="FILE",
        help='write the errors of the first calibration for scripts: {"axes": {"Fx": {"rms": ..., "max": ...}, ...}, "samples": N} '
        "(N, N·m)",
    )
    add_report_option(val, "the first calibration with this validation as its held-out error")
    val.add_argument(
        "--max-error", dest="max_error_percent", type=float, metavar="PERCENT", help="exit 1 when an error exceeds this %% of full scale"
    )
    val.add_argument(
        "--min-coverage",
        type=float,
        default=MIN_COVERAGE,
        metavar="SHARE",
        help=f"exit 1 when fewer than this share of the recording's samples could be compared (default {MIN_COVERAGE:g})",
    )


#: The sub-commands, in the order ``fts-calib --help`` lists them; ``NAME`` runs ``fts_calib.app.NAME.run``.
COMMANDS = {
    "demo": _add_demo,
    "robots": _add_robots,
    "trajectory": _add_trajectory,
    "calibrate": _add_calibrate,
    "live": _add_live,
    "replay": _add_replay,
    "simulate": _add_simulate,
    "validate": _add_validate,
    "report": lambda commands: add_report(commands, add_command),
    "tare": add_tare,
    "payload": add_payload,
    "export": add_export,
    "monitor": lambda commands: add_monitor(commands, add_command, add_address),
}


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``fts-calib`` with all its sub-commands."""
    from .._version import __version__

    # by number for the reader (EXIT_CODES is in the order errors are looked up)
    codes = "\n".join(f"  {int(entry.code):>3}  {entry.meaning}" for entry in sorted(EXIT_CODES, key=lambda entry: entry.code))
    parser = Parser(
        prog="fts-calib",
        description="In-situ calibration of six-axis strain-gauge force/torque sensors.",
        epilog=f"Run 'fts-calib COMMAND --help' for the options and an example of each command.\n\nexit codes:\n{codes}",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"fts-calib {__version__}")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND")
    for add in COMMANDS.values():
        add(commands)
    return parser

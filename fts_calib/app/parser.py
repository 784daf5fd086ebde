"""The argument parser of ``fts-calib``: each command's purpose, description and examples, and the options it takes, in groups.

A command takes the options declared in :mod:`fts_calib.app.options` (:data:`COMMAND_OPTIONS`):
at most :data:`~fts_calib.app.options.MAIN_OPTIONS` before the groups titled ``advanced: ...``, so
that its ``--help`` opens with what a person needs. A command may ask an option to be required,
give it its own default, or add a note to its help (:func:`use`); nothing else about an option
is said twice.

The parser class makes errors explain (a missing ``--tool`` names the shipped tools) and
opens each help with the purpose and an example; after the command line is read it stores
what old spellings stand for and warns, naming the new ones
(:func:`fts_calib.core.deprecation.apply_old_spellings`).

An option's destination is a parameter of ``fts_calib.app.NAME.run`` or a field of a dataclass
that ``run`` takes (:func:`fts_calib.app.cli.run_command`), with the same default: the command
line and Python take the same arguments (``tests/test_app.py`` checks it).
"""

from __future__ import annotations

import argparse
import textwrap
from dataclasses import dataclass, field, replace
from typing import Any

from ..core.deprecation import SOURCES_DEST, OldFlag, OldSpelling, add_old_flag, apply_old_spellings
from ..core.exceptions import ConfigError
from .exit_codes import EXIT_CODES
from .options import (
    DEFAULT_LISTEN,
    OPTIONS,
    ORIENTATION_HELP,
    PLOT_SUFFIXES,
    RECORDING_HELP,
    Number,
    Option,
    add_address,
    plot_path,
    udp_source,
)

__all__ = ["COMMANDS", "PLOT_SUFFIXES", "Parser", "add_address", "add_command", "build_parser", "plot_path"]


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

    def _get_values(self, action, arg_strings):
        """Argparse's, but ``--x=--`` gives the option the text ``--`` (argparse would drop it and store an empty list)."""
        if action.option_strings and action.nargs is None and arg_strings == ["--"]:
            value = self._get_value(action, "--")
            self._check_value(action, value)
            return value
        return super()._get_values(action, arg_strings)

    def _get_value(self, action, arg_string):
        """Argparse's; a numeric option's text through its checked converter (:class:`~fts_calib.app.options.Number`).

        Text that is not a number is a usage error (exit 2), a number the option cannot use (nan,
        inf) a :class:`ConfigError` (exit 3); both messages name the option.
        """
        if not isinstance(action.type, Number):
            return super()._get_value(action, arg_string)
        try:
            return action.type(arg_string)
        except argparse.ArgumentTypeError as error:
            raise argparse.ArgumentError(action, str(error)) from None
        except ConfigError as error:
            flag = max(action.option_strings, key=len, default=action.dest)
            raise ConfigError(flag, arg_string, error.expected, message=f"option {flag}: {error.reason}") from None

    def parse_known_args(self, args=None, namespace=None):
        """Argparse's, then what the old spellings given stand for is stored (and warned about)."""
        namespace, extras = super().parse_known_args(args, namespace)
        given = apply_old_spellings(namespace)
        if given:
            namespace.old_given = [*getattr(namespace, "old_given", []), *given]
        return namespace, extras

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


#: Each command's one-line purpose, its description and its examples (the first is shown first).
TEXTS: dict[str, tuple[str, str, str]] = {
    "demo": (
        "the whole loop in simulation on the built-in UR5, with plots",
        "Plan the sweeps, simulate the recording (true C = Table 1 of the paper), calibrate with the quasi-static "
        "filter, follow C_bar_11 sample by sample (paper Fig. 7) and validate on another motion with another tool; "
        "print the results beside the truth and the targets, and write everything with PNG plots into one folder.",
        "fts-calib demo -o out/\n  fts-calib demo --drift -o out_drift/   # offsets that move, calibrated right",
    ),
    "robots": (
        "list the shipped robots, or show one",
        "Without NAME: the shipped robot definitions. With NAME (a shipped name or a YAML path): its joints, "
        "limits, frames and sensor mount.",
        "fts-calib robots ur5",
    ),
    "trajectory": (
        "plan and check calibration sweeps for a robot and a tool",
        "Plan jerk-limited sweeps of the last two joints (ruckig), once per tool configuration; check limits, "
        "clearance and the predicted excitation before anything moves; write one CSV per configuration, plan.yaml "
        "and plan.png, with the predicted accuracy budget (strain noise, tool tolerance, encoders, stream timing, mount) "
        "in % of full scale. By default the raster is the shortest whose budget meets --target-error. Exits 1 when a "
        "check fails (the CSVs are then not written).",
        "fts-calib trajectory --robot ur5 --tool paper_tool -o out/trajectories --rate 500 --target-error 0.05",
    ),
    "calibrate": (
        "calibrate from a recording (CSV or ROS 2 bag) or a live feed (UDP, a UR arm)",
        "Read a recording (CSV: time, joints, strain_1..n, tool; or a ROS 2 bag of joint states and channels), "
        "keep the quasi-static samples (or, for a recording that moves without stops, the moving samples the dynamic "
        "filter trusts: --filter auto says which), accumulate the least squares and write the calibration. Prints a progress bar, "
        "then a summary: samples kept and why the rest were dropped, rank, condition, residuals, standard errors, and "
        "the fit check: the residual of each axis in each tool configuration against the strain noise of the data. "
        "A poor fit is refused (exit 15, no file) with its likely cause (labels permuted, centre of mass in mm or cm, "
        "a mistyped mass, a collinear tool file). Then the measured accuracy budget (noise in the data, tool tolerance, "
        "encoders, timing, mount; in % of full scale and N or N·m) and the joint stream's latency from the moving samples "
        "(ms), both written into the file. Exits 8 when the data cannot determine C (1 when a live run received no sample). "
        "A live source (udp://HOST:PORT: the JSON datagrams of the live protocol; ur://HOST: a UR controller through RTDE) "
        "is paired and filtered as it comes, with a status line; the calibration is written on the sender's 'end' or "
        "Ctrl-C, with checkpoints every few seconds (--resume continues after a crash).",
        "fts-calib calibrate --robot ur5 --tool paper_tool recording.csv -o calibration.yaml\n"
        "  fts-calib calibrate --robot ur5 --tool paper_tool run_bag/ -o calibration.yaml   # a ROS 2 bag (MCAP or sqlite3)\n"
        "  fts-calib calibrate --robot ur5 --tool paper_tool --sensor factory_sensor wrench_run.csv   # a 6-axis wrench, strain_1..6\n"
        "  fts-calib calibrate --robot ur5 --tool paper_tool udp://127.0.0.1:5005 -o calibration.yaml   # live datagrams\n"
        "  fts-calib calibrate --robot ur5 --tool paper_tool ur://192.168.1.10 --sensor factory_sensor --configuration A -o ur.yaml",
    ),
    "live": (
        "calibrate from live feeds: now 'calibrate udp://HOST:PORT' or 'calibrate ur://HOST' (kept for this release)",
        "The old spelling of calibrate with a live source, kept for this release with a warning: --listen HOST:PORT "
        "(default 127.0.0.1:5005) is the source udp://HOST:PORT, --ur HOST the source ur://HOST; every other option is "
        "calibrate's, and the run is calibrate's.",
        "fts-calib live --robot ur5 --tool paper_tool --listen 127.0.0.1:5005 -o calibration.yaml   # calibrate udp://127.0.0.1:5005",
    ),
    "record": (
        "record joints and raw channels on one clock (UR, UDP, a serial line, an ATI Net F/T)",
        "Read the joints (ur://HOST through RTDE, or the joint datagrams of udp://HOST:PORT) and the raw channels "
        "(serial://DEVICE?baud=115200&sep=,&channels=8: one line of integers per sample; netft://HOST: an ATI Net F/T "
        "box's counts over RDT; or the strain datagrams of udp://HOST:PORT), stamp every stream on arrival with this "
        "host's monotonic clock, pair them and write a recording (CSV) that calibrate reads; beside it FILE.streams.yaml "
        "gives each stream's rate, interval jitter, latency and clock offset. Progress per configuration on a status line; "
        "the sender's end, --seconds, --idle-timeout, a device that stops, Ctrl-C or SIGTERM end it, the recording whole.",
        "fts-calib record serial:///dev/ttyUSB0?baud=115200 udp://127.0.0.1:5005 --robot ur5 --configuration A -o a.csv\n"
        "  fts-calib record netft://192.168.1.1 ur://192.168.1.10 --robot ur5 --configuration B -o b.csv",
    ),
    "replay": (
        "send a recording as the live protocol",
        "Send a recording's rows as live datagrams (joints, strain, tool, end), with options for a slower joint "
        "rate, added latency, loss and reordering, to test and show the live path without a robot.",
        "fts-calib replay recording.csv --to 127.0.0.1:5005 --speed 1.0",
    ),
    "simulate": (
        "simulate a recording from planned trajectories",
        "Play planned trajectories (one CSV per tool configuration) through the kinematics with the tool's full "
        "dynamic wrench (mass, centre of mass, inertia) and the simulated sensor of the sensor file (true C, offsets, "
        "noise, ADC quantization and rails, null content, drift, nonlinearity); write a recording in exactly the format a robot produces.",
        "fts-calib simulate --robot ur5 --tool paper_tool --trajectory out/trajectories -o recording.csv",
    ),
    "validate": (
        "compare measured and expected wrenches over a recording",
        "Over a recording made with another motion and another tool (the paper's third stage): the wrench measured "
        "with the calibration against the tool's wrench from the kinematics (moving tool, Newton-Euler; --static for "
        "its weight alone). Error per axis in N or N·m and in % of full scale; with two calibrations, the same "
        "between them (paper: Table 1 against Table 2); --plot writes Fx and its error (paper Figs 9-10). "
        "Exits 1 when an error exceeds --max-error, or when less than --min-coverage of the samples could be compared.",
        "fts-calib validate --calibration calibration.yaml --robot ur5 --tool validation_tool validation.csv --plot validation.png",
    ),
    "report": (
        "write the one-page HTML report of a calibration, or compare two",
        "Build the self-contained HTML report of a calibration file afterwards: the verdict first (fit, accuracy budget "
        "against the target, held-out error, model), then the gravity directions reached, the residuals, the budget, "
        "the model selection, C with its standard errors, the offsets, what was skipped and the provenance. With the "
        "recording it was made from, the pictures of the samples are recomputed from it (robot and tool from the file's "
        "provenance unless given). With --against OLD.yaml: the change of every coefficient in standard errors and the "
        "wrench difference over the full-scale box, and whether the sensor changed beyond its uncertainty.",
        "fts-calib report calibration.yaml recording.csv -o report.html\n"
        "  fts-calib report new.yaml --against old.yaml -o change.html   # did the sensor change?",
    ),
    "tare": (
        "new offsets D for a calibration file, from a short still window",
        "Estimate the offsets D again with C_bar kept, from a recording or a live window (udp://HOST:PORT, --seconds long) "
        "with the sensor still, with nothing mounted or with a known tool configuration (then --robot gives its "
        "orientation, or without it the recording or feed gives the sensor's). The file keeps the previous offsets and "
        "when they were replaced.",
        "fts-calib tare --calibration calibration.yaml tare.csv\n"
        "  fts-calib tare --calibration calibration.yaml --tool paper_tool --configuration A still_A.csv   # qw,qx,qy,qz columns\n"
        "  fts-calib tare --calibration calibration.yaml udp://127.0.0.1:5005 --seconds 2   # a live window",
    ),
    "payload": (
        "identify an unknown payload: mass, centre of mass, offsets",
        "From a recording (or the live feed of udp://HOST:PORT, or a channel device with the joints' source) of the payload "
        "held still in orientations that tilt "
        "gravity about two axes: its mass, centre of mass (in the sensor frame) and the offsets, with standard errors, "
        "written as a tool file for gravity compensation. Judges the whole set (the spread of the gravity directions, "
        "the fit's conditioning) and refuses one that cannot determine the payload, saying what is missing. From a short "
        "continuous motion instead: the inertia too (physically consistent), the joint stream's latency estimated. "
        "Which of the two the data are is decided from them and said (--motion still or moving forces it); a live feed "
        "is collected until the sender's end, --seconds or Ctrl-C.",
        "fts-calib payload --calibration calibration.yaml --robot ur5 gripper.csv -o configs/gripper.yaml\n"
        "  fts-calib payload --calibration calibration.yaml gripper_tcp.csv --mount 0 0 0.785 -o gripper.yaml   # tcp_rx,tcp_ry,tcp_rz\n"
        "  fts-calib payload udp://127.0.0.1:5005 --seconds 10 --calibration calibration.yaml --robot ur5 -o gripper.yaml",
    ),
    "export": (
        "export a calibration as a C header, JSON, ROS 2 parameters or an ATI file",
        "c-header: C and D as arrays and an inline wrench function for firmware; json: C, C_bar, D, quality, "
        "provenance; ros2: ros2_controllers' force_torque_sensor_broadcaster parameters (its offset, added to the "
        "reading, and multiplier) with control_toolbox's GravityCompensationWrench filter for a payload; ati: C as the "
        "UserAxis rows of an ATI calibration file (N and N-m per channel unit). The format is the suffix of -o's "
        "(.h, .json, .yaml or .yml, .cal) unless --format says.",
        "fts-calib export --calibration calibration.yaml -o fts_calib.h\n"
        "  fts-calib export --calibration calibration.yaml --payload paper_tool --configuration A -o ft.yaml   # ROS 2\n"
        "  fts-calib export --calibration calibration.yaml --sensor FT12345.cal -o FT12345_insitu.cal",
    ),
    "monitor": (
        "watch the sensor's health over a recording or a live feed: faulty bridges, named",
        "With the parity model the calibration learnt (the channels' combinations that carry no load, docs/health.md): "
        "a bridge whose gain changed, a jump, a frozen channel, a channel at its rail or beyond any load's reading; "
        "each with its time and the channel it points to. A live feed (udp://HOST:PORT) is watched until the sender's "
        "end or Ctrl-C. Exits 1 when a fault is found.",
        "fts-calib monitor --calibration calibration.yaml service.csv --json health.json\n"
        "  fts-calib monitor --calibration calibration.yaml udp://127.0.0.1:5005   # a live feed",
    ),
}


_LISTEN = OldFlag("--listen", "the source {value}", to=udp_source, type=add_address, metavar="HOST:PORT", example=("HOST", "PORT"))

# --- the options of each command, in groups --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Use:
    """An option as a command takes it: required, with its own default or a note added to its help."""

    option: Option
    note: str = ""
    changes: dict[str, Any] = field(default_factory=dict)

    def resolved(self) -> Option:
        """The option with this command's changes and note."""
        option = replace(self.option, **self.changes) if self.changes else self.option
        return replace(option, help=f"{option.help}{self.note}") if self.note else option


def use(name: str, note: str = "", **changes: Any) -> Use:
    """Option ``name`` (:data:`OPTIONS`) in a command, with ``changes`` (required, default, choices, nargs, help) and a note."""
    return Use(OPTIONS[name], note, changes)


def _uses(*items: str | Use) -> list[Use]:
    return [item if isinstance(item, Use) else use(item) for item in items]


#: Without --robot, what gives the orientation (the note of --robot where it is optional).
_ORIENTATION = f"; without it the source gives the sensor's orientation ({ORIENTATION_HELP})"
_BAGS = (
    "advanced: ROS 2 bags (topic names; docs/formats.md, ROS 2 bags)",
    _uses(*(f"{k}-topic" for k in ("joints", "pose", "channels", "configuration")), "joint-stamps"),
)
_RECORDINGS = use("names", help=RECORDING_HELP, metavar="RECORDING")
_LIVE_SOURCE = use(
    "names",
    nargs="*",
    help="recording with the sensor still (CSV, CSV.gz or a ROS 2 bag), or a live feed udp://HOST:PORT (read for --seconds)",
)
_TOOL_REQUIRED = use("tool", " (required: a wrong tool gives a wrong calibration)", required=True)

#: fts_calib.payload.samples.IDLE_TIMEOUT_S [s], written here: importing it would load the
#: kinematics into the parser (tests/test_app.py checks the two defaults agree).
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
            if getattr(namespace, SOURCES_DEST, None) is not None:
                parser.error(f"argument --motion: invalid choice: {values!r} (choose from {', '.join(MOTIONS)})")
            setattr(namespace, SOURCES_DEST, values)
            values = None
        setattr(namespace, self.dest, True if values is None else values)


class PayloadSource(argparse.Action):
    """``payload``'s SOURCE: kept when a bare ``--motion`` took it already; two are refused (a device and its joints excepted)."""

    def __call__(self, parser, namespace, values, option_string=None):
        """Store the SOURCE unless ``--motion`` stored it (two sources: an error, unless both are given here: checked later)."""
        given = getattr(namespace, self.dest, None)
        items = [values] if isinstance(values, str) else list(values or [])
        if not items or items == [given]:
            return
        if given is not None:
            parser.error(f"two sources, {given} and {' '.join(items)}: give one (--motion takes {', '.join(MOTIONS)})")
        setattr(namespace, self.dest, items[0] if len(items) == 1 else items)


#: The groups of each command: (title, options), the advanced ones last.
COMMAND_OPTIONS: dict[str, list[tuple[str, list[Use]]]] = {
    "demo": [
        ("output", _uses(use("output", " (a folder; default: out)", default="out"), "seed", "quick", "drift")),
    ],
    "robots": [
        ("robot", [use("names", help="shipped robot name (e.g. ur5) or path to a robot YAML file", nargs="?", metavar="NAME", dest="name")])
    ],
    "trajectory": [
        ("setup", [use("robot", required=True), use("tool", required=True)]),
        ("output", [use("output", ": a folder (one CSV per configuration, plan.yaml, plan.png)", required=True)]),
        (
            "plan",
            _uses(
                "motion",
                use(
                    "target-error",
                    help="size the plan: the shortest raster whose predicted accuracy budget is within this on every axis, "
                    "in %% of full scale (default: 0.05; with a fixed raster only compared)",
                ),
                use("rate", help="sample rate of the trajectory files in Hz (default: 500)", default=500.0),
            ),
        ),
        (
            "advanced: setup",
            _uses(
                use("sensor", " (here: its nominal model for the excitation report)"),
                "pipeline",
                use(
                    "model",
                    " (here: the model the plan must determine: quadratic or cubic need loads of more masses and centres of mass "
                    "than the paper's jig; when the tool's configurations cannot determine it, nothing is planned, the jig that "
                    "would is named and written to OUTPUT/suggested_tool.yaml, exit 9; default: linear)",
                    choices=("linear", "quadratic", "cubic"),
                ),
            ),
        ),
        ("advanced: raster", _uses("validation", "levels", "stops", "dwell", "span", "return-pass", "configurations")),
        ("advanced: checks", _uses("margin", "min-clearance", "tool-radius", "tool-length")),
        (
            "advanced: the predicted budget",
            _uses(
                use("noise", " (here: for the excitation report; else the pipeline's design.noise_std)"),
                "joint-noise",
                "latency-uncertainty",
                "inertia-tolerance",
            ),
        ),
        ("advanced: files", _uses("compress", "no-plot")),
    ],
    "calibrate": [
        ("source", [use("names")]),
        ("setup", [use("robot", _ORIENTATION), _TOOL_REQUIRED, use("sensor")]),
        (
            "output",
            [
                use("output", ": the calibration file (default: calibration.yaml)", default="calibration.yaml"),
                use("report", " of the calibration, also when it is refused (the diagnosis first)"),
            ],
        ),
        ("filter", _uses("filter")),
        ("advanced: setup", _uses("pipeline", "mount", "joint-unit")),
        (
            "advanced: model",
            _uses(
                "model",
                "offsets",
                "prior",
                "prior-weight",
                "accept-poor-fit",
                use(
                    "target-error",
                    help="the accuracy target the plan was sized to (trajectory --target-error), in %% of full scale: recorded "
                    "in the calibration file, the target its report, validate --report and report judge the budget against "
                    "(default: 0.05)",
                ),
            ),
        ),
        (
            "advanced: checkpoint",
            _uses(
                "checkpoint",
                "resume",
                "restart",
                use(
                    "quiet",
                    help="a recording: print the verdict and the file written, no progress bar or summary; a live source: no status line",
                ),
            ),
        ),
        (
            "advanced: live sources (udp://, ur://)",
            _uses(
                use("configuration", " (default: wait for a tool datagram)"),
                "plan",
                "listen-any",
                "ur-wrench",
                "ur-timeout",
                "idle-timeout",
                use("latency", " (default: the pipeline's)"),
                "max-gap",
            ),
        ),
        _BAGS,
    ],
    "replay": [
        ("source", [_RECORDINGS]),
        (
            "feed",
            _uses("to", "speed", "joint-rate", use("latency", " (made so late; default 0)", default=0.0), "loss", "reorder"),
        ),
        ("advanced: seed", _uses("seed")),
        (_BAGS[0], _uses(*(f"{k}-topic" for k in ("joints", "channels", "configuration")), "joint-stamps")),
    ],
    "simulate": [
        ("setup", [use("robot", required=True), use("tool", required=True), use("sensor", " (with a 'simulation' section)")]),
        ("input", _uses("trajectory")),
        ("output", [use("output", ": the recording (.csv or .csv.gz); with --pose-files, a folder", required=True)]),
        ("noise", _uses("seed")),
        ("advanced: the simulated sensor", _uses("noise", "noiseless", "drift-rate", use("static", " (simulated)"))),
        ("advanced: the recording", _uses("tool-change", "poses-only", "pose-files")),
    ],
    "validate": [
        ("source", [_RECORDINGS]),
        ("setup", [use("robot", " (default: the calibration's)" + _ORIENTATION), use("tool", " (default: the calibration's)")]),
        (
            "input",
            [
                use(
                    "calibration",
                    " (give two to compare them)",
                    dest="calibrations",
                    action="append",
                    metavar="CALIBRATION",
                    help="calibration file: fts-calib YAML or an ATI .cal",
                )
            ],
        ),
        (
            "output",
            [
                use(
                    "json",
                    ': the errors of the first calibration: {"axes": {"Fx": {"rms": ..., "max": ...}, ...}, "samples": N} (N, N·m)',
                ),
                use("plot"),
                use("report", " of the first calibration with this validation as its held-out error"),
            ],
        ),
        (
            "advanced: setup",
            _uses(use("sensor", " (here: its full scale)"), "mount", "static", "full-scale-force", "full-scale-moment", "reference"),
        ),
        ("advanced: pass or fail", _uses("max-error", "min-coverage")),
        _BAGS,
    ],
    "report": [
        (
            "input",
            [
                use("calibration", help="calibration file (fts-calib YAML)", required=False, metavar="CALIBRATION", flags=()),
                use(
                    "names",
                    help="the recording it was made from (CSV or ROS 2 bag), optional",
                    nargs="?",
                    metavar="RECORDING",
                    dest="recording",
                ),
                use("against"),
            ],
        ),
        ("output", [use("output", ": the HTML file", required=True, metavar="FILE.html")]),
        (
            "setup",
            [
                use("robot", " for the recording (default: the calibration's provenance)"),
                use("tool", " (default: the calibration's provenance)"),
                use("target-error"),
            ],
        ),
        ("advanced: setup", [use("sensor", " (here: channel limits and full scale)"), use("pipeline")]),
    ],
    "tare": [
        ("source", [_LIVE_SOURCE]),
        ("input", [use("calibration", help="calibration file to update")]),
        ("output", [use("output", ": the calibration updated (default: the --calibration file, in place)")]),
        (
            "setup",
            [
                use("robot", " (used with a mounted configuration; default: the calibration's)" + _ORIENTATION),
                use("tool", " (default: the calibration's)"),
                use("configuration", " (default: nothing mounted)"),
            ],
        ),
        ("advanced: setup", [use("seconds", " (default 2)"), use("pipeline"), use("mount")]),
    ],
    "payload": [
        (
            "source",
            [
                use(
                    "names",
                    nargs="*",
                    action=PayloadSource,
                    help="recording of the payload (still in several orientations, or moving), or udp://HOST:PORT for a live feed, "
                    "or a channel device (serial://..., netft://HOST) with the joints' source (udp://HOST:PORT or ur://HOST)",
                )
            ],
        ),
        ("input", [use("calibration", help="the sensor's calibration file")]),
        ("output", [use("output", ": the payload's tool file (for gravity compensation)", required=True)]),
        (
            "setup",
            [
                use("robot", _ORIENTATION),
                use("mount", "; to estimate a small mount rotation: --estimate-mount"),
                use(
                    "motion",
                    action=PayloadMotion,
                    nargs="?",
                    choices=None,
                    default="auto",
                    metavar="{auto,still,moving}",
                    help="still poses, or a continuous motion (the inertia too, physically consistent); default auto: decided "
                    "from the data, and said (a bare --motion, the flag of the release before: moving)",
                ),
            ],
        ),
        (
            "advanced: the fit",
            _uses("estimate-mount", "min-spread", use("name", help="name of the payload in the tool file", default="payload"), "pipeline"),
        ),
        (
            "advanced: live sources (udp://)",
            [
                use("seconds", " of motion (default: to the sender's end or Ctrl-C)"),
                use(
                    "idle-timeout",
                    help=f"with a live source: the longest wait for a datagram in s; none at all is a timeout (default {IDLE_TIMEOUT_S:g})",
                    default=IDLE_TIMEOUT_S,
                ),
            ],
        ),
    ],
    "export": [
        ("input", [use("calibration", help="calibration file: fts-calib YAML or an ATI .cal")]),
        (
            "output",
            [
                use("output", ": the file ('-': standard output; a device or FIFO is written in place)", required=True),
                use("format"),
            ],
        ),
        (
            "payload (ros2)",
            [use("payload"), use("configuration", " (the payload's; default: its first)")],
        ),
        ("sensor (ati)", [use("sensor", " (here: the full scale an ATI file states as max)")]),
        ("advanced: names", _uses("name", "sensor-frame", "world-frame")),
    ],
    "monitor": [
        (
            "source",
            [
                use(
                    "names",
                    nargs="*",
                    help="recording (CSV or CSV.gz) or ROS 2 bags of the sensor in service, or a live feed udp://HOST:PORT "
                    "(its strain datagrams)",
                )
            ],
        ),
        ("input", [use("calibration", help="calibration file with its health section (fts-calib YAML)")]),
        ("output", [use("json", ': the events: {"events": [{"time_s", "kind", "channel", "detail"}]}')]),
        (
            "offsets that stay right (a known payload and the joints)",
            [
                use("robot", ": the payload's wrench from the joints; the offset tracked without contact"),
                use("tool", " (the payload; default: the calibration's)"),
                use("configuration", " (default: each sample's, the recording's tool column)"),
                use("auto-tare"),
            ],
        ),
        ("advanced: health", _uses("false-alarms", "rate", use("sensor", " (here: its full scale)"), "tare-threshold")),
        ("advanced: live sources (udp://)", _uses("idle-timeout", "listen-any", "quiet")),
    ],
}

#: ``live``: calibrate's options without SOURCE, its sources given the old way.
COMMAND_OPTIONS["record"] = [
    (
        "source",
        [
            use(
                "names",
                nargs="+",
                metavar="SOURCE",
                help="the channels (serial://DEVICE?baud=&sep=&channels=, netft://HOST, or udp://HOST:PORT) and the joints "
                "(ur://HOST, or udp://HOST:PORT)",
            )
        ],
    ),
    (
        "setup",
        [
            use("robot", required=True),
            use("configuration", " (default: the tool datagrams')"),
            use(
                "plan",
                help="the plan being followed (its plan.yaml, its folder, or a shipped plan by name: ur5): its configurations "
                "in order, each for the plan's duration; on a terminal each tool change is asked for (mount it, press Enter), "
                "else they follow one another unasked; the run ends after the last (not with --configuration)",
            ),
        ],
    ),
    ("output", [use("output", ": the recording (CSV or CSV.gz; its streams' figures beside it, FILE.streams.yaml)", required=True)]),
    ("advanced: live sources", _uses("seconds", "idle-timeout", "listen-any", "ur-timeout", "quiet")),
]
COMMAND_OPTIONS["live"] = [group for group in COMMAND_OPTIONS["calibrate"] if group[0] != "source"]
#: The old options of the commands that had them: (command, old spellings of the source).
OLD_SOURCES = {
    "tare": (_LISTEN,),
    "payload": (_LISTEN,),
    "monitor": (replace(_LISTEN, nargs="?", const=DEFAULT_LISTEN),),
    "live": (
        replace(_LISTEN, of_command=True),
        OldFlag("--ur", "the source {value}", to=lambda host: f"ur://{host}", metavar="HOST", of_command=True, example="HOST"),
    ),
}


def add_options(parser: argparse.ArgumentParser, command: str) -> None:
    """Add ``command``'s options (:data:`COMMAND_OPTIONS`) to its parser, group by group, and its old spellings of a source."""
    for title, uses in COMMAND_OPTIONS[command]:
        group = parser.add_argument_group(title)
        for item in uses:
            item.resolved().add_to(group)
    for spelling in OLD_SOURCES.get(command, ()):
        add_old_flag(parser, spelling, SOURCES_DEST)
    if command == "live":
        parser.set_defaults(names=[udp_source(DEFAULT_LISTEN)])


def old_spellings(parser: argparse.ArgumentParser) -> dict[str, str]:
    """The old flags a parser still reads, each with the new spelling in words."""
    found = {}
    for action in parser._actions:
        if isinstance(action, OldSpelling):
            for flag, spelling in action.old.items():
                found[flag] = spelling.described()
    return found


def _maker(name: str):
    def make(commands) -> None:
        add_options(add_command(commands, name, *TEXTS[name]), name)

    return make


#: The sub-commands, in the order ``fts-calib --help`` lists them; ``NAME`` runs ``fts_calib.app.NAME.run`` (``live``: calibrate's).
COMMANDS = {
    name: _maker(name)
    for name in (
        *("demo", "robots", "trajectory", "calibrate", "live", "record", "replay", "simulate"),
        *("validate", "report", "tare", "payload", "export", "monitor"),
    )
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

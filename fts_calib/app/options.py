"""Every option of the command line, declared once, and the groups each command shows them in.

An option (:class:`Option`) is its flags, its destination, its meaning with units, its type and
default: :data:`OPTIONS` holds each once, and a flag has one meaning across the commands
(``--sensor`` is the sensor file whatever the command reads of it, ``--tool`` the tool mounted
during the recording, ``-o/--output`` what the command writes, ``--target-error`` the accuracy
target), grouped below by what it names: the source, the setup (robot, tool, sensor, pipeline,
models), the outputs, then each command's own. Which options a command takes, and in which
groups of its ``--help``, is the parser's (:data:`fts_calib.app.parser.COMMAND_OPTIONS`).

An option's destination is the name it takes in Python: a parameter of the command's ``run``
or a field of one of the dataclasses ``run`` takes (:class:`fts_calib.app.setup.Setup` and the
others: :func:`fts_calib.app.cli.run_command` fills them by field name).

Old spellings (:class:`~fts_calib.core.deprecation.OldFlag`) keep working for one release: the
option is given as it was, the value it stands for is stored, and a warning names the new
spelling (:mod:`fts_calib.core.deprecation`, the one mechanism of every old name).
"""

from __future__ import annotations

import argparse
import builtins
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..core.deprecation import OldFlag, OldSpelling, add_old_flag
from ..core.exceptions import ConfigError
from ..filters.settings import FILTER_CHOICES
from ..model.features import MODEL_SETTINGS
from ..model.offset_models import OFFSET_SETTINGS
from ..sources.bag import JOINT_STAMPS, BagTopics
from ..sources.source import MIN_COVERAGE
from ..sources.ur import TIMEOUT_S

#: Options a command shows before its advanced groups.
MAIN_OPTIONS = 6
#: The title every advanced group starts with.
ADVANCED = "advanced"
#: Image formats a plot may be written in (matplotlib's Agg backend; no suffix: PNG).
PLOT_SUFFIXES = (".png", ".pdf", ".svg", ".jpg", ".jpeg", ".eps", ".ps", ".tif", ".tiff", ".webp")
#: The formats of ``export`` and the suffixes that name them (the default of ``--format``).
EXPORT_FORMATS = {"c-header": (".h",), "json": (".json",), "ros2": (".yaml", ".yml"), "ati": (".cal",)}
#: The joint units of ``--joint-unit``: auto detects degrees from the data.
JOINT_UNITS = ("auto", "rad", "deg")
#: The live address a source ``udp://`` stands for when ``live`` names none (its old default).
DEFAULT_LISTEN = ("127.0.0.1", 5005)

#: Help text of a recording.
RECORDING_HELP = (
    "recording CSV (or .csv.gz); several CSVs read as one, in order (e.g. one per static pose: a.csv b.csv, or a quoted "
    "pattern 'poses/*.csv', expanded in natural order); or ROS 2 bags: RUN.mcap, RUN.db3 or a bag folder; "
    "one bag per tool configuration as BAG:CONFIGURATION (e.g. a.mcap:A b.mcap:B)"
)
#: What a feed gives instead of joints when there is no ``--robot`` (fts_calib.robot.orientation).
ORIENTATION_HELP = (
    "CSV columns qw,qx,qy,qz or roll,pitch,yaw or tcp_rx,tcp_ry,tcp_rz; a bag's geometry_msgs/msg/PoseStamped topic; "
    'datagrams with an "R" or "quat" field; gravity -Z of the world'
)


# --- types of option values ------------------------------------------------------------------------------------------


def plot_path(text: str) -> str:
    """The type of a plot option: its suffix must name an image format (checked before the job, not by matplotlib after it)."""
    suffix = Path(text).suffix.lower()
    if suffix and suffix not in PLOT_SUFFIXES:
        raise argparse.ArgumentTypeError(f"{text!r} is not an image file: expected a name ending in {', '.join(PLOT_SUFFIXES)}")
    return text


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


@dataclass(frozen=True)
class Number:
    """The checked converter of every numeric option (``_declare`` gives it to each option declared ``type=float`` or ``int``).

    Text that is not a number (``--``, ``abc``, an empty value) raises argparse's error type: a usage
    error, exit 2, ``argument --x: expected a number, got '--'``. A number no option can use (nan,
    inf, or 1e999, which overflows to inf) raises :class:`ConfigError` (exit 3), which the parser
    re-raises naming the option (:meth:`fts_calib.app.parser.Parser._get_value`).

    Attributes:
        kind: ``float`` or ``int``.
    """

    kind: Callable[[str], float | int] = float

    def __call__(self, text: str) -> float | int:
        """The value of ``text``, finite."""
        try:
            value = self.kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {'an integer' if self.kind is int else 'a number'}, got {text!r}") from None
        if not math.isfinite(value):
            raise ConfigError("value", text, "a finite number", reason=f"expected a finite number, got {text!r}")
        return value


def udp_source(address: tuple[str, int]) -> str:
    """The source ``udp://HOST:PORT`` of an address (host, port)."""
    return f"udp://{address[0]}:{address[1]}"


# --- the declarations ------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Option:
    """One option of the command line (or a positional argument: no flags).

    Attributes:
        flags: Its flags, e.g. ``("-o", "--output")``; empty for a positional argument.
        dest: The name it takes in Python (a ``run`` parameter or a field of what ``run`` takes).
        help: What it means, with units and its default in words.
        default: Its value when not given.
        type: The type of its value.
        choices: The values it takes.
        metavar: Its value's name in the help.
        action: Argparse's action (``store_true``, ``store_false``, ``append``, or an Action class); None: store a value.
        nargs: Argparse's nargs.
        const: The value of a bare flag with nargs '?'.
        required: Must be given.
        old: Its old spellings (:class:`~fts_calib.core.deprecation.OldFlag`).
    """

    flags: tuple[str, ...]
    dest: str
    help: str
    default: Any = None
    type: Callable[[str], Any] | None = None
    choices: Sequence[str] | None = None
    metavar: str | tuple[str, ...] | None = None
    action: str | builtins.type[argparse.Action] | None = None
    nargs: Any = None
    const: Any = None
    required: bool = False
    old: tuple[OldFlag, ...] = ()

    @property
    def name(self) -> str:
        """Its key in :data:`OPTIONS`: the long flag without dashes, or the destination of a positional."""
        longs = [f for f in self.flags if f.startswith("--")]
        return longs[0][2:] if longs else self.dest

    def add_to(self, group) -> argparse.Action:
        """Add it to an argparse parser or group, with its old spellings; returns its action."""
        kwargs: dict[str, Any] = {"help": self.help}
        for key in ("type", "choices", "metavar", "nargs", "const"):
            if getattr(self, key) is not None:
                kwargs[key] = getattr(self, key)
        if self.action is not None:
            kwargs["action"] = self.action
        elif self.old:  # a renamed option: its old flags reach this very action
            kwargs["action"], kwargs["old"] = OldSpelling, self.old
        if not self.flags:
            return group.add_argument(self.dest, **kwargs)
        kwargs["default"] = self.default
        if self.required:
            kwargs["required"] = True
        action = group.add_argument(*self.flags, dest=self.dest, **kwargs)
        for spelling in self.old:
            if self.action is None and spelling.renames:
                group._option_string_actions[spelling.flag] = action  # hidden from the help, read as the new flag
            else:
                add_old_flag(group, spelling, self.dest)
        return action


#: Every option, by name (:attr:`Option.name`).
OPTIONS: dict[str, Option] = {}


def _declare(*flags: str, dest: str, help: str, **kwargs: Any) -> Option:
    if kwargs.get("action") in ("store_true", "store_false"):  # a flag's value when not given
        kwargs.setdefault("default", kwargs["action"] == "store_false")
    if kwargs.get("type") in (float, int):  # every numeric option through the one checked converter
        kwargs["type"] = Number(kwargs["type"])
    option = Option(tuple(flags), dest, help, **kwargs)
    if option.name in OPTIONS:
        raise ValueError(f"option {option.name} declared twice")
    OPTIONS[option.name] = option
    return option


# the source: what the command reads ---------------------------------------------------------------------------------
_declare(
    dest="names",
    metavar="SOURCE",
    nargs="+",
    help=f"{RECORDING_HELP}; or a live feed: udp://HOST:PORT (the live protocol's datagrams; port 0: any free port), "
    "ur://HOST (a UR arm through RTDE: its joints, and its built-in sensor's wrench unless udp://HOST:PORT is given too for "
    "the strain datagrams)",
)
_declare(
    "--joint-unit",
    dest="joint_unit",
    choices=JOINT_UNITS,
    default="auto",
    help="unit of the recording's joint columns: auto (default: degrees when the readings pass a turn at speeds "
    "impossible in rad, said in the summary), rad or deg",
    old=(OldFlag("--joints-in-degrees", "--joint-unit deg", value="deg"),),
)
_declare(
    "--seconds",
    dest="window_s",
    type=float,
    metavar="SECONDS",
    help="with a live source: the length read, in s",
)
_declare(
    "--rate",
    dest="rate_hz",
    type=float,
    metavar="HZ",
    help="sample rate in Hz (default: measured from the time stamps of the source, and said)",
)
_declare(
    "--idle-timeout",
    dest="idle_timeout_s",
    type=float,
    metavar="SECONDS",
    help="with a live source: stop after this many seconds without data (default: wait)",
)
_declare(
    "--listen-any",
    dest="listen_any",
    action="store_true",
    help="let a udp:// source bind every network interface (0.0.0.0: any host that reaches this one can feed the run; warned about)",
)
_declare(
    "--ur-wrench",
    dest="ur_wrench",
    action="store_true",
    help="with ur://HOST and udp://HOST:PORT: the channels are the built-in sensor's raw wrench anyway (without udp:// "
    "they are; needs a wrench-6 --sensor, e.g. factory_sensor)",
)
_declare(
    "--ur-timeout",
    dest="ur_timeout_s",
    type=float,
    default=TIMEOUT_S,
    metavar="SECONDS",
    help=f"with ur://HOST: the longest wait for the controller's handshake, connection and first sample, in s (default "
    f"{TIMEOUT_S:g}; then exit 18)",
)
_TOPICS = BagTopics()
_declare("--joints-topic", dest="joints_topic", default=_TOPICS.joints, help=f"sensor_msgs/msg/JointState topic (default {_TOPICS.joints})")
_declare(
    "--pose-topic",
    dest="pose_topic",
    default=_TOPICS.pose,
    help=f"without --robot: geometry_msgs/msg/PoseStamped topic of the sensor's orientation, read instead of the joints "
    f"(default {_TOPICS.pose})",
)
_declare(
    "--channels-topic",
    dest="channels_topic",
    default=_TOPICS.channels,
    help=f"std_msgs/msg/Float64MultiArray or geometry_msgs/msg/WrenchStamped topic (default {_TOPICS.channels})",
)
_declare(
    "--configuration-topic",
    dest="configuration_topic",
    default=_TOPICS.configuration,
    help=f"std_msgs/msg/String topic of the tool configuration (default {_TOPICS.configuration})",
)
_declare(
    "--joint-stamps",
    dest="joint_stamps",
    choices=JOINT_STAMPS,
    default=_TOPICS.joint_stamps,
    help="time of a joint message: its header stamp (default), or the bag's log time (a log of simulated time whose "
    "header stamps stay 0, or a joint driver on another clock)",
)

# the setup: the robot, the tool, the sensor, the pipeline --------------------------------------------------------------
_declare(
    "--robot",
    dest="robot_file",
    metavar="ROBOT",
    help="robot definition: a shipped name (ur5) or a YAML path",
)
_declare(
    "--mount",
    dest="mount_rpy",
    nargs=3,
    type=float,
    metavar=("R", "P", "Y"),
    help="without --robot: roll, pitch, yaw in rad from the frame whose orientation the source gives (e.g. the TCP of "
    "tcp_rx,tcp_ry,tcp_rz) to the sensor (default: 0 0 0)",
)
_declare(
    "--tool",
    dest="tool_file",
    metavar="TOOL",
    help="the tool mounted during the recording: a shipped name (paper_tool) or a YAML path",
)
_declare(
    "--configuration",
    dest="configuration",
    help="the configuration of the tool mounted throughout",
)
_declare(
    "--sensor",
    dest="sensor_file",
    metavar="SENSOR",
    default="sensor",
    help="the sensor file, whatever the command reads of it (channel layout, full scale, nominal model, simulation): a "
    "shipped name, a YAML path or an ATI .cal (default: sensor, the paper's 8 bridges; factory_sensor: a 6-axis wrench)",
)
_declare(
    "--pipeline",
    dest="pipeline_file",
    metavar="PIPELINE",
    default="pipeline",
    help="pipeline settings: filter thresholds, live settings; a shipped name or a YAML path (default: pipeline)",
)
_declare(
    "--filter",
    dest="filter_mode",
    choices=FILTER_CHOICES,
    help="sample filter: auto (default, from the pipeline file: quasi-static, or dynamic for a recording that moves "
    "without stops, said in the summary), quasi-static (still samples, the tool's weight), dynamic (every moving sample "
    "whose expected wrench is trusted, with the tool's Newton-Euler wrench: docs/method.md#dynamic-mode) or none (every "
    "valid sample, for comparison)",
    old=(OldFlag("--no-filter", "--filter none", value="none"),),
)
_declare(
    "--static",
    dest="dynamic",
    action="store_false",
    default=True,
    help="the tool's weight alone (no dynamics: the moving tool's Newton-Euler wrench by default)",
)
_declare(
    "--model",
    dest="model",
    choices=MODEL_SETTINGS,
    help="sensor model: auto (default, from the sensor file: the simplest whose held-out error is the best within its "
    "noise, chosen together with the offset model), linear (the paper's C), quadratic or cubic (products of the "
    "laid-out channels up to the degree)",
)
_declare(
    "--offsets",
    dest="offsets",
    choices=OFFSET_SETTINGS,
    help="offset model: auto (default, from the pipeline file: the simplest the data support, by held-out error, or by "
    "BIC with --model linear), constant (the paper), per-configuration (one D per tool configuration), drift "
    "(per-configuration plus time and temperature)",
)
_declare(
    "--prior",
    dest="prior_file",
    metavar="CALIBRATION",
    help="shrink C_bar toward this calibration (fts-calib YAML or the factory ATI .cal) when the excitation is weak",
)
_declare(
    "--prior-weight",
    dest="prior_weight",
    type=float,
    default=1.0,
    metavar="LAMBDA",
    help="weight of --prior relative to the data: 0 none, 1 as much as the data, 1e12 (the most): the prior (default: 1)",
)
_declare(
    "--latency",
    dest="latency_s",
    type=float,
    metavar="SECONDS",
    help="how late the joint stamps are behind the channels', in s",
)
_declare(
    "--max-gap",
    dest="max_gap_s",
    type=float,
    metavar="SECONDS",
    help="longest joint gap interpolated across, in s (default: the pipeline's)",
)
_declare(
    "--noise",
    dest="noise_std",
    type=float,
    help="noise per channel, in the channels' raw unit (default: the sensor file's)",
)
_declare(
    "--joint-noise",
    dest="joint_noise",
    type=float,
    help="continuous: noise of the joint readings in rad (default: filter.joint_noise, auto: 1e-5)",
)
_declare(
    "--latency-uncertainty",
    dest="latency_uncertainty_s",
    type=float,
    metavar="SECONDS",
    help="continuous: standard deviation of the stream-latency estimate in s (default: filter.latency_uncertainty_s, auto: 1e-4)",
)
_declare(
    "--inertia-tolerance",
    dest="inertia_tolerance",
    type=float,
    help="continuous: each inertia element known to this fraction of the largest principal moment "
    "(default: the pipeline's filter.inertia_tolerance)",
)
_declare("--tool-radius", dest="tool_radius", type=float, help="override the tool envelope's radius in m")
_declare("--tool-length", dest="tool_length", type=float, help="override the tool envelope's length in m")
_declare("--full-scale-force", dest="full_scale_force", type=float, help="full scale of the forces in N (default: the sensor file's)")
_declare("--full-scale-moment", dest="full_scale_moment", type=float, help="full scale of the moments in N·m (default: the sensor file's)")

# what the command writes ----------------------------------------------------------------------------------------------
_declare("-o", "--output", dest="output", help="what the command writes", old=(OldFlag("--out", "-o/--output {value}"),))
_declare(
    "--report",
    dest="report",
    metavar="FILE.html",
    help="write a self-contained HTML report (verdict first; readable on a phone, prints on A4)",
)
_declare(
    "--json",
    dest="json_path",
    metavar="FILE",
    help="write the results as JSON for scripts",
)
_declare("--plot", dest="plot_path", type=plot_path, metavar="PNG", help="PNG (or .pdf, .svg) of Fx and its error")
_declare("--checkpoint", dest="checkpoint", help="checkpoint file, written every few seconds (default: none; live: OUTPUT.checkpoint.json)")
_declare("--resume", dest="resume", action="store_true", help="continue from the checkpoint (it must be of this source)")
_declare("--restart", dest="restart", action="store_true", help="start afresh, overwriting an existing checkpoint")
_declare("--quiet", dest="quiet", action="store_true", help="no progress bar or status line")
_declare(
    "--target-error",
    dest="target_error_percent",
    type=float,
    metavar="PERCENT",
    help="accuracy target of the budget total, in %% of full scale (default: 0.05)",
    old=(OldFlag("--target", "--target-error {value}"),),
)
_declare(
    "--accept-poor-fit",
    dest="accept_poor_fit",
    action="store_true",
    help="write the calibration even when its fit check is poor (the file says so)",
)

# calibrations read -------------------------------------------------------------------------------------------------
_declare("--calibration", dest="calibration", required=True, help="calibration file: fts-calib YAML (or an ATI .cal where read only)")
_declare(
    "--reference",
    dest="reference",
    metavar="CALIBRATION",
    help="a reference calibration compared too, e.g. the sensor's factory ATI .cal (the same as a second --calibration)",
)
_declare(
    "--against",
    dest="against",
    metavar="OLD.yaml",
    help="an older calibration of the same sensor: write the comparison instead",
)
_declare(
    "--plan",
    dest="plan",
    help="plan.yaml of the sized trajectories being run (or its folder, or a shipped plan by name: ur5): the status line "
    "shows the motion left and the next configuration",
)

# live sources: old spellings of a SOURCE (live, tare, monitor) ------------------------------------------------------

# trajectory ---------------------------------------------------------------------------------------------------------
_declare(
    "--motion",
    dest="motion",
    choices=("stop", "continuous", "smooth", "payload"),
    default="stop",
    help="stop: dwell at each stop (quasi-static samples); continuous: no dwell, every sample calibrates in the "
    "dynamic filter mode, the budget with its dynamic terms; smooth: continuous, every joint on a sinusoid ramped in and "
    "out at home, sized by --target-error (the raster options unused): the dynamic filter trusts most of its samples; "
    "payload: the motion of 'payload --motion moving' for the --tool file's payload (the three last joints together, "
    "about 8 s), checked for limits and clearance, with the predicted standard errors of its mass, centre of mass and "
    "inertia (default: stop)",
)
_declare(
    "--levels",
    dest="levels",
    type=int,
    help="positions of the first sweep joint: fixes the raster (unfixed, it is sized to --target-error); when another option fixes it: 4",
)
_declare(
    "--stops",
    dest="stops",
    type=int,
    help="positions of the second sweep joint per level: fixes the raster (else sized); when another option fixes it: 6",
)
_declare(
    "--dwell",
    dest="dwell_s",
    type=float,
    metavar="SECONDS",
    help="time still at each stop in s: fixes the raster (else sized); when another option fixes it: 0.5",
)
_declare(
    "--span",
    dest="span",
    type=float,
    help="fraction of the second sweep joint's range the stops cover: fixes the raster (else sized); when another option fixes it: 1",
)
_declare(
    "--return-pass",
    dest="return_pass",
    action="store_true",
    help="visit the stops again in reverse order: drifting offsets become separable from the orientation "
    "(the drift model then costs no precision of C) for about twice the sweep time; fixes the raster",
)
_declare(
    "--validation",
    dest="validation",
    action="store_true",
    help="plan a validation motion for any tool (one configuration too): the raster (4 levels x 6 stops unless given), "
    "checked for limits and clearance, no rank or accuracy target (validate compares, it does not fit); plan.yaml says "
    "purpose: validation",
)
_declare(
    "--configurations",
    dest="configurations",
    type=int,
    help="plan for the tool's first N configurations (1, 2, ...; continuous only): refused, naming what each number "
    "reaches, when the target is out of reach (default: all)",
)
_declare("--margin", dest="margin", type=float, default=0.02, help="distance kept from position limits in rad (default: 0.02)")
_declare("--min-clearance", dest="min_clearance", type=float, default=0.02, help="smallest distance allowed in m (default: 0.02)")
_declare("--compress", dest="compress", action="store_true", help="write .csv.gz files")
_declare("--no-plot", dest="plot", action="store_false", default=True, help="do not write plan.png")

# simulate and demo -------------------------------------------------------------------------------------------------
_declare(
    "--trajectory",
    dest="trajectory",
    required=True,
    help="folder of trajectory CSVs (one per configuration), or one file; or a shipped plan by name (ur5, ur5/A.csv.gz)",
)
_declare("--seed", dest="seed", type=int, default=0, help="seed of the random numbers: noise, motion, losses (default 0)")
_declare("--noiseless", dest="noiseless", action="store_true", help="no noise at all")
_declare(
    "--drift-rate",
    dest="drift_rate",
    type=float,
    help="offset drift of every bridge, raw units per s (default: the sensor file's)",
    old=(OldFlag("--drift", "--drift-rate {value}"),),
)
_declare(
    "--tool-change",
    dest="tool_change_s",
    type=float,
    default=2.0,
    metavar="SECONDS",
    help="pause between configurations in s (default 2)",
)
_declare(
    "--poses-only",
    dest="poses_only",
    action="store_true",
    help="record only the samples where the arm holds still at a stop: a static-pose recording (poses separated by gaps)",
)
_declare(
    "--pose-files",
    dest="pose_files",
    action="store_true",
    help="as --poses-only, but one file per pose: -o is then a folder that receives pose_01.csv, pose_02.csv, ..., "
    "each from time 0 (calibrate them with 'FOLDER/*.csv'); poses and seconds per pose: trajectory --levels --stops --dwell",
)
_declare("--quick", dest="quick", action="store_true", help="a smaller run: 3 levels x 4 stops at 100 Hz")
_declare(
    "--drift",
    dest="drift",
    action="store_true",
    help="the sensor's offsets drift (up to 1 N/min, a warm-up with a temperature channel, 1 N jumps at tool changes); "
    "plots the estimated against the true offsets over time (offsets_drift.png)",
)

# validate ----------------------------------------------------------------------------------------------------------
_declare(
    "--max-error",
    dest="max_error_percent",
    type=float,
    metavar="PERCENT",
    help="exit 1 when an error exceeds this %% of full scale",
)
_declare(
    "--min-coverage",
    dest="min_coverage",
    type=float,
    default=MIN_COVERAGE,
    metavar="SHARE",
    help=f"exit 1 when fewer than this share of the recording's samples could be compared (default {MIN_COVERAGE:g})",
)

# replay ------------------------------------------------------------------------------------------------------------
_declare(
    "--to", dest="to", type=add_address, default=DEFAULT_LISTEN, metavar="HOST:PORT", help="address to send to (default 127.0.0.1:5005)"
)
_declare("--speed", dest="speed", type=float, default=1.0, help="time scale: 1 real time, 10 ten times faster, 0 no pacing")
_declare("--joint-rate", dest="joint_rate_hz", type=float, metavar="HZ", help="joint messages per second (default: one per row)")
_declare("--loss", dest="loss", type=float, default=0.0, help="fraction of joint and strain messages dropped (default 0)")
_declare("--reorder", dest="reorder", type=float, default=0.0, help="fraction of messages delayed by 1-5 places (default 0)")

# export ------------------------------------------------------------------------------------------------------------
_declare(
    "--format",
    dest="fmt",
    choices=tuple(EXPORT_FORMATS),
    help="what to write (default: from the suffix of -o: "
    + ", ".join(f"{' '.join(suffixes)} {name}" for name, suffixes in EXPORT_FORMATS.items())
    + ")",
)
_declare("--payload", dest="payload", help="tool file of the payload (ros2); its gravity is the one exported")
_declare(
    "--name", dest="name", default="fts_calib", help="the name written into the output: the prefix of the C identifiers (default fts_calib)"
)
_declare("--sensor-frame", dest="sensor_frame", default="ft_sensor", help="TF frame of the sensor (ros2, default ft_sensor)")
_declare("--world-frame", dest="world_frame", default="world", help="TF frame with z up (ros2, default world)")

# payload -----------------------------------------------------------------------------------------------------------
_declare(
    "--estimate-mount",
    dest="estimate_mount",
    action="store_true",
    help="also estimate a small rotation of the sensor mount (beyond --mount's; still poses)",
)
_declare(
    "--min-spread",
    dest="min_spread_deg",
    type=float,
    default=3.0,
    metavar="DEG",
    help="smallest RMS spread of the gravity directions about each of two axes, in deg (default 3)",
)

# monitor -----------------------------------------------------------------------------------------------------------
_declare(
    "--false-alarms",
    dest="false_alarms_per_hour",
    type=float,
    metavar="PER_HOUR",
    default=1e-3,
    help="false-alarm budget per hour of service (default 1e-3)",
)
_declare(
    "--auto-tare",
    dest="auto_tare",
    action="store_true",
    help="re-tare into the calibration file when the offset error exceeds the threshold",
)
_declare(
    "--tare-threshold",
    dest="tare_threshold_percent",
    type=float,
    default=0.05,
    metavar="PERCENT",
    help="offset error tolerated, in %% of full scale (default 0.05)",
)

"""Command-line arguments of the feeds: a recording or ROS 2 bags, and a UR arm through RTDE.

Used by :mod:`fts_calib.app.parser` for ``calibrate``, ``validate``, ``replay`` (the
recording and a bag's topic names) and ``live`` (``--ur``); each destination is a parameter
of the command's ``run``.

Command-line arguments of the models: ``--model``, ``--offsets`` (calibrate, live), ``--drift`` (demo), ``--return-pass``.

Used by :mod:`fts_calib.app.parser`; each destination is a parameter of the command's
``run`` (:mod:`fts_calib.model.offset_models` for the models).

Command-line arguments of the HTML report: ``--report FILE.html`` and the ``report`` command.

Used by :mod:`fts_calib.app.parser`; each destination is a parameter of the command's
``run`` (:mod:`fts_calib.app.calibrate`, ``live``, ``validate``, and ``report`` in
:mod:`fts_calib.app.report`).

Command-line arguments of the sensor: its channel layout (``--sensor``) and a prior calibration (``--prior``).

Used by :mod:`fts_calib.app.parser` for ``calibrate`` and ``live``; each destination is
a parameter of the command's ``run``.
"""

from __future__ import annotations

import argparse

from ..filters.settings import FILTER_MODES
from ..model.features import MODEL_SETTINGS
from ..model.offset_models import OFFSET_SETTINGS
from ..sources.bag import JOINT_STAMPS, BagTopics
from ..sources.ur import TIMEOUT_S

#: Help text of the recording argument of calibrate, validate and replay.
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


def add_robot_or_orientation(parser: argparse.ArgumentParser, what: str = "the recording", required_for: str = "", note: str = "") -> None:
    """``--robot`` (optional) and ``--mount R P Y``: joints and a robot, or a feed that gives the sensor's orientation.

    Args:
        parser: The command's parser.
        what: What gives the orientation without a robot (for the help text).
        required_for: When the orientation is needed at all (e.g. "with a mounted configuration"), for the help text.
        note: Appended to the help of ``--mount``.
    """
    needed = f" ({required_for})" if required_for else ""
    parser.add_argument(
        "--robot",
        help=f"robot definition: a shipped name (ur5) or a YAML path{needed}; without it {what} gives the sensor's "
        f"orientation ({ORIENTATION_HELP})",
    )
    parser.add_argument(
        "--mount",
        dest="mount_rpy",
        nargs=3,
        type=float,
        metavar=("R", "P", "Y"),
        help=f"without --robot: roll, pitch, yaw in rad from the frame whose orientation {what} gives (e.g. the "
        f"TCP of tcp_rx,tcp_ry,tcp_rz) to the sensor (default: 0 0 0){note}",
    )


def add_recording(parser: argparse.ArgumentParser, pose: bool = False) -> None:
    """The recording argument (a CSV, or ROS 2 bags) and the topic names of a bag (``pose``: the pose topic too)."""
    parser.add_argument("recording", nargs="+", metavar="RECORDING", help=RECORDING_HELP)
    default = BagTopics()
    bag = parser.add_argument_group("ROS 2 bags (topic names; docs/formats.md, ROS 2 bags)")
    bag.add_argument("--joints-topic", default=default.joints, help=f"sensor_msgs/msg/JointState topic (default {default.joints})")
    if pose:
        bag.add_argument(
            "--pose-topic",
            default=default.pose,
            help=f"without --robot: geometry_msgs/msg/PoseStamped topic of the sensor's orientation, read instead of the joints "
            f"(default {default.pose})",
        )
    bag.add_argument(
        "--channels-topic",
        default=default.channels,
        help=f"std_msgs/msg/Float64MultiArray or geometry_msgs/msg/WrenchStamped topic (default {default.channels})",
    )
    bag.add_argument(
        "--configuration-topic",
        default=default.configuration,
        help=f"std_msgs/msg/String topic of the tool configuration (default {default.configuration})",
    )
    bag.add_argument(
        "--joint-stamps",
        choices=JOINT_STAMPS,
        default=default.joint_stamps,
        help="time of a joint message: its header stamp (default), or the bag's log time (a log of simulated time whose "
        "header stamps stay 0, or a joint driver on another clock)",
    )


def add_ur(parser: argparse.ArgumentParser) -> None:
    """--ur HOST and --ur-wrench: a UR arm's joints (and built-in sensor) through RTDE (live)."""
    ur = parser.add_argument_group("UR arms through RTDE (pip install 'fts-calib[ur]')")
    ur.add_argument("--ur", metavar="HOST", help="read the joints of the UR controller at HOST through RTDE instead of joint datagrams")
    ur.add_argument(
        "--ur-wrench",
        action="store_true",
        help="with --ur: the channels are the built-in sensor's raw wrench (needs a wrench-6 --sensor, e.g. factory_sensor)",
    )
    ur.add_argument(
        "--ur-timeout",
        dest="ur_timeout_s",
        type=float,
        default=TIMEOUT_S,
        metavar="SECONDS",
        help=f"with --ur: the longest wait for the controller's handshake, connection and first sample, in s (default {TIMEOUT_S:g}; "
        "then exit 16)",
    )


def add_offsets(parser: argparse.ArgumentParser) -> None:
    """--model and --offsets: the sensor model and the estimator's offset model (calibrate, live)."""
    parser.add_argument(
        "--model",
        choices=MODEL_SETTINGS,
        help="sensor model: auto (default, from the sensor file: the simplest whose held-out error is the best within its "
        "noise, chosen together with the offset model), linear (the paper's C), quadratic or cubic (products of the "
        "laid-out channels up to the degree)",
    )
    parser.add_argument(
        "--offsets",
        choices=OFFSET_SETTINGS,
        help="offset model: auto (default, from the pipeline file: the simplest the data support, by held-out error, or by "
        "BIC with --model linear), constant (the paper), per-configuration (one D per tool configuration), drift "
        "(per-configuration plus time and temperature)",
    )


def add_filter_mode(parser: argparse.ArgumentParser) -> None:
    """--filter: the sample filter's mode (calibrate, live)."""
    parser.add_argument(
        "--filter",
        dest="filter_mode",
        choices=FILTER_MODES,
        help="sample filter: quasi-static (default, from the pipeline file: still samples, the tool's weight) or dynamic "
        "(every moving sample whose expected wrench is trusted, with the tool's Newton-Euler wrench, weighted by its "
        "predicted error: docs/method.md#dynamic-mode)",
    )


def add_drift_demo(parser: argparse.ArgumentParser) -> None:
    """--drift: the demo's sensor has offsets that move."""
    parser.add_argument(
        "--drift",
        action="store_true",
        help="the sensor's offsets drift (up to 1 N/min, a warm-up with a temperature channel, 1 N jumps at tool changes); "
        "plots the estimated against the true offsets over time (offsets_drift.png)",
    )


def add_return_pass(parser: argparse.ArgumentParser) -> None:
    """--return-pass: the trajectory visits its stops again in reverse order."""
    parser.add_argument(
        "--return-pass",
        action="store_true",
        help="visit the stops again in reverse order: drifting offsets become separable from the orientation "
        "(the drift model then costs no precision of C) for about twice the sweep time; fixes the raster",
    )


def add_report_option(parser: argparse.ArgumentParser, what: str) -> None:
    """--report FILE.html: the one-page HTML report of the run (calibrate, live, validate)."""
    parser.add_argument(
        "--report",
        metavar="FILE.html",
        help=f"write a self-contained HTML report of {what} (verdict first; readable on a phone, prints on A4)",
    )


def add_report(commands, add) -> None:
    """The ``report`` command, made with ``add(commands, name, help, description, example)`` (the parser's sub-command maker)."""
    rep = add(
        commands,
        "report",
        "write the one-page HTML report of a calibration, or compare two",
        "Build the self-contained HTML report of a calibration file afterwards: the verdict first (fit, accuracy budget "
        "against the target, held-out error, model), then the gravity directions reached, the residuals, the budget, "
        "the model selection, C with its standard errors, the offsets, what was skipped and the provenance. With the "
        "recording it was made from, the pictures of the samples are recomputed from it (robot and tool from the file's "
        "provenance unless given). With --against OLD.yaml: the change of every coefficient in standard errors and the "
        "wrench difference over the full-scale box, and whether the sensor changed beyond its uncertainty.",
        "fts-calib report calibration.yaml recording.csv -o report.html\n"
        "  fts-calib report new.yaml --against old.yaml -o change.html   # did the sensor change?",
    )
    rep.add_argument("calibration", metavar="CALIBRATION", help="calibration file (fts-calib YAML)")
    rep.add_argument("recording", nargs="?", metavar="RECORDING", help="the recording it was made from (CSV or ROS 2 bag), optional")
    rep.add_argument("-o", "--output", required=True, metavar="FILE.html", help="HTML file to write")
    rep.add_argument("--against", metavar="OLD.yaml", help="an older calibration of the same sensor: write the comparison instead")
    rep.add_argument("--robot", help="robot definition for the recording (default: the calibration's provenance)")
    rep.add_argument("--tool", help="tool file for the recording (default: the calibration's provenance)")
    rep.add_argument("--pipeline", default="pipeline", help="pipeline configuration: filter thresholds (default: pipeline)")
    rep.add_argument("--sensor", default="sensor", help="sensor configuration: channel limits and full scale (default: sensor)")
    rep.add_argument(
        "--target", dest="target_percent", type=float, metavar="PERCENT", help="accuracy target of the budget total, %% of full scale"
    )


def add_sensor(parser: argparse.ArgumentParser) -> None:
    """--sensor: the sensor configuration whose channel layout the data must have (calibrate, live)."""
    parser.add_argument(
        "--sensor",
        default="sensor",
        help="sensor configuration: its 'channels' layout (maltese-cross-8, wrench-6 or a 6 x n projection), or an "
        "ATI .cal file (P = its factory matrix) (default: sensor, the paper's 8 bridges; factory_sensor: a 6-axis wrench)",
    )


def add_prior(parser: argparse.ArgumentParser) -> None:
    """--prior and --prior-weight: ridge regression of C_bar toward a known calibration (calibrate, live)."""
    parser.add_argument(
        "--prior",
        metavar="CALIBRATION",
        help="shrink C_bar toward this calibration (fts-calib YAML or the factory ATI .cal) when the excitation is weak",
    )
    parser.add_argument(
        "--prior-weight",
        type=float,
        default=1.0,
        metavar="LAMBDA",
        help="weight of --prior relative to the data: 0 none, 1 as much as the data, 1e12 (the most): the prior (default: 1)",
    )

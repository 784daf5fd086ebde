"""The command line's service commands: tare, payload and export (what runs after a calibration)."""

from __future__ import annotations

from .feed_arguments import add_robot_or_orientation
from .parser import add_address, add_command

#: fts_calib.service.payload.MIN_SPREAD_DEG [deg], written here: importing it would load the
#: kinematics into the parser (tests/test_app.py checks the two defaults agree).
MIN_SPREAD_DEG = 3.0
#: fts_calib.service.payload_live.IDLE_TIMEOUT_S [s], written here for the same reason (checked alike).
IDLE_TIMEOUT_S = 10.0


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
    """``payload``: identify an unknown payload's mass and centre of mass from still poses."""
    pay = add_command(
        commands,
        "payload",
        "identify an unknown payload: mass, centre of mass, offsets",
        "From a recording of the payload held still in orientations that tilt gravity about two axes: its mass, "
        "centre of mass (in the sensor frame) and the offsets, with standard errors, written as a tool file for "
        "gravity compensation. Judges the whole set (the spread of the gravity directions, the fit's conditioning) "
        "and refuses one that cannot determine the payload, saying what is missing. With --motion, from a short "
        "continuous motion instead: the inertia too (physically consistent), the joint stream's latency estimated; "
        "with --motion --listen, from the live feeds (joints and strain datagrams) until the sender's end, --seconds or Ctrl-C.",
        "fts-calib payload --calibration calibration.yaml --robot ur5 gripper.csv -o configs/gripper.yaml\n"
        "  fts-calib payload --calibration calibration.yaml gripper_tcp.csv --mount 0 0 0.785 -o gripper.yaml   # tcp_rx,tcp_ry,tcp_rz\n"
        "  fts-calib payload --motion --listen 5005 --seconds 10 --calibration calibration.yaml --robot ur5 -o gripper.yaml",
    )
    pay.add_argument("recording", nargs="?", help="recording of the payload in several still orientations (or moving, with --motion)")
    pay.add_argument("--calibration", required=True, help="the sensor's calibration file")
    add_robot_or_orientation(pay, note="; to estimate a small mount rotation: --estimate-mount")
    pay.add_argument("-o", "--output", required=True, help="tool file to write")
    pay.add_argument("--name", default="payload", help="name of the payload (default: payload)")
    pay.add_argument(
        "--estimate-mount", dest="mount", action="store_true", help="also estimate a small rotation of the sensor mount (beyond --mount's)"
    )
    pay.add_argument(
        "--motion",
        action="store_true",
        help="the recording is a continuous motion (no still poses): identify the inertia too, physically consistent",
    )
    pay.add_argument(
        "--listen", type=add_address, metavar="HOST:PORT", help="with --motion: collect the motion from a live feed on this address instead"
    )
    pay.add_argument(
        "--seconds", type=float, help="with --listen: end after this many seconds of motion (default: the sender's end or Ctrl-C)"
    )
    pay.add_argument(
        "--idle-timeout",
        dest="idle_timeout_s",
        type=float,
        default=IDLE_TIMEOUT_S,
        help=f"with --listen: the longest wait for a datagram in s; none at all is a timeout (default {IDLE_TIMEOUT_S:g})",
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

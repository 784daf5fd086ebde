"""The ``monitor`` command's options (its own module: the parser module stays under its size)."""

from __future__ import annotations

import argparse
from collections.abc import Callable


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

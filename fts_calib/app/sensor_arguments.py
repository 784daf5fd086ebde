"""Command-line arguments of the sensor: its channel layout (``--sensor``) and a prior calibration (``--prior``).

Used by :mod:`fts_calib.app.arguments` for ``calibrate`` and ``live``; each destination is
a parameter of the command's ``run``.
"""

from __future__ import annotations

import argparse


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

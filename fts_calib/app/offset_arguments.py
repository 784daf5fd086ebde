"""Command-line arguments of the models: ``--model``, ``--offsets`` (calibrate, live), ``--drift`` (demo), ``--return-pass``.

Used by :mod:`fts_calib.app.arguments`; each destination is a parameter of the command's
``run`` (:mod:`fts_calib.model.offset_basis` for the models).
"""

from __future__ import annotations

import argparse

from ..model.features import MODEL_SETTINGS
from ..model.offset_basis import OFFSET_SETTINGS
from ..pipeline.settings import FILTER_MODES


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

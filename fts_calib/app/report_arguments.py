"""Command-line arguments of the HTML report: ``--report FILE.html`` and the ``report`` command.

Used by :mod:`fts_calib.app.arguments`; each destination is a parameter of the command's
``run`` (:mod:`fts_calib.app.calibrate`, ``live``, ``validate``, and ``report`` in
:mod:`fts_calib.app.report`).
"""

from __future__ import annotations

import argparse


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

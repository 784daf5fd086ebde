"""A snapshot of what the package shows the world, to compare before and after a change of its layout (not collected by pytest).

It records, in a folder:

- ``tests.txt``: every test id pytest collects;
- ``help/<command>.txt``: every command's ``--help``;
- ``api.txt``: every public name of every module with its signature (``module.name(signature)``), and ``fts_calib.__all__``;
- ``outputs/``: what ``demo``, ``calibrate``, ``validate``, ``payload`` (still and ``--motion``), ``tare``, ``monitor``
  (``--robot --tool --auto-tare`` on a recording shifted 0.5 N) and ``export`` print and write on the shipped data
  (simulated with fixed seeds), with the numbers and words only: timings, times of day, versions and
  temporary paths are blanked.

``compare`` then lists what differs between two snapshots, with a rename map (old module -> new) for the API and tests.

Run: .venv/bin/python -m tests.layout_snapshot take FOLDER
     .venv/bin/python -m tests.layout_snapshot compare BEFORE AFTER [RENAMES.txt]
"""

from __future__ import annotations

import contextlib
import difflib
import hashlib
import importlib
import inspect
import io
import os
import pkgutil
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
COMMANDS = ("demo", "robots", "trajectory", "calibrate", "live", "replay", "simulate", "validate", "report", "tare", "payload", "export",
            "monitor", "record")  # fmt: skip
#: What varies from run to run and is not a result: blanked before any comparison.
VOLATILE = [
    (re.compile(r"\d+(\.\d+)? s \(\d+k rows/s\)"), "<time>"),
    (re.compile(r"in \d+(\.\d+)? s"), "in <time>"),
    (re.compile(r"time: .*total \d+(\.\d+)? s"), "time: <timings>"),
    (re.compile(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ"), "<date>"),
    (re.compile(r"software_version: \S+"), "software_version: <version>"),
    (re.compile(r"/tmp/[^\s'\"]+"), "<tmp>"),
    (re.compile(r"\d+(\.\d+)?k rows/s"), "<rate>"),
    (re.compile(r"\[#*\s*\] \d+\.\d %[^\n]*"), ""),
    (re.compile(r"[+-]?\d+(\.\d+)? N/h on average"), "<rate> N/h on average"),  # over the wall-clock time since the calibration
    (re.compile(r"\b[0-9a-f]{64}\b"), "<sha256>"),  # of files that hold a time of day; the recordings are hashed apart
]


def _clean(text: str, folder: Path) -> str:
    text = text.replace(str(folder), "<out>")
    for pattern, repl in VOLATILE:
        text = pattern.sub(repl, text)
    return text


def _run(folder: Path, argv: list[str]) -> str:
    """One command in-process, its standard output and error with its exit status."""
    from fts_calib.app.cli import main

    out, err = io.StringIO(), io.StringIO()
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                status = main(argv)
            except SystemExit as exc:
                status = exc.code
    finally:
        os.chdir(cwd)
    return f"$ fts-calib {' '.join(argv)}\nexit {status}\n{out.getvalue()}{err.getvalue()}"


def _api() -> list[str]:
    import fts_calib

    lines = [f"fts_calib.__all__ = {sorted(fts_calib.__all__)}"]
    for info in pkgutil.walk_packages(fts_calib.__path__, "fts_calib."):
        try:
            module = importlib.import_module(info.name)
        except Exception as exc:  # noqa: BLE001 - a module that cannot import is itself a finding
            lines.append(f"{info.name}: cannot import: {exc}")
            continue
        for name, value in sorted(vars(module).items()):
            if name.startswith("_") or getattr(value, "__module__", None) != info.name:
                continue
            if inspect.isclass(value) or inspect.isfunction(value):
                try:
                    signature = str(inspect.signature(value))
                except (TypeError, ValueError):
                    signature = "(...)"
                lines.append(f"{info.name}.{name}{signature}")
    return lines


def _simulate_motion(path: Path) -> None:
    """The validation payload moved along the payload excitation, joints 8 ms late and noisy, offsets drifting (seed 7)."""
    import numpy as np

    from fts_calib.core.resources import resolve
    from fts_calib.payload.inertia_motion import payload_excitation
    from fts_calib.robot.definition import load_robot
    from fts_calib.robot.kinematics import Kinematics
    from fts_calib.robot.tool import load_tool
    from fts_calib.sim.drift import OffsetDrift
    from fts_calib.sim.payload_run import simulate_payload_motion
    from fts_calib.sim.sensor import load_simulated_sensor

    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    payload = load_tool(resolve("validation_tool", "configs")).configurations[0]
    home = np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0])  # [rad] the UR5's payload pose of the tests
    motion = payload_excitation(kin, home, seconds=10.0, amplitude=1.0)
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    rng = np.random.default_rng(7)
    simulate_payload_motion(path, kin, payload, sensor, motion, rng, 0.008, 1e-5, drift=OffsetDrift.typical())


def _shift(recording: Path, calibration: Path, shifted: Path, copy: Path) -> None:
    """The recording with every wrench shifted by 0.5 N on Fx, and a copy of the calibration for monitor to re-tare."""
    import csv

    import numpy as np

    from fts_calib.model.calibration import load_calibration

    cal = load_calibration(calibration)
    shift_channels = np.linalg.pinv(cal.C) @ np.array([0.5, 0.0, 0.0, 0.0, 0.0, 0.0])  # [N]
    with open(recording, newline="") as source, open(shifted, "w", newline="") as target:
        reader, writer = csv.reader(source), csv.writer(target)
        header = next(reader)
        writer.writerow(header)
        columns = [header.index(f"strain_{k + 1}") for k in range(len(shift_channels))]
        for row in reader:
            for k, column in enumerate(columns):
                row[column] = repr(float(row[column]) + float(shift_channels[k]))
            writer.writerow(row)
    copy.write_bytes(calibration.read_bytes())


def take(folder: Path) -> None:
    """Write the snapshot into ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    collect = [sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider"]
    tests = subprocess.run(collect, cwd=ROOT, capture_output=True, text=True).stdout
    (folder / "tests.txt").write_text("\n".join(sorted(line for line in tests.splitlines() if "::" in line)) + "\n")
    (folder / "help").mkdir(exist_ok=True)
    from fts_calib.app.cli import main

    for command in COMMANDS:
        out = io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
            try:
                main([command, "--help"])
            except SystemExit:
                pass
        (folder / "help" / f"{command}.txt").write_text(out.getvalue())
    (folder / "api.txt").write_text("\n".join(_api()) + "\n")
    outputs = folder / "outputs"
    outputs.mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for name in ("configs", "robots", "trajectories"):
            (work / name).symlink_to(ROOT / name)
        steps = [
            ("demo", ["demo", "-o", "demo"]),
            ("simulate", ["simulate", "--robot", "ur5", "--tool", "paper_tool", "--trajectory", "trajectories/ur5", "-o", "rec.csv"]),
            ("calibrate", ["calibrate", "--robot", "ur5", "--tool", "paper_tool", "rec.csv", "-o", "cal.yaml"]),
            (
                "validate",
                [
                    "validate",
                    "--calibration",
                    "cal.yaml",
                    "--robot",
                    "ur5",
                    "--tool",
                    "validation_tool",
                    "demo/recordings/validation.csv",
                    "--json",
                    "validate.json",
                ],
            ),  # fmt: skip
            (
                "simulate_payload",
                ["simulate", "--robot", "ur5", "--tool", "validation_tool", "--trajectory", "vplan", "--poses-only", "-o", "payload.csv"],
            ),  # fmt: skip
            ("payload", ["payload", "--calibration", "cal.yaml", "--robot", "ur5", "payload.csv", "-o", "payload_tool.yaml"]),
            (
                "tare",
                [
                    "tare",
                    "--calibration",
                    "cal.yaml",
                    "--robot",
                    "ur5",
                    "--tool",
                    "validation_tool",
                    "--configuration",
                    "V",
                    "payload.csv",
                    "-o",
                    "tared.yaml",
                ],
            ),  # fmt: skip
            ("simulate_motion", None),
            (
                "payload_motion",
                ["payload", "--motion", "--calibration", "cal.yaml", "--robot", "ur5", "motion.csv", "-o", "motion_tool.yaml"],
            ),  # fmt: skip
            ("shift", None),
            (
                "monitor",
                [
                    "monitor",
                    "--calibration",
                    "monitor_cal.yaml",
                    "--robot",
                    "ur5",
                    "--tool",
                    "paper_tool",
                    "--auto-tare",
                    "--json",
                    "monitor.json",
                    "shifted.csv",
                ],
            ),  # fmt: skip
            ("export_c", ["export", "--format", "c-header", "--calibration", "cal.yaml", "-o", "cal.h"]),
            ("export_json", ["export", "--format", "json", "--calibration", "cal.yaml", "-o", "cal.json"]),
            ("export_ros2", ["export", "--format", "ros2", "--calibration", "cal.yaml", "-o", "cal_ros2.yaml"]),
        ]
        for name, argv in steps:
            if name == "simulate_payload":  # the validation tool held still at the plan's stops: configuration V
                (work / "vplan").mkdir(exist_ok=True)
                import gzip

                text = gzip.open(ROOT / "trajectories" / "ur5" / "A.csv.gz", "rt").read()
                (work / "vplan" / "V.csv").write_text(re.sub(r",A$", ",V", text, flags=re.M))
            if name == "simulate_motion":
                _simulate_motion(work / "motion.csv")
                continue
            if name == "shift":
                _shift(work / "rec.csv", work / "cal.yaml", work / "shifted.csv", work / "monitor_cal.yaml")
                continue
            (outputs / f"{name}.txt").write_text(_clean(_run(work, argv), work))
        for path in sorted(work.rglob("*")):
            if (
                path.is_file()
                and not path.is_symlink()
                and path.suffix in (".yaml", ".json", ".h", ".csv", ".html")
                and "configs" not in path.parts
            ):
                data = path.read_bytes()
                if path.suffix in (".yaml", ".json", ".h", ".html"):
                    text = _clean(data.decode("utf-8", "replace"), work)
                    text = re.sub(r'("?time"?: )"?<date>"?', r"\1<date>", text)
                    (outputs / (str(path.relative_to(work)).replace("/", "__") + ".txt")).write_text(text)
                else:
                    digest = hashlib.sha256(data).hexdigest()
                    (outputs / (str(path.relative_to(work)).replace("/", "__") + ".sha256")).write_text(digest + "\n")


def compare(before: Path, after: Path, renames: Path | None = None) -> int:
    """Print what differs; 0 when nothing but renames does."""
    mapping: list[tuple[str, str]] = []
    if renames is not None:
        for line in renames.read_text().splitlines():
            if "->" in line and not line.startswith("#"):
                old, new = (part.strip() for part in line.split("->"))
                mapping.append((old, new))
    differences = 0
    for path in sorted(before.rglob("*")):
        if not path.is_file():
            continue
        other = after / path.relative_to(before)
        old = path.read_text().splitlines()
        new = other.read_text().splitlines() if other.exists() else []
        if path.name in ("api.txt", "tests.txt"):
            renamed = set()
            for line in old:
                for a, b in mapping:
                    line = line.replace(a, b)
                renamed.add(line)
            lost = sorted(renamed - set(new))
            if lost:
                differences += len(lost)
                print(f"== {path.relative_to(before)}: {len(lost)} lost (after the renames):")
                print("\n".join(f"  - {x}" for x in lost[:200]))
            continue
        if old != new:
            differences += 1
            print(f"== {path.relative_to(before)} differs:")
            print("\n".join(line[:300] for line in list(difflib.unified_diff(old, new, lineterm="", n=1))[:60]))
    return 1 if differences else 0


if __name__ == "__main__":
    if sys.argv[1:2] == ["take"]:
        take(Path(sys.argv[2]))
    elif sys.argv[1:2] == ["compare"]:
        sys.exit(compare(Path(sys.argv[2]), Path(sys.argv[3]), Path(sys.argv[4]) if len(sys.argv) > 4 else None))
    else:
        print(__doc__)
        sys.exit(2)

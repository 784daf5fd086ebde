"""Build the wheel, install it into a fresh venv and run it from a folder outside the checkout.

Run by ``make wheel-check`` (and so by ``.ci/run``). It proves what an editable install
cannot: that the shipped robots, configs and trajectories are inside the wheel and are
found wherever the package is installed. Dependencies are installed at the versions of
``uv.lock``; only ``fts-calib`` itself comes from the freshly built wheel.

Usage:
    .venv/bin/python tests/wheel_check.py [--keep]
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
UV = Path(sys.executable).parent / "uv"
SHIPPED_ROBOTS = ("kinova", "panda", "ur10", "ur5", "xarm7")
#: The data folders the package ships (pyproject.toml maps them into fts_calib/): every file must be in the wheel.
DATA = ("robots", "configs", "trajectories")


def run(cmd: list[str | Path], cwd: Path, env: dict[str, str]) -> str:
    """Run a command, echo it, return its standard output; exit with its output on failure."""
    started = time.perf_counter()
    shown = " ".join(str(c) for c in cmd)
    result = subprocess.run([str(c) for c in cmd], cwd=cwd, env=env, capture_output=True, text=True)
    print(f"$ {shown}  ({time.perf_counter() - started:.1f} s, exit {result.returncode})", flush=True)
    if result.returncode != 0:
        print(result.stdout[-4000:], result.stderr[-4000:], sep="\n", file=sys.stderr)
        raise SystemExit(f"wheel check failed: {shown}")
    return result.stdout


def expect(condition: bool, message: str) -> None:
    """Fail the check with ``message`` unless ``condition`` holds."""
    if not condition:
        raise SystemExit(f"wheel check failed: {message}")


def main() -> int:
    """Build, install into a fresh venv, run three commands from a temporary folder."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--keep", action="store_true", help="keep the temporary folder and print its path")
    args = parser.parse_args()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env |= {"UV_CACHE_DIR": str(ROOT / ".cache" / "uv"), "UV_PYTHON_DOWNLOADS": "never", "MPLBACKEND": "Agg"}
    work = Path(tempfile.mkdtemp(prefix="fts-calib-wheel-"))
    try:
        dist, venv, outside = work / "dist", work / "venv", work / "elsewhere"
        outside.mkdir()
        run([UV, "build", "--wheel", "--out-dir", dist, ROOT], ROOT, env)
        wheels = sorted(dist.glob("fts_calib-*.whl"))
        expect(len(wheels) == 1, f"expected one wheel in {dist}, found {[w.name for w in wheels]}")
        inside = set(zipfile.ZipFile(wheels[0]).namelist())
        shipped = {f"fts_calib/{p.relative_to(ROOT).as_posix()}" for kind in DATA for p in (ROOT / kind).rglob("*") if p.is_file()}
        missing = sorted(shipped - inside) + ([] if "fts_calib/py.typed" in inside else ["fts_calib/py.typed"])
        expect(not missing, f"the wheel lacks {missing}")
        pins = work / "pins.txt"
        pins.write_text(run([UV, "export", "--frozen", "--no-dev", "--no-emit-project", "--no-hashes"], ROOT, env))
        base_python = getattr(sys, "_base_executable", sys.executable)
        run([base_python, "-m", "venv", "--without-pip", venv], work, env)
        run([UV, "pip", "install", "--python", venv / "bin" / "python", "-c", pins, wheels[0]], work, env)
        cli = venv / "bin" / "fts-calib"

        listed = run([cli, "robots"], outside, env)
        for name in SHIPPED_ROBOTS:
            expect(name in listed, f"'fts-calib robots' does not list {name}:\n{listed}")
        planned = run(
            [cli, "trajectory", "--robot", "ur5", "--tool", "paper_tool", "-o", "traj", "--rate", "50", "--no-plot"], outside, env
        )
        for name in ("A", "B", "C"):
            expect((outside / "traj" / f"{name}.csv").is_file(), f"trajectory wrote no {name}.csv:\n{planned}")
        demo = run([cli, "demo", "--quick", "--out", "demo"], outside, env)
        expect((outside / "demo" / "calibration.yaml").is_file(), f"demo wrote no calibration.yaml:\n{demo}")
        example = run([venv / "bin" / "python", ROOT / "examples" / "01_wrench_loop.py"], outside, env)  # against the wheel
        expect("wrench error RMS" in example, f"examples/01_wrench_loop.py printed no result:\n{example}")
        imported = run([venv / "bin" / "python", "-c", "import fts_calib; print(fts_calib.__file__)"], outside, env)
        expect(str(ROOT) not in imported, f"fts_calib was imported from the checkout: {imported}")
        print(
            f"wheel check passed: {wheels[0].name} holds py.typed and the {len(shipped)} files of {', '.join(DATA)}; installed "
            "outside the checkout, robots, trajectory, demo --quick and examples/01 ran"
        )
        return 0
    finally:
        if args.keep:
            print(f"kept {work}")
        else:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    raise SystemExit(main())

"""The package surface: every exported name exists, the list is sorted, the code is lint-clean."""

import importlib
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import fts_calib

ROOT = Path(__file__).resolve().parents[1]


def test_every_name_in_all_is_importable_and_sorted():
    assert fts_calib.__all__ == sorted(fts_calib.__all__)
    for name in fts_calib.__all__:
        assert hasattr(fts_calib, name), name


def test_version_and_typed_marker():
    assert fts_calib.__version__.count(".") == 2
    assert (ROOT / "fts_calib" / "py.typed").exists()


def test_every_module_has_a_docstring():
    for path in sorted((ROOT / "fts_calib").glob("*.py")):
        module = importlib.import_module(f"fts_calib.{path.stem}")
        assert module.__doc__ and module.__doc__.strip(), f"{path.name} has no module docstring"


@pytest.mark.skipif(shutil.which("ruff", path=str(Path(sys.executable).parent)) is None, reason="ruff not installed")
def test_ruff_is_clean():
    ruff = shutil.which("ruff", path=str(Path(sys.executable).parent))
    folders = [f for f in ("fts_calib", "tests", "bench", "examples") if (ROOT / f).exists()]
    result = subprocess.run([ruff, "check", *folders], cwd=ROOT, capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr

"""Exports: the C header compiles and computes what Python does; JSON and ROS 2 parameters."""

import json
import shutil
import subprocess

import numpy as np
import pytest

from fts_calib import Calibration, ConfigError, load_calibration
from fts_calib.app.cli import main
from fts_calib.app.exit_codes import ExitCode
from fts_calib.core.resources import resolve
from fts_calib.model.calibration import save_calibration
from fts_calib.model.channels import WRENCH_6
from fts_calib.service.exports import c_header, export, json_text
from fts_calib.sim.sensor import load_simulated_sensor


@pytest.fixture(scope="module")
def calibration():
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    return Calibration(sensor.C_bar, sensor.D, provenance={"method": "test", "software_version": "0"})


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not installed")
@pytest.mark.parametrize("precision", ["float", "double"])
@pytest.mark.parametrize("layout", ["maltese-cross-8", "wrench-6"])
def test_the_c_header_compiles_and_matches_python(tmp_path, calibration, rng, precision, layout):
    if layout == "wrench-6":  # a factory wrench's correction: C is 6 x 6
        calibration = Calibration(np.eye(6) * 1.03, calibration.D, layout=WRENCH_6)
    n = calibration.layout.n_channels
    (tmp_path / "calibration.h").write_text(c_header(calibration))
    strains = rng.standard_normal((50, n)) * 0.2
    rows = ",\n".join("{" + ", ".join(f"{v:.17g}" for v in s) + "}" for s in strains)
    source = f"""
#include <stdio.h>
#include "calibration.h"
static const double strains[50][{n}] = {{ {rows} }};
int main(void) {{
    for (int n = 0; n < 50; ++n) {{
        fts_calib_real s[{n}], w[6];
        for (int k = 0; k < {n}; ++k) s[k] = (fts_calib_real)strains[n][k];
        fts_calib_wrench(s, w);
        for (int i = 0; i < 6; ++i) printf("%.17g%c", (double)w[i], i == 5 ? '\\n' : ' ');
    }}
    return 0;
}}
"""
    (tmp_path / "main.c").write_text(source)
    flags = ["-DFTS_CALIB_DOUBLE"] if precision == "double" else []
    build = subprocess.run(
        ["gcc", "-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror", *flags, "-o", str(tmp_path / "main"), str(tmp_path / "main.c")],
        capture_output=True,
        text=True,
    )
    assert build.returncode == 0, build.stderr
    out = subprocess.run([str(tmp_path / "main")], capture_output=True, text=True, check=True).stdout
    got = np.array([[float(v) for v in line.split()] for line in out.strip().splitlines()])
    expected = calibration.wrench(strains)
    # float: the wrench of a 1e-5 relative error on the largest terms; double: round-off only
    tolerance = 1e-5 if precision == "float" else 1e-12
    scale = np.abs(strains) @ np.abs(calibration.C).T + np.abs(calibration.D)
    assert np.all(np.abs(got - expected) <= tolerance * scale), np.max(np.abs(got - expected) / scale)


def test_json_export_holds_the_calibration(calibration):
    data = json.loads(json_text(calibration))
    assert data["format"] == "fts-calib/1"
    # JSON numbers are Python reprs, which read back as the same double: exact
    np.testing.assert_array_equal(data["C"], calibration.C)
    np.testing.assert_array_equal(data["D"], calibration.D)


def test_cli_export_and_bad_calibration_files(tmp_path, calibration, capsys):
    path = save_calibration(calibration, tmp_path / "cal.yaml")
    assert main(["export", "--format", "json", "--calibration", str(path), "-o", str(tmp_path / "c.json")]) == 0
    assert json.loads((tmp_path / "c.json").read_text())["D"] == calibration.D.tolist()
    assert main(["export", "--format", "ros2", "--calibration", str(path), "-o", str(tmp_path / "r.yaml")]) == ExitCode.CONFIG
    assert "give its tool file (--payload)" in capsys.readouterr().err
    bad = tmp_path / "bad.yaml"
    bad.write_text(path.read_text().replace("fts-calib/1", "fts-calib/9"))
    assert main(["export", "--format", "c-header", "--calibration", str(bad), "-o", str(tmp_path / "h.h")]) == ExitCode.FILE
    assert "field 'format': is 'fts-calib/9' but expected 'fts-calib/1'" in capsys.readouterr().err
    wrong_shape = tmp_path / "shape.yaml"
    wrong_shape.write_text(path.read_text().replace("D: [", "D: [0.0, "))
    assert main(["export", "--format", "c-header", "--calibration", str(wrong_shape), "-o", str(tmp_path / "h.h")]) == ExitCode.FILE
    assert "field 'D': shape (7,) but expected (6,)" in capsys.readouterr().err
    assert load_calibration(path).D.tolist() == calibration.D.tolist()


def test_export_refuses_an_unknown_format_and_ros2_without_a_payload(calibration):
    with pytest.raises(ConfigError, match="format='xml' but expected one of c-header, json, ros2"):
        export(calibration, "xml")
    with pytest.raises(ConfigError, match=r"the ros2 export describes the payload to compensate: give its tool file \(--payload\)"):
        export(calibration, "ros2")


def test_an_output_below_a_file_names_that_file(tmp_path, capsys):
    """Before: 'cannot write notes.txt/x.json: File exists', of a file the user did not name."""
    (tmp_path / "notes.txt").write_text("a file, not a folder\n")
    out = tmp_path / "notes.txt" / "sub" / "x.json"
    calibration = str(resolve("paper_table1_calibration", "configs"))
    assert main(["export", "--format", "json", "--calibration", calibration, "-o", str(out)]) == ExitCode.FILE_ACCESS
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"cannot write {out}: {tmp_path / 'notes.txt'} is a file, not a folder" in err[0], err

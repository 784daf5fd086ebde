"""Trajectory files: round trip, gzip, and errors that name the line and column."""

import gzip

import numpy as np
import pytest

from fts_calib import ConfigError, RecordingError
from fts_calib.planning.trajectory_files import read_trajectory, write_trajectory


@pytest.mark.parametrize("name", ["A.csv", "A.csv.gz"])
def test_round_trip(tmp_path, rng, name):
    t = np.arange(50) / 100
    q, qd, qdd = rng.standard_normal((3, 50, 2))
    path = write_trajectory(tmp_path / name, ["j1", "j2"], t, q, qd, qdd, "A")
    back = read_trajectory(path)
    assert back.joint_names == ("j1", "j2") and back.tool == "A"
    np.testing.assert_allclose(back.q, q, atol=5e-10)
    np.testing.assert_allclose(back.time, t, atol=5e-7)
    header = (gzip.open(path, "rt") if name.endswith(".gz") else open(path)).readline().strip()
    assert header == "time,j1,j1_vel,j1_acc,j2,j2_vel,j2_acc,tool"


def test_gzip_output_is_deterministic(tmp_path):
    t = np.arange(5) / 10
    z = np.zeros((5, 1))
    a = write_trajectory(tmp_path / "a.csv.gz", ["j"], t, z, z, z, "A").read_bytes()
    b = write_trajectory(tmp_path / "b.csv.gz", ["j"], t, z, z, z, "A").read_bytes()
    assert a == b


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("", "line 1: empty file"),
        ("time,j1,j1_vel,tool\n", "line 1: expected the header"),
        ("time,j1,j1_vel,j1_acc,tool\n0.0,1,2,3,A\n0.1,1,x,3,A\n", "line 3, column 'j1_vel': 'x' is not a number"),
        ("time,j1,j1_vel,j1_acc,tool\n0.0,1,2,3,A\n0.1,1,2,A\n", "line 3: 4 values but the header has 5 columns"),
        ("time,j1,j1_vel,j1_acc,tool\n0.1,1,2,3,A\n0.0,1,2,3,A\n", "line 3, column 'time': time goes backwards"),
        ("time,j1,j1_vel,j1_acc,tool\n0.0,1,2,3,A\n0.1,1,2,3,B\n", "one tool configuration per file"),
    ],
)
def test_errors_name_line_and_column(tmp_path, text, match):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(RecordingError, match=match):
        read_trajectory(path)


def test_a_tool_name_that_cannot_be_a_csv_cell_is_refused(tmp_path):
    z = np.zeros((2, 1))
    with pytest.raises(ConfigError, match=r"tool='A,B' but expected a configuration name without ','"):
        write_trajectory(tmp_path / "t.csv", ["j"], np.arange(2.0), z, z, z, "A,B")
    assert not list(tmp_path.iterdir())

"""Simulated recordings: the format a robot writes, read back by calibrate unchanged."""

from pathlib import Path

import numpy as np
import pytest

from fts_calib import load_calibration
from fts_calib.app.cli import main
from fts_calib.app.exit_codes import ExitCode
from fts_calib.core.resources import data_dir, resolve
from fts_calib.planning.trajectory_files import read_trajectory
from fts_calib.sim.runs import tool_wrenches
from fts_calib.sim.sensor import load_simulated_sensor
from fts_calib.sources.recording import RecordingReader

TRAJECTORIES = data_dir("trajectories") / "ur5"


def test_noiseless_recording_holds_exactly_the_tool_wrench_through_the_sensor(tmp_path, ur5, paper_tool, capsys):
    out = tmp_path / "rec.csv"
    assert (
        main(["simulate", "--robot", "ur5", "--tool", "paper_tool", "--trajectory", str(TRAJECTORIES), "-o", str(out), "--noiseless"]) == 0
    )
    assert "configurations A, B, C" in capsys.readouterr().out
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    with RecordingReader(out, ur5.joint_names, paper_tool.names) as reader:
        chunks = list(reader)
    assert reader.skipped == {}
    traj = read_trajectory(TRAJECTORIES / "B.csv.gz")
    k = np.concatenate([c.configuration for c in chunks])
    strain = np.concatenate([c.channels for c in chunks])[k == 1]
    expected = sensor.channels(tool_wrenches(ur5, paper_tool, "B", traj.q, traj.qd, traj.qdd))
    np.testing.assert_allclose(strain, expected, rtol=0, atol=2e-9 * np.abs(expected).max() + 1e-12)
    times = np.concatenate([c.time for c in chunks])
    assert np.all(np.diff(times) > 0)  # configurations one after the other, with a pause


def test_a_simulated_recording_is_calibrated_unchanged(tmp_path, capsys, seed):
    rec, cal = tmp_path / "rec.csv.gz", tmp_path / "cal.yaml"
    assert (
        main(["simulate", "--robot", "ur5", "--tool", "paper_tool", "--trajectory", str(TRAJECTORIES), "-o", str(rec), "--seed", str(seed)])
        == 0
    )
    assert main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(rec), "-o", str(cal), "--quiet"]) == 0
    calibration = load_calibration(cal)
    truth = load_simulated_sensor(resolve("sensor", "configs"))
    assert calibration.quality.rank == 7 and "malformed line" not in calibration.quality.skipped
    # 48 coefficients at 5 standard errors: P(any outside) < 48 x 6e-7 = 3e-5 for a seed
    assert np.all(np.abs(calibration.C - truth.C) <= 5 * calibration.quality.stderr_C)


def test_simulate_needs_trajectories_of_the_tool(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    assert (
        main(["simulate", "--robot", "ur5", "--tool", "paper_tool", "--trajectory", str(tmp_path / "empty"), "-o", str(tmp_path / "r.csv")])
        == ExitCode.FILE
    )
    assert "no trajectory file" in capsys.readouterr().err
    assert (
        main(["simulate", "--robot", "ur5", "--tool", "validation_tool", "--trajectory", str(TRAJECTORIES), "-o", str(tmp_path / "r.csv")])
        == ExitCode.FILE
    )
    assert "no trajectory for the configurations ['V']" in capsys.readouterr().err


def test_a_shipped_plan_is_named_from_any_folder(tmp_path, monkeypatch, capsys):
    """``--trajectory ur5`` (and ``ur5/A.csv.gz``, ``--plan ur5``) from an empty folder: the shipped plan, not a path."""
    from fts_calib.core.exceptions import ResourceNotFound
    from fts_calib.core.resources import locate_trajectory, shipped
    from fts_calib.session.plan_progress import load_plan_progress

    monkeypatch.chdir(tmp_path)
    assert locate_trajectory("ur5") == TRAJECTORIES
    assert locate_trajectory("ur5/A.csv.gz") == TRAJECTORIES / "A.csv.gz"
    assert main(["simulate", "--robot", "ur5", "--tool", "paper_tool", "--trajectory", "ur5/A.csv.gz", "-o", "a.csv", "--noiseless"]) == 0
    rows = len(read_trajectory(TRAJECTORIES / "A.csv.gz").time)
    assert f"wrote a.csv: {rows:,} rows, configurations A" in capsys.readouterr().out
    assert set(load_plan_progress("ur5", 500.0).expected) == {"A", "B", "C"}
    (tmp_path / "ur5").mkdir()  # a folder of the user's own wins over the shipped plan of that name
    assert locate_trajectory("ur5") == Path("ur5")
    with pytest.raises(ResourceNotFound) as refused:
        locate_trajectory("ur6")
    assert all(name in str(refused.value) for name in shipped("trajectories")), refused.value
    assert main(["simulate", "--robot", "ur5", "--tool", "paper_tool", "--trajectory", "ur6", "-o", "b.csv"]) == ExitCode.FILE
    assert "no shipped trajectory of that name; shipped: kinova, panda, ur10, ur5, xarm7" in capsys.readouterr().err

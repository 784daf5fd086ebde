"""Simulated recordings: the format a robot writes, read back by calibrate unchanged."""

import numpy as np

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

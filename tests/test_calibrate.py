"""The calibrate job: the filter against a moving tool, the summary, and bad recordings."""

import numpy as np
import pytest

from fts_calib import load_calibration
from fts_calib.app.cli import main
from fts_calib.app.exit_codes import ExitCode
from fts_calib.core.resources import resolve
from fts_calib.session.calibration_run import calibrate_recording
from fts_calib.sim.sensor import load_simulated_sensor


@pytest.fixture(scope="module")
def truth():
    return load_simulated_sensor(resolve("sensor", "configs"))


def _error(calibration, truth):
    """Largest coefficient error relative to its row's largest coefficient."""
    return np.max(np.abs(calibration.C - truth.C) / np.abs(truth.C).max(axis=1, keepdims=True))


def test_the_filter_makes_the_error_at_least_five_times_smaller_on_a_moving_tool(ur5, paper_tool, ur5_recording, truth):
    """The recording has the moving tool's full Newton-Euler wrench: without the filter,
    accelerations and centripetal terms enter the fit as if they were weight."""
    with_filter = calibrate_recording(ur5_recording, ur5, paper_tool).calibration
    without = calibrate_recording(ur5_recording, ur5, paper_tool, use_filter=False).calibration
    e_with, e_without = _error(with_filter, truth), _error(without, truth)
    assert e_without >= 5 * e_with, (e_with, e_without)  # 340 to 1000 times over 40 seeds
    # With the filter only the strain noise is left: about 1,130 kept samples give standard errors
    # of 4.3e-5 to 4.6e-5 of the row's largest coefficient, so the largest of 48 errors stays
    # below 5 sigma, 2.5e-4 (a fixed figure: it also catches standard errors that grew).
    assert e_with < 2.5e-4, e_with
    # 48 coefficients at 5 sigma: P(any outside) < 48 x 6e-7 = 3e-5 for a seed
    z = np.abs(with_filter.C - truth.C) / with_filter.quality.stderr_C
    assert np.all(z <= 5), f"largest error {z.max():.2f} standard errors"


def test_cli_calibrate_summary_and_file(tmp_path, ur5_recording, capsys):
    out = tmp_path / "cal.yaml"
    assert main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(ur5_recording), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    for part in ("rows in", "kept (", "filter: joint speed", "rank 7 of 7", "residual RMS: Fx", "± standard error", "D: Fx", "wrote"):
        assert part in text, part
    cal = load_calibration(out)
    assert cal.provenance["robot"]["name"] == "ur5" and cal.provenance["source"] == str(ur5_recording)
    assert cal.quality.samples_seen == 9012 and cal.quality.skipped["filter: joint speed"] > 0
    # the measured budget: its total is the largest error a user reads, the latency from the moves (none simulated)
    assert "measured accuracy budget" in text and "largest error: " in text and "stream latency: joint stream behind" in text
    budget = cal.quality.budget
    assert budget["kind"] == "measured" and set(budget["terms_percent_fs"]) >= {"strain noise", "tool mass", "sensor mount"}
    assert budget["largest_percent_fs"] == pytest.approx(max(budget["total_percent_fs"].values()), rel=1e-3)
    assert abs(budget["stream_latency_estimate"]["latency_ms"]) < 0.05


def _lines(path):
    return path.read_text().splitlines(keepends=True)


def test_a_recording_of_one_configuration_cannot_determine_c(tmp_path, ur5_recording, capsys):
    lines = _lines(ur5_recording)
    only_a = tmp_path / "a.csv"
    only_a.write_text("".join([lines[0], *[line for line in lines[1:] if line.rstrip().endswith(",A")]]))
    assert (
        main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(only_a), "-o", str(tmp_path / "c.yaml"), "--quiet"]) == 8
    )  # missing centres of mass: ExitCode.EXCITATION
    text = capsys.readouterr().out
    assert "NO CALIBRATION: insufficient excitation: the information matrix has rank 4 of 7" in text
    assert "one centre of mass (configuration A); mount two more, not on one line with it (B and C of the tool file)" in text
    assert not (tmp_path / "c.yaml").exists()


def test_bad_rows_are_counted_and_the_run_goes_on(tmp_path, ur5_recording, capsys):
    lines = _lines(ur5_recording)
    bad = list(lines)
    bad[100] = bad[100].replace(",A\n", ",D\n")  # unknown tool configuration
    cells = bad[200].split(",")
    cells[8] = "nan"
    bad[200] = ",".join(cells)  # a NaN strain
    bad[301] = bad[250]  # an earlier row: time goes backwards
    bad[400] = bad[400].replace(",", ";", 1)  # malformed
    bad[-1] = bad[-1][:30]  # truncated last line
    path = tmp_path / "bad.csv"
    path.write_text("".join(bad))
    out = tmp_path / "c.yaml"
    assert main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(path), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "unknown tool configuration" in text and "line 101: column 'tool': unknown tool configuration 'D'" in text
    assert "non-finite value" in text and "time going backwards" in text and "malformed line" in text
    assert f"line {len(bad)}: truncated (no line end)" in text
    skipped = load_calibration(out).quality.skipped
    assert skipped["unknown tool configuration"] == 1 and skipped["non-finite value"] == 1
    assert skipped["malformed line"] == 2 and skipped["time going backwards"] == 1


def test_missing_column_and_empty_file_are_clear_errors(tmp_path, ur5_recording, capsys):
    lines = _lines(ur5_recording)
    path = tmp_path / "no_tool.csv"
    path.write_text("".join(line.rsplit(",", 1)[0] + "\n" for line in lines[:50]))
    assert main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(path), "-o", str(tmp_path / "c.yaml")]) == ExitCode.RECORDING
    assert "no_tool.csv, line 1, column 'tool': missing column(s) ['tool']" in capsys.readouterr().err
    (tmp_path / "empty.csv").write_text("")
    assert main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(tmp_path / "empty.csv"), "--quiet"]) == ExitCode.RECORDING
    assert "empty.csv, line 1: empty file" in capsys.readouterr().err


def test_joint_columns_in_degrees(tmp_path, ur5_recording, capsys):
    lines = _lines(ur5_recording)
    header = lines[0].strip().split(",")
    joints = range(1, 7)
    out_lines = [lines[0]]
    for line in lines[1:]:
        cells = line.rstrip("\n").split(",")
        for j in joints:
            cells[j] = str(float(np.degrees(float(cells[j]))))
        out_lines.append(",".join(cells) + "\n")
    path = tmp_path / "deg.csv"
    path.write_text("".join(out_lines))
    assert header[1] == "shoulder_pan_joint"
    calibrate = ["calibrate", "--robot", "ur5", "--tool", "paper_tool"]
    assert main([*calibrate, str(ur5_recording), "-o", str(tmp_path / "rad.yaml")]) == 0
    capsys.readouterr()
    # the default (--joint-unit auto): found in degrees by the clock check's rule (57x the velocity limits), converted, said
    assert main([*calibrate, str(path), "-o", str(tmp_path / "c.yaml")]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[1].startswith("joints: degrees (--joint-unit auto: |wrist_3_joint| up to 180, beyond a turn in rad,"), out
    degrees, rad = load_calibration(tmp_path / "c.yaml"), load_calibration(tmp_path / "rad.yaml")
    np.testing.assert_allclose(degrees.C, rad.C, rtol=0, atol=1e-12 * np.abs(rad.C).max())  # the same samples, the same sums
    # rad forced: refused before anything is solved, naming the unit
    assert main([*calibrate, str(path), "-o", str(tmp_path / "r.yaml"), "--joint-unit", "rad"]) == ExitCode.RECORDING
    captured = capsys.readouterr()
    assert "the joint columns look like degrees" in captured.err and "--joint-unit deg" in captured.err
    # degrees given, the old way too (warned)
    assert main([*calibrate, str(path), "-o", str(tmp_path / "d.yaml"), "--joint-unit", "deg"]) == 0
    assert main([*calibrate, str(path), "-o", str(tmp_path / "o.yaml"), "--joints-in-degrees"]) == 0
    assert "--joints-in-degrees is now --joint-unit deg" in capsys.readouterr().err


def test_a_robot_with_continuous_joints_calibrates(tmp_path, capsys):
    """Kinova's Gen3 has continuous joints: the clock check and the filter unwrap them."""
    from fts_calib.app.exit_codes import ExitCode
    from fts_calib.core.resources import data_dir

    recording = tmp_path / "kinova.csv"
    assert (
        main(
            [
                "simulate",
                "--robot",
                "kinova",
                "--tool",
                "paper_tool",
                "--trajectory",
                str(data_dir("trajectories") / "kinova"),
                "-o",
                str(recording),
            ]
        )
        == 0
    )
    assert (
        main(["calibrate", "--robot", "kinova", "--tool", "paper_tool", str(recording), "-o", str(tmp_path / "cal.yaml"), "--quiet"])
        == ExitCode.OK
    )
    assert "fit consistent" in capsys.readouterr().out
    assert load_calibration(tmp_path / "cal.yaml").quality.rank == 7


def test_the_default_filter_keeps_the_still_samples_of_a_recording_with_stops_and_says_so(ur5_recording, ur5, paper_tool):
    """filter.mode auto (the shipped default): a recording with stops is the quasi-static filter's, as before, and the result says why."""
    from fts_calib.filters.settings import PipelineConfig

    auto = calibrate_recording(ur5_recording, ur5, paper_tool, PipelineConfig())
    forced = calibrate_recording(ur5_recording, ur5, paper_tool, PipelineConfig().with_filter_mode("quasi-static"))
    assert auto.decided == (
        "filter: quasi-static (--filter auto: the arm holds still at its stops; --filter dynamic calibrates the moving samples too)",
    )
    assert not forced.decided and auto.session.settings.filter.mode == "quasi-static"
    np.testing.assert_array_equal(auto.calibration.C, forced.calibration.C)


def test_quiet_prints_the_verdict_and_the_file(ur5_recording, tmp_path, capsys):
    """``--quiet`` once printed the whole summary (54 lines): now the fit verdict with the budget's largest error, and the file."""
    out = tmp_path / "cal.yaml"
    common = ["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(ur5_recording), "-o", str(out)]
    assert main(common) == 0
    whole = capsys.readouterr()
    assert main([*common, "--quiet"]) == 0
    quiet = capsys.readouterr()
    lines = quiet.out.splitlines()
    assert len(lines) == 2 and quiet.err == "" and lines[1] == f"wrote {out}", quiet
    verdict = next(line for line in whole.out.splitlines() if line.startswith("fit consistent: "))
    head, _, largest = lines[0].rpartition("; largest error ")
    assert head == verdict and largest.endswith(" % of full scale"), lines[0]
    budget = load_calibration(out).quality.budget
    assert float(largest.split()[0]) == pytest.approx(budget["largest_percent_fs"], abs=1e-4)
    assert len(whole.out.splitlines()) > 20


def test_the_progress_bar_logs_quarters_of_a_long_file_only():
    """Into a file or a pipe: a line per quarter of a recording of LOG_BYTES or more; a short one shows none (so that
    the summary of a short run is all its output, without --quiet)."""
    import io

    from fts_calib.app.calibrate import LOG_BYTES, ProgressBar

    for size, lines in ((1e6, 0), (LOG_BYTES, 4)):
        log = io.StringIO()
        bar = ProgressBar(size, "rows", log)
        for k in range(1, 101):
            bar.update(size * k / 100, 1000 * k)
        bar.close()
        assert len(log.getvalue().splitlines()) == lines and "\r" not in log.getvalue(), (size, log.getvalue())

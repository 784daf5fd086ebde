"""Bad input answered in one clear line: a wrong clock, one wild value, damaged files, typos in YAML.

Each test is a case of issue 12 that failed before: a traceback, a silent acceptance, a
run lost to one cell, or a message that sent the user the wrong way. Recordings are
variants of the small simulated UR5 recording of ``conftest.py`` (9,012 rows at 100 Hz).
"""

import dataclasses
import gzip
import shutil
import warnings

import numpy as np
import pytest

from fts_calib import ConfigError, FileFormatError, FtsCalibWarning, Kinematics, RecordingError
from fts_calib.app.cli import main
from fts_calib.app.exit_codes import ExitCode
from fts_calib.core.resources import resolve
from fts_calib.filters.clock import check_clock
from fts_calib.filters.sample_checks import NON_FINITE, OUT_OF_RANGE, SampleChecks
from fts_calib.filters.settings import PipelineConfig, load_pipeline_config
from fts_calib.model.sensor_config import load_sensor_config
from fts_calib.robot.definition import load_robot
from fts_calib.robot.tool import load_tool
from fts_calib.session.calibration_run import calibrate_recording
from fts_calib.sources.batch import SampleBatch
from fts_calib.sources.recording import RecordingReader

STRAIN_3 = 9  # column index of strain_3 in the UR5 recording (time, 6 joints, strains)


def _cells(line):
    return line.rstrip("\n").split(",")


def _join(cells):
    return ",".join(cells) + "\n"


def _variant(tmp_path, source, name, change=None, rows=None):
    """A copy of ``source`` whose data rows went through ``change(cells)`` (or are ``rows``)."""
    lines = source.read_text().splitlines(keepends=True)
    body = lines[1:] if rows is None else rows
    if change is not None:
        body = [_join(change(_cells(line))) for line in body]
    path = tmp_path / name
    path.write_text(lines[0] + "".join(body))
    return path


def _retime(factor=1.0, fn=None):
    def change(cells):
        t = float(cells[0])
        cells[0] = repr(fn(t) if fn else t * factor)
        return cells

    return change


def _one_error_line(capsys):
    """Stderr of a failed command: exactly one line, the error."""
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


def _calibrate(path, tmp_path, *extra):
    return main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(path), "-o", str(tmp_path / "cal.yaml"), *extra])


# -- clock sanity ------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("name", "change", "expected"),
    [
        ("ms.csv", _retime(1e3), "the time column looks like ms (0.01 s, 100 Hz when read as ms); write the time in s (divide it by 1000)"),
        ("us.csv", _retime(1e6), "the time column looks like µs"),
        ("equal.csv", _retime(fn=lambda t: 0.0), "all 9,012 time stamps of the first rows are equal"),
        ("coarse.csv", _retime(fn=lambda t: float(np.floor(10 * t) / 10)), "the clock ticks every 0.1 s (90 % of consecutive rows"),
        ("fast.csv", _retime(1e-2), "the time column advances too slowly for the motion"),
    ],
)
def test_a_wrong_clock_is_refused_before_the_calibration_is_written(tmp_path, ur5_recording, capsys, name, change, expected):
    """Before: the filter kept 77-100 % of the samples (moving ones too) and C was 6-8 % off, exit 0."""
    path = _variant(tmp_path, ur5_recording, name, change)
    assert _calibrate(path, tmp_path) == ExitCode.RECORDING
    line = _one_error_line(capsys)
    assert f"{name}, column 'time': " in line and expected in line, line
    assert not (tmp_path / "cal.yaml").exists()


def test_a_sound_clock_passes_and_a_glitch_does_not_trip_the_speed_rule(ur5, ur5_recording):
    with RecordingReader(ur5_recording, ur5.joint_names, None) as reader:
        first = next(iter(reader))
    assert check_clock(ur5_recording, first.time, first.joints, ur5, PipelineConfig().filter).period_s == pytest.approx(0.01)
    joints = first.joints.copy()
    joints[4000:4003, 5] += 3.0  # three corrupt readings: 300 rad/s for a moment, not a wrong clock
    assert check_clock(ur5_recording, first.time, joints, ur5, PipelineConfig().filter).max_speed_ratio < 2


def test_joint_columns_in_degrees_are_named_as_such(ur5, ur5_recording):
    with RecordingReader(ur5_recording, ur5.joint_names, None) as reader:
        first = next(iter(reader))
    with pytest.raises(RecordingError, match=r"the joint columns look like degrees .* give --joint-unit deg") as caught:
        check_clock(ur5_recording, first.time, np.degrees(first.joints), ur5, PipelineConfig().filter)
    assert caught.value.column in ur5.joint_names


def test_joint_columns_in_degrees_are_found_when_the_unit_is_not_given(ur5, ur5_recording):
    """The refusal's rule, as a decision: degrees found (and said), converted; rad read as it is; a unit given taken as given."""
    from fts_calib.filters.clock import clock_checked, degrees_found

    with RecordingReader(ur5_recording, ur5.joint_names, None) as reader:
        chunks = list(reader)
    degrees = [dataclasses.replace(c, joints=np.degrees(c.joints)) for c in chunks]
    assert degrees_found(chunks[0].time, chunks[0].joints, ur5) == ""
    said = []
    converted = list(clock_checked(ur5_recording, degrees, ur5, PipelineConfig().filter, None, said.append))
    assert len(said) == 1 and said[0].startswith("|wrist_3_joint| up to 180, beyond a turn in rad, moving at "), said
    np.testing.assert_allclose(converted[0].joints, chunks[0].joints, rtol=0, atol=1e-12)
    assert list(clock_checked(ur5_recording, chunks, ur5, PipelineConfig().filter, None, said.append))[0] is chunks[0]
    assert len(said) == 1  # rad: nothing said
    with pytest.raises(RecordingError, match="look like degrees"):
        list(clock_checked(ur5_recording, degrees, ur5, PipelineConfig().filter, False))


# -- one bad value never loses a run -----------------------------------------------------


def test_one_wild_strain_cell_is_one_bad_sample_not_a_lost_run(tmp_path, ur5, paper_tool, ur5_recording):
    """Before: one cell of 1e160 made every still sample of its window "not stationary": 0 kept."""
    row = 3000
    rows = ur5_recording.read_text().splitlines(keepends=True)[1:]
    cells = _cells(rows[row])
    cells[STRAIN_3] = "1e160"
    rows[row] = _join(cells)
    path = _variant(tmp_path, ur5_recording, "wild.csv", rows=rows)
    clean, wild = calibrate_recording(ur5_recording, ur5, paper_tool), calibrate_recording(path, ur5, paper_tool)
    assert wild.session.skipped[OUT_OF_RANGE] == 1
    assert any(f"line {row + 2}: column 'strain_3': 1e+160 is beyond" in p for p in wild.problems), wild.problems
    # the kept samples differ at most within the filter's windows around that row (0.15 s at 100 Hz)
    kept_clean, kept_wild = clean.session.progress().kept, wild.session.progress().kept
    assert abs(kept_clean - kept_wild) <= 15, (kept_clean, kept_wild)
    difference = np.abs(wild.calibration.C - clean.calibration.C)
    assert np.all(difference <= clean.calibration.quality.stderr_C), difference.max()


def test_the_checks_count_a_channel_out_of_range_and_an_inf_is_no_degree(ur5):
    checks = SampleChecks(ur5, max_abs_channel=1e3)
    n = 5
    joints = np.zeros((n, ur5.n_joints))
    joints[1, 0] = np.inf
    channels = np.zeros((n, 8))
    channels[3, 2] = 1e4
    batch = SampleBatch(np.arange(n) * 0.01, joints, channels, np.zeros(n, dtype=np.int64))
    with warnings.catch_warnings():
        warnings.simplefilter("error", FtsCalibWarning)  # before: "joint readings look like degrees"
        ok = checks.accept(batch)
    assert ok.tolist() == [True, False, True, False, True]
    assert checks.skipped == {NON_FINITE: 1, OUT_OF_RANGE: 1}


def test_the_plausible_channel_range_is_a_pipeline_setting(tmp_path):
    assert PipelineConfig().checks.max_abs_channel == 1e9
    path = tmp_path / "pipeline.yaml"
    path.write_text("checks:\n  max_abs_channel: 50.0\n")
    assert load_pipeline_config(path).checks.max_abs_channel == 50.0
    path.write_text("checks:\n  max_abs_channel: 0\n")
    with pytest.raises(FileFormatError, match=r"field 'checks.max_abs_channel': is 0.0 but expected a finite value > 0"):
        load_pipeline_config(path)
    assert load_pipeline_config(resolve("pipeline", "configs")).checks.max_abs_channel == 1e9


# -- no traceback, one clear line --------------------------------------------------------


def test_a_truncated_csv_gz_is_one_line(tmp_path, ur5_recording, capsys):
    packed = gzip.compress(ur5_recording.read_bytes())
    path = tmp_path / "cut.csv.gz"
    path.write_bytes(packed[: len(packed) // 2])
    assert _calibrate(path, tmp_path) == ExitCode.RECORDING
    line = _one_error_line(capsys)
    assert "cut.csv.gz: the compressed stream ends before its end marker: the file is truncated" in line, line
    assert "gzip -dc cut.csv.gz > recovered.csv" in line


def test_a_binary_calibration_file_is_one_line(tmp_path, ur5_recording, capsys):
    path = tmp_path / "cal.yaml"
    path.write_bytes(bytes(range(256)) * 4)
    assert main(["validate", "--robot", "ur5", "--calibration", str(path), str(ur5_recording)]) == ExitCode.FILE
    assert "cal.yaml: not a text file (byte 0x80 at offset 128 is not UTF-8): expected YAML" in _one_error_line(capsys)


@pytest.mark.parametrize(
    ("option", "expected"), [(["--speed", "-1"], "speed=-1.0 but expected"), (["--loss", "1.5"], "loss=1.5 but expected a fraction")]
)
def test_replay_options_out_of_range_are_one_line(ur5_recording, capsys, option, expected):
    assert main(["replay", str(ur5_recording), "--to", "127.0.0.1:9", *option]) == ExitCode.CONFIG
    assert expected in _one_error_line(capsys)


def test_trajectory_with_a_sensor_file_without_simulation_names_the_file(tmp_path, capsys):
    path = tmp_path / "plain_sensor.yaml"
    path.write_text("name: plain\nstrain_unit: mV/V\nfull_scale: {force: 50.0, moment: 5.0}\n")
    assert (
        main(["trajectory", "--robot", "ur5", "--tool", "paper_tool", "--sensor", str(path), "-o", str(tmp_path / "t"), "--no-plot"])
        == ExitCode.FILE
    )
    assert "plain_sensor.yaml: field 'simulation': missing: the excitation report needs" in _one_error_line(capsys)
    assert not (tmp_path / "t").exists()


def test_validate_over_no_usable_sample_fails(tmp_path, ur5_recording, capsys):
    """Before: exit 0 with every error printed as 0."""
    calibration = str(resolve("paper_table1_calibration", "configs"))
    args = ["validate", "--robot", "ur5", "--tool", "validation_tool", "--calibration", calibration, str(ur5_recording)]
    assert main([*args, "--max-error", "0.2"]) == ExitCode.CHECK_FAILED  # the rows are of A, B, C: none of V
    line = _one_error_line(capsys)
    assert "no sample was compared: every row was skipped (unknown tool configuration: 9,012)" in line, line


def test_bad_cells_are_named_with_their_lines_and_the_notes_end_with_how_many_more(tmp_path, ur5_recording, capsys):
    rows = ur5_recording.read_text().splitlines(keepends=True)[1:]
    for k in range(100, 2100, 100):  # 20 NaN strains
        cells = _cells(rows[k])
        cells[STRAIN_3] = "nan"
        rows[k] = _join(cells)
    cells = _cells(rows[50])
    cells[2] = "inf"  # a joint
    rows[50] = _join(cells)
    rows[61] = rows[40]  # time goes backwards at line 63
    path = _variant(tmp_path, ur5_recording, "cells.csv", rows=rows)
    assert _calibrate(path, tmp_path) == ExitCode.OK
    captured = capsys.readouterr()
    assert "look like degrees" not in captured.err, captured.err  # before: inf was taken for degrees
    notes = [line.strip() for line in captured.out.splitlines() if line.strip().startswith("note:")]
    assert notes[0].endswith("cells.csv, line 52: column 'shoulder_lift_joint': inf is not a finite number; the sample is skipped")
    assert "line 63: column 'time': 0.4 s is earlier than 0.6 s before it (time going backwards)" in notes[1]
    assert "line 102: column 'strain_3': nan is not a finite number" in notes[2]
    assert len(notes) == 11 and notes[-1] == "note: and 12 more problem(s) not listed (the counts by reason are complete)"


def test_a_header_only_file_says_it_has_no_data_rows(tmp_path, ur5_recording, capsys):
    path = _variant(tmp_path, ur5_recording, "header.csv", rows=[])
    assert _calibrate(path, tmp_path) == ExitCode.RECORDING
    line = _one_error_line(capsys)
    assert "header.csv, line 2: no data rows" in line and "hold the arm still" not in line


def test_a_semicolon_delimited_file_gets_a_hint(tmp_path, ur5_recording, capsys):
    path = tmp_path / "semi.csv"
    path.write_text("".join(line.replace(",", ";") for line in ur5_recording.read_text().splitlines(keepends=True)[:20]))
    assert _calibrate(path, tmp_path) == ExitCode.RECORDING
    assert "the file is delimited by ';', but a recording is comma-separated" in _one_error_line(capsys)


def test_a_gzip_file_named_csv_and_a_bom_header_are_read(tmp_path, ur5, paper_tool, ur5_recording):
    named = tmp_path / "packed.csv"
    with open(ur5_recording, "rb") as source, gzip.open(named, "wb") as target:
        shutil.copyfileobj(source, target)
    with pytest.warns(FtsCalibWarning, match="packed.csv: the file is gzip-compressed although its name ends in '.csv'"):
        assert calibrate_recording(named, ur5, paper_tool).calibration is not None
    bom = tmp_path / "bom.csv"
    bom.write_bytes(b"\xef\xbb\xbf" + ur5_recording.read_bytes())  # Excel's "CSV UTF-8"
    with RecordingReader(bom, ur5.joint_names, paper_tool.names) as reader:
        assert sum(len(chunk) for chunk in reader) == 9012


# -- YAML: typos and degrees are refused ---------------------------------------------------


def test_an_unknown_tool_key_is_refused_with_the_known_keys(tmp_path):
    path = tmp_path / "tool.yaml"
    path.write_text("name: t\nconfigurations:\n  - {name: A, mass: 1.0, mas: 2.0, com: [0.1, 0, 0]}\n")
    with pytest.raises(FileFormatError, match=r"field 'configurations\[0\]': unknown keys \['mas'\] \('mas': did you mean 'mass'\?\)"):
        load_tool(path)
    path.write_text("name: t\ngravty: 9.8\nconfigurations:\n  - {name: A, mass: 1.0, com: [0.1, 0, 0]}\n")
    with pytest.raises(FileFormatError, match=r"tool.yaml: unknown keys \['gravty'\].*known keys: name, gravity, shape, configurations"):
        load_tool(path)


def _robot_file(tmp_path, sensor="  rpy: [-pi/2, -pi/2, 0.0]\n", extra=""):
    ur5 = resolve("ur5", "robots").read_text()
    text = ur5.replace("  rpy: [-pi/2, -pi/2, 0.0]     # S: X = flange Z (tool axis), Y = flange X, Z = flange Y\n", sensor)
    path = tmp_path / "robot.yaml"
    path.write_text(text + extra)
    return path


def test_a_sensor_rpy_in_degrees_and_an_unknown_robot_key_are_refused(tmp_path):
    assert load_robot(_robot_file(tmp_path)).sensor.rpy[0] == pytest.approx(-np.pi / 2)  # the edit keeps a sound file sound
    with pytest.raises(FileFormatError, match=r"field 'sensor.rpy': is \[-90.0, -90.0, 0.0\] rad, beyond ±2π: it looks like degrees"):
        load_robot(_robot_file(tmp_path, "  rpy: [-90, -90, 0]\n"))
    with pytest.raises(FileFormatError, match=r"field 'sensor': unknown keys \['rpz'\]"):
        load_robot(_robot_file(tmp_path, "  rpz: [0, 0, 0]\n"))
    with pytest.raises(FileFormatError, match=r"unknown keys \['home_pose'\].*known keys: name, urdf, sensor"):
        load_robot(_robot_file(tmp_path, extra="home_pose: {}\n"))


def test_a_sensor_mount_in_mm_is_refused_from_the_file_and_from_python(tmp_path, ur5):
    """Before: xyz [0, 0, 20] (mm for 2 cm) put the sensor 20 m from the flange and the calibration exited 0."""
    ur5_file = resolve("ur5", "robots").read_text()
    assert "  xyz: [0.0, 0.0, 0.02]" in ur5_file
    path = tmp_path / "robot.yaml"
    path.write_text(ur5_file.replace("  xyz: [0.0, 0.0, 0.02]", "  xyz: [0.0, 0.0, 20]"))
    with pytest.raises(
        FileFormatError, match=r"field 'sensor.xyz': is \[0.0, 0.0, 20.0\] m from the frame: it looks like mm; .*\[0.0, 0.0, 0.02\]"
    ):
        load_robot(path)
    with pytest.raises(ConfigError, match=r"xyz is \[0.0, 0.0, 20.0\] m from the frame: it looks like mm"):
        Kinematics.from_urdf(ur5.robot.urdf, "tool0", xyz=(0.0, 0.0, 20.0))
    path.write_text(ur5_file)
    assert load_robot(path).sensor.xyz[2] == 0.02  # [m] the file as shipped loads


def test_unknown_keys_of_sensor_and_pipeline_files_are_refused(tmp_path):
    sensor = tmp_path / "sensor.yaml"
    sensor.write_text(resolve("sensor", "configs").read_text().replace("  noise_std:", "  noise_sdt:"))
    with pytest.raises(
        FileFormatError, match=r"field 'simulation': unknown keys \['noise_sdt'\] \('noise_sdt': did you mean 'noise_std'\?\)"
    ):
        load_sensor_config(sensor)
    pipeline = tmp_path / "pipeline.yaml"
    pipeline.write_text("design:\n  noise: 1.0e-5\n")
    with pytest.raises(FileFormatError, match=r"field 'design': unknown keys \['noise'\].*known keys: noise_std"):
        load_pipeline_config(pipeline)


def test_a_recording_whose_every_row_is_skipped_says_so_not_hold_the_arm_still(tmp_path, ur5_recording, capsys):
    """Before: a temperature column of text (every row malformed) ended with 'hold the arm still at the stops'."""
    lines = ur5_recording.read_text().splitlines()
    path = tmp_path / "warm.csv"
    path.write_text("\n".join([lines[0] + ",temperature", *[line + ",warm" for line in lines[1:]]]) + "\n")
    assert _calibrate(path, tmp_path) == ExitCode.EXCITATION
    out = capsys.readouterr().out
    assert "warm.csv, line 2: column 'temperature': 'warm' is not a number" in out, out
    expected = "NO CALIBRATION: no usable sample: every row was skipped before the filter (malformed line: 9,012); the notes above"
    assert expected in out and "hold the arm still" not in out, out
    assert not (tmp_path / "cal.yaml").exists()


def test_a_temperature_in_kelvin_is_warned_about_once_and_its_samples_are_kept(ur5):
    """Before: 298 'degrees C' went into the calibration file's temperature_C fields without a word."""
    n = 5
    batch = SampleBatch(np.arange(n) * 0.01, np.zeros((n, ur5.n_joints)), np.zeros((n, 8)), np.zeros(n, dtype=np.int64))
    checks = SampleChecks(ur5)
    kelvin = SampleBatch(batch.time, batch.joints, batch.channels, batch.configuration, np.full(n, 298.15))
    with pytest.warns(FtsCalibWarning, match=r"temperature 298.15 °C is beyond what a sensor can have \(-40 to 125 °C\).*kelvin"):
        assert checks.accept(kelvin).all()
    with warnings.catch_warnings():
        warnings.simplefilter("error", FtsCalibWarning)
        later = SampleBatch(batch.time + 1.0, batch.joints, batch.channels, batch.configuration, np.full(n, 300.0))
        assert checks.accept(later).all()  # once per stream
        # a warm sensor, or 77 °F taken for °C: within the range, not to be told apart
        warm = SampleBatch(batch.time, batch.joints, batch.channels, batch.configuration, np.full(n, 77.0))
        assert SampleChecks(ur5).accept(warm).all()


@pytest.mark.parametrize(
    ("option", "expected"),
    [
        (
            ["--sensor", "paper_tool"],
            "paper_tool.yaml: unknown keys ['gravity', 'shape', 'tolerance', 'configurations'] (it looks like a tool file",
        ),
        (["--sensor", "paper_table1_calibration"], "(it looks like a calibration file, not the kind of file expected here)"),
        (["--tool", "sensor"], "sensor.yaml: unknown keys ['strain_unit', 'full_scale', 'rate_hz', 'simulation'] (it looks like a sensor"),
    ],
)
def test_a_file_of_another_kind_given_to_an_option_is_named_as_such(tmp_path, ur5_recording, capsys, option, expected):
    """Before: only the unknown keys, which read as typos in a file the user did not mean to give."""
    assert _calibrate(ur5_recording, tmp_path, *option) == ExitCode.FILE
    line = _one_error_line(capsys)
    assert expected in line, line
    assert not (tmp_path / "cal.yaml").exists()


def test_a_urdf_a_folder_or_a_mistyped_tool_name_is_named_as_such(tmp_path, ur5, ur5_recording, capsys):
    """Before: 'not valid YAML at line 310', 'no file' for a folder, and a tool list holding sensors and calibrations."""
    cases = [
        (["--robot", str(ur5.robot.urdf)], "ur5_robot.urdf: is a URDF, not a robot file: write a robot YAML that names it"),
        (["--robot", str(tmp_path)], f"{tmp_path}: is a folder, not a robot YAML file"),
        (
            ["--robot", "ur5", "--tool", "papertool"],
            "no file 'papertool' and no shipped tool of that name; shipped: paper_tool, validation_tool\n",
        ),
        (["--robot", "ur5", "--tool", str(tmp_path / "my_tool.yaml")], "my_tool.yaml: file not found"),
    ]
    for options, expected in cases:
        command = ["calibrate", *options, *(["--tool", "paper_tool"] if "--tool" not in options else [])]
        assert main([*command, str(ur5_recording), "-o", str(tmp_path / "cal.yaml")]) == ExitCode.FILE, options
        line = _one_error_line(capsys) + "\n"  # the end of the line: nothing listed after the tools
        assert line.startswith("fts-calib calibrate: error: ") and expected in line, line
    assert not (tmp_path / "cal.yaml").exists()


def test_a_mistyped_parent_frame_names_the_robot_file_its_field_and_the_closest_frame(tmp_path, ur5_recording, capsys):
    path = tmp_path / "robot.yaml"
    path.write_text(resolve("ur5", "robots").read_text().replace("parent_frame: tool0", "parent_frame: tool_0"))
    assert (
        main(["calibrate", "--robot", str(path), "--tool", "paper_tool", str(ur5_recording), "-o", str(tmp_path / "c.yaml")])
        == ExitCode.ROBOT
    )
    line = _one_error_line(capsys)
    assert line.startswith(f"fts-calib calibrate: error: {path}: field 'sensor.parent_frame': frame 'tool_0' is not in the model "), line
    assert "(did you mean 'tool0'?); frames that exist: universe, world" in line, line

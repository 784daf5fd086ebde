"""ATI calibration files: import (units to SI), export round trip, bad files, and a factory matrix re-calibrated in situ.

The fixture files are written here, in the structure ATI ships (FTSensor > Calibration >
Axis, BasicTransform, UserAxis); the numbers are made up, of the size of a Mini45's.
"""

import numpy as np
import pytest

from fts_calib.app.cli import main
from fts_calib.app.exit_codes import ExitCode
from fts_calib.core.exceptions import FileFormatError
from fts_calib.core.resources import resolve
from fts_calib.model.calibration import load_calibration
from fts_calib.model.sensor_config import SimulationSpec
from fts_calib.service.ati import AXIS_NAMES, ati_text, load_ati_calibration, read_calibration
from fts_calib.service.validation import validate_recording
from fts_calib.sim.sensor import SimulatedSensor

#: A factory matrix of six gauges, [N per V] (rows Fx Fy Fz) and [N m per V] (rows Tx Ty Tz).
FACTORY_SI = np.array(
    [
        [0.35, 0.12, -1.10, -45.20, 0.80, 44.90],
        [1.40, 52.30, -0.60, -26.10, -0.30, -25.80],
        [66.10, -0.90, 65.40, -1.20, 66.80, -0.70],
        [0.0150, 0.3780, -1.0890, -0.2090, 1.0740, -0.1830],
        [1.2510, -0.0210, -0.6330, 0.3090, -0.6160, -0.2880],
        [0.0260, -0.6450, 0.0180, -0.6380, 0.0310, -0.6520],
    ]
)
RATED_SI = np.array([290.0, 290.0, 580.0, 10.0, 10.0, 10.0])  # [N, N, N, N m, N m, N m]
LBF, INCH = 4.4482216152605, 0.0254  # [N], [m]


def cal_file(path, matrix_si=FACTORY_SI, force="N", torque="N-mm", force_scale=1.0, torque_scale=1e-3, rated=RATED_SI):
    """Write an ATI-style file whose UserAxis rows are ``matrix_si`` in the given units."""
    rows = []
    for k, (name, row, r) in enumerate(zip(AXIS_NAMES, matrix_si, rated, strict=True)):
        scale = force_scale if k < 3 else torque_scale
        values = " ".join(repr(float(v / scale)) for v in row)
        rows.append(f'    <UserAxis Name="{name}" values=" {values} " max="{float(r / scale)!r}"/>')
    path.write_text(
        '<?xml version="1.0" encoding="utf-8"?>\n'
        "<!-- NOTE: use the UserAxis elements to construct the calibration matrix. -->\n"
        '<FTSensor Serial="FT99999" BodyStyle="Mini45" Family="DAQ" NumGages="6" CalFileVersion="1.1">\n'
        f'  <Calibration PartNumber="SI-290-10" CalDate="1/2/2026" ForceUnits="{force}" TorqueUnits="{torque}" DistUnits="mm">\n'
        '    <Axis Name="Fx" values=" 1 2 3 4 5 6 " max="290" scale="5.0"/>\n'
        '    <BasicTransform Dx="0" Dy="0" Dz="12.5" Rx="0" Ry="0" Rz="0"/>\n' + "\n".join(rows) + "\n  </Calibration>\n</FTSensor>\n"
    )
    return path


def test_import_normalises_the_units_to_si(tmp_path):
    metric = load_ati_calibration(cal_file(tmp_path / "n.cal"))
    imperial = load_ati_calibration(cal_file(tmp_path / "lbf.cal", force="lbf", torque="lbf-in", force_scale=LBF, torque_scale=LBF * INCH))
    for ati in (metric, imperial):
        # the file holds each value divided by its unit; reading multiplies back: 2 roundings
        np.testing.assert_allclose(ati.matrix, FACTORY_SI, rtol=0, atol=4e-16 * np.abs(FACTORY_SI).max())
        np.testing.assert_allclose(ati.max, RATED_SI, rtol=4e-16)
    assert (metric.serial, metric.body_style, metric.torque_units) == ("FT99999", "Mini45", "N-mm")
    calibration = metric.calibration()
    assert calibration.layout.name == "projection" and calibration.layout.n_channels == 6
    np.testing.assert_array_equal(calibration.C_bar, np.eye(6))
    np.testing.assert_array_equal(calibration.C, metric.matrix)  # C = P: the factory matrix
    assert calibration.provenance["sensor"]["serial"] == "FT99999"


def test_export_then_import_gives_the_same_matrix(tmp_path, rng):
    ati = load_ati_calibration(cal_file(tmp_path / "f.cal"))
    from fts_calib import Calibration

    ours = Calibration(np.eye(6) + 0.01 * rng.standard_normal((6, 6)), rng.standard_normal(6), layout=ati.layout)
    (tmp_path / "ours.cal").write_text(ati_text(ours, RATED_SI, serial="FT99999"))
    again = read_calibration(tmp_path / "ours.cal")
    np.testing.assert_array_equal(again.C, ours.C)  # repr of each value: exact
    np.testing.assert_array_equal(load_ati_calibration(tmp_path / "ours.cal").max, RATED_SI)
    assert "Offsets D, not part of this format" in (tmp_path / "ours.cal").read_text()


@pytest.mark.parametrize(
    ("edit", "words"),
    [
        (lambda t: t.replace('<UserAxis Name="Fz"', '<Other Name="Fz"'), r"UserAxis\[Fz\]'.*missing: expected UserAxis Fz"),
        (
            lambda t: t.replace("-45.2 ", "", 1),
            r"UserAxis\[Fx\].values'.*line \d+: 5 numbers but NumGages is 6",
        ),
        (lambda t: t.replace('TorqueUnits="N-m"', 'TorqueUnits="ozf-in"'), r"TorqueUnits'.*'ozf-in' but expected one of n-m, n-mm"),
        (lambda t: t.replace("</Calibration>", "</Calib>"), r"line 13, column \d+: not valid XML \(mismatched tag\)"),
        (lambda t: t.replace("FTSensor", "Sensor"), r"root element is <Sensor> but expected <FTSensor>"),
        (lambda t: t.replace('max="0.0145', 'max="-1'), r"UserAxis\[Tx\].max'.*expected a rated range > 0"),
        (lambda t: t.replace("-0.6 -26.1", "nan -26.1"), r"UserAxis\[Fy\].values': line 8: a value is not finite"),
        (  # Fy a copy of Fx: before, 'projection=rank 5' (exit 3) without the file's name
            lambda t: t.replace("1.4 52.3 -0.6 -26.1 -0.3 -25.8", "0.35 0.12 -1.1 -45.2 0.8 44.9"),
            r"f.cal: field 'UserAxis': the matrix has rank 5 but expected full row rank 6",
        ),
    ],
)
def test_bad_files_name_the_element_and_line(tmp_path, edit, words):
    path = cal_file(tmp_path / "f.cal", torque="N-m", torque_scale=1.0, rated=np.array([290.0, 290.0, 580.0, 0.0145, 10.0, 10.0]))
    path.write_text(edit(path.read_text()))
    with pytest.raises(FileFormatError, match=words):
        load_ati_calibration(path)


@pytest.fixture(scope="module")
def gauge_run(tmp_path_factory, short_plan, seed):
    """A recording of raw gauge voltages of a sensor whose factory matrix is 3 % off and rotated by 2°."""
    from fts_calib.planning.trajectory_files import TrajectoryFile
    from fts_calib.robot.definition import load_robot
    from fts_calib.robot.kinematics import Kinematics
    from fts_calib.robot.tool import load_tool
    from fts_calib.sim.runs import simulate_recording
    from fts_calib.sim.sensor import load_simulated_sensor

    folder = tmp_path_factory.mktemp("ati")
    ati = load_ati_calibration(cal_file(folder / "FT99999.cal"))
    truth = load_simulated_sensor(resolve("factory_sensor", "configs"))  # C_bar: 3 %, 2°, and offsets
    sensor = SimulatedSensor.from_spec(SimulationSpec(truth.C_bar, truth.D, noise_std=2e-4, layout=ati.layout))  # [V]
    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    tool = load_tool(resolve("paper_tool", "configs"))
    p = short_plan
    trajectories = [TrajectoryFile(p.joint_names, p.time, p.q, p.qd, p.qdd, c.name) for c in tool.configurations]
    recording = simulate_recording(folder / "gauges.csv", kin, tool, trajectories, sensor, np.random.default_rng(seed))
    return folder / "FT99999.cal", recording, sensor, kin, tool


def test_the_factory_matrix_is_recalibrated_and_validated_against_the_file(tmp_path, gauge_run, capsys):
    cal, recording, truth, kin, tool = gauge_run
    out = tmp_path / "insitu.yaml"
    assert (
        main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(recording), "--sensor", str(cal), "-o", str(out), "--quiet"])
        == ExitCode.OK
    )
    ours = load_calibration(out)
    assert ours.layout == load_ati_calibration(cal).layout
    z = np.abs(ours.C_bar - truth.C_bar) / ours.quality.stderr_C_bar  # 36 coefficients at 5 sigma
    assert z.max() <= 5.0, z.max()
    factory = read_calibration(cal)
    result = validate_recording(recording, kin, tool, [ours, factory], load_ati_calibration(cal).max)
    # the moving tool's wrench against each: the factory file, untared and 3 % off, is 0.9 to
    # 2 N off; ours by the noise, 2e-4 V x 66 N/V = 0.013 N (and 5e-4 N m)
    mine, reference = result.errors
    assert np.all(mine.rms < reference.rms / 20), (mine.rms, reference.rms)
    capsys.readouterr()
    args = ["validate", "--calibration", str(out), "--reference", str(cal), "--robot", "ur5", "--tool", "paper_tool", "--sensor", str(cal)]
    assert main([*args, str(recording)]) == ExitCode.OK
    text = capsys.readouterr().out
    assert f"{out} against {cal}" in text and "full scale 290 N, 10 N·m" in text


def test_cli_exports_an_ati_file(tmp_path, gauge_run):
    cal, *_ = gauge_run
    out = tmp_path / "again.cal"
    assert main(["export", "--format", "ati", "--calibration", str(cal), "--sensor", str(cal), "-o", str(out)]) == ExitCode.OK
    np.testing.assert_array_equal(read_calibration(out).C, read_calibration(cal).C)


def test_two_configurations_and_the_factory_file_as_the_prior(tmp_path, gauge_run, capsys):
    """Without configuration C the tool's two centres of mass leave one direction that only
    strain noise fills: the plain solve is refused (rank 6 of 7, however noisy the sensor),
    and the factory file as the prior (lambda = 10) gives a calibration near the factory's."""
    cal, recording, truth, *_ = gauge_run
    lines = recording.read_text().splitlines(keepends=True)
    two = tmp_path / "ab.csv"
    two.write_text("".join([lines[0], *[line for line in lines[1:] if not line.rstrip().endswith(",C")]]))
    args = ["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(two), "--sensor", str(cal), "--offsets", "constant"]
    factory_error = np.abs(np.eye(6) - truth.C_bar).max()  # 0.0298
    assert main([*args, "-o", str(tmp_path / "plain.yaml")]) == ExitCode.EXCITATION
    assert "rank 6 of 7" in capsys.readouterr().out
    assert not (tmp_path / "plain.yaml").exists()
    assert main([*args, "-o", str(tmp_path / "prior.yaml"), "--prior", str(cal), "--prior-weight", "10"]) == ExitCode.OK
    assert f"prior {cal}, weight 10" in capsys.readouterr().out
    ours = load_calibration(tmp_path / "prior.yaml")
    assert 0.5 < ours.quality.prior["shrinkage"] < 1
    assert ours.quality.prior["rank_without_prior"] == 6
    assert np.abs(ours.C_bar - truth.C_bar).max() < 2 * factory_error, (np.abs(ours.C_bar - truth.C_bar).max(), factory_error)


def test_an_ati_export_with_the_sensor_of_another_channel_count_is_refused(tmp_path, capsys):
    """Before: the 8-channel calibration was written with the 6-gauge file's rated ranges as its max."""
    paper = resolve("paper_table1_calibration", "configs")  # 8 channels
    out = tmp_path / "out.cal"
    args = ["export", "--format", "ati", "--calibration", str(paper), "--sensor", str(cal_file(tmp_path / "f.cal")), "-o", str(out)]
    assert main(args) == ExitCode.CONFIG
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "has 8 channels (maltese-cross-8) but --sensor" in err[0] and "f.cal has 6 (projection)" in err[0], err
    assert not out.exists()

"""The one-page HTML report: its numbers against independent truths, refused runs, comparisons, a strict HTML5 parse.

The page is checked by :func:`check_page` (every section, nothing that leaves the file, a
strict HTML5 parse); the demo's page is also rendered in headless Chromium (test_demo.py).
"""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import numpy as np
import pytest

from fts_calib.app import cli
from fts_calib.app.exit_codes import ExitCode
from fts_calib.core.resources import resolve
from fts_calib.filters.settings import load_pipeline_config
from fts_calib.model.calibration import Calibration, load_calibration
from fts_calib.model.channels import channel_layout
from fts_calib.report.compare import CHANGE_SIGMAS, compare
from fts_calib.report.content import KeptCollector, ReportContent, model_selection, sphere_gap
from fts_calib.report.html import render_report
from fts_calib.robot.definition import load_robot
from fts_calib.robot.kinematics import Kinematics
from fts_calib.session.calibration_run import calibrate_recording

from .report_checks import check_page

#: The Fibonacci grid that probes the sphere has 1000 points about 6.4° apart: the largest gap
#: is found to within half that spacing.
GAP_TOLERANCE_DEG = 4.0
#: Size target of a report of the short run, [bytes].
MAX_REPORT_BYTES = 1_000_000


def test_sphere_gap_against_known_coverings():
    k = np.arange(20_000) + 0.5  # a dense Fibonacci covering: no gap
    z = 1 - 2 * k / len(k)
    phi = k * math.pi * (3 - math.sqrt(5))
    dense = np.column_stack([np.sqrt(1 - z**2) * np.cos(phi), np.sqrt(1 - z**2) * np.sin(phi), z])
    assert math.degrees(sphere_gap(dense)) < GAP_TOLERANCE_DEG
    half = dense[dense[:, 0] >= 0]  # a hemisphere: the pole -X is 90° from the nearest
    assert abs(math.degrees(sphere_gap(half)) - 90.0) < GAP_TOLERANCE_DEG
    one = np.array([[0.0, 0.0, 1.0]])  # one direction: its antipode is 180° away
    assert abs(math.degrees(sphere_gap(one)) - 180.0) < GAP_TOLERANCE_DEG
    assert sphere_gap(np.zeros((0, 3))) == math.pi


@pytest.fixture(scope="module")
def calibrated(ur5_recording, paper_tool):
    """The short UR5 recording calibrated, with its kept samples collected."""
    collector = KeptCollector()
    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    result = calibrate_recording(ur5_recording, kin, paper_tool, load_pipeline_config(resolve("pipeline", "configs")), on_kept=collector)
    assert result.calibration is not None, result.error
    return result, collector


def test_report_of_a_calibration(calibrated, tmp_path):
    result, collector = calibrated
    cal = result.calibration
    samples = collector.samples(cal)
    # the residuals recomputed sample by sample match the estimator's residual RMS (from its sums): the same samples and
    # model; the estimator weights samples by nothing but the filter, so the two agree to rounding
    rms = np.sqrt(np.mean(samples.residual**2, axis=0))
    np.testing.assert_allclose(rms, cal.quality.residual_rms, rtol=1e-3, err_msg="recomputed residual RMS vs the estimator's")
    # the known force is m g: its direction is a unit vector, its size the tool's weight
    weight = np.linalg.norm(samples.w_sensor[:, :3], axis=1)
    np.testing.assert_allclose(weight, 2.0 * 9.81, rtol=1e-9)
    content = ReportContent("a short run", cal, samples=samples, configurations=tuple(result.session.tool.names))
    page = render_report(content)
    check_page(page)
    assert len(page.encode()) < MAX_REPORT_BYTES
    verdict = page[page.index('<section id="verdict">') : page.index('<section id="sphere">')]
    assert "GOOD" in verdict and cal.quality.fit["verdict"] in verdict
    # the budget total shown is the file's, to its printed digits
    total = cal.quality.budget["largest_percent_fs"]
    assert f"{total:.4f} % FS" in verdict


def test_residuals_through_a_drift_model(ur5_recording, paper_tool):
    # the offsets forced to drift with time: the residuals through the file's offset model D(t, configuration) match the
    # estimator's residual RMS as the constant model's do (a wrong D(t) would leave the drift in them)
    collector = KeptCollector()
    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    settings = load_pipeline_config(resolve("pipeline", "configs")).with_offsets("drift")
    result = calibrate_recording(ur5_recording, kin, paper_tool, settings, on_kept=collector)
    cal = result.calibration
    assert cal is not None and cal.offset_model["model"] == "drift", cal.offset_model and cal.offset_model["model"]
    rms = np.sqrt(np.mean(collector.samples(cal).residual ** 2, axis=0))
    np.testing.assert_allclose(rms, cal.quality.residual_rms, rtol=1e-3, err_msg="residual RMS through D(t) vs the estimator's")


def test_model_selection_shows_what_the_file_holds(calibrated):
    cal = calibrated[0].calibration
    chosen, rows = model_selection(cal)  # today's files: the offset model's BIC candidates
    assert "constant" in chosen or cal.offset_model["model"] in chosen
    assert [r["model"] for r in rows] == [c["model"] for c in cal.offset_model["candidates"]]
    table = {
        "chosen": "quadratic",
        "candidates": [
            {"model": "linear", "held_out_rms": {"Fx": 0.011}, "parameters": 49},
            {"model": "quadratic", "held_out_rms": {"Fx": 0.004}, "parameters": 265, "chosen": True},
        ],
    }
    newer = dataclasses.replace(cal, extra={"model_selection": table})  # a newer file's table: its columns, whatever they are
    chosen, rows = model_selection(newer)
    assert chosen == "quadratic" and rows[1]["held_out_rms Fx"] == 0.004 and rows[0]["parameters"] == 49
    page = render_report(ReportContent("newer", newer))
    check_page(page)
    assert "held_out_rms Fx" in page and "265" in page
    assert "not recorded" in render_report(ReportContent("none", None, diagnosis="no sample"))


def _section(page: str, sid: str) -> str:
    start = page.index(f'<section id="{sid}">')
    return page[start : page.index("</section>", start)]


def test_the_region_section_draws_the_calibrated_loads_and_the_samples_beyond_them(calibrated):
    result, collector = calibrated
    cal = result.calibration
    region, samples = cal.region, collector.samples(cal)
    names = tuple(result.session.tool.names)
    section = _section(render_report(ReportContent("a short run", cal, samples=samples, configurations=names)), "region")
    # the numbers of the file, to their printed digits; the kept samples are the region: none outside
    assert f"|F| ≤ {region.force_max:.4g} N, |M| ≤ {region.moment_max:.4g} N·m, from the {region.samples:,} samples" in section
    assert f"<td>{region.low[1]:+.4g} N</td><td>{region.high[1]:+.4g} N</td>" in section
    assert f"0 of {len(samples.time):,} lie outside the region" in section
    # the same loads twice as heavy (a 4 kg tool): counted outside as the region's own rule says
    heavy = dataclasses.replace(samples, w_sensor=2.0 * samples.w_sensor, label="heavier samples")
    page = render_report(ReportContent("heavier", cal, samples=heavy, configurations=names))
    check_page(page)
    outside = int(np.count_nonzero(~region.contains(heavy.w_sensor)))
    assert outside == len(heavy.time)  # |F| = 39.2 N > 19.62 N + 0.87 N
    assert f"{outside:,} of {len(heavy.time):,} lie outside the region (red)" in _section(page, "region")
    bare = render_report(ReportContent("typed in", dataclasses.replace(cal, region=None)))
    assert "not recorded: the calibration records no load region" in _section(bare, "region")


def test_compare_against_noiseless_truths(calibrated):
    cal = calibrated[0].calibration
    q = cal.quality
    same = compare(cal, cal)
    assert not same.changed and np.all(same.z_C == 0) and np.all(same.wrench_difference == 0)
    # an offset shift of 2σ on Fx: z = 2/√2 (two equal σ), the wrench moves by exactly the shift everywhere in the box
    shift = np.zeros(6)
    shift[0] = 2 * q.stderr_D[0]
    moved = compare(dataclasses.replace(cal, D=cal.D + shift), cal)
    assert moved.z_D[0] == pytest.approx(2 / math.sqrt(2), rel=1e-12)
    np.testing.assert_allclose(moved.wrench_difference, np.abs(shift), atol=1e-12 * np.abs(cal.D).max())
    assert not moved.changed  # 1.4σ, and far below the budget
    # C scaled by (1 + eps): the difference is eps (W - D_old), largest at the box corner away from D_old
    eps = 1e-3
    scaled = dataclasses.replace(cal, C_bar=cal.C_bar * (1 + eps))
    change = compare(scaled, cal)
    expected = eps * (change.full_scale + np.abs(cal.D))
    np.testing.assert_allclose(change.wrench_difference, expected, rtol=1e-9)
    assert change.changed and np.max(np.abs(change.z_C)) > CHANGE_SIGMAS
    assert any("max |Δ|/σ" in r for r in change.reasons) and any("beyond the combined budget" in r for r in change.reasons)
    # the paper's two tables carry no standard errors: any change counts, and the page says so
    tables = [load_calibration(resolve(f"paper_table{k}_calibration", "configs")) for k in (1, 2)]
    typed = compare(tables[1], tables[0])
    assert typed.changed and "without standard errors" in typed.reasons[0]


def test_calibrate_writes_a_report_when_it_refuses(ur5_recording, tmp_path):
    # a mistyped mass in configuration B: the fit check refuses (exit 15) and the report says why, first
    text = Path(resolve("paper_tool", "configs")).read_text()
    tool = tmp_path / "tool.yaml"
    tool.write_text(text.replace("  - name: B              # weight moved along Y\n    mass: 2.0", "  - name: B\n    mass: 2.6", 1))
    report, output = tmp_path / "refused.html", tmp_path / "cal.yaml"
    args = ["calibrate", "--robot", "ur5", "--tool", str(tool), str(ur5_recording), "-o", str(output), "--report", str(report), "--quiet"]
    assert cli.main(args) == ExitCode.POOR_FIT
    assert not output.exists() and report.exists()
    page = report.read_text()
    check_page(page)
    verdict = page[page.index('<section id="verdict">') : page.index('<section id="sphere">')]
    assert "REFUSED" in verdict and "fit poor" in verdict and "configuration B" in verdict


def test_calibrate_reports_insufficient_excitation(ur5_recording, tmp_path):
    # one configuration only: rank 4 of 7, no calibration; the report shows the directions that were reached
    lines = ur5_recording.read_text().splitlines()
    header = lines[0].split(",")
    tool_column = header.index("tool")
    only_a = tmp_path / "only_a.csv"
    only_a.write_text("\n".join([lines[0], *[row for row in lines[1:] if row.split(",")[tool_column] == "A"]]) + "\n")
    report = tmp_path / "r.html"
    args = ["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(only_a), "-o", str(tmp_path / "c.yaml"), "--report", str(report)]
    assert cli.main([*args, "--quiet"]) == ExitCode.EXCITATION
    page = report.read_text()
    check_page(page)
    assert "REFUSED" in page and "rank" in page.lower()
    assert "<svg" in page[page.index('<section id="sphere">') : page.index('<section id="residuals">')]


def test_report_command_and_comparison(calibrated, ur5_recording, tmp_path):
    cal_path = tmp_path / "cal.yaml"
    calibrated[0].calibration.save(cal_path)
    out = tmp_path / "r.html"
    assert cli.main(["report", str(cal_path), str(ur5_recording), "-o", str(out)]) == ExitCode.OK
    page = out.read_text()
    check_page(page)
    assert "GOOD" in page and "not recorded: no sample" not in page
    old = load_calibration(cal_path)
    worn = dataclasses.replace(old, C_bar=old.C_bar * 1.002)
    worn_path = tmp_path / "worn.yaml"
    worn.save(worn_path)
    change = tmp_path / "change.html"
    assert cli.main(["report", str(worn_path), "--against", str(cal_path), "-o", str(change)]) == ExitCode.OK
    page = change.read_text()
    check_page(page, ("verdict", "coefficients", "wrench", "provenance"))
    assert "CHANGED" in page and "Rule:" in page
    assert cli.main(["report", str(cal_path), "--against", str(cal_path), "-o", str(change)]) == ExitCode.OK
    assert "UNCHANGED" in change.read_text()


def test_validate_writes_a_report(calibrated, ur5_recording, tmp_path):
    cal_path = tmp_path / "cal.yaml"
    calibrated[0].calibration.save(cal_path)
    report = tmp_path / "v.html"
    args = [
        "validate",
        "--calibration",
        str(cal_path),
        "--robot",
        "ur5",
        "--tool",
        "paper_tool",
        str(ur5_recording),
        "--report",
        str(report),
    ]
    assert cli.main(args) == ExitCode.OK
    page = report.read_text()
    check_page(page)
    assert "RMS" in page and "% FS (largest axis; validation with" in page
    # each sample under the configuration it was recorded in (the recording holds A, B and C), not all under A
    counts = dict(re.findall(r"<tr><td>(\w+)</td><td>([\d,]+)</td>", _section(page, "sphere")))
    counts = {name: int(n.replace(",", "")) for name, n in counts.items()}
    assert set(counts) == {"A", "B", "C", "all"} and min(counts["A"], counts["B"], counts["C"]) > 0, counts
    assert counts["A"] + counts["B"] + counts["C"] == counts["all"], counts


def test_report_command_refuses_bad_input(calibrated, ur5_recording, tmp_path, capsys):
    cal_path = tmp_path / "cal.yaml"
    cal = calibrated[0].calibration
    cal.save(cal_path)
    out = str(tmp_path / "r.html")
    assert cli.main(["report", str(cal_path), "-o", out, "--target", "0"]) == ExitCode.CONFIG
    assert "--target" in capsys.readouterr().err
    anonymous = tmp_path / "anonymous.yaml"  # typed in by hand: no robot or tool to read the recording with
    dataclasses.replace(cal, provenance={}).save(anonymous)
    assert cli.main(["report", str(anonymous), str(ur5_recording), "-o", out]) == ExitCode.CONFIG
    assert "--robot" in capsys.readouterr().err
    six = tmp_path / "six.yaml"  # another sensor layout: the coefficients cannot be compared
    Calibration(cal.C_bar, cal.D, layout=channel_layout("wrench-6")).save(six)
    assert cli.main(["report", str(cal_path), "--against", str(six), "-o", out]) != ExitCode.OK
    assert "shape (6, 8) and (6, 6)" in capsys.readouterr().err
    assert cli.main(["report", str(cal_path), "--against", str(cal_path), "-o", str(cal_path)]) == ExitCode.CONFIG  # -o is an input
    assert not Path(out).exists()


def test_the_held_out_line_shows_the_chosen_models_held_out_rms_in_percent_of_full_scale(calibrated):
    """Not the dimensionless score ("1 (heldout_error)"): the chosen candidate's held-out RMS over full scale, largest axis."""
    cal = calibrated[0].calibration
    full_scale = cal.quality.budget["full_scale"]
    assert [full_scale[a] for a in ("Fx", "Fy", "Fz", "Mx", "My", "Mz")] == [50.0, 50.0, 50.0, 5.0, 5.0, 5.0]  # the shipped sensor's
    rms = [0.01, 0.02, 0.005, 0.0019, 0.0002, 0.0003]  # N, N·m: Fy 0.04 % FS, Mx 0.038 % FS
    candidates = [
        {"model": "linear", "offsets": "constant", "heldout_rms": [1.0] * 6, "heldout_error": 9.0, "chosen": False},
        {"model": "linear", "offsets": "drift", "heldout_rms": rms, "heldout_error": 1.0, "chosen": True},
    ]
    table = {"units": 18, "chosen": "linear + drift", "candidates": candidates}
    verdict = _section(render_report(ReportContent("a short run", dataclasses.replace(cal, model_selection=table))), "verdict")
    assert "heldout_error" not in verdict
    assert "RMS 0.0400 % FS (Fy, the largest axis; one of 18 units of this recording left out at a time" in verdict, verdict
    bare = dataclasses.replace(cal, model_selection=table, quality=dataclasses.replace(cal.quality, budget=None))
    verdict = _section(render_report(ReportContent("no budget", bare)), "verdict")  # no full scale: in N and N·m
    assert "RMS Fx 0.01 N, Fy 0.02 N, Fz 0.005 N, Mx 0.0019 N·m, My 0.0002 N·m, Mz 0.0003 N·m (one of 18 units" in verdict, verdict


def test_a_comparison_without_budgets_is_not_judged_green(tmp_path):
    """Two files without an accuracy budget: the wrench difference is shown in % FS and not judged (once "0", in green)."""
    from fts_calib.report.compare import render_comparison

    old = load_calibration(resolve("paper_table1_calibration", "configs"))
    old = dataclasses.replace(old, quality=None, D=np.array([1.0, 2.0, 0.5, 0.01, 0.3, 0.02]))  # My farthest: 10.6 % FS
    new = dataclasses.replace(old, C_bar=1.1 * old.C_bar)  # 10 % more gain: W_new - W_old = 0.1 (W - D_old) over the box
    full_scale = np.array([50.0, 50.0, 50.0, 5.0, 5.0, 5.0])
    percent = 100 * 0.1 * (full_scale + np.abs(old.D)) / full_scale  # the box's worst corner, per axis
    axis = ("Fx", "Fy", "Fz", "Mx", "My", "Mz")[int(np.argmax(percent))]
    page = render_comparison(new, old, "new.yaml", "old.yaml")
    verdict = _section(page, "verdict")
    expected = f"not judged: no accuracy budget in new.yaml or old.yaml; the largest difference is {percent.max():.3g} % FS ({axis})"
    assert expected in verdict, verdict
    assert '<div class="kv good"><span>Wrench difference / budget' not in verdict


def test_the_target_the_plan_was_sized_to_is_the_reports(ur5_recording, tmp_path, capsys):
    """``calibrate --target-error 0.1`` records the target: its report, ``report`` and ``validate --report`` judge against it, not 0.05."""
    cal_path, page = tmp_path / "cal.yaml", tmp_path / "cal.html"
    common = ["--robot", "ur5", "--tool", "paper_tool"]
    assert cli.main(["calibrate", str(ur5_recording), *common, "-o", str(cal_path), "--report", str(page), "--target-error", "0.1"]) == 0
    cal = load_calibration(cal_path)
    assert cal.quality.budget["target_percent_fs"] == 0.1
    largest = float(cal.quality.budget["largest_percent_fs"])
    assert f"{largest:.4f} % FS vs target 0.1 % " in _section(page.read_text(), "verdict")
    later = tmp_path / "later.html"
    assert cli.main(["report", str(cal_path), "-o", str(later)]) == 0
    assert "vs target 0.1 % " in _section(later.read_text(), "verdict")
    assert cli.main(["report", str(cal_path), "-o", str(later), "--target-error", "0.02"]) == 0  # the option wins
    assert "vs target 0.02 % " in _section(later.read_text(), "verdict")
    check = tmp_path / "v.html"
    assert cli.main(["validate", str(ur5_recording), "--calibration", str(cal_path), *common, "--report", str(check)]) == 0
    assert "vs target 0.1 % " in _section(check.read_text(), "verdict")
    assert cli.main(["calibrate", str(ur5_recording), *common, "-o", str(tmp_path / "x.yaml"), "--target-error", "0"]) == ExitCode.CONFIG
    assert "--target-error" in capsys.readouterr().err and not (tmp_path / "x.yaml").exists()


def test_the_report_does_not_scroll_sideways_at_1000_px(calibrated, tmp_path):
    """The model-selection table (1,286 px) once widened the page, the residual and budget tables scrolled in 351 px beside
    their pictures: at 1,000 px nothing scrolls sideways or ends beyond the window."""
    from .report_checks import overflowing

    result, collector = calibrated
    rms = [0.002190368679999415, 0.003777819838850614, 0.003594630286757239, 5.8307187883568854e-05, 3.98e-05, 4.07e-05]
    offsets = ("constant", "per-configuration", "drift (time^1)", "drift (time^1, time^2)")
    candidates = [  # the candidates a calibrate of today writes: their columns as the file has them
        {"model": "linear", "offsets": o, "parameters_per_axis": 7 + k, "heldout_rms": rms, "heldout_error": 1.0048023136643827,
         "standard_error_vs_best": 0.0072922725839889785, "held_directions": 0, "chosen": k == 0}
        for k, o in enumerate(offsets)
    ]  # fmt: skip
    cal = dataclasses.replace(result.calibration, model_selection={"units": 18, "chosen": "linear + constant", "candidates": candidates})
    content = ReportContent("a short run", cal, samples=collector.samples(cal), configurations=tuple(result.session.tool.names))
    page = tmp_path / "report.html"
    page.write_text(render_report(content), encoding="utf-8")
    assert overflowing(page, tmp_path, 1000) == []

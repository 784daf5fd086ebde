"""The choice of the sensor model and offset model by held-out error, the held-out units, the model-error budget.

The choice is checked on a few seeds here; ``tests/model_choice_sweep.py`` runs 100 per kind.
"""

from __future__ import annotations

import numpy as np
import pytest

from fts_calib.core.exceptions import ConfigError
from fts_calib.model.budget import MODEL_ERROR, model_error
from fts_calib.model.estimator import OnlineEstimator
from fts_calib.model.offset_basis import OffsetBasis
from fts_calib.pipeline.units import UNIT_GAP_S, UNIT_SPAN_S, HeldOutUnits

from .model_choice_sweep import KINDS
from .nonlinear import TOOL, pose_data


def _estimator(data, model: str = "auto") -> OnlineEstimator:
    est = OnlineEstimator(offsets="auto", basis=OffsetBasis(len(TOOL), 2, 600.0, False), model=model)
    est.update_batch(data.W, data.channels, time=data.time, configuration=data.configuration, unit=data.unit)
    return est


@pytest.mark.parametrize("name", list(KINDS))
def test_auto_picks_the_true_model_and_offsets(name):
    kind, truth = KINDS[name]
    for seed in (1, 2):
        selection = _estimator(pose_data(seed, **kind)).selection()
        assert selection is not None
        chosen = (selection.chosen.family, selection.chosen.offsets.model)
        assert chosen == truth, (
            f"{name}, seed {seed}: chose {chosen}; table {[(s.family, s.offsets.columns, s.error) for s in selection.scores]}"
        )


def test_the_chosen_model_fits_a_nonlinear_sensor_to_its_noise_and_the_linear_one_does_not():
    """2 % FS quadratic: the quadratic model's held-out RMS is that of the linear model on a linear sensor, within 30 %."""
    cal = _estimator(pose_data(3, quadratic=0.02)).solve(configurations=list("ABCDE"))
    ideal = _estimator(pose_data(3)).solve(configurations=list("ABCDE"))
    rows = {(c["model"], c["offsets"]): np.array(c["heldout_rms"]) for c in cal.model_selection["candidates"]}
    noise = np.array([c for c in ideal.model_selection["candidates"] if c["chosen"]][0]["heldout_rms"])
    assert cal.family == "quadratic" and cal.model_selection["chosen"] == "quadratic + constant"
    np.testing.assert_array_less(rows[("quadratic", "constant")], 1.3 * noise)
    assert np.max(rows[("linear", "constant")] / noise) > 2.0


def test_a_linear_model_keeps_the_paper_path_and_its_bic():
    est = _estimator(pose_data(4), model="linear")
    assert est.units is None and est.selection() is None
    cal = est.solve(configurations=list("ABCDE"))
    assert cal.model is None and cal.model_selection is None and cal.offset_model["criterion"].startswith("BIC")


def test_held_out_sums_survive_a_checkpoint_and_a_merge_equals_one_pass():
    data = pose_data(5, quadratic=0.02)
    one = _estimator(data)
    half = len(data.W) // 2
    a, b = OnlineEstimator(offsets="auto", basis=one.basis, model="auto"), OnlineEstimator(offsets="auto", basis=one.basis, model="auto")
    for est, part in ((a, slice(0, half)), (b, slice(half, None))):
        est.update_batch(
            data.W[part], data.channels[part], time=data.time[part], configuration=data.configuration[part], unit=data.unit[part]
        )
    merged = a.merge(b)
    resumed = OnlineEstimator.from_state(one.state())
    expected = one.selection()
    for other in (merged, resumed):
        got = other.selection()
        assert got is not None and expected is not None and got.chosen.family == expected.chosen.family
        errors = np.array([s.error for s in got.scores])
        np.testing.assert_allclose(errors, [s.error for s in expected.scores], rtol=1e-6)


def test_held_out_sums_cannot_forget():
    with pytest.raises(ConfigError, match="forgetting"):
        OnlineEstimator(forgetting=0.99, model="auto")


def test_units_are_poses_separated_by_gaps_configurations_and_blocks_of_a_long_stretch():
    rng = np.random.default_rng(0)
    # two poses of configuration 0 (a gap between them), then one long still stretch of configuration 1
    time = np.r_[
        np.arange(0.0, 2.0, 0.01), 2.0 + 2 * UNIT_GAP_S + np.arange(0.0, 2.0, 0.01), 10.0 + np.arange(0.0, 2.5 * UNIT_SPAN_S, 0.01)
    ]
    codes = np.r_[np.zeros(400, dtype=int), np.ones(len(time) - 400, dtype=int)]
    codes[200:400] = 0
    whole = HeldOutUnits().assign(time, codes)
    assert list(np.unique(whole)) == [0, 1, 2, 3, 4]  # two poses, three blocks of the stretch
    assert np.all(whole[:200] == 0) and np.all(whole[200:400] == 1)
    # online: any split into batches gives the same units
    cuts = np.sort(rng.choice(np.arange(1, len(time)), 7, replace=False))
    units = HeldOutUnits()
    parts = [units.assign(t, c) for t, c in zip(np.split(time, cuts), np.split(codes, cuts), strict=True)]
    np.testing.assert_array_equal(np.concatenate(parts), whole)


def test_the_model_error_is_the_residual_beyond_the_noise():
    residual = np.array([5.0, 0.3, 0.1, 0.5, 0.03, 0.01])
    noise = np.array([0.1, 0.4, 0.1, 0.01, 0.04, 0.01])
    np.testing.assert_allclose(model_error(residual, noise), np.sqrt(np.maximum(residual**2 - noise**2, 0.0)))
    assert MODEL_ERROR == "model error"


def test_the_measured_budget_holds_the_model_error_and_is_finite_with_a_prior(ur5, paper_tool, ur5_recording):
    """Residuals of 10 % of full scale cannot print less; one configuration alone (rank 4, paper eqs 18-20) with a prior is finite."""
    from fts_calib.model.budget import wrench_noise
    from fts_calib.pipeline.calibrate import calibrate_recording
    from fts_calib.planning.accuracy import KeptSamples, measured_budget

    kept = KeptSamples()
    result = calibrate_recording(ur5_recording, ur5, paper_tool, on_kept=kept)
    cal = result.calibration
    full_scale = np.array([50.0] * 3 + [5.0] * 3)
    sigma = wrench_noise(cal.C, result.session.filter.noise_floor)
    budget = measured_budget(ur5, paper_tool, kept, cal, sigma, full_scale, residual_rms=0.1 * full_scale)
    # the model error alone is 10 % of full scale (less the noise, 1e-4 of it), expanded by the coverage factor 2
    assert np.all(budget.total_percent >= 2 * 10.0 * 0.999)
    clean = measured_budget(ur5, paper_tool, kept, cal, sigma, full_scale, residual_rms=sigma)
    np.testing.assert_array_equal(clean.terms[MODEL_ERROR], 0.0)

    time, W, channels, codes, joints = kept.arrays()
    only_a = KeptSamples()
    mine = codes == 0
    only_a(time[mine], W[mine], channels[mine], codes[mine], joints[mine])
    without = measured_budget(ur5, paper_tool, only_a, cal, sigma, full_scale)
    assert not np.all(np.isfinite(without.total))  # the data alone do not determine C
    shrunk = measured_budget(ur5, paper_tool, only_a, cal, sigma, full_scale, residual_rms=cal.quality.residual_rms, prior_weight=1.0)
    for name, value in shrunk.terms.items():
        assert np.all(np.isfinite(value)), name
    assert np.all(np.isfinite(shrunk.total_percent))


def test_the_fit_check_of_a_nonlinear_model_judges_its_own_residual(paper_tool):
    """2 % FS quadratic: the quadratic model's residual per configuration is the noise (0.5 counts and the rounding)."""
    from fts_calib.model.channels import MALTESE_CROSS_8
    from fts_calib.pipeline.fit import FitCheck, check_model_fit

    est = _estimator(pose_data(6, quadratic=0.02), model="quadratic")
    residuals = est.model_residuals()
    assert residuals is not None
    rms, C_bar = residuals
    assert sorted(rms) == list(range(len(TOOL)))
    noise = np.sqrt(0.5**2 + 1 / 12)  # [counts] white noise and rounding
    named = {f"c{k}": v for k, v in rms.items()}
    linear = FitCheck("poor", 40.0, {}, np.ones(6), "the linear model's diagnosis")
    check = check_model_fit(paper_tool, named, C_bar, np.full(8, noise), MALTESE_CROSS_8, linear)
    # 9,000 samples, 33 parameters per axis: the residual is the noise within a few %
    assert check.verdict == "consistent" and check.max_ratio < 1.2, check.summary()
    worse = check_model_fit(paper_tool, {k: 10 * v for k, v in named.items()}, C_bar, np.full(8, noise), MALTESE_CROSS_8, linear)
    assert worse.verdict == "poor" and worse.diagnosis == "the linear model's diagnosis"


def test_calibrate_prints_the_table_of_candidates_and_the_file_records_it(tmp_path, ur5_recording, capsys):
    """An ideal simulated sensor: auto keeps the linear model; --model linear keeps the paper's path and BIC."""
    from fts_calib.app.cli import main
    from fts_calib.model.calibration import load_calibration

    out = tmp_path / "cal.yaml"
    assert main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(ur5_recording), "-o", str(out), "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "model: linear + " in printed and "held-out RMS per axis" in printed and "Fx [N]" in printed
    cal = load_calibration(out)
    assert cal.model is None and cal.model_selection is not None
    chosen = [c for c in cal.model_selection["candidates"] if c["chosen"]]
    assert len(chosen) == 1 and chosen[0]["model"] == "linear"
    assert {c["model"] for c in cal.model_selection["candidates"]} == {"linear", "quadratic"}
    assert "model error" in cal.quality.budget["terms_percent_fs"]
    assert (
        main(
            [
                "calibrate",
                "--robot",
                "ur5",
                "--tool",
                "paper_tool",
                str(ur5_recording),
                "-o",
                str(tmp_path / "lin.yaml"),
                "--quiet",
                "--model",
                "linear",
            ]
        )
        == 0
    )
    printed = capsys.readouterr().out
    assert "held-out RMS" not in printed and "(chosen by BIC" in printed
    assert load_calibration(tmp_path / "lin.yaml").model_selection is None

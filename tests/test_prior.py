"""The prior: ridge regression of C_bar toward a known calibration, for weak excitation."""

import numpy as np
import pytest

from fts_calib import Calibration, InsufficientExcitation
from fts_calib.app.cli import main
from fts_calib.app.exit_codes import ExitCode
from fts_calib.app.setup import load_prior
from fts_calib.core.exceptions import ConfigError
from fts_calib.model.calibration import load_calibration, save_calibration
from fts_calib.model.channels import MALTESE_CROSS_8, WRENCH_6
from fts_calib.model.estimator import OnlineEstimator
from fts_calib.model.prior import Prior

from .helpers import C_BAR_TRUE, COMS, D_TRUE, TOOL_MASS, paper_simulation, random_gravity, strains_eq22, tool_wrench


def _estimator(W, S) -> OnlineEstimator:
    est = OnlineEstimator(offsets="constant")
    est.update_batch(W, S)
    return est


def _error(C_bar) -> float:
    """Largest |C_bar - truth| over the largest |truth| (dimensionless)."""
    return float(np.abs(C_bar - C_BAR_TRUE).max() / np.abs(C_BAR_TRUE).max())


def test_no_weight_is_the_plain_least_squares(rng):
    W, S, _ = paper_simulation(300, rng, noise_std=1e-4)
    est = _estimator(W, S)
    plain, ridge = est.solve(), est.solve(prior=Prior(np.eye(6), 0.0, "identity"))
    np.testing.assert_allclose(ridge.C_bar, plain.C_bar, rtol=0, atol=1e-10 * np.abs(plain.C_bar).max())
    np.testing.assert_allclose(ridge.D, plain.D, rtol=0, atol=1e-10 * np.abs(plain.D).max())
    assert ridge.quality.prior["shrinkage"] == pytest.approx(0.0, abs=1e-9)
    assert ridge.quality.prior["effective_parameters"] == pytest.approx(7.0, abs=1e-9)


@pytest.mark.parametrize("weight", [0.1, 1.0, 10.0])
def test_a_true_prior_on_noiseless_data_changes_nothing(rng, weight):
    W, S, _ = paper_simulation(100, rng)
    calibration = _estimator(W, S).solve(prior=Prior(C_BAR_TRUE, weight))
    assert _error(calibration.C_bar) < 1e-9
    np.testing.assert_allclose(calibration.D, D_TRUE, rtol=0, atol=1e-9 * np.abs(D_TRUE).max())


def test_an_overwhelming_prior_returns_the_prior(rng):
    W, S, _ = paper_simulation(100, rng, noise_std=1e-4)
    prior = C_BAR_TRUE * 1.01
    calibration = _estimator(W, S).solve(prior=Prior(prior, 1e9))
    # the data's pull is 1/(1 + lambda) of the 1 % difference: 1e-11 of it
    np.testing.assert_allclose(calibration.C_bar, prior, rtol=0, atol=1e-9 * np.abs(prior).max())
    assert calibration.quality.prior["shrinkage"] == pytest.approx(6 / 7, abs=1e-6)  # only D is the data's


def test_weak_excitation_two_centres_of_mass(rng):
    """Two centres of mass leave one direction of [C_bar, D] undetermined (rank 6 of 7): the
    plain solve refuses; with a prior 1 % off the truth, the data fix what they determine and
    the prior the rest, so the result is closer to the truth than the prior was."""
    W = np.vstack([tool_wrench(TOOL_MASS, com, random_gravity(300, rng)) for com in COMS[:2]])
    S = strains_eq22(C_BAR_TRUE, D_TRUE, W) + 1e-5 * rng.standard_normal((len(W), 8))
    est = _estimator(W, S)
    with pytest.raises(InsufficientExcitation):
        est.solve()
    prior = C_BAR_TRUE * (1 + 0.01 * rng.standard_normal((6, 6)))
    shrinkage = []
    for weight in (1e-3, 1e-1, 10.0):
        calibration = est.solve(prior=Prior(prior, weight, "previous.yaml"))
        report = calibration.quality.prior
        assert report["rank_without_prior"] == 6 and report["source"] == "previous.yaml"
        assert _error(calibration.C_bar) < _error(prior), (weight, _error(calibration.C_bar), _error(prior))
        shrinkage.append(report["shrinkage"])
    assert 0 < shrinkage[0] < shrinkage[1] < shrinkage[2] < 1, shrinkage  # a heavier prior shrinks more


def test_the_prior_is_kept_in_the_calibration_file(tmp_path, rng):
    W, S, _ = paper_simulation(50, rng, noise_std=1e-4)
    calibration = _estimator(W, S).solve(prior=Prior(np.eye(6), 0.5, "factory.cal"))
    loaded = load_calibration(save_calibration(calibration, tmp_path / "c.yaml"))
    assert loaded.quality.prior == pytest.approx(calibration.quality.prior)


def test_a_prior_of_another_layout_is_refused(tmp_path):
    path = save_calibration(Calibration(np.eye(6), np.zeros(6), layout=WRENCH_6), tmp_path / "w.yaml")
    with pytest.raises(ConfigError, match=r"is a calibration of a wrench-6 sensor \(6 channels\) but the sensor is maltese-cross-8"):
        load_prior(path, 1.0, MALTESE_CROSS_8)
    with pytest.raises(ConfigError, match="prior_weight"):
        Prior(np.eye(6), -1.0)


def test_cli_calibrate_with_a_prior(tmp_path, ur5_recording, capsys):
    previous = save_calibration(Calibration(C_BAR_TRUE * 1.002, D_TRUE), tmp_path / "previous.yaml")
    out = tmp_path / "cal.yaml"
    args = ["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(ur5_recording), "-o", str(out)]
    assert main([*args, "--prior", str(previous), "--prior-weight", "0.01"]) == ExitCode.OK
    text = capsys.readouterr().out
    assert f"prior {previous}, weight 0.01: the data determine" in text
    assert load_calibration(out).quality.prior["weight"] == 0.01


@pytest.mark.parametrize(
    ("options", "expected"),
    [
        (["--prior-weight", "5"], "--prior-weight 5 without --prior: name the calibration to shrink toward (--prior FILE)"),
        (["--prior", "PRIOR", "--prior-weight", "-1"], "--prior-weight -1.0 but expected a finite value >= 0 (0: no prior"),
    ],
)
def test_cli_a_prior_weight_without_a_prior_or_below_zero_is_one_line(tmp_path, ur5_recording, capsys, options, expected):
    """Before: a weight without --prior was ignored silently; a negative one was named 'prior_weight=', not the option."""
    previous = save_calibration(Calibration(C_BAR_TRUE, D_TRUE), tmp_path / "previous.yaml")
    out = tmp_path / "cal.yaml"
    args = ["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(ur5_recording), "-o", str(out)]
    assert main([*args, *[str(previous) if o == "PRIOR" else o for o in options]]) == ExitCode.CONFIG
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and expected in err[0], err
    assert not out.exists()

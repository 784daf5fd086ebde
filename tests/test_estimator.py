"""The online and jig estimators against the paper's simulation validation (eqs 21-22)."""

import math

import numpy as np
import pytest

from fts_calib import ConfigError, InsufficientExcitation, OnlineEstimator, ShapeError
from fts_calib.model.channels import c_from_c_bar
from fts_calib.model.least_squares import information_rank
from fts_calib.model.offline import jig_calibration
from fts_calib.model.retare import estimate_offsets

from .helpers import C_BAR_TRUE, COMS, D_TRUE, TOOL_MASS, paper_simulation, random_gravity, strains_eq22, tool_wrench

RTOL_EXACT = 1e-9  # noiseless data: relative recovery, as the issue asks

# Two paths to the same sums or the same fit differ by round-off only, but BLAS sums in
# another order on another CPU: compare with an absolute tolerance scaled to the largest
# entry of the whole quantity, never entry by entry (C_bar and S_XX hold entries near zero).
# - A sum of N products: |error| <= N eps max(diag S_XX) (Cauchy-Schwarz); N <= 300 gives 7e-14.
TOL_SUM = 1e-12  # of the largest entry
# - A solve amplifies that by the condition number (< 100 here, see quality.condition_number):
#   7e-12 of the largest coefficient at worst, 4e-14 seen over 200 seeds; 1e-10 (the figure
#   these tests had entry by entry) is 14 times the worst case.
TOL_SOLVE = 1e-10  # of the largest entry
# - A standard error comes from a residual variance: a difference of sums that agree to
#   (sigma_W / |W|)^2 ~ 3e-7 of themselves (moments, noise 1e-4), so its round-off is
#   N eps (|W| / sigma_W)^2 / 2 ~ 1e-7 of itself at worst (up to 2e-8 seen over 200 seeds, above
#   the 1e-8 these tests had). Standard errors are positive and none is near zero: relative to
#   each entry is the right scale here.
RTOL_STDERR = 2e-7


def _assert_round_off(actual, expected, tol, what=""):
    """``actual`` equals ``expected`` to ``tol`` of the largest entry of ``expected``."""
    np.testing.assert_allclose(actual, expected, rtol=0, atol=tol * np.abs(expected).max(), err_msg=what)


def _relative_error(C_bar, D):
    scale_C = np.abs(C_BAR_TRUE).max()
    return np.max(np.abs(C_bar - C_BAR_TRUE)) / scale_C, np.max(np.abs(D - D_TRUE)) / np.abs(D_TRUE).max()


def test_noiseless_three_configurations_recover_c_bar_and_d(rng):
    W, S, _ = paper_simulation(300, rng)
    est = OnlineEstimator()
    est.update_batch(W, S)
    cal = est.solve()
    err_C, err_D = _relative_error(cal.C_bar, cal.D)
    assert err_C < RTOL_EXACT and err_D < RTOL_EXACT, (err_C, err_D)
    C_true = c_from_c_bar(C_BAR_TRUE)
    np.testing.assert_allclose(cal.C, C_true, rtol=0, atol=RTOL_EXACT * np.abs(C_true).max())
    assert cal.quality.rank == 7 and cal.quality.samples_used == 900


def test_rank_grows_4_6_7_and_c11_error_falls_at_each_change(rng):
    """The paper's Fig. 7 story."""
    W, S, idx = paper_simulation(200, rng)
    est = OnlineEstimator()
    ranks, c11_errors = [], []
    for k in range(3):
        est.update_batch(W[idx == k], S[idx == k])
        ranks.append(est.rank()[0])
        cal = est.solve(min_norm=True)
        c11_errors.append(abs(cal.C_bar[0, 0] / C_BAR_TRUE[0, 0] - 1))
    assert ranks == [4, 6, 7]
    assert c11_errors[0] > c11_errors[1] > c11_errors[2]
    assert c11_errors[0] > 1e-4 and c11_errors[2] < RTOL_EXACT


@pytest.mark.parametrize(("configs", "rank"), [([0], 4), ([0, 1], 6), ([0, 1, 2], 7)])
def test_solve_refuses_rank_deficient_data_naming_the_missing_directions(rng, configs, rank):
    W, S, idx = paper_simulation(100, rng)
    est = OnlineEstimator()
    mask = np.isin(idx, configs)
    est.update_batch(W[mask], S[mask])
    if rank == 7:
        est.solve()
        return
    with pytest.raises(InsufficientExcitation, match=f"rank {rank} of 7, {7 - rank} independent") as info:
        est.solve()
    assert info.value.rank == rank and info.value.missing == 7 - rank


def test_collinear_centres_of_mass_give_rank_6_at_most(rng):
    est = OnlineEstimator()
    for com in ([0.1, 0, 0], [0.2, 0, 0], [0.3, 0, 0]):  # on one line through the origin
        W = tool_wrench(TOOL_MASS, np.array(com), random_gravity(100, rng))
        est.update_batch(W, strains_eq22(C_BAR_TRUE, D_TRUE, W))
    assert est.rank()[0] == 6


def test_empty_estimator_refuses_to_solve():
    with pytest.raises(InsufficientExcitation, match="no sample"):
        OnlineEstimator().solve()


def test_per_sample_and_batch_updates_give_identical_sums(rng):
    W, S, _ = paper_simulation(50, rng)
    weights = rng.uniform(0.5, 2.0, len(W))
    for forgetting in (1.0, 0.99):
        one, batch = OnlineEstimator(forgetting), OnlineEstimator(forgetting)
        for w, s, k in zip(W, S, weights, strict=True):
            one.update(w, s, k)
        batch.update_batch(W, S, weights)
        _assert_round_off(batch.S_XX, one.S_XX, TOL_SUM, f"S_XX, forgetting {forgetting}")
        _assert_round_off(batch.S_WX, one.S_WX, TOL_SUM, f"S_WX, forgetting {forgetting}")
        assert batch.weight_sum == pytest.approx(one.weight_sum, rel=1e-12)  # a sum of positive terms: relative


def test_sample_order_does_not_matter(rng):
    W, S, _ = paper_simulation(100, rng, noise_std=1e-4)
    perm = rng.permutation(len(W))
    a, b = OnlineEstimator(), OnlineEstimator()
    a.update_batch(W, S)
    b.update_batch(W[perm], S[perm])
    _assert_round_off(b.solve().C_bar, a.solve().C_bar, TOL_SOLVE, "C_bar, permuted samples")


def test_merge_equals_one_pass(rng):
    W, S, _ = paper_simulation(100, rng, noise_std=1e-4)
    whole, first, second = OnlineEstimator(), OnlineEstimator(), OnlineEstimator()
    whole.update_batch(W, S)
    first.update_batch(W[:170], S[:170])
    second.update_batch(W[170:], S[170:])
    merged = first.merge(second)
    _assert_round_off(merged.S_XX, whole.S_XX, TOL_SUM, "S_XX")
    a, b = merged.solve(), whole.solve()
    _assert_round_off(a.C_bar, b.C_bar, TOL_SOLVE, "C_bar")
    np.testing.assert_allclose(a.quality.stderr_C_bar, b.quality.stderr_C_bar, rtol=RTOL_STDERR)
    assert merged.samples_used == whole.samples_used == 300


def test_merge_with_forgetting_treats_the_other_as_newer(rng):
    W, S, _ = paper_simulation(40, rng)
    whole, first, second = OnlineEstimator(0.98), OnlineEstimator(0.98), OnlineEstimator(0.98)
    whole.update_batch(W, S)
    first.update_batch(W[:50], S[:50])
    second.update_batch(W[50:], S[50:])
    _assert_round_off(first.merge(second).S_XX, whole.S_XX, TOL_SUM, "S_XX with forgetting")


def test_weight_of_two_equals_a_duplicated_sample(rng):
    W, S, _ = paper_simulation(60, rng, noise_std=1e-4)
    weights = np.ones(len(W))
    weights[::3] = 2.0
    dup = np.concatenate([np.arange(len(W)), np.arange(len(W))[::3]])
    weighted, duplicated = OnlineEstimator(), OnlineEstimator()
    weighted.update_batch(W, S, weights)
    duplicated.update_batch(W[dup], S[dup])
    a, b = weighted.solve(), duplicated.solve()
    _assert_round_off(a.C_bar, b.C_bar, TOL_SOLVE, "C_bar")
    _assert_round_off(a.D, b.D, TOL_SOLVE, "D")
    np.testing.assert_allclose(a.quality.stderr_C_bar, b.quality.stderr_C_bar, rtol=RTOL_STDERR)


def test_forgetting_tracks_a_change_of_offsets(rng):
    """With forgetting, old data fade: after a shift of D, the estimate follows the new D."""
    est = OnlineEstimator(forgetting=0.99)
    W, S, _ = paper_simulation(400, rng)
    est.update_batch(W, S)
    D_new = D_TRUE + np.array([3.0, 0, 0, 0, 0, 0])
    W2, _, _ = paper_simulation(400, rng)
    W2 = W2[rng.permutation(len(W2))]  # configurations interleaved: the recent window sees all three
    est.update_batch(W2, strains_eq22(C_BAR_TRUE, D_new, W2))
    # the oldest kept weight is 0.99**1200 ~ 6e-6 of the newest sample's
    assert abs(est.solve().D[0] - D_new[0]) < 1e-3


def test_error_shrinks_like_one_over_sqrt_n_and_stderr_matches_the_spread(seed):
    """200 seeds (spawned from ``seed``) at N and 4N samples per configuration.

    The empirical standard deviation s of each coefficient over 200 seeds follows
    sigma sqrt(chi2_199 / 199): a relative spread of 1/sqrt(2 * 199) = 5 %, and 5 sigma (with
    the chi distribution's skew, Wilson-Hilferty) is s / sigma in [0.75, 1.25], so reported /
    empirical must lie in [0.8, 1.33]; for 84 such ratios P(fail) < 1e-4 for a seed.
    Quadrupling N must halve the spread: the log of a ratio of two independent spreads has a
    sampling error of sqrt(2) * 5 % = 7.1 %, so 5 sigma is a factor exp(0.354) = 1.42 either
    side of 2. The mean of the 42 ratios is 2.01 (residual degrees of freedom) with a spread of
    0.035 over 80 seeds (more than 0.022 for independent ratios: the coefficients' errors are
    correlated): 5 sigma is 2.01 +- 0.18.
    """
    noise = 2e-4  # [strain unit], about 0.05 N on Fx
    results = {}
    for n in (150, 600):
        estimates, stderrs = [], []
        for child in np.random.SeedSequence(seed).spawn(200):
            W, S, _ = paper_simulation(n, np.random.default_rng(child), noise_std=noise)
            est = OnlineEstimator()
            est.update_batch(W, S)
            cal = est.solve()
            estimates.append(np.concatenate([cal.C_bar.ravel(), cal.D]))
            stderrs.append(np.concatenate([cal.quality.stderr_C_bar.ravel(), cal.quality.stderr_D]))
        results[n] = (np.std(estimates, axis=0, ddof=1), np.mean(stderrs, axis=0))
    for n, (spread, reported) in results.items():
        ratio = reported / spread
        assert np.all((ratio > 0.8) & (ratio < 1.33)), f"N={n}: reported/empirical stderr in [{ratio.min():.2f}, {ratio.max():.2f}]"
    shrink = results[150][0] / results[600][0]
    assert np.all((shrink > 2 / 1.42) & (shrink < 2 * 1.42)), f"spread ratio N vs 4N in [{shrink.min():.2f}, {shrink.max():.2f}]"
    assert 1.83 < shrink.mean() < 2.19, f"mean spread ratio {shrink.mean():.3f}, expected 2.01"


def test_nan_and_inf_strains_are_rejected_and_counted(rng):
    W, S, _ = paper_simulation(50, rng)
    S = S.copy()
    S[3, 2] = np.nan
    S[7, 0] = np.inf
    W = W.copy()
    W[11, 4] = -np.inf
    batch, single = OnlineEstimator(), OnlineEstimator()
    assert batch.update_batch(W, S) == len(W) - 3
    accepted = [single.update(w, s) for w, s in zip(W, S, strict=True)]
    assert accepted.count(False) == 3
    for est in (batch, single):
        assert est.skipped == {"non-finite wrench, strain or weight": 3}
        assert est.samples_seen == len(W) and est.samples_used == len(W) - 3
        cal = est.solve()
        assert cal.quality.samples_seen == len(W)
        assert _relative_error(cal.C_bar, cal.D)[0] < RTOL_EXACT
    _assert_round_off(batch.S_XX, single.S_XX, TOL_SUM, "S_XX")


@pytest.mark.parametrize(
    ("w", "s", "match"),
    [
        (np.zeros(5), np.zeros(8), r"w_sensor.shape=\(5,\)"),
        (np.zeros(6), np.zeros((2, 8)), r"channels.shape=\(2, 8\)"),
    ],
)
def test_update_with_wrong_shapes_names_received_and_expected(w, s, match):
    with pytest.raises(ShapeError, match=match):
        OnlineEstimator().update(w, s)


def test_batch_with_mismatched_rows_or_widths_is_a_clear_error():
    est = OnlineEstimator()
    with pytest.raises(ShapeError, match=r"channels.shape=\(4, 7\) but expected \(8,\) or \(N, 8\)"):
        est.update_batch(np.zeros((4, 6)), np.zeros((4, 7)))
    with pytest.raises(ShapeError, match="4 rows but channels has 3"):
        est.update_batch(np.zeros((4, 6)), np.zeros((3, 8)))
    with pytest.raises(ValueError, match="forgetting"):
        OnlineEstimator(forgetting=1.5)


def test_checkpoint_state_round_trip(rng):
    W, S, _ = paper_simulation(50, rng, noise_std=1e-4)
    est = OnlineEstimator()
    est.update_batch(W, S)
    copy = OnlineEstimator.from_state(est.state())
    np.testing.assert_array_equal(copy.solve().C_bar, est.solve().C_bar)
    assert copy.samples_used == est.samples_used


# -- the jig (offline) method ------------------------------------------------------------


def _jig_data(rng, noise_std=0.0):
    """Pure axial loads in 10 steps over +-50 N and +-5 N m (the paper's jig), offsets removed."""
    full_scale = np.array([50.0, 50.0, 50.0, 5.0, 5.0, 5.0])
    steps = np.linspace(-1.0, 1.0, 21)
    W = np.vstack([np.outer(steps, np.eye(6)[k] * full_scale[k]) for k in range(6)])
    S = strains_eq22(C_BAR_TRUE, np.zeros(6), W)
    return W, S + noise_std * rng.standard_normal(S.shape)


def test_jig_recovers_table_1_from_noiseless_axial_loads(rng):
    W, S = _jig_data(rng)
    cal = jig_calibration(W, S)
    assert np.max(np.abs(cal.C_bar - C_BAR_TRUE)) / np.abs(C_BAR_TRUE).max() < RTOL_EXACT
    np.testing.assert_array_equal(cal.D, np.zeros(6))


def test_jig_and_online_give_the_same_c_on_the_same_data(rng):
    """The paper: 'almost identical values' from eq 9 and from eqs 15, 16, 12."""
    W, S = _jig_data(rng, noise_std=1e-4)
    jig = jig_calibration(W, S)
    online = OnlineEstimator()
    online.update_batch(W, S)
    cal = online.solve()
    # both fit the same data; the online one also fits D (near 0), so they differ by a
    # fraction of the standard error only
    diff = np.abs(cal.C - jig.C)
    assert np.all(diff <= 0.5 * cal.quality.stderr_C + 1e-12), np.max(diff / cal.quality.stderr_C)
    assert np.all(np.abs(cal.D) < 5 * cal.quality.stderr_D)  # 6 offsets at 5 sigma: P < 4e-6 for a seed


def test_jig_refuses_loads_missing_an_axis(rng):
    W, S = _jig_data(rng)
    keep = W[:, 5] == 0  # no Mz load at all
    with pytest.raises(InsufficientExcitation, match="rank 5 of 6, 1 independent direction"):
        jig_calibration(W[keep], S[keep])


# -- offsets only (re-tare) ----------------------------------------------------------------


def test_retare_recovers_offsets_with_a_known_load(rng):
    D_shifted = D_TRUE + np.array([0.8, -0.3, 0.2, 0.01, 0.02, -0.03])
    W = tool_wrench(TOOL_MASS, COMS[0], random_gravity(20, rng))
    S = strains_eq22(C_BAR_TRUE, D_shifted, W)
    est = estimate_offsets(C_BAR_TRUE, S, W)
    np.testing.assert_allclose(est.D, D_shifted, atol=1e-10)
    assert est.samples_used == 20


def test_retare_with_nothing_mounted_and_noise_is_within_its_stderr(rng):
    S = strains_eq22(C_BAR_TRUE, D_TRUE, np.zeros((400, 6))) + 1e-4 * rng.standard_normal((400, 8))
    S[5] = np.nan
    est = estimate_offsets(C_BAR_TRUE, S)
    assert est.samples_skipped == 1 and est.samples_used == 399
    assert np.all(np.abs(est.D - D_TRUE) < 5 * est.stderr_D)  # 6 offsets at 5 sigma: P < 4e-6 for a seed


def test_information_rank_is_unit_free(rng):
    X = rng.standard_normal((100, 7))
    X[:, 3] = X[:, 2] * 2.0  # one dependent column
    rank, cond = information_rank(X.T @ X)
    scaled = X * np.array([1e-6, 1, 1e3, 1e3, 1, 1, 1])
    assert information_rank(scaled.T @ scaled)[0] == rank == 6
    assert math.isinf(cond)


def test_merge_refuses_another_forgetting_factor():
    with pytest.raises(ConfigError, match=r"cannot merge estimators with forgetting 1.0 and 0.98") as info:
        OnlineEstimator().merge(OnlineEstimator(0.98))
    assert info.value.field == "forgetting" and info.value.value == 0.98


def test_a_bad_first_row_neither_enters_the_sums_nor_sets_the_time_origin(rng):
    """The one-product path of a block falls back to the row checks: the sums and origins are those without the row."""
    W, S = rng.standard_normal((50, 6)), rng.standard_normal((50, 8))
    t = 10.0 + 0.01 * np.arange(50)
    bad = S.copy()
    bad[0, 3] = np.nan
    a, b = OnlineEstimator(), OnlineEstimator()
    assert a.update_batch(W, bad, time=t) == 49 and b.update_batch(W[1:], S[1:], time=t[1:]) == 49
    assert a.time_origin == b.time_origin == t[1] and a.skipped == {"non-finite wrench, strain or weight": 1}
    np.testing.assert_allclose(a.state()["S"], b.state()["S"], rtol=1e-12, atol=1e-12)  # the same rows, summed by BLAS


def test_precision_weights_keep_one_observation_per_sample(rng):
    """Weights that are inverse variances (the dynamic filter's 1 / (1 + rho^2), often ~0.004): equal ones give the plain least
    squares' standard errors exactly, not infinite ones (their sum, 0.6 here, was taken as the samples' count: below the 7
    coefficients, 'inf' was written and the file refused on reading)."""
    W, S, _ = paper_simulation(50, rng, noise_std=1e-4)
    plain, precise = OnlineEstimator(), OnlineEstimator()
    plain.update_batch(W, S)
    precise.update_batch(W, S, np.full(len(W), 0.004), precision=True)
    a, b = plain.solve(), precise.solve()
    assert precise.weight_sum == pytest.approx(0.6) and precise.observations == len(W)
    for name in ("stderr_C_bar", "stderr_D", "stderr_C"):
        np.testing.assert_allclose(getattr(b.quality, name), getattr(a.quality, name), rtol=RTOL_STDERR)
    frequency = OnlineEstimator()  # the same weights as frequencies: 0.6 samples for 7 coefficients, refused
    frequency.update_batch(W, S, np.full(len(W), 0.004))
    with pytest.raises(
        InsufficientExcitation,
        match=r"150 samples \(0.6 observations after weights and forgetting\) for 7 coefficients per wrench axis leave 0 degrees",
    ):
        frequency.solve()


@pytest.mark.parametrize("n, refused", [(7, True), (8, False)])
def test_no_degree_of_freedom_is_refused_not_an_infinite_stderr(rng, n, refused):
    """n samples that determine the 7 coefficients per axis: 7 leave no residual to estimate the noise from (refused, naming
    the samples and the degrees of freedom), 8 leave one (finite standard errors)."""
    W, S, _ = paper_simulation(3, rng, noise_std=1e-4)
    est = OnlineEstimator()
    est.update_batch(W[:n], S[:n])
    assert est.rank()[0] == 7
    if refused:
        with pytest.raises(
            InsufficientExcitation,
            match=r"insufficient data: 7 samples for 7 coefficients per wrench axis leave 0 degrees of freedom.*at least 8 kept",
        ):
            est.solve()
    else:
        assert np.all(np.isfinite(est.solve().quality.stderr_C_bar))

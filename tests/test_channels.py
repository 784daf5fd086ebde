"""Channel layouts: the paper's 8 bridges, a factory wrench (P = I), an explicit 6 x n projection."""

import numpy as np
import pytest

from fts_calib.core.exceptions import ConfigError, FileFormatError, InsufficientExcitation, ShapeError, StructureError
from fts_calib.model.calibration import Calibration, load_calibration, save_calibration
from fts_calib.model.channels import MALTESE_CROSS_8, WRENCH_6, ChannelLayout, P, channel_layout
from fts_calib.model.estimator import OnlineEstimator
from fts_calib.model.offline import jig_calibration
from tests.helpers import COMS, TOOL_MASS, random_gravity, tool_wrench


def _runs(rng, layout: ChannelLayout, C_bar, D, n_per_config=200, noise=0.0):
    """Wrenches of three CoMs and the channels a sensor of this layout reads (minimum-norm lift)."""
    W = np.vstack([tool_wrench(TOOL_MASS, com, random_gravity(n_per_config, rng)) for com in COMS])
    bar = np.linalg.solve(C_bar, (W - D).T).T
    channels = bar @ layout.pinv.T
    return W, channels + noise * rng.standard_normal(channels.shape)


def _random_projection(rng, n: int) -> np.ndarray:
    return rng.standard_normal((6, n))


@pytest.mark.parametrize("name", ["wrench-6", "projection"])
def test_estimator_recovers_any_layout_noiseless(rng, name):
    layout = WRENCH_6 if name == "wrench-6" else channel_layout(_random_projection(rng, 10))
    # a factory wrench 3 % off in scale and rotated by 2 degrees about an oblique axis
    angle = np.radians(2.0)
    axis = np.array([1.0, 2.0, -1.0]) / np.sqrt(6.0)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    R = np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K
    C_bar = np.kron(np.eye(2), R) * 1.03
    D = np.array([1.0, -2.0, 0.5, 0.01, -0.02, 0.03])
    W, channels = _runs(rng, layout, C_bar, D)
    estimator = OnlineEstimator(layout=layout)
    estimator.update_batch(W, channels)
    calibration = estimator.solve()
    assert calibration.layout == layout
    assert calibration.C.shape == (6, layout.n_channels)
    np.testing.assert_allclose(calibration.C_bar, C_bar, atol=1e-9)
    np.testing.assert_allclose(calibration.D, D, atol=1e-9)
    np.testing.assert_allclose(calibration.wrench(channels), W, atol=1e-8)
    assert calibration.quality is not None and calibration.quality.stderr_C.shape == (6, layout.n_channels)


def test_layout_is_kept_through_state_and_merge(rng):
    layout = channel_layout(_random_projection(rng, 9))
    W, channels = _runs(rng, layout, np.eye(6), np.zeros(6), n_per_config=50)
    a, b = OnlineEstimator(layout=layout), OnlineEstimator(layout=layout)
    a.update_batch(W[:75], channels[:75])
    b.update_batch(W[75:], channels[75:])
    merged = OnlineEstimator.from_state(a.state()).merge(b)
    assert merged.layout == layout
    np.testing.assert_allclose(merged.solve().C_bar, np.eye(6), atol=1e-9)
    with pytest.raises(ConfigError, match="channel layouts"):
        a.merge(OnlineEstimator())


def test_calibration_file_round_trip_for_each_layout(tmp_path, rng):
    for layout in (MALTESE_CROSS_8, WRENCH_6, channel_layout({"projection": _random_projection(rng, 7).tolist()})):
        W, channels = _runs(rng, layout, np.eye(6), np.zeros(6), n_per_config=30)
        estimator = OnlineEstimator(layout=layout)
        estimator.update_batch(W, channels)
        calibration = estimator.solve()
        path = save_calibration(calibration, tmp_path / f"{layout.name}.yaml")
        loaded = load_calibration(path)
        assert loaded.layout == layout
        np.testing.assert_array_equal(loaded.C, calibration.C)


def test_a_file_without_channels_is_the_paper_sensor(tmp_path):
    path = save_calibration(Calibration(C_bar=np.eye(6), D=np.zeros(6)), tmp_path / "c.yaml")
    text = path.read_text().replace("channels: maltese-cross-8\n", "")
    assert "channels" not in text
    path.write_text(text)
    assert load_calibration(path).layout == MALTESE_CROSS_8


def test_a_file_whose_C_has_the_wrong_width_names_the_field(tmp_path):
    path = save_calibration(Calibration(C_bar=np.eye(6), D=np.zeros(6), layout=WRENCH_6), tmp_path / "c.yaml")
    path.write_text(path.read_text().replace("channels: wrench-6", "channels: maltese-cross-8"))
    with pytest.raises(FileFormatError, match=r"C.*shape \(6, 6\) but expected \(6, 8\)"):
        load_calibration(path)


@pytest.mark.parametrize(
    ("value", "words"),
    [
        ("maltese-cross-6", "maltese-cross-8, wrench-6"),
        (np.zeros((6, 8)).tolist(), "full row rank"),
        (np.ones((5, 8)).tolist(), "6 x n"),
        ({"projection": [[1.0] * 6] * 6, "extra": 1}, "projection: 6 x n rows"),
    ],
)
def test_bad_layouts_are_refused_with_what_is_expected(value, words):
    with pytest.raises(ConfigError, match=words):
        channel_layout(value)


def test_paper_layout_is_the_paper_projection():
    assert channel_layout(None) is MALTESE_CROSS_8
    np.testing.assert_array_equal(MALTESE_CROSS_8.projection, P)
    np.testing.assert_allclose(MALTESE_CROSS_8.pinv @ np.diag([4, 2, 2, 4, 2, 2]), P.T, atol=1e-12)
    with pytest.raises(ShapeError, match=r"channels.shape=\(6,\).*\(8,\)"):
        OnlineEstimator().update(np.zeros(6), np.zeros(6))


def test_c_bar_from_c_checks_the_structure_of_any_layout(rng):
    layout = channel_layout(_random_projection(rng, 8))
    C_bar = rng.standard_normal((6, 6))
    np.testing.assert_allclose(layout.c_bar_from_c(layout.c_from_c_bar(C_bar)), C_bar, atol=1e-10)
    with pytest.raises(StructureError):
        layout.c_bar_from_c(rng.standard_normal((6, 8)))


def test_jig_with_a_factory_wrench(rng):
    W = rng.uniform(-50, 50, (60, 6))
    C_bar = np.eye(6) * 0.97
    calibration = jig_calibration(W, np.linalg.solve(C_bar, W.T).T, layout=WRENCH_6)
    np.testing.assert_allclose(calibration.C, C_bar, atol=1e-10)


@pytest.mark.parametrize("name", ["wrench-6", "maltese-cross-8"])
def test_noise_does_not_fill_the_directions_the_loads_leave_out(rng, name):
    """One centre of mass excites rank 4, two rank 6, however noisy the channels: strain noise
    alone spans every direction a little, and S_XX by itself would read rank 5 to 7."""
    layout = channel_layout(name)
    noise = 0.05 if name == "wrench-6" else 1e-4  # [N] of a factory sensor; [mV/V] ten times the paper sensor's
    estimator = OnlineEstimator(layout=layout, offsets="constant")
    expected = {1: 4, 2: 6, 3: 7}
    for count, com in enumerate(COMS, start=1):
        W = tool_wrench(TOOL_MASS, com, random_gravity(2000, rng))
        estimator.update_batch(W, W @ layout.pinv.T + noise * rng.standard_normal((2000, layout.n_channels)))
        rank, condition = estimator.rank()
        assert rank == expected[count]
        if count < 3:
            assert condition == np.inf
            with pytest.raises(InsufficientExcitation, match=f"rank {rank} of 7"):
                estimator.solve()
    estimator.solve()


def test_strains_the_loads_explain_leave_only_the_noise(rng):
    """With one centre of mass the strain scatter the loads leave unexplained is the noise (ratio ~1);
    strains of another centre of mass labelled as this one leave far more."""
    from fts_calib.model.least_squares import unexplained_strain

    noise = 1e-4
    noise_cov = (MALTESE_CROSS_8.projection * noise**2) @ MALTESE_CROSS_8.projection.T
    W = tool_wrench(TOOL_MASS, COMS[0], random_gravity(3000, rng))
    strains = W @ MALTESE_CROSS_8.pinv.T + noise * rng.standard_normal((3000, 8))
    estimator = OnlineEstimator(offsets="constant")
    estimator.update_batch(W, strains)
    sums = estimator.model_sums(estimator.model_in_use()[0])
    assert 0.8 < unexplained_strain(sums, noise_cov, estimator.weight_sum) < 1.3
    wrong = tool_wrench(TOOL_MASS, COMS[2], random_gravity(3000, rng))
    mislabelled = OnlineEstimator(offsets="constant")
    mislabelled.update_batch(W, wrong @ MALTESE_CROSS_8.pinv.T + noise * rng.standard_normal((3000, 8)))
    sums = mislabelled.model_sums(mislabelled.model_in_use()[0])
    assert unexplained_strain(sums, noise_cov, mislabelled.weight_sum) > 100


@pytest.mark.parametrize(
    ("channels", "words"),
    [
        ("wrench6", r"field 'channels': is 'wrench6' but expected .* \(did you mean 'wrench-6'\?\)"),
        ("6", r"field 'channels': is 6 but expected maltese-cross-8, wrench-6"),
        (
            "[[1, 0], [0, 1, 2], [1], [1], [1], [1]]",
            r"field 'channels.projection': has rows of \[2, 3, 1, 1, 1, 1\] numbers but expected 6 rows",
        ),
        ("[[a, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0]]", r"field 'channels.projection': has the entry 'a' but expected numbers"),
        ("{projection: [[1, 0, 0], [0, 1, 0]]}", r"field 'channels.projection': has shape \(2, 3\) but expected a 6 x n matrix"),
        (
            "{projection: [[1, 0, 0, 0, 0, 0], [1, 0, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0], "
            "[0, 0, 0, 1, 0, 0], [0, 0, 0, 0, 1, 0], [0, 0, 0, 0, 0, 1]]}",
            r"field 'channels.projection': has rank 5 but expected full row rank 6",
        ),
    ],
)
def test_a_sensor_file_with_a_bad_layout_names_the_field_and_what_is_wrong(tmp_path, channels, words):
    """Before: 'projection' for a field the file calls channels, a quoted "'shape (2, 3)'", and for ragged rows or text
    entries only the list of accepted layouts."""
    from fts_calib.model.sensor_config import load_sensor_config

    path = tmp_path / "s.yaml"
    path.write_text(f"name: s\nstrain_unit: V\nfull_scale: {{force: 50.0, moment: 5.0}}\nchannels: {channels}\n")
    with pytest.raises(FileFormatError, match=words):
        load_sensor_config(path)

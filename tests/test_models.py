"""Sensor model families: features, recovery from noiseless data, one runtime, exports."""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest

from fts_calib.core.exceptions import ConfigError, FileFormatError
from fts_calib.model.calibration import load_calibration, save_calibration
from fts_calib.model.channels import P_NULL, P
from fts_calib.model.estimator import OnlineEstimator
from fts_calib.model.features import SensorModel, feature_names, features, monomials, n_features
from fts_calib.model.offset_models import OffsetBasis
from fts_calib.model.retare import estimate_offsets
from fts_calib.robot.tool import ToolConfiguration
from fts_calib.service.exports import c_header, export, json_text
from fts_calib.service.reader import WrenchReader

from .nonlinear import FULL_SCALE, JIG, OTHER_TOOL, pose_data

#: Noiseless fits in double precision: coefficients and wrenches to about 1e-9 of their size.
RTOL_NOISELESS = 1e-9


def _truth(rng, degree: int, fraction: float = 0.03) -> tuple[np.ndarray, np.ndarray]:
    """A sensor's true coefficients (6, p) over the features of u = P Delta up to ``degree``, and D (6,)."""
    data = pose_data(0, quadratic=fraction if degree >= 2 else 0.0, cubic=fraction if degree >= 3 else 0.0)
    return data.theta[:, : len(monomials(6, degree))], data.D


def _box_samples(rng, theta: np.ndarray, D: np.ndarray, degree: int, n: int = 3000) -> tuple[np.ndarray, np.ndarray]:
    """Loads spread over the full-scale box (a jig, not gravity alone) and their exact channels (no noise, no rounding)."""
    W = rng.uniform(-1.0, 1.0, size=(n, 6)) * FULL_SCALE
    u = np.linalg.solve(theta[:, :6], (W - D).T).T
    for _ in range(100):  # the inverse of the model by fixed point (its nonlinear part is a few % of the linear one)
        u = np.linalg.solve(theta[:, :6], (W - D - features(u, degree)[:, 6:] @ theta[:, 6:].T).T).T
    channels = u @ np.linalg.pinv(P).T + np.array([150.0, -100.0]) @ P_NULL
    return W, channels


def test_features_are_the_monomials_in_degree_order_and_each_family_extends_the_smaller_one():
    rng = np.random.default_rng(1)
    u = rng.normal(size=(5, 6))
    assert [n_features(6, f) for f in ("linear", "quadratic", "cubic")] == [6, 27, 83]
    phi = features(u, 3)
    expected = np.stack([np.prod(u[:, list(m)], axis=1) for m in monomials(6, 3)], axis=1)
    np.testing.assert_allclose(phi, expected, rtol=1e-14, atol=0)
    np.testing.assert_array_equal(features(u, 2), phi[:, :27])
    assert feature_names(6, 2)[:8] == ["u1", "u2", "u3", "u4", "u5", "u6", "u1*u1", "u1*u2"]


@pytest.mark.parametrize("degree, family", [(2, "quadratic"), (3, "cubic")])
def test_noiseless_loads_over_the_range_recover_every_coefficient(degree, family):
    rng = np.random.default_rng(degree)
    theta, D = _truth(rng, degree)
    W, channels = _box_samples(rng, theta, D, degree)
    units = np.arange(len(W)) // 300  # ten blocks
    est = OnlineEstimator(offsets="constant", basis=OffsetBasis(1, 0, temperature=False), model=family)
    est.update_batch(W, channels, unit=units)
    cal = est.solve()
    assert cal.family == family and cal.quality is not None and cal.quality.held_directions["count"] == 0
    assert cal.model is not None
    scale = np.abs(theta).max(axis=1, keepdims=True)
    np.testing.assert_allclose(cal.model.coefficients / scale, theta / scale, rtol=0, atol=1e-7)
    np.testing.assert_allclose(cal.D, D, rtol=0, atol=RTOL_NOISELESS * np.abs(W).max() * 100)
    np.testing.assert_allclose(cal.wrench(channels), W, rtol=0, atol=RTOL_NOISELESS * np.abs(W).max() * 10)


def test_on_gravity_spheres_a_quadratic_model_holds_what_no_weight_excites_and_predicts_new_poses_and_another_tool():
    """A linear sensor under weights: F . M = 0 on every weight's load (paper eq 20), a direction no jig excites, held at zero."""
    data = pose_data(3, noise_counts=0.0, rounding=False, poses=16)
    train = np.isin(data.unit % 16, np.arange(12))
    est = OnlineEstimator(offsets="constant", basis=OffsetBasis(len(JIG), 0, temperature=False), model="quadratic")
    est.update_batch(data.W[train], data.channels[train], configuration=data.configuration[train], unit=data.units[train])
    cal = est.solve()
    held = cal.quality.held_directions["count"]
    assert 1 <= held < 27, f"{held} directions held of 28"
    other = pose_data(4, noise_counts=0.0, rounding=False, tool=OTHER_TOOL, sensor_seed=3)
    atol = 1e-7 * np.abs(data.W).max()  # noiseless: round-off of the minimum-norm solve
    np.testing.assert_allclose(cal.wrench(data.channels[~train]), data.W[~train], rtol=0, atol=atol)
    np.testing.assert_allclose(cal.wrench(other.channels), other.W, rtol=0, atol=atol)


def test_a_free_matrix_over_the_raw_channels_holds_the_two_load_free_patterns():
    """``channels: full`` on the 8-bridge sensor: the null patterns of P carry a constant only."""
    data = pose_data(4, noise_counts=0.0, rounding=False)
    est = OnlineEstimator(offsets="constant", basis=OffsetBasis(len(JIG), 0, temperature=False), model="linear", full_channels=True)
    est.update_batch(data.W, data.channels, configuration=data.configuration, unit=data.units)
    cal = est.solve()
    assert cal.model is not None and cal.model.full and cal.quality.held_directions["count"] == 2
    np.testing.assert_allclose(cal.wrench(data.channels), data.W, rtol=0, atol=1e-8 * np.abs(data.W).max())


@pytest.fixture(scope="module")
def quadratic_calibration():
    data = pose_data(5, quadratic=0.03)
    est = OnlineEstimator(offsets="constant", basis=OffsetBasis(len(JIG), 0, temperature=False), model="quadratic")
    est.update_batch(data.W, data.channels, configuration=data.configuration, unit=data.units)
    return est.solve(), data


def test_a_nonlinear_calibration_round_trips_through_its_file_and_every_reader_agrees(tmp_path, quadratic_calibration):
    cal, data = quadratic_calibration
    path = save_calibration(cal, tmp_path / "cal.yaml")
    loaded = load_calibration(path)
    assert loaded.family == "quadratic" and loaded.model_selection["chosen"] == "quadratic + constant"
    expected = cal.wrench(data.channels)
    atol = 1e-12 * np.abs(expected).max()
    np.testing.assert_allclose(loaded.wrench(data.channels), expected, rtol=0, atol=atol)
    reader = WrenchReader(loaded)
    np.testing.assert_allclose(reader.wrench_batch(data.channels), expected, rtol=0, atol=atol)
    for k in (0, 7, len(expected) - 1):
        np.testing.assert_allclose(reader.wrench(data.channels[k]), expected[k], rtol=0, atol=atol)
    # a re-tare with the model: the offsets of still samples under a known load
    estimate = estimate_offsets(loaded.C_bar, data.channels, data.W, loaded.layout, loaded.model)
    np.testing.assert_allclose(estimate.D, loaded.D, atol=5 * np.abs(estimate.stderr_D).max() + 1e-9)


def test_a_file_of_an_older_version_is_linear_and_a_malformed_model_is_refused(tmp_path, quadratic_calibration):
    cal, _ = quadratic_calibration
    path = save_calibration(cal, tmp_path / "cal.yaml")
    text = path.read_text()
    old = tmp_path / "old.yaml"
    old.write_text(text.split("\nmodel:")[0] + "\n")  # the fields after it are optional too
    assert load_calibration(old).model is None
    bad = tmp_path / "bad.yaml"
    bad.write_text(text.replace("family: quadratic", "family: quartic"))
    with pytest.raises(FileFormatError, match="model.family"):
        load_calibration(bad)


def test_formats_of_one_matrix_refuse_a_nonlinear_model_and_say_why(quadratic_calibration):
    cal, _ = quadratic_calibration
    payload = ToolConfiguration("P", 1.0, np.zeros(3))
    with pytest.raises(ConfigError, match="holds one matrix C"):
        export(cal, "ros2", payload=payload)
    with pytest.raises(ConfigError, match="holds one matrix C"):
        export(cal, "ati", full_scale=FULL_SCALE)
    assert '"family": "quadratic"' in json_text(cal)


def test_the_c_header_polynomial_matches_python_on_random_channel_vectors(tmp_path, quadratic_calibration):
    compiler = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    if compiler is None:
        pytest.skip("no C compiler on this machine: the header's polynomial is not compiled")
    cal, data = quadratic_calibration
    (tmp_path / "fts_calib.h").write_text(c_header(cal))
    rng = np.random.default_rng(11)
    lo, hi = data.channels.min(axis=0), data.channels.max(axis=0)
    channels = rng.uniform(lo - 0.2 * (hi - lo), hi + 0.2 * (hi - lo), size=(10_000, 8))
    np.savetxt(tmp_path / "in.txt", channels, fmt="%.17g")
    main = r"""
#define FTS_CALIB_DOUBLE
#include <stdio.h>
#include "fts_calib.h"
int main(void) {
    double s[8], w[6];
    while (scanf("%lf %lf %lf %lf %lf %lf %lf %lf", s, s + 1, s + 2, s + 3, s + 4, s + 5, s + 6, s + 7) == 8) {
        fts_calib_wrench(s, w);
        printf("%.17g %.17g %.17g %.17g %.17g %.17g\n", w[0], w[1], w[2], w[3], w[4], w[5]);
    }
    return 0;
}
"""
    (tmp_path / "main.c").write_text(main)
    exe = tmp_path / "main"
    subprocess.run([compiler, "-Wall", "-Werror", "-std=c99", "-O2", "-o", str(exe), str(tmp_path / "main.c")], check=True)
    out = subprocess.run([str(exe)], input=(tmp_path / "in.txt").read_text(), capture_output=True, text=True, check=True).stdout
    result = np.loadtxt(out.splitlines())
    expected = cal.wrench(channels)
    assert result.shape == expected.shape
    np.testing.assert_allclose(result, expected, rtol=0, atol=1e-9 * np.abs(expected).max())


def test_a_model_of_the_wrong_shape_is_refused():
    with pytest.raises(ConfigError, match="coefficients"):
        SensorModel("quadratic", np.zeros((6, 6)), P, 8)
    with pytest.raises(ConfigError, match="family"):
        SensorModel("quartic", np.zeros((6, 6)), P, 8)


def test_the_sensor_file_names_the_model_beside_the_layout(tmp_path):
    from fts_calib.model.sensor_config import load_sensor_config

    path = tmp_path / "sensor.yaml"
    path.write_text("name: low-cost\nchannels: full\nmodel: quadratic\n")
    spec = load_sensor_config(path)
    assert spec.model == "quadratic" and spec.full_channels and spec.layout.n_channels == 8
    path.write_text("name: default\n")
    assert load_sensor_config(path).model == "auto" and not load_sensor_config(path).full_channels
    path.write_text("name: typo\nmodel: quartic\n")
    with pytest.raises(FileFormatError, match="model.*'auto' or 'linear' or 'quadratic' or 'cubic'"):
        load_sensor_config(path)

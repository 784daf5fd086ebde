"""The simulated sensor and the sensor configuration file."""

import numpy as np
import pytest
import yaml

from fts_calib import ConfigError, FileFormatError, ShapeError, SimulatedSensor
from fts_calib.core.resources import resolve
from fts_calib.model.channels import project
from fts_calib.model.sensor_config import SensorSpec, SimulationSpec, load_sensor_config

from .helpers import C_BAR_TRUE, D_TRUE
from .paper import TABLE_1


def test_noiseless_strains_invert_the_model_exactly(rng):
    sensor = SimulatedSensor(C_BAR_TRUE, D_TRUE, null_coupling=rng.standard_normal((2, 6)) * 1e-3, null_offset=[0.1, -0.2])
    W = rng.standard_normal((50, 6)) * 10
    S = sensor.channels(W)
    np.testing.assert_allclose(project(S) @ C_BAR_TRUE.T + D_TRUE, W, atol=1e-10)


def test_null_content_is_invisible_to_the_model_but_present(rng):
    plain = SimulatedSensor(C_BAR_TRUE, D_TRUE)
    coupled = SimulatedSensor(C_BAR_TRUE, D_TRUE, null_offset=[0.1, -0.2])
    W = rng.standard_normal((5, 6))
    assert np.max(np.abs(coupled.channels(W) - plain.channels(W))) > 0.05
    np.testing.assert_allclose(project(coupled.channels(W)), project(plain.channels(W)), atol=1e-12)


def test_quantization_step_and_saturation():
    sensor = SimulatedSensor(C_BAR_TRUE, adc_bits=24, adc_full_scale=1000.0 / 128)
    assert sensor.lsb == pytest.approx(2 * 1000 / 128 / 2**24)
    S = sensor.channels(np.array([[20.0, 5, -3, 0.5, 0.2, -0.1], [1e6, 0, 0, 0, 0, 0]]))
    np.testing.assert_allclose(S[0] / sensor.lsb, np.round(S[0] / sensor.lsb), atol=1e-6)
    assert np.max(np.abs(S[1])) <= sensor.adc_full_scale


def test_noise_has_the_configured_spread(rng):
    sensor = SimulatedSensor(C_BAR_TRUE, noise_std=np.full(8, 1e-3))
    S = sensor.channels(np.zeros((20000, 6)), rng=rng)
    # std of a std estimate from 20000 samples: 1/sqrt(40000) = 0.5%
    np.testing.assert_allclose(S.std(axis=0), 1e-3, rtol=0.03)


def test_drift_adds_rate_times_time():
    sensor = SimulatedSensor(C_BAR_TRUE, drift_rate=np.full(8, 1e-4))
    S = sensor.channels(np.zeros((2, 6)), time=np.array([0.0, 10.0]))
    np.testing.assert_allclose(S[1] - S[0], 1e-3)


def test_shipped_sensor_config_is_table_1():
    spec = load_sensor_config(resolve("sensor", "configs"))
    assert spec.simulated is not None
    np.testing.assert_allclose(spec.simulated.C, TABLE_1, atol=5e-5)
    np.testing.assert_array_equal(spec.full_scale, [50, 50, 50, 5, 5, 5])
    assert spec.simulated.lsb == pytest.approx(9.3132e-7, rel=1e-4)


def test_sensor_config_errors_name_the_field(tmp_path):
    path = tmp_path / "s.yaml"
    bad_C = (TABLE_1 + np.eye(6, 8) * 0.5).tolist()
    path.write_text(yaml.safe_dump({"name": "s", "simulation": {"C": bad_C}}))
    with pytest.raises(FileFormatError, match="field 'simulation.C': C is not of the form C_bar @ P"):
        load_sensor_config(path)
    path.write_text(yaml.safe_dump({"name": "s", "full_scale": {"force": -5}}))
    with pytest.raises(FileFormatError, match="field 'full_scale.force': is -5.0 but expected a finite value > 0"):
        load_sensor_config(path)


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"noise_std": -1e-6}, r"noise_std=\[-1e-06, .*\] but expected values >= 0"),
        ({"drift_rate": [0.0] * 7 + [float("nan")]}, r"drift_rate=\[0.0, .*, nan\] but expected finite values"),
        ({"D": [0.0, 0.0, float("inf"), 0.0, 0.0, 0.0]}, r"D=\[0.0, 0.0, inf, 0.0, 0.0, 0.0\] but expected finite values"),
        ({"adc_bits": 7}, r"adc_bits=7 but expected 0 \(off\) or an integer from 8 to 32"),
        ({"adc_bits": 12.5}, r"adc_bits=12.5 but expected 0 \(off\) or an integer from 8 to 32"),
        ({"adc_full_scale": 0.0}, r"adc_full_scale=0.0 but expected a finite value > 0"),
    ],
)
def test_the_simulation_section_refuses_bad_values_in_python(changes, match):
    with pytest.raises(ConfigError, match=match):
        SimulationSpec(C_BAR_TRUE, **changes)


def test_per_bridge_values_take_one_number_or_eight():
    assert SimulationSpec(C_BAR_TRUE, noise_std=2e-6).noise_std.tolist() == [2e-6] * 8
    with pytest.raises(ShapeError, match=r"noise_std.shape=\(3,\) but expected \(\) or \(8,\)"):
        SimulationSpec(C_BAR_TRUE, noise_std=[1e-6] * 3)


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"rate_hz": 0.0}, r"sensor 's': rate_hz=0.0 Hz but expected a finite value > 0"),
        (
            {"full_scale": [50.0, 50.0, -50.0, 5.0, 5.0, 5.0]},
            r"sensor 's': full_scale=\[50.0, 50.0, -50.0, 5.0, 5.0, 5.0\] but expected finite values > 0",
        ),
    ],
)
def test_the_sensor_spec_refuses_bad_values_in_python(changes, match):
    with pytest.raises(ConfigError, match=match):
        SensorSpec(**{"name": "s", "strain_unit": "mV/V", "full_scale": [50.0] * 3 + [5.0] * 3, "rate_hz": 1000.0, **changes})


@pytest.mark.parametrize(
    ("data", "match"),
    [
        ({"rate_hz": 0}, r"s.yaml: field 'rate_hz': is 0.0 Hz but expected a finite value > 0"),
        (
            {"simulation": {"C_bar": C_BAR_TRUE.tolist(), "noise_std": -1.0}},
            r"field 'simulation.noise_std': is \[-1.0, .*\] but expected values >= 0",
        ),
        (
            {"simulation": {"C_bar": C_BAR_TRUE.tolist(), "adc": {"bits": 40}}},
            r"field 'simulation.adc.bits': is 40 but expected 0 \(off\) or an integer",
        ),
        (
            {"simulation": {"C_bar": C_BAR_TRUE.tolist(), "adc": {"bits": 12.5}}},
            r"field 'simulation.adc.bits': is 12.5 but expected an integer",
        ),
    ],
)
def test_the_loader_names_the_file_and_field_of_a_refused_value(tmp_path, data, match):
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump({"name": "s", **data}))
    with pytest.raises(FileFormatError, match=match):
        load_sensor_config(path)

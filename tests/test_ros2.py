"""ros2_control export: golden files, and the broadcaster and control_toolbox's filter run on the exported numbers.

The two functions below are Python ports of what the ROS 2 code does with the parameters
(read from ros2_controllers' ForceTorqueSensorBroadcaster and control_toolbox's
GravityCompensation<WrenchStamped>::update): the broadcaster adds ``offset`` to each axis and
multiplies by ``multiplier``; the filter subtracts the tool's weight, rotated into the sensor
frame, and the torque of that weight about ``tool.CoG``.
"""

from pathlib import Path

import numpy as np
import pytest
import yaml

from fts_calib import Calibration, ConfigError, FtsCalibWarning
from fts_calib.app.cli import main
from fts_calib.core.resources import resolve
from fts_calib.model.calibration import save_calibration
from fts_calib.model.channels import WRENCH_6
from fts_calib.robot.tool import load_tool
from fts_calib.service.reader import GravityCompensator
from fts_calib.service.ros2 import BROADCASTER, FILTER_TYPE, broadcaster_correction, ros2_parameters
from fts_calib.sim.sensor import load_simulated_sensor

DATA = Path(__file__).parent / "data"
GRAVITY = 9.81  # [m/s^2]


def broadcaster(params: dict, reading: np.ndarray) -> np.ndarray:
    """ForceTorqueSensorBroadcaster: ``(reading + offset) * multiplier`` per axis (offset first)."""
    axes = [(part, axis) for part in ("force", "torque") for axis in "xyz"]
    offset = np.array([params["offset"][p][a] for p, a in axes])
    multiplier = np.array([params["multiplier"][p][a] for p, a in axes])
    return (reading + offset) * multiplier


def gravity_compensation(params: dict, w_sensor: np.ndarray, R_sensor_world: np.ndarray) -> np.ndarray:
    """GravityCompensation::update with data_in and data_out in the sensor frame."""
    tool = params["tool"]
    f_sensor = R_sensor_world @ (tool["mass"] * np.array(tool["gravity_field"], dtype=float))
    out = np.array(w_sensor, dtype=float)
    out[:3] -= f_sensor
    out[3:] -= np.cross(tool["CoG"], f_sensor)
    return out


def _node(text: str) -> dict:
    return yaml.safe_load(text)[BROADCASTER]["ros__parameters"]


@pytest.fixture(scope="module")
def payload():
    return load_tool(resolve("paper_tool", "configs")).configuration("A")  # 2 kg at [0.12, 0, 0] m


@pytest.fixture(scope="module")
def factory():
    """The factory sensor's true correction: 3 % gain and a 2° rotation (cross terms)."""
    sensor = load_simulated_sensor(resolve("factory_sensor", "configs"))
    return Calibration(sensor.C_bar, sensor.D, layout=WRENCH_6, provenance={"software_version": "0"})


@pytest.fixture(scope="module")
def diagonal():
    """A wrench-6 correction the broadcaster applies exactly: gains only, and offsets."""
    C_bar = np.diag([0.97, 1.02, 1.03, 0.99, 1.01, 0.98])
    return Calibration(C_bar, np.array([1.5, -0.8, 2.0, 0.05, -0.03, 0.02]), layout=WRENCH_6)


def test_control_toolbox_computation_case_on_our_numbers(payload, diagonal):
    """control_toolbox's TestGravityCompensationComputation: world = sensor frame, gravity
    [0, 0, -9.81]; an input with force.x = 1 and torque.x = 10 keeps them, and force.z
    becomes +m g. Our payload's CoG is not at the origin: the torque also loses CoG x m g."""
    node = _node(ros2_parameters(diagonal, payload, GRAVITY, "world", "world"))
    params = node["sensor_filter_chain"]["filter1"]["params"]
    out = gravity_compensation(params, np.array([1.0, 0, 0, 10.0, 0, 0]), np.eye(3))
    m, c = payload.mass, payload.p_sensor_com
    np.testing.assert_allclose(out[:3], [1.0, 0.0, m * GRAVITY], rtol=0, atol=1e-12)
    np.testing.assert_allclose(out[3:], [10.0, 0, 0] - np.cross(c, [0, 0, -m * GRAVITY]), rtol=0, atol=1e-12)
    assert out[4] == pytest.approx(-m * GRAVITY * c[0], abs=1e-12)  # -2.3544 N m
    assert node["sensor_filter_chain"]["filter1"]["type"] == FILTER_TYPE


def test_the_ros_chain_reproduces_our_compensation(rng, payload, diagonal):
    """Factory readings of the payload plus an external wrench, in random orientations, through
    the broadcaster and the filter: the external wrench, as fts-calib's GravityCompensator finds it."""
    node = _node(ros2_parameters(diagonal, payload, GRAVITY, "ft_sensor", "world"))
    params = node["sensor_filter_chain"]["filter1"]["params"]
    compensator = GravityCompensator(diagonal, payload, g_world=(0.0, 0.0, -GRAVITY))
    for _ in range(50):
        q, _r = np.linalg.qr(rng.standard_normal((3, 3)))
        R_world_sensor = q * np.sign(np.linalg.det(q))
        external = rng.uniform(-20, 20, 6) * np.array([1, 1, 1, 0.1, 0.1, 0.1])
        W = payload.static_wrench(R_world_sensor.T @ [0.0, 0.0, -GRAVITY]) + external
        reading = np.linalg.solve(diagonal.C_bar, W - diagonal.D)  # what the factory-calibrated sensor reports
        ros = gravity_compensation(params, broadcaster(node, reading), R_world_sensor.T)
        ours = compensator.external(reading, R_world_sensor)
        scale = np.abs(W).max()  # [N]: round-off of sums of this size
        np.testing.assert_allclose(ros, external, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(ros, ours, rtol=0, atol=1e-12 * scale)


def test_a_reading_bias_is_exported_as_its_opposite(payload):
    bias = np.array([0.4, -1.2, 3.0, 0.01, 0.02, -0.03])  # the reading with nothing mounted [N, N m]
    calibration = Calibration(np.eye(6), -bias, layout=WRENCH_6)
    node = _node(ros2_parameters(calibration, payload, GRAVITY))
    np.testing.assert_array_equal(broadcaster(node, bias), np.zeros(6))
    assert node["offset"]["force"]["z"] == -3.0 and node["multiplier"]["torque"]["x"] == 1.0


def test_cross_terms_are_named_and_warned_about(factory, payload):
    correction = broadcaster_correction(factory)
    assert correction.coupling == pytest.approx(0.029454754 / 1.029477127, abs=1e-12)  # the largest cross term, row Fz
    with pytest.warns(FtsCalibWarning, match=r"cross terms \(up to 0.0286 of a diagonal term\)"):
        text = ros2_parameters(factory, payload, GRAVITY)
    assert "# Not applied: C_bar's cross terms, up to 0.0286" in text


def test_a_rotated_wrench_sensor_is_refused_not_exported_with_infinite_offsets(payload):
    """A factory frame turned 90 deg about x against S: C_bar's Fy and Fz rows have zero diagonal terms."""
    C_bar = np.eye(6)
    C_bar[1:3, 1:3] = C_bar[4:6, 4:6] = [[0.0, -1.0], [1.0, 0.0]]
    calibration = Calibration(C_bar, np.ones(6), layout=WRENCH_6)
    with pytest.raises(ConfigError, match=r"row Fy is dominated by a cross term.*--format c-header"):
        ros2_parameters(calibration, payload, GRAVITY)


def test_a_strain_gauge_layout_takes_c_delta_from_the_hardware(payload):
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    calibration = Calibration(sensor.C_bar, sensor.D)
    node = _node(ros2_parameters(calibration, payload, GRAVITY))
    np.testing.assert_array_equal(broadcaster(node, np.zeros(6)), sensor.D)  # C Delta = 0: the offsets
    assert broadcaster_correction(calibration).reading.startswith("C times the 8 raw channels")


@pytest.mark.parametrize("name", ["factory", "diagonal"])
def test_golden_files(request, name, payload):
    """The whole file, byte for byte (regenerate deliberately: the golden file is the contract)."""
    calibration = request.getfixturevalue(name)
    with pytest.warns(FtsCalibWarning) if name == "factory" else _no_warning():
        text = ros2_parameters(calibration, payload, GRAVITY, "ft_sensor", "base_link")
    assert text == (DATA / f"ros2_{name}.yaml").read_text()


def test_cli_writes_the_ros2_file(tmp_path, diagonal, capsys):
    path = save_calibration(diagonal, tmp_path / "cal.yaml")
    out = tmp_path / "ros2.yaml"
    args = ["export", "--format", "ros2", "--calibration", str(path), "--payload", "paper_tool", "-o", str(out)]
    assert main([*args, "--sensor-frame", "ft_sensor", "--world-frame", "base_link"]) == 0
    node = _node(out.read_text())
    assert node["frame_id"] == "ft_sensor" and node["sensor_filter_chain"]["filter1"]["params"]["world_frame"] == "base_link"
    np.testing.assert_array_equal(node["multiplier"]["force"]["x"], 0.97)


class _no_warning:
    def __enter__(self):
        import warnings

        self._catch = warnings.catch_warnings()
        self._catch.__enter__()
        warnings.simplefilter("error", FtsCalibWarning)

    def __exit__(self, *exc):
        self._catch.__exit__(*exc)

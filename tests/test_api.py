"""The public API: a small lazy surface, the light and strict in-controller path, shipped names, one file whatever the route."""

import ast
import importlib
import json
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import fts_calib
from fts_calib import Calibration, GravityCompensator, Kinematics, ShapeError, WrenchReader, calibrate, load_robot, load_tool
from fts_calib.app.cli import main
from fts_calib.core.exceptions import (
    ConfigError,
    FileFormatError,
    FrameNotFound,
    FtsCalibWarning,
    InsufficientExcitation,
    NotARotation,
    ResourceNotFound,
    UnknownToolConfiguration,
)
from fts_calib.core.files import load_yaml
from fts_calib.core.resources import resolve
from fts_calib.sim.runs import simulate_batches
from fts_calib.sim.sensor import load_simulated_sensor

#: Modules the in-controller path must not load: pandas, ruckig, matplotlib and rosbags (imported inside the functions that need
#: them), and Pinocchio, coal, PyYAML.
HEAVY = ("pandas", "ruckig", "matplotlib", "rosbags", "pinocchio", "coal", "yaml")
ATOL_POSE = 1e-12  # [m] and [-]: the same forward kinematics, only the construction differs


@pytest.fixture(scope="module")
def truth():
    return load_simulated_sensor(resolve("sensor", "configs"))


@pytest.fixture(scope="module")
def calibration(truth):
    return Calibration(truth.C_bar, truth.D)


@pytest.fixture(scope="module")
def payload():
    return load_tool("validation_tool").configurations[0]


def _rotation(rng) -> np.ndarray:
    q, r = np.linalg.qr(rng.standard_normal((3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


# --- the package surface ---------------------------------------------------------------------------------


def test_at_most_40_names_loaded_lazily_and_dir_lists_them():
    assert len(fts_calib.__all__) <= 40 and fts_calib.__all__ == sorted(fts_calib.__all__)
    assert set(fts_calib.__all__) <= set(dir(fts_calib))
    for name in fts_calib.__all__:
        assert getattr(fts_calib, name) is not None, name
    with pytest.raises(AttributeError, match="no attribute 'strain_reader'"):
        fts_calib.strain_reader  # noqa: B018


def test_type_checkers_see_every_name_from_the_module_it_is_loaded_from():
    """The ``if TYPE_CHECKING:`` imports (what mypy and IDEs read) and the run-time table name the same places."""
    tree = ast.parse(Path(fts_calib.__file__).read_text(encoding="utf-8"))
    block = next(node for node in tree.body if isinstance(node, ast.If) and getattr(node.test, "id", "") == "TYPE_CHECKING")
    seen = {alias.name: "." + node.module for node in block.body if isinstance(node, ast.ImportFrom) for alias in node.names}
    assert seen == fts_calib._WHERE
    assert sorted([*seen, "__version__"]) == fts_calib.__all__


def test_the_in_controller_import_loads_nothing_heavy():
    code = "import json, sys; from fts_calib import Calibration, WrenchReader; print(json.dumps(sorted(sys.modules)))"
    loaded = set(json.loads(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout))
    assert not loaded & set(HEAVY), f"heavy modules on the in-controller path: {sorted(loaded & set(HEAVY))}"


# --- the in-controller path: right answers for what converts, ShapeError naming the argument for the rest ---


def test_reader_takes_a_list_or_float32_and_names_a_wrong_argument(calibration):
    reader = WrenchReader(calibration)
    x = np.linspace(-0.2, 0.3, 8)  # [mV/V]
    expected = calibration.C @ x + calibration.D
    atol = 1e-12 * np.abs(expected).max()
    np.testing.assert_allclose(reader.wrench(x), expected, rtol=0, atol=atol)
    np.testing.assert_allclose(reader.wrench(x.tolist()), expected, rtol=0, atol=atol)
    np.testing.assert_allclose(calibration.wrench(x.tolist()), expected, rtol=0, atol=atol)
    # float32 rounds the readings to 6e-8 relative: the wrench to that of the largest term
    np.testing.assert_allclose(reader.wrench(x.astype(np.float32)), expected, rtol=0, atol=1e-6 * np.abs(calibration.C).max())
    with pytest.raises(ShapeError, match=r"channels.shape=\(7,\) but expected \(8,\)"):
        reader.wrench(x[:7])
    with pytest.raises(ShapeError, match=r"channels.shape=\(2, 8\) but expected \(8,\)"):
        reader.wrench(np.vstack([x, x]))
    with pytest.raises(ShapeError, match="channels must be numbers"):
        reader.wrench(["a"] * 8)
    with pytest.raises(ShapeError, match=r"channels.shape=\(7,\)"):
        calibration.wrench(x[:7])


def test_compensator_takes_a_pin_se3_and_refuses_what_is_not_a_rotation(calibration, payload, rng):
    comp = GravityCompensator(calibration, payload)
    x = rng.standard_normal(8) * 0.1
    R = _rotation(rng)
    expected = comp.external(x, R).copy()
    atol = 1e-12 * np.abs(expected).max()
    np.testing.assert_allclose(comp.external(x, pin.SE3(R, np.ones(3))), expected, rtol=0, atol=atol)
    np.testing.assert_allclose(comp.external(x.tolist(), R.tolist()), expected, rtol=0, atol=atol)
    T = np.eye(4)
    T[:3, :3] = R
    with pytest.raises(ShapeError, match=r"R_world_sensor.shape=\(4, 4\) but expected \(3, 3\).*T\[:3, :3\]"):
        comp.external(x, T)
    with pytest.raises(NotARotation, match=r"R_world_sensor is not a rotation: \|R\^T R - I\| = 0.0348"):
        comp.external(x, 1.01 * R)  # R^T R - I = (1.01^2 - 1) I: Frobenius norm 0.0201 sqrt(3)
    with pytest.raises(NotARotation, match=r"reflection \(det = -1\)"):
        comp.external(x, R @ np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(NotARotation, match="not a rotation"):
        comp.external(x, np.full((3, 3), np.nan))
    with pytest.raises(ShapeError, match=r"point.shape=\(2,\) but expected \(3,\)"):
        comp.external(x, R, point=[0.1, 0.2])
    Rs = np.stack([_rotation(rng) for _ in range(4)])
    Rs[2] *= 1.001
    with pytest.raises(NotARotation, match=r"R_world_sensor\[2\] is not a rotation"):
        comp.external_batch(np.zeros((4, 8)), Rs)


def test_a_rotation_within_float_rounding_is_accepted(calibration, payload, rng):
    """Products of rotations drift from orthonormal by ~1e-15 per product: far below the 1e-6 tolerance."""
    comp = GravityCompensator(calibration, payload)
    R = np.eye(3)
    for _ in range(1000):
        R = R @ _rotation(rng)
    comp.external(np.zeros(8), R)


# --- one name per concept: the old keywords work for one release, with a DeprecationWarning --------------


def test_old_keyword_names_warn_and_give_the_same_result(calibration, ur5, truth):
    reader = WrenchReader(calibration)
    x = np.linspace(0.1, 0.8, 8)
    expected = reader.wrench(x).copy()
    with pytest.warns(DeprecationWarning, match=r"'strain' is now 'channels'"):
        np.testing.assert_array_equal(reader.wrench(strain=x), expected)
    with pytest.warns(DeprecationWarning, match=r"'strain' is now 'channels'"):
        np.testing.assert_array_equal(calibration.wrench(strain=x), expected)
    with pytest.raises(TypeError, match="both 'strain' and 'channels'"):
        reader.wrench(strain=x, channels=x)
    joints = np.array([0.1, -1.2, 1.4, -0.3, 0.5, 0.6])  # [rad]
    with pytest.warns(DeprecationWarning, match=r"configuration\(\) is now q_from_joints\(\)"):
        q = ur5.configuration(joints)
    np.testing.assert_array_equal(q, ur5.q_from_joints(joints))
    with pytest.warns(DeprecationWarning, match=r"'readings' is now 'joints'"):
        np.testing.assert_array_equal(ur5.g_sensor(readings=joints), ur5.g_sensor(joints))
    with pytest.warns(DeprecationWarning, match=r"strains\(\) is now channels\(\)"):
        np.testing.assert_array_equal(truth.strains(np.ones(6)), truth.channels(np.ones(6)))
    for old, new in (("robot.load", "robot.tool"), ("robot.load_errors", "budget.sensitivities"), ("pipeline.session", "session.session")):
        sys.modules.pop(f"fts_calib.{old}", None)
        with pytest.warns(DeprecationWarning, match=f"fts_calib.{old} is now fts_calib.{new}"):
            moved = importlib.import_module(f"fts_calib.{old}")
        assert moved is importlib.import_module(f"fts_calib.{new}")  # the same module: what it holds, the old path holds
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the new names never warn
        reader.wrench(channels=x)
        ur5.g_sensor(joints=joints)


# --- entry points take what users hold: shipped names, a URDF path, a pin.Model --------------------------


def test_load_robot_and_load_tool_take_shipped_names_as_the_command_line_does(tmp_path):
    assert load_robot("ur5").name == "ur5" and load_robot("ur5").source == resolve("ur5", "robots")
    assert load_tool("paper_tool").names == ["A", "B", "C"]
    with pytest.raises(ResourceNotFound, match="no file 'ur55' and no shipped robot of that name; shipped: .*ur5"):
        load_robot("ur55")
    with pytest.raises(FileFormatError, match="file not found"):
        load_tool(tmp_path / "my_tool.yaml")  # a path: its loader names the missing file


def test_kinematics_from_a_urdf_path_or_a_pin_model_equals_the_robot_file(ur5, rng):
    mount = ur5.robot.sensor
    from_urdf = Kinematics.from_urdf(ur5.robot.urdf, "tool0", xyz=mount.xyz, rpy=mount.rpy)
    model = pin.buildModelFromUrdf(str(ur5.robot.urdf))
    frames = model.nframes
    from_model = Kinematics.from_model(model, "tool0", xyz=mount.xyz, rpy=mount.rpy, name="my_ur5")
    assert model.nframes == frames, "the user's model was changed"
    assert from_urdf.joint_names == ur5.joint_names == from_model.joint_names and from_model.robot.name == "my_ur5"
    joints = rng.uniform(-np.pi, np.pi, (50, 6))  # [rad]
    for kin in (from_urdf, from_model):
        R, p = kin.sensor_poses(joints)
        R0, p0 = ur5.sensor_poses(joints)
        np.testing.assert_allclose(R, R0, rtol=0, atol=ATOL_POSE)
        np.testing.assert_allclose(p, p0, rtol=0, atol=ATOL_POSE)
    with pytest.raises(FrameNotFound, match="no_such_frame"):
        Kinematics.from_model(model, "no_such_frame")
    with pytest.raises(FileFormatError, match="URDF file not found"):
        Kinematics.from_urdf("no_such.urdf", "tool0")
    with pytest.raises(ConfigError, match=r"model='ur5' but expected a pin.Model \(a URDF: Kinematics.from_urdf"):
        Kinematics.from_model("ur5", "tool0")


# --- fts_calib.calibrate: arrays in memory or a recording; the same file as the command line -------------


def _arrays(kin, tool, plan, sensor, seed) -> dict:
    """The short plan played through the simulated sensor, as the arrays ``fts_calib.calibrate`` takes."""
    batches = list(simulate_batches(kin, tool, [plan.trajectory(name) for name in tool.names], sensor, np.random.default_rng(seed)))
    return {
        "time": np.concatenate([b.time for b in batches]),  # [s]
        "joints": np.concatenate([b.joints for b in batches]),  # [rad]
        "channels": np.concatenate([b.channels for b in batches]),  # [mV/V]
        "configuration": [tool.names[c] for b in batches for c in b.configuration],
    }


def test_calibrate_from_arrays_in_memory_recovers_the_sensor(ur5, paper_tool, short_plan, truth, seed):
    arrays = _arrays(ur5, paper_tool, short_plan, truth, seed)
    cal = calibrate(arrays, robot=ur5, tool=paper_tool)
    # the same data as the recording of test_calibrate: 48 coefficients within 5 standard errors
    # (P(any outside) < 48 x 6e-7 for a seed)
    z = np.abs(cal.C - truth.C) / cal.quality.stderr_C
    assert np.all(z <= 5), f"largest error {z.max():.2f} standard errors"
    assert cal.quality.budget is not None and "stream_latency_estimate" in cal.quality.budget
    with pytest.raises(ShapeError, match=r"has no \['configuration'\]"):
        calibrate({k: v for k, v in arrays.items() if k != "configuration"}, robot=ur5, tool=paper_tool)
    short = {**arrays, "channels": arrays["channels"][:-1]}
    with pytest.raises(ShapeError, match=r"\d+ rows of channels .* expected one of each per sample"):
        calibrate(short, robot=ur5, tool=paper_tool)
    with pytest.raises(TypeError, match="tool"):
        calibrate(arrays, robot=ur5)  # no default tool


def test_calibrate_names_each_wrong_argument_with_what_was_expected(ur5, paper_tool, short_plan, truth, seed):
    """A newcomer's mistakes: each an FtsCalibError naming the argument, none a numpy or pathlib error."""
    arrays = _arrays(ur5, paper_tool, short_plan, truth, seed)
    n = len(arrays["time"])

    def refused(error, match, tool=paper_tool, robot=ur5, **changed):
        with pytest.raises(error, match=match):
            calibrate({**arrays, **changed}, robot=robot, tool=tool)

    refused(ConfigError, r"tool=None but expected a shipped tool name or the path of a tool YAML file", tool=None)
    refused(ConfigError, r"robot=42 but expected a shipped robot name", robot=42)
    refused(ResourceNotFound, r"no shipped tool of that name; shipped: paper_tool, validation_tool$", tool="papertool")
    refused(
        ShapeError, r"arrays in memory has 6 channels but the sensor's layout maltese-cross-8 has 8", channels=arrays["channels"][:, :6]
    )
    refused(ShapeError, rf"channels.shape=\({n},\) but expected \({n}, k\): one row per sample", channels=arrays["channels"][:, 0])
    refused(ShapeError, "t must be numbers", time=["a"] * n)
    refused(UnknownToolConfiguration, r"'Z' is not in the tool file; configurations: A, B, C", configuration="Z")
    refused(UnknownToolConfiguration, r"'3' is not in the tool file", configuration=np.full(n, 3))
    with pytest.warns(FtsCalibWarning, match="look like degrees"):
        refused(
            InsufficientExcitation,
            rf"none of the {n:,} samples passed the checks: outside joint limits {n:,} \(joint readings in degrees.*joints_in_degrees=True",
            joints=np.degrees(arrays["joints"]),
        )
    refused(InsufficientExcitation, rf"none of the {n:,} samples passed the checks: non-finite value", channels=arrays["channels"] * np.nan)
    empty = {"time": np.zeros(0), "joints": np.zeros((0, 6)), "channels": np.zeros((0, 8)), "configuration": []}
    refused(InsufficientExcitation, "no sample was given", **empty)
    with pytest.raises(ShapeError, match=r"has no \['channels'\].*\(given: time, joints, configuration, chanels\)"):
        calibrate({**{k: v for k, v in arrays.items() if k != "channels"}, "chanels": arrays["channels"]}, robot=ur5, tool=paper_tool)


def test_loaders_name_a_wrong_kind_of_argument(tmp_path, ur5, calibration):
    with pytest.raises(ConfigError, match="robot=None but expected a shipped robot name"):
        load_robot(None)
    with pytest.raises(FileFormatError, match=r"ur5_robot.urdf: is a URDF, not a robot file: .*Kinematics.from_urdf"):
        load_robot(ur5.robot.urdf)
    with pytest.raises(FileFormatError, match=f"{tmp_path}: is a folder, not a robot YAML file"):
        resolve(tmp_path, "robots")
    with pytest.raises(FileFormatError, match="my_robot.yaml: file not found"):  # a path: no list of shipped names
        resolve(tmp_path / "my_robot.yaml", "robots")
    with pytest.raises(ConfigError, match=r"calibration='calibration.yaml' but expected a Calibration \(load_calibration"):
        WrenchReader("calibration.yaml")


def _keys(value, prefix=""):
    """Every key of a nested mapping, as dotted paths (list items are walked, their index left out)."""
    if isinstance(value, dict):
        out = set()
        for key, item in value.items():
            out |= {f"{prefix}{key}"} | _keys(item, f"{prefix}{key}.")
        return out
    if isinstance(value, list):
        return set().union(*(_keys(item, prefix) for item in value)) if value else set()
    return set()


def test_python_and_command_line_write_files_with_the_same_fields(tmp_path, ur5_recording, ur5):
    """The command, fts_calib.calibrate on the recording, and on its arrays in memory (a CalibrationSession, as `live`)."""
    import pandas as pd

    python_file = calibrate(ur5_recording, robot="ur5", tool="paper_tool").save(tmp_path / "python.yaml")
    table = pd.read_csv(ur5_recording)
    arrays = {
        "time": table["time"].to_numpy(),
        "joints": table[list(ur5.joint_names)].to_numpy(),
        "channels": table[[f"strain_{k}" for k in range(1, 9)]].to_numpy(),
        "configuration": table["tool"].tolist(),
    }
    arrays_file = calibrate(arrays, robot=ur5, tool="paper_tool").save(tmp_path / "arrays.yaml")
    argv = ["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(ur5_recording), "-o", str(tmp_path / "cli.yaml"), "--quiet"]
    assert main(argv) == 0
    from_cli = _keys(load_yaml(tmp_path / "cli.yaml"))
    for label, path in (("Python", python_file), ("arrays", arrays_file)):
        keys = _keys(load_yaml(path))
        assert keys == from_cli, f"only in {label}: {sorted(keys - from_cli)}; only in the CLI: {sorted(from_cli - keys)}"
    assert {"quality.accuracy_budget.total_percent_fs", "quality.accuracy_budget.stream_latency_estimate.latency_ms"} <= from_cli

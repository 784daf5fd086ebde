"""Robot definition files and the example-robot-data lookup."""

import math
import re
from pathlib import Path

import pytest
import yaml

from fts_calib import FileFormatError
from fts_calib.app.cli import main
from fts_calib.app.exit_codes import ExitCode
from fts_calib.core import resources
from fts_calib.core.exceptions import ConfigError, RobotDataNotFound, ShapeError
from fts_calib.core.resources import ROBOT_DATA_ENV, example_robot_data_dir, resolve, shipped
from fts_calib.robot.definition import LimitSpec, RobotDefinition, SensorMount, load_robot, parse_angle

SHIPPED = ["kinova", "panda", "ur10", "ur5", "xarm7"]


def test_shipped_robots_are_listed_and_load():
    assert shipped("robots") == SHIPPED
    for name in SHIPPED:
        robot = load_robot(resolve(name, "robots"))
        assert robot.urdf.is_file() and robot.name == name


def test_example_robot_data_is_found_from_the_installed_distribution(monkeypatch):
    monkeypatch.delenv(ROBOT_DATA_ENV, raising=False)
    found = resources._from_metadata()
    assert found, "the installed example-robot-data distribution lists its share folder"
    folder = example_robot_data_dir()
    assert folder == found[0]
    assert (folder / "robots" / "ur_description" / "urdf" / "ur5_robot.urdf").is_file()


def test_environment_variable_overrides_the_lookup(monkeypatch, tmp_path):
    (tmp_path / "robots").mkdir()
    monkeypatch.setenv(ROBOT_DATA_ENV, str(tmp_path))
    assert example_robot_data_dir() == tmp_path
    monkeypatch.setenv(ROBOT_DATA_ENV, str(tmp_path / "nowhere"))
    with pytest.raises(RobotDataNotFound, match="has no robots/ folder"):
        example_robot_data_dir()


def test_missing_example_robot_data_says_what_to_install(monkeypatch):
    monkeypatch.delenv(ROBOT_DATA_ENV, raising=False)
    monkeypatch.setattr(resources, "_from_metadata", lambda: [])
    monkeypatch.setattr(resources, "_from_python_module", lambda: [])
    monkeypatch.setattr(resources, "_from_prefixes", lambda: [Path("/nonexistent/share/example-robot-data")])
    with pytest.raises(RobotDataNotFound, match="run 'pip install example-robot-data'"):
        example_robot_data_dir()
    with pytest.raises(RobotDataNotFound):
        load_robot(resolve("ur5", "robots"))


def test_a_ros_prefix_is_searched(monkeypatch, tmp_path):
    (tmp_path / "share" / "example-robot-data" / "robots").mkdir(parents=True)
    monkeypatch.delenv(ROBOT_DATA_ENV, raising=False)
    monkeypatch.setattr(resources, "_from_metadata", lambda: [])
    monkeypatch.setattr(resources, "_from_python_module", lambda: [])
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path))
    assert example_robot_data_dir() == tmp_path / "share" / "example-robot-data"


@pytest.mark.parametrize(
    ("text", "value"), [("pi/2", math.pi / 2), ("-pi", -math.pi), ("3*pi/4", 3 * math.pi / 4), (0.25, 0.25), ("1.5", 1.5)]
)
def test_angles_accept_pi_expressions(text, value):
    assert parse_angle(text, "f.yaml", "rpy[0]") == pytest.approx(value, abs=1e-15)


def test_bad_angle_names_the_field():
    with pytest.raises(FileFormatError, match=r"field 'home.j1': expected an angle in rad"):
        parse_angle("ninety", "f.yaml", "home.j1")


def _robot(tmp_path, **changes):
    data = yaml.safe_load(resolve("ur5", "robots").read_text())
    data.update(changes)
    for key in [k for k, v in changes.items() if v is None]:
        del data[key]
    path = tmp_path / "robot.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_urdf_path_that_does_not_exist(tmp_path):
    with pytest.raises(FileFormatError, match=r"field 'urdf': 'arms/missing.urdf' resolves to .*arms/missing.urdf, which does not exist"):
        load_robot(_robot(tmp_path, urdf="arms/missing.urdf"))
    with pytest.raises(FileFormatError, match=r"field 'urdf': 'example-robot-data:nope.urdf' resolves to"):
        load_robot(_robot(tmp_path, urdf="example-robot-data:nope.urdf"))


def test_relative_urdf_path_is_relative_to_the_yaml(tmp_path):
    urdf = example_robot_data_dir() / "robots" / "ur_description" / "urdf" / "ur5_robot.urdf"
    (tmp_path / "arms").mkdir()
    (tmp_path / "arms" / "ur5.urdf").write_text(urdf.read_text())
    assert load_robot(_robot(tmp_path, urdf="arms/ur5.urdf")).urdf == (tmp_path / "arms" / "ur5.urdf").resolve()


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"sensor": None}, r"field 'sensor': missing"),
        ({"sensor": {"xyz": [0, 0, 0]}}, r"field 'sensor.parent_frame': missing"),
        ({"sensor": {"parent_frame": "tool0", "xyz": [0, 0]}}, r"field 'sensor.xyz': expected 3 numbers"),
        ({"sweep_joints": ["wrist_3_joint"]}, r"field 'sweep_joints': expected two different joint names"),
        ({"limits": {"acceleration": 0}}, r"field 'limits.acceleration': is 0.0 but expected a finite value > 0"),
        ({"limits": {"jerk": {"wrist_3_joint": -1}}}, r"field 'limits.jerk.wrist_3_joint': is -1.0 but expected a finite value > 0"),
        ({"limits": {"velocity_fraction": 1.5}}, r"field 'limits.velocity_fraction': is 1.5 but expected a fraction"),
        ({"limits": {"speed": 1}}, r"field 'limits': unknown keys \['speed'\]"),
    ],
)
def test_bad_robot_fields_are_named(tmp_path, changes, match):
    with pytest.raises(FileFormatError, match=match):
        load_robot(_robot(tmp_path, **changes))


def _mount(xyz=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0)):
    return SensorMount("tool0", xyz, rpy)


def _definition(**changes):
    return RobotDefinition(**{"name": "arm", "urdf": Path("arm.urdf"), "sensor": _mount(), **changes})


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: LimitSpec(velocity_fraction=1.5), r"limits: velocity_fraction=1.5 but expected a fraction in \(0, 1\]"),
        (lambda: LimitSpec(velocity_fraction=0.0), r"limits: velocity_fraction=0.0 but expected a finite value > 0"),
        (lambda: LimitSpec(acceleration={"*": 0.0}), r"limits: acceleration=0.0 but expected a finite value > 0"),
        (lambda: LimitSpec(jerk={"wrist_3_joint": -1.0}), r"limits: jerk.wrist_3_joint=-1.0 but expected a finite value > 0"),
        (lambda: LimitSpec(velocity={"j1": float("nan")}), r"limits: velocity.j1=nan but expected a finite value > 0"),
        (lambda: LimitSpec(velocity={"*": 1.0}), r"limits: velocity must map joint -> rad/s \(use velocity_fraction for all joints\)"),
        (lambda: _mount(xyz=(0.0, float("nan"), 0.0)), r"sensor mount on 'tool0': xyz=\[0.0, nan, 0.0\] but expected finite values"),
        (lambda: _mount(rpy=(float("inf"), 0.0, 0.0)), r"sensor mount on 'tool0': rpy=\[inf, 0.0, 0.0\] but expected finite values"),
        (
            lambda: _definition(sweep_joints=("j6", "j6")),
            r"robot 'arm': sweep_joints=\('j6', 'j6'\) but expected two different joint names",
        ),
        (lambda: _definition(home={"j1": float("nan")}), r"robot 'arm': home.j1=nan rad but expected a finite value"),
        (lambda: _definition(locked_joints={"finger": "open"}), r"robot 'arm': locked_joints.finger='open' but expected a number"),
        (lambda: _definition(floor_z=float("-inf")), r"robot 'arm': floor_z=-inf m but expected a finite value"),
    ],
)
def test_the_python_api_refuses_what_the_robot_file_refuses(make, match):
    with pytest.raises(ConfigError, match=match):
        make()


def test_a_sensor_mount_needs_three_numbers():
    with pytest.raises(ShapeError, match=r"xyz.shape=\(2,\) but expected \(3,\)"):
        _mount(xyz=(0.0, 0.0))


def test_a_bad_value_the_loader_maps_names_the_file_field(tmp_path):
    with pytest.raises(FileFormatError, match=r"robot.yaml: field 'collision.floor_z': is nan m but expected a finite value"):
        load_robot(_robot(tmp_path, collision={"floor_z": float("nan")}))
    with pytest.raises(FileFormatError, match=r"field 'limits.velocity': must map joint -> rad/s"):
        load_robot(_robot(tmp_path, limits={"velocity": 1.0}))


def test_cli_robots_lists_and_shows(capsys):
    assert main(["robots"]) == 0
    listing = capsys.readouterr().out
    for name in SHIPPED:
        assert f"\n  {name} " in listing
    assert main(["robots", "panda"]) == 0
    details = capsys.readouterr().out
    assert re.search(r"panda_joint6 +revolute +-0.0175 +\+3.7525", details), details
    assert "locked joints: panda_finger_joint1 = 0, panda_finger_joint2 = 0" in details
    assert "sensor frame 'ft_sensor' on 'panda_link8'" in details
    assert main(["robots", "nope"]) == ExitCode.FILE
    assert "shipped: kinova, panda, ur10, ur5, xarm7" in capsys.readouterr().err


def test_the_accuracy_section_is_read_with_documented_defaults(tmp_path):
    default = load_robot(_robot(tmp_path)).accuracy
    assert default.encoder_resolution == pytest.approx(2 * math.pi / 2**20) and default.mount_rotation == 2e-4
    given = load_robot(_robot(tmp_path, accuracy={"encoder_resolution": 1e-5, "latency_s": 0.004, "mount_rotation": 1e-3})).accuracy
    assert (given.encoder_resolution, given.latency_s, given.jitter_s, given.mount_rotation) == (1e-5, 0.004, default.jitter_s, 1e-3)
    with pytest.raises(FileFormatError, match=r"field 'accuracy.jitter_s': is -0.001 s but expected a finite value >= 0"):
        load_robot(_robot(tmp_path, accuracy={"jitter_s": -0.001}))
    with pytest.raises(FileFormatError, match=r"'accuracy'.*'latency'"):
        load_robot(_robot(tmp_path, accuracy={"latency": 0.001}))

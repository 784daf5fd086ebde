"""URDF quirks and the advice a newcomer gets (issue 32, items 1 and 2).

A URDF may give a link and a joint one name (the Unitree Z1's ``gripperStator``, ANYmal C's
legs): frames are looked up by type, a link always as a link. A collision between two links of
the robot names the pair and ``collision.ignore_pairs``; a link beyond the sensor names
``collision.ignore_links`` or ``locked_joints``; sweep joints chosen by default are said so; a
log without the fingers' columns names ``locked_joints``. The truths are read from the URDFs
themselves (:mod:`tests.urdf_chain` multiplies their transforms by hand).
"""

import contextlib
import io

import numpy as np
import pinocchio as pin
import pytest
import yaml

from fts_calib import FileFormatError, FrameNotFound, RecordingError
from fts_calib.app.cli import main
from fts_calib.app.exit_codes import ExitCode
from fts_calib.core.exceptions import ConfigError, JointError
from fts_calib.core.resources import example_robot_data_dir, resolve
from fts_calib.robot.collision import CollisionChecker, collision_model, hand_links
from fts_calib.robot.definition import RobotDefinition, SensorMount, load_robot
from fts_calib.robot.kinematics import Kinematics
from fts_calib.robot.tool import ToolShape
from fts_calib.sim.robot_log import recording_to_bag
from fts_calib.sources.bag import BagReader
from fts_calib.sources.recording import RecordingReader

from .urdf_chain import UrdfChain, homogeneous, rot_rpy

Z1_URDF = example_robot_data_dir() / "robots" / "z1_description" / "urdf" / "z1.urdf"
ANYMAL_C = example_robot_data_dir() / "robots" / "anymal_c_simple_description" / "urdf" / "anymal.urdf"
#: The Z1's arm joints, as its URDF lists them (jointGripper, the gripper, comes after).
Z1_ARM = ("joint1", "joint2", "joint3", "joint4", "joint5", "joint6")
SHAPE = ToolShape(0.08, 0.17)  # the paper tool's envelope [m]


def _z1(tmp_path, name="z1.yaml", **changes):
    """A robot file for the Z1: the sensor 2 cm out on ``gripperStator`` (a link and a fixed joint of that name), the gripper locked."""
    data = {
        "name": "z1",
        "urdf": "example-robot-data:z1_description/urdf/z1.urdf",
        "sensor": {"parent_frame": "gripperStator", "xyz": [0.02, 0.0, 0.0], "rpy": [0.0, 0.0, 0.0]},
        "locked_joints": {"jointGripper": 0.0},
        "collision": {"srdf": "example-robot-data:z1_description/srdf/z1.srdf"},
    }
    for key, value in changes.items():
        if value is None:
            data.pop(key, None)
        elif isinstance(value, dict) and isinstance(data.get(key), dict):
            data[key] = {**data[key], **value}
        else:
            data[key] = value
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def _cli(*args):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(args))
    return code, out.getvalue(), err.getvalue()


# -- item 1: lookups by frame type ------------------------------------------------------------


def test_the_z1_names_a_link_and_a_joint_gripper_stator():
    """The premise: Pinocchio has two frames of that name, so a lookup by name alone is ambiguous."""
    model = pin.buildModelFromUrdf(str(Z1_URDF))
    types = sorted(str(f.type) for f in model.frames if f.name == "gripperStator")
    assert types == ["BODY", "FIXED_JOINT"]
    with pytest.raises(ValueError, match="Several frames match"):
        model.getFrameId("gripperStator")


def test_a_parent_frame_shared_by_a_link_and_a_joint_is_the_link(tmp_path):
    kin = Kinematics(load_robot(_z1(tmp_path)))
    parent = kin.model.frames[kin.model.frames[kin.sensor_frame_id].parentFrame]
    assert (parent.name, parent.type) == ("gripperStator", pin.FrameType.BODY)
    assert kin.joint_names == Z1_ARM  # jointGripper locked
    chain = UrdfChain(Z1_URDF)
    angles = dict(zip(Z1_ARM, [0.3, -0.7, 0.9, 0.4, -1.1, 0.6], strict=True))
    expected = chain.pose("gripperStator", {**angles, "jointGripper": 0.0}) @ homogeneous(np.eye(3), [0.02, 0.0, 0.0])
    pose = kin.sensor_pose(angles)
    np.testing.assert_allclose(pose.translation, expected[:3, 3], atol=1e-12)
    np.testing.assert_allclose(pose.rotation, expected[:3, :3], atol=1e-12)


def test_a_parent_frame_that_is_only_a_joint_is_the_joint_frame(tmp_path):
    """``jointGripper`` names no link: the joint's frame, which is its child link's (gripperMover) at the URDF's origin."""
    kin = Kinematics(load_robot(_z1(tmp_path, sensor={"parent_frame": "jointGripper"}, locked_joints=None)))
    angles = dict(zip((*Z1_ARM, "jointGripper"), [0.2, 0.5, -0.4, 0.1, 0.8, -0.3, -0.6], strict=True))
    expected = UrdfChain(Z1_URDF).pose("gripperMover", angles) @ homogeneous(rot_rpy(0, 0, 0), [0.02, 0.0, 0.0])
    np.testing.assert_allclose(kin.sensor_pose(angles).translation, expected[:3, 3], atol=1e-12)


def test_a_parent_frame_not_in_the_urdf_names_the_field_and_the_closest(tmp_path):
    path = _z1(tmp_path, sensor={"parent_frame": "gripper_stator"})
    with pytest.raises(FrameNotFound) as info:
        Kinematics(load_robot(path))
    text = str(info.value)
    assert text.startswith(f"{path}: field 'sensor.parent_frame': frame 'gripper_stator' is not in the model (did you mean 'gripperStator'")
    assert text.count("gripperStator") == 2, "each name listed once"  # the hint and the list, not a duplicate
    code, _, err = _cli("robots", str(path))
    assert code == ExitCode.ROBOT and "field 'sensor.parent_frame'" in err and "Traceback" not in err


def test_an_ignored_link_shared_with_a_joint_leaves_out_the_link(tmp_path):
    kin = Kinematics(load_robot(_z1(tmp_path, collision={"ignore_links": ["gripperStator"]})))
    names = [o.name for o in collision_model(kin).geometryObjects]
    full = [o.name for o in collision_model(Kinematics(load_robot(_z1(tmp_path, "all.yaml")))).geometryObjects]
    assert [n for n in full if n not in names] == ["gripperStator_0"]  # the link's body, and nothing else


def test_an_ignored_link_is_looked_up_among_the_links(tmp_path):
    """``joint6`` is a frame of the model but not a link: refused, the links listed, the file and field named."""
    for name, hint in (("gripperstator", "(did you mean 'gripperStator'"), ("joint6", "('joint6' is a joint; its child link is 'link06')")):
        path = _z1(tmp_path, collision={"ignore_links": [name]})
        with pytest.raises(FrameNotFound) as info:
            collision_model(Kinematics(load_robot(path)))
        text = str(info.value)
        assert text.startswith(f"{path}: field 'collision.ignore_links': link '{name}' is not in the model {hint}"), text
        listed = text.split("links that exist: ")[1].split(", ")
        assert "gripperStator" in listed and "link06" in listed and "joint6" not in listed and "jointGripper" not in listed


def test_locking_a_joint_of_a_urdf_with_shared_names_keeps_every_frame(tmp_path):
    """ANYmal C names each leg joint like a link; Pinocchio's own reduction refuses it. Locked legs: the frames keep their
    names, and the sensor sits where the full model, legs at their values, puts it."""
    locked = {"LH_HAA": 0.1, "LH_HFE": 0.4, "LH_KFE": -0.8, "RF_HAA": 0.0, "RF_HFE": 0.3, "RF_KFE": -0.6}
    locked |= {"RH_HAA": 0.0, "RH_HFE": -0.3, "RH_KFE": 0.6}
    full = pin.buildModelFromUrdf(str(ANYMAL_C))
    with pytest.raises(ValueError, match="Several frames match"):
        pin.buildReducedModel(full, [full.getJointId(n) for n in locked], pin.neutral(full))
    path = tmp_path / "anymal.yaml"
    spec = "example-robot-data:anymal_c_simple_description/urdf/anymal.urdf"
    sensor = {"parent_frame": "LF_SHANK", "xyz": [0.0, 0.0, 0.0], "rpy": [0.0, 0.0, 0.0]}
    path.write_text(yaml.safe_dump({"name": "anymal", "urdf": spec, "sensor": sensor, "locked_joints": locked}))
    kin = Kinematics(load_robot(path))
    assert kin.joint_names == ("LF_HAA", "LF_HFE", "LF_KFE")
    assert sorted(f.name for f in kin.model.frames if f.name != "ft_sensor") == sorted(f.name for f in full.frames)
    q = pin.neutral(full)
    reading = {"LF_HAA": 0.2, "LF_HFE": -0.5, "LF_KFE": 1.1}
    for name, value in {**locked, **reading}.items():
        q[full.joints[full.getJointId(name)].idx_q] = value
    data = full.createData()
    pin.framesForwardKinematics(full, data, q)
    shank = next(k for k, f in enumerate(full.frames) if f.name == "LF_SHANK" and f.type == pin.FrameType.BODY)
    np.testing.assert_allclose(kin.sensor_pose(reading).homogeneous, data.oMf[shank].homogeneous, atol=1e-12)
    checker = CollisionChecker(kin, SHAPE, "LF_HFE")  # the geometry reduced the same way
    assert {("LF_KFE_0", "LF_KFE"), ("LH_KFE_0", "LH_KFE")} <= set(checker.links.items())  # links named like their joints


def test_a_mesh_not_found_names_package_dirs(tmp_path):
    (tmp_path / "z1.urdf").write_text(Z1_URDF.read_text())
    path = _z1(tmp_path, urdf="z1.urdf", collision=None)
    with pytest.raises(FileFormatError, match=r"field 'package_dirs': the collision geometry of .*z1.urdf cannot be read \(Mesh pack"):
        collision_model(Kinematics(load_robot(path)))


# -- collision.ignore_pairs -------------------------------------------------------------------


@pytest.mark.parametrize(
    ("pairs", "match"),
    [
        ("link04", r"field 'collision.ignore_pairs': expected a list of pairs of link names \(e.g. \[\[link04, link06\]\]\), got 'link04'"),
        ([["link04"]], r"field 'collision.ignore_pairs\[0\]': expected a pair of two link names .*got \['link04'\]"),
        ([["link04", "link06"], "link05"], r"field 'collision.ignore_pairs\[1\]': expected a pair of two link names"),
        ([["link04", 6]], r"field 'collision.ignore_pairs\[0\]': expected a pair of two link names .*got \['link04', 6\]"),
        ([["link04", "link04"]], r"field 'collision.ignore_pairs\[0\]': names 'link04' twice: expected two different links"),
    ],
)
def test_malformed_ignore_pairs_are_named(tmp_path, pairs, match):
    with pytest.raises(FileFormatError, match=match):
        load_robot(_z1(tmp_path, collision={"ignore_pairs": pairs}))


def test_the_python_api_refuses_a_malformed_pair():
    mount = SensorMount("link06", np.zeros(3), np.zeros(3))
    with pytest.raises(ConfigError, match=r"robot 'arm': ignore_pairs\[0\]=\('a', 'a'\) but expected a pair of two different link names"):
        RobotDefinition("arm", Z1_URDF, mount, ignore_pairs=(("a", "a"),))


def test_an_ignored_pair_must_name_links(tmp_path):
    path = _z1(tmp_path, collision={"ignore_pairs": [["link04", "link6"]]})
    with pytest.raises(FrameNotFound, match=r"field 'collision.ignore_pairs': link 'link6' is not in the model \(did you mean 'link06'"):
        collision_model(Kinematics(load_robot(path)))


def test_an_ignored_pair_is_not_checked(tmp_path):
    plain = CollisionChecker(Kinematics(load_robot(_z1(tmp_path))), SHAPE, "joint5")
    ignored = CollisionChecker(
        Kinematics(load_robot(_z1(tmp_path, "pair.yaml", collision={"ignore_pairs": [["link06", "link04"]]}))), SHAPE, "joint5"
    )
    assert ("link04_0", "link06_0") in plain.pairs("wrist")
    everything = set(ignored.pairs("all")) | set(ignored.pairs("home"))
    assert ("link04_0", "link06_0") not in everything
    assert (set(plain.pairs("all")) | set(plain.pairs("home"))) - everything == {("link04_0", "link06_0")}


# -- item 2: the advice ----------------------------------------------------------------------


def test_the_links_beyond_the_sensor_and_the_joints_that_move_them(tmp_path):
    """From the Z1's URDF: link06 -(fixed gripperStator)-> gripperStator -(revolute jointGripper)-> gripperMover."""
    on_flange = Kinematics(load_robot(_z1(tmp_path, sensor={"parent_frame": "link06"}, locked_joints=None)))
    assert hand_links(on_flange) == {"gripperStator": None, "gripperMover": "jointGripper"}
    assert hand_links(Kinematics(load_robot(_z1(tmp_path)))) == {"gripperMover": "jointGripper"}
    assert hand_links(Kinematics(load_robot(resolve("ur5", "robots")))) == {}  # tool0: nothing beyond


def test_the_advice_fits_the_pair(tmp_path):
    kin = Kinematics(load_robot(_z1(tmp_path, sensor={"parent_frame": "link06"}, locked_joints=None)))
    checker = CollisionChecker(kin, SHAPE, "joint5")
    other = "use a smaller tool shape"
    arm = checker.advice(("link04_0", "link06_0"), other)
    assert "'collision.ignore_pairs: [[link04, link06]]'" in arm and "collision.srdf" in arm and other not in arm
    finger = checker.advice(("gripperMover_0", "tool"), other)
    assert "'collision.ignore_links: [gripperMover]'" in finger and "'locked_joints: {jointGripper: VALUE}'" in finger
    assert "ignore_pairs" not in finger and other not in finger
    both = checker.advice(("link03_0", "gripperStator_0"), other)
    assert "[[link03, gripperStator]]" in both and "'collision.ignore_links: [gripperStator]'" in both and "locked_joints" not in both
    assert checker.advice(("link03_0", "tool"), other) == other
    assert checker.advice(("link03_0", "floor"), other) == other
    locked = CollisionChecker(Kinematics(load_robot(_z1(tmp_path, "l.yaml", sensor={"parent_frame": "link06"}))), SHAPE, "joint5")
    assert "lock 'jointGripper' at a value where it clears the tool ('locked_joints')" in locked.advice(("gripperMover_0", "tool"), other)


def test_a_self_collision_names_the_pair_not_the_tool(tmp_path):
    """The Z1's link04 and link06 hulls come 0.015 m apart whatever the home: ignore_pairs, not a smaller tool; the sweep
    joints were chosen by default (the robot file names none), which the message says."""
    code, out, err = _cli("trajectory", "--robot", str(_z1(tmp_path)), "--tool", "paper_tool", "-o", str(tmp_path / "plan"))
    line = err.strip().splitlines()[-1]
    assert code == ExitCode.TRAJECTORY, out + err
    assert line.startswith("fts-calib trajectory: error: 'link04_0' and 'link06_0' come 0.015 m apart during the sweep of joint5")
    assert "'collision.ignore_pairs: [[link04, link06]]'" in line and "smaller tool shape" not in line
    assert "(joint5 and joint6 sweep by default, the last two actuated joints: name others with the robot file's 'sweep_joints')" in line


def test_with_the_pair_ignored_the_z1_plans_and_says_its_sweep_joints_were_chosen(tmp_path):
    path = _z1(tmp_path, collision={"ignore_pairs": [["link04", "link06"]]})
    code, out, err = _cli("trajectory", "--robot", str(path), "--tool", "paper_tool", "-o", str(tmp_path / "plan"), "--rate", "20")
    assert code == ExitCode.OK, out + err
    assert (
        "  sweep joints joint5 and joint6: by default, the last two actuated joints (name others with the robot file's sweep_joints)" in out
    )
    assert (tmp_path / "plan" / "A.csv").is_file()
    named = _z1(tmp_path, "named.yaml", collision={"ignore_pairs": [["link04", "link06"]]}, sweep_joints=["joint5", "joint6"])
    code, out, _ = _cli("trajectory", "--robot", str(named), "--tool", "paper_tool", "-o", str(tmp_path / "named"), "--rate", "20")
    assert code == ExitCode.OK and "by default" not in out


# -- item 2: a log without the fingers -------------------------------------------------------


@pytest.fixture
def panda_with_fingers(tmp_path):
    """The shipped Panda's file without its locked_joints: the fingers are joints of the model."""
    data = yaml.safe_load(resolve("panda", "robots").read_text())
    del data["locked_joints"]
    path = tmp_path / "panda.yaml"
    path.write_text(yaml.safe_dump(data))
    kin = Kinematics(load_robot(path))
    assert kin.joint_names[-2:] == ("panda_finger_joint1", "panda_finger_joint2")  # the URDF's prismatic fingers
    return path, kin


def _arm_only_log(path, joints):
    header = ["time", *joints, *(f"strain_{k}" for k in range(1, 9)), "tool"]
    rows = [[f"{0.01 * k:.2f}", *(["0.1"] * len(joints)), *(["0.0"] * 8), "A"] for k in range(5)]
    path.write_text("\n".join(",".join(r) for r in [header, *rows]) + "\n")
    return path


def test_a_log_without_the_finger_columns_names_locked_joints(tmp_path, panda_with_fingers):
    robot, kin = panda_with_fingers
    log = _arm_only_log(tmp_path / "arm.csv", kin.joint_names[:7])
    with pytest.raises(RecordingError) as info:
        RecordingReader(log, kin.joint_names, ["A", "B", "C"])
    text = str(info.value)
    assert "missing column(s) ['panda_finger_joint1', 'panda_finger_joint2']" in text
    assert "'locked_joints: {panda_finger_joint1: VALUE, panda_finger_joint2: VALUE}'" in text
    code, _, err = _cli("calibrate", "--robot", str(robot), "--tool", "paper_tool", str(log), "-o", str(tmp_path / "c.yaml"))
    assert code == ExitCode.RECORDING and "locked_joints" in err and "Traceback" not in err
    bag = recording_to_bag(log, tmp_path / "bag")
    with pytest.raises(
        RecordingError, match=r"\['panda_finger_joint1', 'panda_finger_joint2'\].*'locked_joints: \{panda_finger_joint1: VALUE"
    ):
        BagReader([bag], kin.joint_names, None)
    with pytest.raises(JointError, match=r"missing joints \['panda_finger_joint1', 'panda_finger_joint2'\] \(.*locked_joints\)"):
        kin.joint_array({name: 0.1 for name in kin.joint_names[:7]})


def test_a_log_without_a_column_that_is_not_a_joint_names_no_locked_joints(tmp_path, panda_with_fingers):
    _, kin = panda_with_fingers
    log = _arm_only_log(tmp_path / "all.csv", kin.joint_names)
    log.write_text(log.read_text().replace(",tool\n", ",tol\n", 1))
    with pytest.raises(RecordingError, match=r"missing column\(s\) \['tool'\]") as info:
        RecordingReader(log, kin.joint_names, ["A"])
    assert "locked_joints" not in str(info.value)

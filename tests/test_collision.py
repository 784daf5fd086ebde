"""Collision checks: an exact tool-to-floor distance, and which pairs are checked."""

import math

import numpy as np
import pytest
import yaml

from fts_calib.core.resources import resolve
from fts_calib.robot.collision import CollisionChecker
from fts_calib.robot.definition import load_robot
from fts_calib.robot.kinematics import Kinematics
from fts_calib.robot.tool import ToolShape

DOWN = np.array([0.0, -math.pi / 2, math.pi / 2, -math.pi / 2, -math.pi / 2, 0.0])  # UR5, tool pointing down


def test_tool_pointing_down_is_its_length_above_the_floor(tmp_path, ur5):
    """A cylinder pointing straight down ends ``length`` below the sensor: with the floor set
    1 cm below that, the closest pair is the tool and the floor, 1 cm apart."""
    z_sensor = ur5.sensor_pose(DOWN).translation[2]
    np.testing.assert_allclose(ur5.sensor_pose(DOWN).rotation[:, 0], [0, 0, -1], atol=1e-9)
    shape = ToolShape(radius=0.04, length=0.15)
    data = yaml.safe_load(resolve("ur5", "robots").read_text())
    data["collision"]["floor_z"] = float(z_sensor - shape.length - 0.01)
    path = tmp_path / "ur5.yaml"
    path.write_text(yaml.safe_dump(data))
    kin = Kinematics(load_robot(path))
    checker = CollisionChecker(kin, shape, "wrist_2_joint")
    found = checker.clearance(DOWN, "all")
    assert found.pair == ("tool", "floor")
    assert found.distance == pytest.approx(0.01, abs=1e-6)


def test_pair_groups(ur5):
    checker = CollisionChecker(ur5, ToolShape(0.05, 0.1), "wrist_2_joint")
    everything = set(checker.pairs("all")) | set(checker.pairs("home"))
    assert ("wrist_2_link_0", "tool") in checker.pairs("wrist")  # the tool against the first sweep joint's link
    assert ("forearm_link_0", "tool") in checker.pairs("sweep")  # depends on the pose
    assert ("upper_arm_link_0", "floor") in checker.pairs("home")  # does not move during a sweep
    assert ("forearm_link_0", "wrist_3_link_0") not in everything  # disabled by the UR5's SRDF
    assert ("wrist_3_link_0", "ee_link_0") not in everything  # same link
    assert not any("base_link_0" in p and "floor" in p for p in everything)  # the base stands on the floor
    assert set(checker.pairs("sweep")) | set(checker.pairs("wrist")) == set(checker.pairs("all"))


def test_ignored_links_have_no_geometry(panda):
    checker = CollisionChecker(panda, ToolShape(0.05, 0.1), "panda_joint6")
    names = [o.name for o in checker.geometry.geometryObjects]
    assert not any(n.startswith(("panda_hand", "panda_leftfinger", "panda_rightfinger")) for n in names)
    assert "tool" in names and "floor" in names

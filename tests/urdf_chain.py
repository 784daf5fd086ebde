"""An independent forward kinematics: the URDF's joint transforms multiplied by hand.

It parses the URDF XML itself and uses the URDF convention R = Rz(yaw) Ry(pitch) Rx(roll),
without Pinocchio, as the truth for the kinematics tests.
"""

import math
import xml.etree.ElementTree as ET

import numpy as np


def rot_rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    cr, sr, cp, sp, cy, sy = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch), math.cos(yaw), math.sin(yaw)
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def rot_axis(axis: np.ndarray, angle: float) -> np.ndarray:
    u = axis / np.linalg.norm(axis)
    K = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def homogeneous(R: np.ndarray, p) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = p
    return T


class UrdfChain:
    """Joints of a URDF, walked from the root link to any link."""

    def __init__(self, path):
        root = ET.parse(path).getroot()
        self.joints = {}
        for joint in root.findall("joint"):
            origin = joint.find("origin")
            xyz = [float(v) for v in (origin.get("xyz", "0 0 0") if origin is not None else "0 0 0").split()]
            rpy = [float(v) for v in (origin.get("rpy", "0 0 0") if origin is not None else "0 0 0").split()]
            axis_el = joint.find("axis")
            axis = np.array([float(v) for v in (axis_el.get("xyz") if axis_el is not None else "1 0 0").split()])
            child = joint.find("child").get("link")
            self.joints[child] = {
                "name": joint.get("name"),
                "type": joint.get("type"),
                "parent": joint.find("parent").get("link"),
                "origin": homogeneous(rot_rpy(*rpy), xyz),
                "axis": axis,
            }

    def pose(self, link: str, angles: dict) -> np.ndarray:
        """T_world_link (4x4) for joint angles {name: rad}; fixed joints need none."""
        chain = []
        while link in self.joints:
            chain.append(self.joints[link])
            link = self.joints[link]["parent"]
        T = np.eye(4)
        for joint in reversed(chain):
            T = T @ joint["origin"]
            if joint["type"] in ("revolute", "continuous"):
                T = T @ homogeneous(rot_axis(joint["axis"], angles[joint["name"]]), [0, 0, 0])
            elif joint["type"] == "prismatic":
                T = T @ homogeneous(np.eye(3), joint["axis"] * angles[joint["name"]])
        return T

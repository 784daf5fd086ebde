"""Clearance of the arm and the tool during a calibration sweep (Pinocchio geometry + coal).

The URDF's collision meshes are replaced by their convex hulls (a hull contains its mesh,
so a distance between hulls is a lower bound of the true one: the check errs on the safe
side, and it is about 25 times faster). The tool is a cylinder along X of the sensor frame
S, from the sensor out; the floor is the half-space below ``floor_z`` in the world frame.

Only pairs whose distance can change during a sweep of the two sweep joints are checked
along it: a body that moves with the first sweep joint (or the tool) against one that does
not, the tool against the links of the first sweep joint, and every moving body against
the floor. Bodies on the same joint or on a joint and its parent touch by design and are
skipped, as are the robot's base against the floor and the link pairs the robot's SRDF
disables. The pose of the arm itself (the home pose) is checked once for every other pair.

The bodies are placed by :meth:`Kinematics.distances` (the only forward kinematics); this
module builds the geometry and chooses the pairs. Distances in [m].
"""

from __future__ import annotations

from dataclasses import dataclass

import coal
import numpy as np
import pinocchio as pin

from ..core.deprecation import renamed
from ..core.exceptions import FileFormatError
from .definition import MOUNT_FRAME_TYPES, frame_id, link_frame_id
from .joints import locked_configuration, reduced_geometry
from .kinematics import Kinematics
from .tool import ToolShape

#: Name of the tool's collision body.
TOOL = "tool"
#: Name of the floor's collision body.
FLOOR = "floor"


def collision_model(kin: Kinematics) -> pin.GeometryModel:
    """The URDF's collision geometry for the kinematics' (reduced) model; meshes from the package dirs.

    Links listed in the definition's ``collision.ignore_links`` are left out. The links are
    looked up as links (``BODY`` frames): a joint of the same name is never taken for one.

    Raises:
        FileFormatError: A mesh of the URDF is not found in the package folders (names them and ``package_dirs``).
        FrameNotFound: A link of ``collision.ignore_links`` or ``collision.ignore_pairs`` is
            not in the model (names the file, the field and the closest links; lists the links).
    """
    robot, model = kin.robot, kin.model
    for a, b in robot.ignore_pairs:  # names checked before the meshes are read
        link_frame_id(model, a, robot.where("collision.ignore_pairs"))
        link_frame_id(model, b, robot.where("collision.ignore_pairs"))
    ignored = {link_frame_id(model, name, robot.where("collision.ignore_links")) for name in robot.ignore_links}
    dirs = [str(p) for p in robot.package_dirs]
    try:
        geometry = pin.buildGeomFromUrdf(kin.full_model, str(robot.urdf), pin.COLLISION, package_dirs=dirs)
    except (ValueError, RuntimeError) as exc:  # a mesh not found, a mesh file Pinocchio cannot read
        reason = " ".join(str(exc).split()) or type(exc).__name__
        message = (
            f"the collision geometry of {robot.urdf} cannot be read ({reason}): expected its meshes under the folders "
            f"searched for package:// paths ({', '.join(dirs) or 'none'}); add the folder that holds the package to package_dirs"
        )
        raise FileFormatError(robot.source or robot.urdf, "package_dirs", message) from None
    lock_ids, q_lock = locked_configuration(kin.full_model, robot.locked_joints)
    if lock_ids:
        geometry = reduced_geometry(kin.full_model, lock_ids, q_lock, geometry)
    doomed = [obj.name for obj in geometry.geometryObjects if obj.parentFrame in ignored]
    for name in doomed:  # names first: removing invalidates the objects
        geometry.removeGeometryObject(name)
    return geometry


def hand_links(kin: Kinematics) -> dict[str, str | None]:
    """The links beyond the sensor's parent frame (a gripper, a flange part), each with the joint nearest it that moves it.

    A link is beyond the parent frame when the parent frame is on its way to the root; the link
    the parent frame belongs to is not. The joint is the nearest joint between the link and the
    parent frame (actuated or locked), or None when the link is fixed to it. Read from the
    URDF's full model: a reduced model's frames of locked joints do not lead to the root.

    Returns:
        Link name -> joint name or None, in the model's frame order.
    """
    model = kin.full_model
    body = pin.FrameType.BODY
    parent = frame_id(model, kin.robot.sensor.parent_frame, MOUNT_FRAME_TYPES)
    out: dict[str, str | None] = {}
    if parent == 0:
        return out
    for k, frame in enumerate(model.frames):
        if frame.type != body or k == parent:
            continue
        chain, f = [], k
        while f != parent and f not in chain and f != 0:
            chain.append(f)
            f = model.frames[f].parentFrame
        if f != parent or (model.frames[parent].type != body and not any(model.frames[c].type == body for c in chain[1:])):
            continue  # not beyond the parent frame, or the link a joint's parent frame belongs to
        out[frame.name] = next((model.frames[c].name for c in chain if model.frames[c].type == pin.FrameType.JOINT), None)
    return out


@dataclass(frozen=True)
class Clearance:
    """The smallest distance found.

    Attributes:
        distance: Signed distance in [m]; negative when the bodies overlap.
        pair: Names of the two bodies.
        index: Index of the reading where it was found.
    """

    distance: float
    pair: tuple[str, str]
    index: int


class CollisionChecker:
    """Distances between the robot's bodies, the tool and the floor at given readings.

    Args:
        kin: Kinematics of the robot (its definition gives ignored links and the floor height).
        shape: The tool's envelope.
        moving_joint: The first joint whose motion is swept (bodies at or below it move).
    """

    def __init__(self, kin: Kinematics, shape: ToolShape, moving_joint: str):
        self.kin = kin
        model = kin.model
        geometry = collision_model(kin)
        for obj in geometry.geometryObjects:
            if isinstance(obj.geometry, coal.BVHModelBase):
                obj.geometry.buildConvexRepresentation(False)
                obj.geometry = obj.geometry.convex
        sensor = model.frames[kin.sensor_frame_id]
        # coal's cylinder is centred on its origin along z: turn z onto X of S, then shift out
        R_sensor_cylinder = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
        placement = sensor.placement * pin.SE3(R_sensor_cylinder, np.array([shape.length / 2, 0.0, 0.0]))
        tool = pin.GeometryObject(TOOL, sensor.parentJoint, kin.sensor_frame_id, placement, coal.Cylinder(shape.radius, shape.length))
        self.tool_id = geometry.addGeometryObject(tool)
        floor = pin.GeometryObject(FLOOR, 0, 0, pin.SE3.Identity(), coal.Halfspace(np.array([0.0, 0.0, 1.0]), kin.robot.floor_z))
        self.floor_id = geometry.addGeometryObject(floor)

        moving_id = model.getJointId(moving_joint)
        above = int(model.parents[moving_id])  # the joint whose link carries the first sweep joint
        objects = geometry.geometryObjects
        joints = [obj.parentJoint for obj in objects]
        links = [model.frames[obj.parentFrame].name for obj in objects]
        allowed = kin.robot.skipped_pairs

        def moves(joint: int) -> bool:
            return moving_id in list(model.supports[joint])

        def adjacent(a: int, b: int) -> bool:
            return a == b or model.parents[a] == b or model.parents[b] == a

        groups: dict[str, list[tuple[int, int]]] = {"sweep": [], "wrist": [], "home": []}
        for i in range(len(objects)):
            for j in range(i + 1, len(objects)):
                a, b = joints[i], joints[j]
                if j == self.floor_id:
                    if a != 0:  # the base stands on the floor
                        groups["sweep" if moves(a) else "home"].append((i, j))
                    continue
                if frozenset((links[i], links[j])) in allowed:
                    continue
                tool_pair = self.tool_id in (i, j)
                if adjacent(a, b) and not (tool_pair and moving_id in (a, b) and a != b):
                    continue
                if moves(a) != moves(b) or (tool_pair and moving_id in (a, b)):
                    # a static body on the link carrying the first sweep joint keeps the same
                    # distance whatever the home pose: only the sweep angles matter
                    static = a if not moves(a) else b
                    groups["wrist" if static == above or (tool_pair and moving_id in (a, b)) else "sweep"].append((i, j))
                elif not moves(a):
                    groups["home"].append((i, j))
        self.geometry = geometry
        #: The link of each body of the robot, by the body's name (the tool and the floor are none).
        self.links = {obj.name: links[k] for k, obj in enumerate(objects) if k not in (self.tool_id, self.floor_id)}
        #: The links beyond the sensor's parent frame (a gripper, a flange part), each with the joint that moves it.
        self.hand = hand_links(kin)
        self._groups = {name: self._with_pairs(pairs) for name, pairs in groups.items()}
        self._groups["all"] = self._with_pairs(groups["sweep"] + groups["wrist"])

    def advice(self, pair: tuple[str, str], otherwise: str) -> str:
        """What to change when the bodies of ``pair`` come too close, in words naming the robot file's key.

        Two links of the robot: the pair and ``collision.ignore_pairs`` (or the SRDF). A link
        beyond the sensor's parent frame (a gripper): ``collision.ignore_links``, or
        ``locked_joints`` for the joint that moves it. Anything else (the tool and the arm,
        the floor): ``otherwise``.

        Args:
            pair: Names of the two bodies (as in :class:`Clearance`).
            otherwise: The advice when neither applies.
        """
        links = [self.links.get(name) for name in pair]
        parts = []
        if links[0] is not None and links[1] is not None:
            a, b = links
            parts.append(
                f"'{pair[0]}' and '{pair[1]}' are bodies of the robot's own links '{a}' and '{b}', not the tool: if these links "
                "cannot meet on the real arm (the check uses the convex hulls of the URDF's collision meshes, which are larger than "
                f"the links), leave the pair out of the checks with 'collision.ignore_pairs: [[{a}, {b}]]' in the robot file "
                "(or a disable_collisions entry of the SRDF named by 'collision.srdf')"
            )
        hand = next((link for link in links if link is not None and link in self.hand), None)
        if hand is not None:
            joint = self.hand[hand]
            text = (
                f"'{hand}' is beyond the sensor's parent frame '{self.kin.robot.sensor.parent_frame}' (part of a gripper or "
                f"flange): if the sensor and the tool replace it, leave it out with 'collision.ignore_links: [{hand}]'"
            )
            if joint is not None and joint in self.kin.robot.locked_joints:
                text += f", or lock '{joint}' at a value where it clears the tool ('locked_joints')"
            elif joint is not None:
                text += f", or hold '{joint}' where it clears the tool with 'locked_joints: {{{joint}: VALUE}}'"
            parts.append(text)
        return "; ".join(parts) if parts else otherwise

    def _with_pairs(self, pairs: list[tuple[int, int]]) -> tuple[pin.GeometryModel, pin.GeometryData, list[tuple[str, str]]]:
        geometry = self.geometry.copy()
        for i, j in pairs:
            geometry.addCollisionPair(pin.CollisionPair(i, j))
        names = [(geometry.geometryObjects[i].name, geometry.geometryObjects[j].name) for i, j in pairs]
        return geometry, pin.GeometryData(geometry), names

    def pairs(self, group: str = "all") -> list[tuple[str, str]]:
        """Names of the pairs of a group.

        Groups: 'all', every pair whose distance changes during a sweep; 'sweep', those of
        them that also depend on the home pose; 'wrist', those that depend on the sweep
        angles only (a body on the link carrying the first sweep joint, or the tool against
        that joint's links); 'home', pairs that do not move during a sweep.
        """
        return list(self._groups[group][2])

    @renamed(readings="joints")
    def clearance(self, joints, group: str = "all") -> Clearance:
        """The smallest distance over the joint readings, and where.

        Args:
            joints: Joint readings [rad], (n_joints,) or (N, n_joints).
            group: Which pairs (see :meth:`pairs`).

        Returns:
            The minimum over readings and pairs (inf distance when there is no pair).
        """
        geometry, data, names = self._groups[group]
        theta, _ = self.kin.joint_array(joints)
        best = Clearance(np.inf, ("", ""), -1)
        if not names:
            return best
        for k, reading in enumerate(theta):
            index = self.kin.distances(reading, geometry, data)
            distance = float(data.distanceResults[index].min_distance)
            if distance < best.distance:
                best = Clearance(distance, names[index], k)
        return best

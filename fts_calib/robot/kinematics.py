r"""Robot kinematics with Pinocchio: the sensor frame's pose, velocity and acceleration.

One class, :class:`Kinematics`, owns Pinocchio's ``model`` and ``data`` and is the only
place in fts-calib that runs forward kinematics.

Frames: the world frame is the URDF's root; the sensor frame S is added to the model at
the robot definition's mount. ``R_world_sensor`` rotates vectors from S into the world;
``T_world_sensor`` is the pose of S in the world (Pinocchio's ``oMf``). Gravity in S is
``g_sensor = R_world_sensor.T @ g_world``.

Joint readings are angles in [rad] (or positions in [m] for prismatic joints), one per
actuated joint, in the order of :attr:`Kinematics.joint_names`, or a mapping joint name ->
value (see :mod:`fts_calib.robot.joints`); continuous joints take a plain angle.

Two paths compute the same thing: one reading goes through Pinocchio
(``forwardKinematics``); a batch of N readings goes through a vectorised recursion over the
chain from the root to the sensor (:mod:`fts_calib.robot._batch`, private to this class).
Tests check the two paths against each other and against the URDF's transforms multiplied
by hand.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..core.arrays import frozen
from ..core.bounded import read_bounded
from ..core.exceptions import FileFormatError, FrameNotFound, JointError, ShapeError, UnsupportedJoint
from ._batch import Chain
from .definition import RobotDefinition
from .joints import JointInfo, ReadingCheck, find_problems, known_joints, locked_configuration, reading_array, resolve_limits, warn_problems


@dataclass(frozen=True)
class SensorMotion:
    """Velocity and classical acceleration of the sensor frame, expressed in the sensor frame.

    Attributes:
        omega: Angular velocity [rad/s]. Shape (3,) or (N, 3).
        alpha: Angular acceleration [rad/s^2]. Shape (3,) or (N, 3).
        v: Linear velocity of the origin of S [m/s]. Shape (3,) or (N, 3).
        a: Classical linear acceleration of the origin of S [m/s^2]. Shape (3,) or (N, 3).
        R_world_sensor: Orientation of S. Shape (3, 3) or (N, 3, 3).
    """

    omega: np.ndarray
    alpha: np.ndarray
    v: np.ndarray
    a: np.ndarray
    R_world_sensor: np.ndarray


def _build_model(robot: RobotDefinition) -> pin.Model:
    """Pinocchio's model of the robot definition's URDF.

    Raises:
        FileFormatError: The file is not a URDF Pinocchio can read (the message names it and
            the robot file's ``urdf`` field).
    """
    where = robot.source if robot.source is not None else robot.urdf
    head = read_bounded(robot.urdf, "URDF")
    if b"<robot" not in head:  # before Pinocchio, whose XML parser prints to the terminal
        raise FileFormatError(
            where, "urdf", f"{robot.urdf} is not a URDF: it holds no <robot> element (expected the robot's URDF XML file)"
        )
    try:
        return pin.buildModelFromUrdf(str(robot.urdf))
    except (ValueError, RuntimeError) as exc:  # Pinocchio's "does not contain a valid URDF model", a parse error
        reason = " ".join(str(exc).split()) or type(exc).__name__
        message = f"{robot.urdf} is not a URDF that Pinocchio can read ({reason}): expected a <robot> XML file"
        raise FileFormatError(where, "urdf", message) from None


class Kinematics:
    """Forward kinematics of a robot definition, for one reading or a batch.

    Args:
        robot: A robot definition (see :func:`fts_calib.robot.definition.load_robot`).

    Attributes:
        full_model: The URDF's model, every joint included (the locked ones too).
        model: The model of the actuated joints, holding the sensor frame.
        continuous: Which actuated joints are continuous (their readings wrap at 2 pi), in
            :attr:`joint_names` order; the one continuous-joint mask. Shape (n_joints,) bool.

    Raises:
        FrameNotFound: The sensor's parent frame is not in the URDF (lists the frames).
        JointError: A locked, sweep, home or limit joint name is not in the URDF.
        UnsupportedJoint: A joint is neither revolute, continuous nor prismatic.
    """

    def __init__(self, robot: RobotDefinition):
        self.robot = robot
        full = _build_model(robot)
        self.full_model = full
        lock_ids, q_lock = locked_configuration(full, robot.locked_joints)
        model = pin.buildReducedModel(full, lock_ids, q_lock) if lock_ids else full
        self.model = model
        self.joints = tuple(self._joint_info(model))
        self.joint_names = tuple(j.name for j in self.joints)
        if robot.sweep_joints is None and len(self.joints) < 2:  # the sweeps turn two joints: the last two by default
            found = ", ".join(f"'{name}'" for name in self.joint_names) or "none"
            message = (
                f"{robot.urdf} has {len(self.joints)} actuated joint(s) ({found}) but a calibration sweeps two "
                "(the last two actuated joints, or the robot file's sweep_joints)"
            )
            raise JointError(message, list(self.joint_names), [])
        self._index = {name: i for i, name in enumerate(self.joint_names)}
        self.sensor_frame_id = self._add_sensor_frame(model, robot)
        self.data = model.createData()
        self.sweep_joints = self._check_names(list(robot.sweep_joints or self.joint_names[-2:]), "sweep joint")
        if robot.home is not None:
            self._check_names(list(robot.home), "home joint")
        self.limits = resolve_limits(self.joints, robot.limits)
        self._chain = Chain(model, self.joints, self.sensor_frame_id)
        self._plain_q = all(j.kind != "continuous" for j in self.joints) and model.nq == len(self.joints)
        self.continuous = np.array([j.kind == "continuous" for j in self.joints], dtype=bool)  # a mask: stays bool
        self.continuous.setflags(write=False)
        self._bounded = np.array([j.kind == "revolute" for j in self.joints])
        self._g_cache: dict[float | None, np.ndarray] = {}

    # -- construction -------------------------------------------------------------------

    @staticmethod
    def _joint_info(model: pin.Model) -> list[JointInfo]:
        data = model.createData()
        q0 = pin.neutral(model)
        pin.computeJointJacobians(model, data, q0)
        infos = []
        for jid in range(1, model.njoints):
            joint = model.joints[jid]
            short = joint.shortname()
            name = model.names[jid]
            if joint.nv != 1 or not (short.startswith("JointModelR") or short.startswith("JointModelP")):
                raise UnsupportedJoint(f"joint '{name}' is a {short}; only revolute, continuous and prismatic joints are supported")
            # a one-joint model's Jacobian comes back as a vector: shape it (6, nv) again
            column = np.reshape(pin.getJointJacobian(model, data, jid, pin.LOCAL), (6, -1))[:, joint.idx_v]
            prismatic = short.startswith("JointModelP")
            axis = column[:3] if prismatic else column[3:]
            axis = axis / np.linalg.norm(axis)
            kind = "prismatic" if prismatic else ("continuous" if joint.nq == 2 else "revolute")
            lower = -math.inf if kind == "continuous" else float(model.lowerPositionLimit[joint.idx_q])
            upper = math.inf if kind == "continuous" else float(model.upperPositionLimit[joint.idx_q])
            infos.append(
                JointInfo(name, kind, frozen(axis), lower, upper, float(model.velocityLimit[joint.idx_v]), joint.idx_q, joint.idx_v)
            )
        return infos

    @staticmethod
    def _add_sensor_frame(model: pin.Model, robot: RobotDefinition) -> int:
        mount = robot.sensor
        if not model.existFrame(mount.parent_frame):
            raise FrameNotFound(mount.parent_frame, [f.name for f in model.frames])
        parent_id = model.getFrameId(mount.parent_frame)
        parent = model.frames[parent_id]
        T_parent_sensor = pin.SE3(pin.rpy.rpyToMatrix(*mount.rpy), np.asarray(mount.xyz, dtype=float))
        frame = pin.Frame(mount.name, parent.parentJoint, parent_id, parent.placement * T_parent_sensor, pin.FrameType.OP_FRAME)
        return model.addFrame(frame)

    def _check_names(self, names: list[str], what: str) -> tuple[str, ...]:
        return known_joints(names, self.joint_names, what)

    # -- collision geometry: placed by forward kinematics --------------------------------

    def distances(self, reading, geometry: pin.GeometryModel, geometry_data: pin.GeometryData) -> int:
        """Distances of every collision pair of ``geometry`` at one reading.

        Fills ``geometry_data.distanceResults`` and returns the index of the closest pair.
        """
        theta, single = self.readings(reading)
        if not single:
            raise ShapeError(f"distances takes one reading; got {len(theta)}")
        q = theta[0] if self._plain_q else self._q(theta)[0]
        return int(pin.computeDistances(self.model, self.data, geometry, geometry_data, q))

    def jacobian(self, reading) -> np.ndarray:
        """Jacobian of the sensor frame at one reading, axes of the world, origin of S.

        ``[v; omega] = J qdot``: linear velocity of the origin of S and angular velocity, in
        the world frame, from joint velocities in :attr:`joint_names` order.

        Returns:
            Shape (6, n_joints).
        """
        theta, single = self.readings(reading)
        if not single:
            raise ShapeError(f"jacobian takes one reading; got {len(theta)}")
        q = theta[0] if self._plain_q else self._q(theta)[0]
        return pin.computeFrameJacobian(self.model, self.data, q, self.sensor_frame_id, pin.LOCAL_WORLD_ALIGNED)

    def joint_axis_world(self, reading, joint_name: str) -> np.ndarray:
        """Unit axis of a joint in the world frame at one reading. Shape (3,)."""
        self._check_names([joint_name], "joint")
        self.sensor_pose(reading)  # runs forwardKinematics on this reading
        jid = self.model.getJointId(joint_name)
        return self.data.oMi[jid].rotation @ self.joints[self._index[joint_name]].axis

    def chain_joints(self, joint_name: str) -> list[str]:
        """Actuated joints from the root down to ``joint_name`` (inclusive), in order."""
        jid = self.model.getJointId(joint_name)
        return [self.model.names[j] for j in list(self.model.supports[jid])[1:]]

    # -- readings -----------------------------------------------------------------------

    @property
    def n_joints(self) -> int:
        """Number of actuated joints (one reading each)."""
        return len(self.joints)

    def readings(self, readings) -> tuple[np.ndarray, bool]:
        """Joint readings as a float array (N, n_joints), and whether it was one reading.

        Args:
            readings: An array (n_joints,) or (N, n_joints) in :attr:`joint_names` order, or
                a mapping joint name -> value or -> array (N,).

        Raises:
            JointError: Unknown or missing joint names, or the wrong number of values; the
                message lists the expected joints.
        """
        if type(readings) is np.ndarray and readings.dtype == np.float64 and readings.shape == (self.n_joints,):
            return readings[None, :], True  # the common single reading, without further checks
        return reading_array(readings, self.joint_names)

    def configuration(self, readings) -> np.ndarray:
        """Pinocchio configurations from joint readings (continuous joints -> cos, sin).

        Returns:
            q, shape (nq,) for one reading or (N, nq) for a batch.
        """
        theta, single = self.readings(readings)
        q = self._q(theta)
        return q[0] if single else q

    def _q(self, theta: np.ndarray) -> np.ndarray:
        if self._plain_q:
            return np.array(theta, dtype=float, order="C")
        q = np.empty((len(theta), self.model.nq))
        for k, joint in enumerate(self.joints):
            if joint.kind == "continuous":
                q[:, joint.idx_q] = np.cos(theta[:, k])
                q[:, joint.idx_q + 1] = np.sin(theta[:, k])
            else:
                q[:, joint.idx_q] = theta[:, k]
        return q

    def reading_problems(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
        """Soft problems of readings (N, n_joints), without warnings.

        Returns:
            ``(outside (N, n_joints) bool: outside the limits, outside_rows (N,) bool,
            joints whose readings look like degrees)``.
        """
        return find_problems(theta, self.joint_names, self.limits, self._bounded)

    def check_readings(self, readings) -> ReadingCheck:
        """Warn about readings outside the joint limits or that look like degrees.

        Emits one :class:`FtsCalibWarning` per kind of problem and returns the counts.
        """
        theta, _ = self.readings(readings)
        return warn_problems(theta, self.joint_names, self.limits, self._bounded, stacklevel=2)

    # -- one reading: Pinocchio ---------------------------------------------------------

    def sensor_pose(self, readings) -> pin.SE3:
        """``T_world_sensor`` for one reading, through Pinocchio.

        Args:
            readings: One reading, (n_joints,) or a mapping joint name -> value.
        """
        theta, single = self.readings(readings)
        if not single:
            raise ShapeError(f"sensor_pose takes one reading; got {len(theta)} (use sensor_poses for a batch)")
        return self._pose_one(theta[0])

    def _pose_one(self, theta: np.ndarray) -> pin.SE3:
        q = theta if self._plain_q else self._q(theta[None, :])[0]
        pin.forwardKinematics(self.model, self.data, q)
        return pin.updateFramePlacement(self.model, self.data, self.sensor_frame_id)

    # -- batches: vectorised recursion --------------------------------------------------

    def sensor_poses(self, readings) -> tuple[np.ndarray, np.ndarray]:
        """Poses of S in the world for a batch, by the vectorised recursion.

        Args:
            readings: (N, n_joints) or a mapping joint name -> (N,).

        Returns:
            ``(R_world_sensor (N, 3, 3), p_world_sensor (N, 3))`` in [m].
        """
        theta, _ = self.readings(readings)
        return self._chain.poses(theta)

    def R_world_sensor(self, readings) -> np.ndarray:
        """Orientation of the sensor frame in the world.

        Args:
            readings: One reading (n_joints,) or a batch (N, n_joints), or a mapping.

        Returns:
            ``R_world_sensor``, shape (3, 3) or (N, 3, 3).
        """
        theta, single = self.readings(readings)
        if single:
            return self._pose_one(theta[0]).rotation
        return self._chain.rotations(theta)

    def g_world(self, gravity: float | None = None) -> np.ndarray:
        """Gravity in the world frame [m/s^2]: the model's direction, with magnitude ``gravity`` if given."""
        cached = self._g_cache.get(gravity)
        if cached is None:
            g = np.asarray(self.model.gravity.linear, dtype=float).copy()
            if gravity is not None:
                g *= gravity / np.linalg.norm(g)
            g.setflags(write=False)
            cached = self._g_cache[gravity] = g
        return cached

    def g_sensor(self, readings, gravity: float | None = None) -> np.ndarray:
        """Gravity in the sensor frame, ``R_world_sensor.T @ g_world``, in [m/s^2].

        Args:
            readings: One reading or a batch (see :meth:`readings`).
            gravity: Magnitude of gravity [m/s^2] (e.g. the tool file's); the model's when None.

        Returns:
            Shape (3,) or (N, 3).
        """
        g = self.g_world(gravity)
        theta, single = self.readings(readings)
        if single:
            return self._pose_one(theta[0]).rotation.T.dot(g)
        return self._chain.in_sensor(theta, g)

    def sensor_motion(self, readings, velocities, accelerations) -> SensorMotion:
        """Spatial velocity and classical acceleration of S, expressed in S.

        Args:
            readings: Joint positions, one (n_joints,) or a batch (N, n_joints), or a mapping.
            velocities: Joint velocities [rad/s or m/s], same shape as the readings.
            accelerations: Joint accelerations [rad/s^2 or m/s^2], same shape.

        Returns:
            :class:`SensorMotion` with arrays (3,) for one reading or (N, 3) for a batch.
        """
        theta, single = self.readings(readings)
        dtheta, _ = self.readings(velocities)
        ddtheta, _ = self.readings(accelerations)
        if dtheta.shape != theta.shape or ddtheta.shape != theta.shape:
            raise ShapeError(f"positions {theta.shape}, velocities {dtheta.shape} and accelerations {ddtheta.shape} must match")
        if single:
            q = self._q(theta)[0]
            pin.forwardKinematics(self.model, self.data, q, dtheta[0], ddtheta[0])
            pin.updateFramePlacement(self.model, self.data, self.sensor_frame_id)
            vel = pin.getFrameVelocity(self.model, self.data, self.sensor_frame_id, pin.LOCAL)
            acc = pin.getFrameClassicalAcceleration(self.model, self.data, self.sensor_frame_id, pin.LOCAL)
            R = self.data.oMf[self.sensor_frame_id].rotation.copy()
            return SensorMotion(vel.angular.copy(), acc.angular.copy(), vel.linear.copy(), acc.linear.copy(), R)
        return SensorMotion(*self._chain.motion(theta, dtheta, ddtheta))

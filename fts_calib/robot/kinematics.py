r"""Robot kinematics with Pinocchio: the sensor frame's pose, velocity and acceleration.

One class, :class:`Kinematics`, owns Pinocchio's ``model`` and ``data`` and is the only
place in fts-calib that runs forward kinematics.

Frames: the world frame is the URDF's root; the sensor frame S is added to the model at
the robot definition's mount. ``R_world_sensor`` rotates vectors from S into the world;
``T_world_sensor`` is the pose of S in the world (Pinocchio's ``oMf``). Gravity in S is
``g_sensor = R_world_sensor.T @ g_world``.

Joint readings are angles in [rad] (or positions in [m] for prismatic joints), one per
actuated joint, in the order of :attr:`Kinematics.joint_names`, or a mapping joint name ->
value. Continuous joints, which Pinocchio represents by ``(cos q, sin q)``, take a plain
angle; 3.5 rad and 3.5 - 2 pi rad give the same pose.

Two paths compute the same thing: one reading goes through Pinocchio
(``forwardKinematics``); a batch of N readings goes through a vectorised recursion over the
chain from the root to the sensor, built from the model's joint placements and axes:

.. math::

    R_k = R_{k-1} M_k R_{u_k}(q_k), \quad
    \omega_k = \omega_{k-1} + z_k \dot q_k, \quad
    \alpha_k = \alpha_{k-1} + \omega_{k-1} \times z_k \dot q_k + z_k \ddot q_k,

    a_k = a_{k-1} + \alpha_{k-1} \times r_k + \omega_{k-1} \times (\omega_{k-1} \times r_k)

with ``z_k`` the joint axis and ``r_k`` the offset of joint k from its parent, both in the
world frame (prismatic joints add their velocity and Coriolis terms). Tests check the two
paths against each other and against the URDF's transforms multiplied by hand.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..core.arrays import frozen
from ..core.exceptions import FrameNotFound, FtsCalibError, FtsCalibWarning, JointError, ShapeError
from .definition import RobotDefinition

#: Readings of a bounded revolute joint beyond this magnitude look like degrees.
DEGREES_SUSPECT = 3.0 * math.pi  # [rad]

_LIMIT_TOLERANCE = 1e-6  # [rad or m]: readings this close outside a limit are inside


class UnsupportedJoint(FtsCalibError):
    """The URDF has a joint type the calibration cannot read from one number per joint."""


@dataclass(frozen=True)
class JointInfo:
    """One actuated joint of the (reduced) model.

    Attributes:
        name: URDF joint name.
        kind: 'revolute', 'continuous' or 'prismatic'.
        axis: Joint axis in the joint frame (unit). Shape (3,).
        lower: Lower position limit in [rad or m] (-inf for continuous joints).
        upper: Upper position limit in [rad or m] (+inf for continuous joints).
        velocity: URDF velocity limit in [rad/s or m/s].
        idx_q: Index of the joint's first entry in Pinocchio's q.
        idx_v: Index of the joint in Pinocchio's v.
    """

    name: str
    kind: str
    axis: np.ndarray
    lower: float
    upper: float
    velocity: float
    idx_q: int
    idx_v: int


@dataclass(frozen=True)
class JointLimits:
    """Resolved motion limits per actuated joint, in :attr:`Kinematics.joint_names` order.

    Attributes:
        lower: Lower position limits [rad or m], -inf when unbounded. Shape (n,).
        upper: Upper position limits [rad or m], +inf when unbounded. Shape (n,).
        velocity: Velocity limits [rad/s or m/s] (URDF limit times the fraction, or as set). Shape (n,).
        acceleration: Acceleration limits [rad/s^2 or m/s^2]. Shape (n,).
        jerk: Jerk limits [rad/s^3 or m/s^3]. Shape (n,).
    """

    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray

    def __post_init__(self):
        for name in ("lower", "upper", "velocity", "acceleration", "jerk"):
            object.__setattr__(self, name, frozen(getattr(self, name)))


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


@dataclass(frozen=True)
class ReadingCheck:
    """Soft problems found in joint readings (each was also warned about).

    Attributes:
        outside_limits: Readings (rows) with at least one joint outside its limits.
        outside_by_joint: Rows outside the limits, per joint name (only joints with any).
        degrees_suspected: Joints whose readings look like degrees.
    """

    outside_limits: int
    outside_by_joint: Mapping[str, int]
    degrees_suspected: tuple[str, ...]


def _skew_columns(axis: np.ndarray) -> tuple[int, int, float] | None:
    """For an axis equal to +-e_i: the two other column indices (cyclic) and the sign."""
    for i in range(3):
        if abs(abs(axis[i]) - 1.0) < 1e-12 and np.allclose(np.delete(axis, i), 0.0, atol=1e-12):
            return (i + 1) % 3, (i + 2) % 3, float(np.sign(axis[i]))
    return None


# The batch path stores a stack of N rotations by columns, ``cols`` of shape (3, N, 3) with
# ``cols[j, n] = R[n][:, j]``: a joint rotation then mixes two contiguous arrays, and a
# product with a constant matrix is one (3, 3N) matrix product.


def _compose(cols: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Columns of ``R[n] @ C`` for every n; C (3, 3) constant."""
    return (C.T @ cols.reshape(3, -1)).reshape(cols.shape)


def _apply(cols: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``R[n] @ x`` for every n, shape (N, 3); x (3,) constant."""
    return (x @ cols.reshape(3, -1)).reshape(cols.shape[1], 3)


def _transpose_apply(cols: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``R[n].T @ x[n]`` for every n, shape (N, 3); x (N, 3) or (3,)."""
    if x.ndim == 1:
        return (cols.reshape(-1, 3) @ x).reshape(3, -1).T
    return np.einsum("jni,ni->nj", cols, x)


def _matrices(cols: np.ndarray) -> np.ndarray:
    """The stack of rotation matrices (N, 3, 3) from its columns."""
    return np.ascontiguousarray(np.transpose(cols, (1, 2, 0)))


class _ChainLink:
    """One joint of the root-to-sensor chain, for the vectorised path."""

    __slots__ = ("R_parent", "p_parent", "axis", "kind", "reading", "aligned", "skew")

    def __init__(self, placement: pin.SE3, axis: np.ndarray, kind: str, reading: int):
        self.R_parent = placement.rotation.copy()
        self.p_parent = placement.translation.copy()
        self.axis = axis
        self.kind = kind
        self.reading = reading
        self.aligned = _skew_columns(axis)
        self.skew = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])

    def rotate(self, cols: np.ndarray, angle: np.ndarray) -> np.ndarray:
        """Columns of ``R[n] @ rot(axis, angle[n])`` for every n."""
        c, s = np.cos(angle)[:, None], np.sin(angle)[:, None]
        if self.aligned is not None:
            j, k, sign = self.aligned
            s = sign * s
            out = cols.copy()
            out[j] = c * cols[j] + s * cols[k]
            out[k] = c * cols[k] - s * cols[j]
            return out
        # Rodrigues: R rot = c R + s R [u]x + (1 - c) (R u) u^T
        Rk, Ru, u = _compose(cols, self.skew), _apply(cols, self.axis), self.axis
        return np.stack([c * cols[m] + s * Rk[m] + (1.0 - c) * u[m] * Ru for m in range(3)])


class Kinematics:
    """Forward kinematics of a robot definition, for one reading or a batch.

    Args:
        robot: A robot definition (see :func:`fts_calib.robot.definition.load_robot`).

    Raises:
        FrameNotFound: The sensor's parent frame is not in the URDF (lists the frames).
        JointError: A locked, sweep, home or limit joint name is not in the URDF.
        UnsupportedJoint: A joint is neither revolute, continuous nor prismatic.
    """

    def __init__(self, robot: RobotDefinition):
        self.robot = robot
        full = pin.buildModelFromUrdf(str(robot.urdf))
        self._full_model = full
        self._lock_ids, self._q_lock = self._locked(full, robot.locked_joints)
        model = pin.buildReducedModel(full, self._lock_ids, self._q_lock) if self._lock_ids else full
        self.model = model
        self.joints = tuple(self._joint_info(model))
        self.joint_names = tuple(j.name for j in self.joints)
        self._index = {name: i for i, name in enumerate(self.joint_names)}
        self.sensor_frame_id = self._add_sensor_frame(model, robot)
        self.data = model.createData()
        self.sweep_joints = self._check_names(list(robot.sweep_joints or self.joint_names[-2:]), "sweep joint")
        if robot.home is not None:
            self._check_names(list(robot.home), "home joint")
        self.limits = self._resolve_limits(robot)
        self._chain = self._build_chain(model)
        self._plain_q = all(j.kind != "continuous" for j in self.joints) and model.nq == len(self.joints)
        self._continuous = np.array([j.kind == "continuous" for j in self.joints])
        self._bounded = np.array([j.kind == "revolute" for j in self.joints])
        self._g_cache: dict[float | None, np.ndarray] = {}

    # -- construction -------------------------------------------------------------------

    @staticmethod
    def _locked(full: pin.Model, locked: Mapping[str, float]) -> tuple[list[int], np.ndarray]:
        q = pin.neutral(full)
        ids = []
        for name, value in locked.items():
            if not full.existJointName(name):
                raise JointError(f"locked joint '{name}' is not in the URDF", [name], list(full.names)[1:])
            jid = full.getJointId(name)
            joint = full.joints[jid]
            if joint.nq == 2:
                q[joint.idx_q : joint.idx_q + 2] = (math.cos(value), math.sin(value))
            else:
                q[joint.idx_q] = value
            ids.append(jid)
        return ids, q

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
            column = pin.getJointJacobian(model, data, jid, pin.LOCAL)[:, joint.idx_v]
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
        unknown = [n for n in names if n not in self._index]
        if unknown:
            raise JointError(f"{what} {unknown} not among the actuated joints", unknown, self.joint_names)
        return tuple(names)

    def _resolve_limits(self, robot: RobotDefinition) -> JointLimits:
        spec = robot.limits
        per_joint = {
            **spec.velocity,
            **{k: v for k, v in spec.acceleration.items() if k != "*"},
            **{k: v for k, v in spec.jerk.items() if k != "*"},
        }
        self._check_names([n for n in per_joint], "limit for joint")
        velocity = np.array([spec.velocity.get(j.name, j.velocity * spec.velocity_fraction) for j in self.joints])
        if np.any(~np.isfinite(velocity) | (velocity <= 0)):
            bad = [j.name for j, v in zip(self.joints, velocity, strict=True) if not (math.isfinite(v) and v > 0)]
            raise JointError(
                f"joints {bad} have no positive velocity limit in the URDF: set limits.velocity for them", bad, self.joint_names
            )

        def table(values: Mapping[str, float]) -> np.ndarray:
            return np.array([values.get(j.name, values.get("*", math.nan)) for j in self.joints])

        return JointLimits(
            lower=np.array([j.lower for j in self.joints]),
            upper=np.array([j.upper for j in self.joints]),
            velocity=velocity,
            acceleration=table(spec.acceleration),
            jerk=table(spec.jerk),
        )

    def _build_chain(self, model: pin.Model) -> list[_ChainLink]:
        frame = model.frames[self.sensor_frame_id]
        chain = []
        for jid in list(model.supports[frame.parentJoint])[1:]:
            info = self.joints[jid - 1]
            chain.append(_ChainLink(model.jointPlacements[jid], np.asarray(info.axis), info.kind, jid - 1))
        self._R_last_sensor = frame.placement.rotation.copy()
        self._p_last_sensor = frame.placement.translation.copy()
        return chain

    # -- collision geometry -------------------------------------------------------------

    def collision_model(self) -> pin.GeometryModel:
        """The URDF's collision geometry for this (reduced) model; meshes from the package dirs.

        Links listed in the definition's ``collision.ignore_links`` are left out.
        """
        geometry = pin.buildGeomFromUrdf(
            self._full_model, str(self.robot.urdf), pin.COLLISION, package_dirs=[str(p) for p in self.robot.package_dirs]
        )
        if self._lock_ids:
            _, geometry = pin.buildReducedModel(self._full_model, geometry, self._lock_ids, self._q_lock)
        for name in self.robot.ignore_links:
            if not self.model.existFrame(name):
                raise FrameNotFound(name, [f.name for f in self.model.frames])
        ignored = {self.model.getFrameId(n) for n in self.robot.ignore_links}
        doomed = [obj.name for obj in geometry.geometryObjects if obj.parentFrame in ignored]
        for name in doomed:  # names first: removing invalidates the objects
            geometry.removeGeometryObject(name)
        return geometry

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
        if isinstance(readings, Mapping):
            unknown = [k for k in readings if k not in self._index]
            missing = [n for n in self.joint_names if n not in readings]
            if unknown or missing:
                parts = ([f"unknown joints {unknown}"] if unknown else []) + ([f"missing joints {missing}"] if missing else [])
                raise JointError("; ".join(parts), unknown + missing, self.joint_names)
            columns = [np.asarray(readings[n], dtype=float) for n in self.joint_names]
            array = np.stack(columns, axis=-1)
        else:
            array = np.asarray(readings, dtype=float)
        if array.ndim not in (1, 2) or array.shape[-1] != self.n_joints:
            raise JointError(
                f"got joint readings of shape {array.shape} but the robot has {self.n_joints} actuated joints "
                f"(expected ({self.n_joints},) or (N, {self.n_joints}))",
                [],
                self.joint_names,
            )
        if array.ndim == 1:
            return array[None, :], True
        return array, False

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
        lim = self.limits
        outside = (theta < lim.lower - _LIMIT_TOLERANCE) | (theta > lim.upper + _LIMIT_TOLERANCE)
        suspect = np.any(np.abs(theta) > DEGREES_SUSPECT, axis=0) & self._bounded
        return outside, np.any(outside, axis=1), tuple(n for n, big in zip(self.joint_names, suspect, strict=True) if big)

    def check_readings(self, readings) -> ReadingCheck:
        """Warn about readings outside the joint limits or that look like degrees.

        Emits one :class:`FtsCalibWarning` per kind of problem and returns the counts.
        """
        theta, _ = self.readings(readings)
        outside, outside_rows, degrees = self.reading_problems(theta)
        by_joint = {name: int(n) for name, n in zip(self.joint_names, outside.sum(axis=0), strict=True) if n}
        rows = int(outside_rows.sum())
        if degrees:
            worst = {n: float(np.max(np.abs(theta[:, self._index[n]]))) for n in degrees}
            warnings.warn(
                f"joint readings look like degrees: {', '.join(f'{n} reaches {v:.1f}' for n, v in worst.items())}, "
                f"far beyond 2π; readings must be in rad",
                FtsCalibWarning,
                stacklevel=2,
            )
        if rows:
            detail = ", ".join(f"{n}: {c}" for n, c in by_joint.items())
            warnings.warn(f"{rows} reading(s) outside the joint limits ({detail})", FtsCalibWarning, stacklevel=2)
        return ReadingCheck(rows, by_joint, degrees)

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
        cols, p = self._forward(theta)
        return _matrices(cols), p

    def _forward(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Columns of R_world_sensor (3, N, 3) and p_world_sensor (N, 3)."""
        n = len(theta)
        cols = np.zeros((3, n, 3))
        for j in range(3):
            cols[j, :, j] = 1.0
        p = np.zeros((n, 3))
        for link in self._chain:
            p += _apply(cols, link.p_parent)
            cols = _compose(cols, link.R_parent)
            q = theta[:, link.reading]
            if link.kind == "prismatic":
                p += _apply(cols, link.axis) * q[:, None]
            else:
                cols = link.rotate(cols, q)
        return _compose(cols, self._R_last_sensor), p + _apply(cols, self._p_last_sensor)

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
        return _matrices(self._forward(theta)[0])

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
        return _transpose_apply(self._forward(theta)[0], g)

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
        return self._motion(theta, dtheta, ddtheta)

    def _motion(self, theta: np.ndarray, dtheta: np.ndarray, ddtheta: np.ndarray) -> SensorMotion:
        n = len(theta)
        cols = np.zeros((3, n, 3))
        for j in range(3):
            cols[j, :, j] = 1.0
        w, al, v, a = (np.zeros((n, 3)) for _ in range(4))
        for link in self._chain:
            r = _apply(cols, link.p_parent)  # offset of this joint from its parent, world frame
            v += np.cross(w, r)
            a += np.cross(al, r) + np.cross(w, np.cross(w, r))
            cols = _compose(cols, link.R_parent)
            k = link.reading
            z = _apply(cols, link.axis)  # joint axis in the world (unchanged by the joint's own rotation)
            qd, qdd = dtheta[:, k, None], ddtheta[:, k, None]
            if link.kind == "prismatic":
                d = z * theta[:, k, None]
                a += np.cross(al, d) + np.cross(w, np.cross(w, d)) + 2.0 * np.cross(w, z * qd) + z * qdd
                v += np.cross(w, d) + z * qd
            else:
                cols = link.rotate(cols, theta[:, k])
                al += np.cross(w, z * qd) + z * qdd
                w = w + z * qd
        r = _apply(cols, self._p_last_sensor)
        v += np.cross(w, r)
        a += np.cross(al, r) + np.cross(w, np.cross(w, r))
        cols = _compose(cols, self._R_last_sensor)
        return SensorMotion(
            _transpose_apply(cols, w), _transpose_apply(cols, al), _transpose_apply(cols, v), _transpose_apply(cols, a), _matrices(cols)
        )

"""Actuated joints: their kinds, axes and limits, and joint readings as arrays.

Joint readings are angles in [rad] (or positions in [m] for prismatic joints), one per
actuated joint, in the order of :attr:`Kinematics.joint_names`, or a mapping joint name ->
value. Continuous joints, which Pinocchio represents by ``(cos q, sin q)``, take a plain
angle; 3.5 rad and 3.5 - 2 pi rad give the same pose. A joint's axis is a unit vector in
the joint's own frame.

Nothing here runs forward kinematics: :class:`~fts_calib.robot.kinematics.Kinematics`
reads the joints from its model, then calls these helpers.
"""

from __future__ import annotations

import math
import warnings
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..core.arrays import frozen
from ..core.exceptions import FtsCalibWarning, JointError, UnsupportedJoint
from .definition import LimitSpec

#: Readings of a bounded revolute joint beyond this magnitude look like degrees.
DEGREES_SUSPECT = 3.0 * math.pi  # [rad]

_LIMIT_TOLERANCE = 1e-6  # [rad or m]: readings this close outside a limit are inside


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


def known_joints(names: Sequence[str], joint_names: Sequence[str], what: str) -> tuple[str, ...]:
    """``names`` as a tuple, after checking that each is an actuated joint.

    Raises:
        JointError: Some names are not in ``joint_names``; ``what`` says what they name.
    """
    unknown = [n for n in names if n not in joint_names]
    if unknown:
        raise JointError(f"{what} {unknown} not among the actuated joints", unknown, tuple(joint_names))
    return tuple(names)


def locked_configuration(full: pin.Model, locked: Mapping[str, float]) -> tuple[list[int], np.ndarray]:
    """Joint ids of the locked joints of the URDF's full model, and its q holding them at their values.

    Args:
        full: The URDF's model, every joint included.
        locked: Locked joint name -> value [rad or m].

    Raises:
        JointError: A locked joint is not in the URDF.
    """
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


def _unique_frames(full: pin.Model) -> tuple[pin.Model, dict[str, str]]:
    """A copy of ``full`` whose frames have unique names, and the names changed (new -> old).

    Pinocchio's ``buildReducedModel`` looks frames up by name alone and finds a joint's frame by
    the joint's name: of the frames sharing a name, the joint's keeps it, the others (a link, a
    fixed joint) take a unique one.
    """
    model = pin.Model(full)
    counts = Counter(frame.name for frame in model.frames)
    renamed: dict[str, str] = {}
    for k, frame in enumerate(model.frames):
        if counts[frame.name] > 1 and frame.type != pin.FrameType.JOINT:
            unique = f"{frame.name}#{k}"
            while unique in counts or unique in renamed:
                unique += "#"
            renamed[unique] = frame.name
            model.frames[k].name = unique
    return model, renamed


def _names_back(model: pin.Model, renamed: dict[str, str]) -> pin.Model:
    """``model`` with the frames :func:`_unique_frames` renamed named back (in place)."""
    for k, frame in enumerate(model.frames):
        if frame.name in renamed:
            model.frames[k].name = renamed[frame.name]
    return model


def reduced_model(full: pin.Model, lock_ids: Sequence[int], q: np.ndarray) -> pin.Model:
    """Pinocchio's reduced model without the locked joints, for any URDF.

    Pinocchio's ``buildReducedModel`` looks frames up by name alone, and fails ("Several
    frames match the filter") on a URDF that gives a link and a joint one name (the Unitree
    Z1's ``gripperStator``, ANYmal C's legs): the model is reduced from a copy whose frames
    have unique names, and the names are given back in the result.

    Args:
        full: The URDF's model, every joint included (not modified).
        lock_ids: Ids of the joints to lock (:func:`locked_configuration`).
        q: Configuration of ``full`` holding the locked joints at their values, shape (nq,).
    """
    model, renamed = _unique_frames(full)
    return _names_back(pin.buildReducedModel(model, list(lock_ids), q), renamed)


def reduced_geometry(full: pin.Model, lock_ids: Sequence[int], q: np.ndarray, geometry: pin.GeometryModel) -> pin.GeometryModel:
    """The geometry of ``full`` for its reduced model (:func:`reduced_model`, the same names rule).

    Args:
        full: The URDF's model, every joint included (not modified).
        lock_ids: Ids of the joints to lock.
        q: Configuration of ``full`` holding the locked joints at their values, shape (nq,).
        geometry: The geometry model built for ``full``.
    """
    model, _ = _unique_frames(full)
    return pin.buildReducedModel(model, geometry, list(lock_ids), q)[1]


def resolve_limits(joints: Sequence[JointInfo], spec: LimitSpec) -> JointLimits:
    """The robot definition's limits resolved against the URDF's, per joint.

    Raises:
        JointError: A limit names a joint that is not actuated, or a joint has no positive
            velocity limit (neither in the URDF nor in the definition).
    """
    names = tuple(j.name for j in joints)
    per_joint = {
        **spec.velocity,
        **{k: v for k, v in spec.acceleration.items() if k != "*"},
        **{k: v for k, v in spec.jerk.items() if k != "*"},
    }
    known_joints(list(per_joint), names, "limit for joint")
    velocity = np.array([spec.velocity.get(j.name, j.velocity * spec.velocity_fraction) for j in joints])
    if np.any(~np.isfinite(velocity) | (velocity <= 0)):
        bad = [j.name for j, v in zip(joints, velocity, strict=True) if not (math.isfinite(v) and v > 0)]
        raise JointError(f"joints {bad} have no positive velocity limit in the URDF: set limits.velocity for them", bad, names)

    def table(values: Mapping[str, float]) -> np.ndarray:
        return np.array([values.get(j.name, values.get("*", math.nan)) for j in joints])

    return JointLimits(
        lower=np.array([j.lower for j in joints]),
        upper=np.array([j.upper for j in joints]),
        velocity=velocity,
        acceleration=table(spec.acceleration),
        jerk=table(spec.jerk),
    )


def reading_array(readings, joint_names: Sequence[str]) -> tuple[np.ndarray, bool]:
    """Joint readings as a float array (N, n_joints), and whether it was one reading.

    Args:
        readings: An array (n_joints,) or (N, n_joints) in ``joint_names`` order, or a
            mapping joint name -> value or -> array (N,).
        joint_names: The actuated joints, in order.

    Raises:
        JointError: Unknown or missing joint names, or the wrong number of values; the
            message lists the expected joints.
    """
    n_joints = len(joint_names)
    if isinstance(readings, Mapping):
        unknown = [k for k in readings if k not in joint_names]
        missing = [n for n in joint_names if n not in readings]
        if unknown or missing:
            # only missing (no typo): joints the data do not hold, a gripper's fingers
            locked = "" if unknown else " (joints the data do not hold: hold them fixed with the robot definition's locked_joints)"
            parts = ([f"unknown joints {unknown}"] if unknown else []) + ([f"missing joints {missing}{locked}"] if missing else [])
            raise JointError("; ".join(parts), unknown + missing, tuple(joint_names))
        columns = [np.asarray(readings[n], dtype=float) for n in joint_names]
        array = np.stack(columns, axis=-1)
    else:
        array = np.asarray(readings, dtype=float)
    if array.ndim not in (1, 2) or array.shape[-1] != n_joints:
        raise JointError(
            f"got joint readings of shape {array.shape} but the robot has {n_joints} actuated joints "
            f"(expected ({n_joints},) or (N, {n_joints}))",
            [],
            tuple(joint_names),
        )
    if array.ndim == 1:
        return array[None, :], True
    return array, False


def find_problems(
    theta: np.ndarray, joint_names: Sequence[str], limits: JointLimits, revolute: np.ndarray
) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """Soft problems of readings (N, n_joints), without warnings.

    Args:
        theta: Joint readings [rad or m]. Shape (N, n_joints).
        joint_names: The actuated joints, in order.
        limits: Their limits.
        revolute: Which joints are bounded revolute joints, whose readings may look like
            degrees. Shape (n_joints,) bool.

    Returns:
        ``(outside (N, n_joints) bool: outside the limits, outside_rows (N,) bool,
        joints whose readings look like degrees)``.
    """
    outside = (theta < limits.lower - _LIMIT_TOLERANCE) | (theta > limits.upper + _LIMIT_TOLERANCE)
    suspect = np.any(np.abs(theta) > DEGREES_SUSPECT, axis=0) & revolute
    return outside, np.any(outside, axis=1), tuple(n for n, big in zip(joint_names, suspect, strict=True) if big)


def warn_problems(
    theta: np.ndarray, joint_names: Sequence[str], limits: JointLimits, revolute: np.ndarray, stacklevel: int = 2
) -> ReadingCheck:
    """Warn about readings outside the joint limits or that look like degrees.

    Emits one :class:`FtsCalibWarning` per kind of problem, attributed ``stacklevel``
    frames up as :func:`warnings.warn` counts them from the caller of this function, and
    returns the counts. Arguments as :func:`find_problems`.
    """
    outside, outside_rows, degrees = find_problems(theta, joint_names, limits, revolute)
    by_joint = {name: int(n) for name, n in zip(joint_names, outside.sum(axis=0), strict=True) if n}
    rows = int(outside_rows.sum())
    if degrees:
        worst = {n: float(np.max(np.abs(theta[:, list(joint_names).index(n)]))) for n in degrees}
        warnings.warn(
            f"joint readings look like degrees: {', '.join(f'{n} reaches {v:.1f}' for n, v in worst.items())}, "
            f"far beyond 2π; readings must be in rad",
            FtsCalibWarning,
            stacklevel=stacklevel + 1,
        )
    if rows:
        detail = ", ".join(f"{n}: {c}" for n, c in by_joint.items())
        warnings.warn(f"{rows} reading(s) outside the joint limits ({detail})", FtsCalibWarning, stacklevel=stacklevel + 1)
    return ReadingCheck(rows, by_joint, degrees)


def joint_infos(model: pin.Model) -> list[JointInfo]:
    """The actuated joints of a model, in order: name, kind, axis, limits, indices.

    Raises:
        UnsupportedJoint: A joint is neither revolute, continuous nor prismatic.
    """
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
        infos.append(JointInfo(name, kind, frozen(axis), lower, upper, float(model.velocityLimit[joint.idx_v]), joint.idx_q, joint.idx_v))
    return infos

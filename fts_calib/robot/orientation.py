"""Recordings that give the sensor's orientation instead of joint angles.

Real datasets often hold the orientation itself: a unit quaternion from a robot driver, roll,
pitch and yaw typed into a script, or the TCP pose a UR controller reports. Each form is
turned into the three angles of a gimbal, ``R_world_flange = Rz(yaw) Ry(pitch) Rx(roll)``,
whose kinematics (:func:`orientation_kinematics`: three continuous joints ``yaw``, ``pitch``,
``roll`` at the world's origin, the sensor frame on the last with the mount rotation) then
serve every command as a robot's would. Gravity is -Z of the world (its magnitude the tool
file's). The forms, by their CSV columns:

- ``qw,qx,qy,qz``: the unit quaternion of ``R_world_sensor`` (normalised on reading);
- ``roll,pitch,yaw``: ``R_world_sensor = Rz(yaw) Ry(pitch) Rx(roll)`` [rad];
- ``tcp_rx,tcp_ry,tcp_rz``: the rotation vector of ``R_base_tcp`` [rad] (a UR controller's
  TCP pose, the base frame's Z up), the sensor turned from the TCP by ``--mount R P Y``.

The mount rotation turns the frame the recording gives into the sensor frame, for every
form; it is zero by default, so that a quaternion or angles are the sensor's own. Without
positions, the sensor's linear acceleration is not known: the
expected wrench is the weight plus the rotational terms of the tool, so record still poses
or slow motions (the quasi-static filter keeps the still samples).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from ..core.exceptions import RecordingError
from .kinematics import Kinematics

#: The gimbal's joints, outermost first: ``R = Rz(yaw) Ry(pitch) Rx(roll)``.
GIMBAL_JOINTS = ("yaw", "pitch", "roll")
#: The orientation forms a recording may give, by their columns.
ORIENTATION_FORMS = {
    "quaternion": ("qw", "qx", "qy", "qz"),
    "roll-pitch-yaw": ("roll", "pitch", "yaw"),
    "tcp": ("tcp_rx", "tcp_ry", "tcp_rz"),
}
#: Largest departure from a rotation accepted of one given orientation (a datagram's ``R`` or
#: ``quat``, a bag's quaternion): ``| |q| - 1 |``, or the largest element of ``R^T R - I``.
#: Within it the value is made exact (``q / |q|``; the nearest rotation to ``R``); beyond it,
#: or with ``det R < 0`` (a reflection), it is refused.
UNIT_TOLERANCE = 1e-3
#: The gimbal's frame the sensor is mounted on.
FLANGE = "flange"
#: Within this of pitch +-90 deg (cos pitch below its sine), roll and yaw turn about one axis: yaw is set to 0 [rad].
GIMBAL_LOCK = math.radians(0.05)


def orientation_kinematics(mount_rpy: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0), name: str = "orientation") -> Kinematics:
    """Kinematics of a recording that gives orientations: the gimbal of the module docstring.

    Args:
        mount_rpy: Roll, pitch, yaw from the frame whose orientation the recording gives
            (the flange) to the sensor [rad], shape (3,).
        name: The robot's name in the calibration's provenance.
    """
    model = pin.Model()
    model.name = name
    parent = 0
    for joint, axis in zip(GIMBAL_JOINTS, (pin.JointModelRUBZ(), pin.JointModelRUBY(), pin.JointModelRUBX()), strict=True):
        parent = model.addJoint(parent, axis, pin.SE3.Identity(), joint)
        model.appendBodyToJoint(parent, pin.Inertia.Zero(), pin.SE3.Identity())
    model.addFrame(pin.Frame(FLANGE, parent, 0, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
    model.gravity.linear = np.array([0.0, 0.0, -9.81])  # -Z of the world; the magnitude is the tool file's
    return Kinematics.from_model(model, FLANGE, rpy=np.asarray(mount_rpy, dtype=float), name=name, sweep_joints=("pitch", "roll"))


def orientation_form(columns: Sequence[str]) -> str | None:
    """The orientation form a header gives (a key of :data:`ORIENTATION_FORMS`), or None."""
    present = set(columns)
    found = [form for form, names in ORIENTATION_FORMS.items() if set(names) <= present]
    return found[0] if found else None


def rotations(form: str, values: np.ndarray) -> np.ndarray:
    """The rotation matrices of N orientations of one form, shape (N, 3, 3).

    Args:
        form: A key of :data:`ORIENTATION_FORMS`.
        values: The form's columns in its order, shape (N, 3) or (N, 4).
    """
    values = np.asarray(values, dtype=float)
    if form == "quaternion":
        q = values / np.linalg.norm(values, axis=1, keepdims=True)
        w, x, y, z = q.T
        return np.stack(
            [
                np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
                np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
                np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
            ],
            axis=1,
        )
    if form == "roll-pitch-yaw":
        return np.array([pin.rpy.rpyToMatrix(*row) for row in values])
    return np.array([pin.exp3(row) for row in values])


def checked_rotation(value, field: str) -> np.ndarray:
    """One given orientation as a rotation matrix, shape (3, 3), or a ValueError naming ``field``.

    Args:
        value: A quaternion ``[w, x, y, z]`` (``field`` ``'quat'``), or a rotation matrix, row-major:
            9 numbers or 3 rows of 3 (any other ``field``, e.g. ``'R'``).
        field: The name of the value, for the message.

    Raises:
        ValueError: Not numbers, of the wrong length, not finite, or farther than
            :data:`UNIT_TOLERANCE` from a unit quaternion or a rotation (a reflection too).
    """
    quaternion = field == "quat"
    expected = "a unit quaternion [w, x, y, z]" if quaternion else "a rotation matrix, 9 numbers row-major or 3 rows of 3"
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"'{field}' must be {expected}, got {value!r:.80}") from None
    if array.shape not in (((4,),) if quaternion else ((9,), (3, 3))):
        raise ValueError(f"'{field}' must be {expected}, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"'{field}' holds a number that is not finite: expected {expected}")
    if quaternion:
        norm = float(np.linalg.norm(array))
        if abs(norm - 1.0) > UNIT_TOLERANCE:
            raise ValueError(f"'{field}' has norm {norm:.6g}, not 1 (within {UNIT_TOLERANCE:g}): expected {expected}")
        return rotations("quaternion", array[None])[0]
    R = array.reshape(3, 3)
    departure = float(np.abs(R.T @ R - np.eye(3)).max())
    if departure > UNIT_TOLERANCE:
        raise ValueError(f"'{field}' is not orthonormal (R^T R - I up to {departure:.3g}, at most {UNIT_TOLERANCE:g}): expected {expected}")
    if np.linalg.det(R) < 0:
        raise ValueError(f"'{field}' has determinant {np.linalg.det(R):.6g}: a reflection, not a rotation (expected det +1)")
    u, _, vt = np.linalg.svd(R)
    return u @ vt


def gimbal_angles(R: np.ndarray) -> np.ndarray:
    """The gimbal's joints ``[yaw, pitch, roll]`` [rad] of rotations ``R = Rz(yaw) Ry(pitch) Rx(roll)``, (N, 3)."""
    rpy = np.array([pin.rpy.matrixToRpy(r) for r in np.asarray(R, dtype=float).reshape(-1, 3, 3)]).reshape(-1, 3)
    return rpy[:, ::-1].copy()


def mount_rpy(R: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw of a rotation ``R = Rz(yaw) Ry(pitch) Rx(roll)``, as ``--mount`` and ``sensor.rpy`` take them.

    Within :data:`GIMBAL_LOCK` of pitch +-90 deg only ``roll -+ yaw`` is determined: pitch is set to +-90
    deg, yaw to 0 and roll takes the rest (``-90 -90 0``, not ``-112.8 -90 22.8``).

    Args:
        R: A rotation, shape (3, 3).

    Returns:
        ``[roll, pitch, yaw]`` [rad], shape (3,).
    """
    roll, pitch, yaw = (float(v) for v in pin.rpy.matrixToRpy(np.asarray(R, dtype=float)))
    if abs(math.cos(pitch)) < math.sin(GIMBAL_LOCK):
        pitch = math.copysign(math.pi / 2.0, pitch)
        roll = roll + yaw if pitch < 0 else roll - yaw  # Rz(y) Ry(-+pi/2) Rx(r) = Ry(-+pi/2) Rx(r +- y)
        roll, yaw = math.remainder(roll, 2.0 * math.pi), 0.0
    return np.array([roll, pitch, yaw])


def orientation_joints(form: str, values: np.ndarray) -> np.ndarray:
    """The gimbal's joints [rad] of N recorded orientations, shape (N, 3), :data:`GIMBAL_JOINTS` order.

    Args:
        form: A key of :data:`ORIENTATION_FORMS`.
        values: The form's columns, shape (N, 3) or (N, 4).
    """
    return gimbal_angles(rotations(form, values))


def missing_orientation(path, columns: Sequence[str]) -> RecordingError:
    """The error of a recording that gives neither the gimbal's joints nor an orientation form."""
    forms = " or ".join(",".join(names) for names in ORIENTATION_FORMS.values())
    return RecordingError(
        path,
        1,
        None,
        f"no --robot given, so the recording must give the sensor's orientation: columns {forms}; the header has {list(columns)}",
    )

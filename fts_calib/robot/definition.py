"""Robot definitions (``robots/NAME.yaml``): the URDF, the sensor mount, sweep joints, limits.

Fields: ``name``; ``urdf``, a path relative to the YAML file or
``example-robot-data:<path inside its robots/ folder>``; ``sensor.parent_frame`` (a URDF
frame) with ``sensor.xyz`` [m] and ``sensor.rpy`` [rad] from that frame to the sensor frame
S (X along the tool axis), and optional ``sensor.name``; optional ``sweep_joints`` (default:
the last two actuated joints), ``home`` (joint name -> rad; planned automatically when
absent), ``locked_joints`` (name -> value, e.g. gripper fingers, removed with a reduced
model), ``limits`` (``velocity_fraction`` of the URDF velocity limits, ``velocity``
rad/s per joint, ``acceleration`` rad/s^2 and ``jerk`` rad/s^3, each one number for all
joints or a mapping joint -> value), ``collision`` (``ignore_links``: links whose geometry
is left out, e.g. a gripper the sensor replaces; ``ignore_pairs``: pairs of links never
checked against each other, ``[[link_a, link_b], ...]``, e.g. two links whose coarse meshes
meet where the links do not; ``srdf``: an SRDF, path or ``example-robot-data:<path>``, whose
``disable_collisions`` pairs are not checked; ``floor_z``: height of the floor in the world
frame [m]), ``accuracy`` (``encoder_resolution``
[rad], ``latency_s`` and ``jitter_s`` [s], ``mount_rotation`` [rad]: :class:`RobotAccuracy`,
for the accuracy budget), and ``package_dirs`` (folders for ``package://`` mesh paths, relative to
the YAML file).

Angles may be written as numbers or as simple expressions of pi: ``pi/2``, ``-pi``,
``3*pi/4``; a sensor ``rpy`` beyond ±2π is refused as degrees. An unknown key (a typo) is
refused with the known keys listed.

This module only reads and checks the file; joint and frame names are checked against the
URDF by :class:`fts_calib.robot.kinematics.Kinematics`.

The robot's URDF read into Pinocchio's model, with the checks a calibration needs of it.

A file that is not a URDF is named as such before Pinocchio parses it (its XML parser
prints to the terminal), and a robot with fewer than the two joints a sweep turns is
refused, naming the joints it has.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from ..core import arrays as validation
from ..core.arrays import as_matrix, frozen
from ..core.bounded import read_bounded
from ..core.exceptions import ConfigError, FileFormatError, FrameNotFound, JointError
from ..core.files import check_keys, fields_of, load_yaml, read_number, require
from ..core.resources import example_robot_data_dir, locate

#: How far the sensor frame may be from its parent frame, in [m]: an adapter plate or a tool changer
#: puts it centimetres away; a metre is none of them, and a mount written in mm (35 for 0.035) is 35 m.
MAX_MOUNT_OFFSET = 1.0

#: What a URDF given as the robot file is told.
URDF_GIVEN = (
    "is a URDF, not a robot file: write a robot YAML that names it (urdf: PATH) and says where the sensor is mounted "
    "(sensor: parent_frame, xyz, rpy; docs/formats.md), or from Python use Kinematics.from_urdf(PATH, parent_frame=...)"
)

#: Prefix of URDF paths inside the example-robot-data package.
ROBOT_DATA_PREFIX = "example-robot-data:"

#: Defaults of the motion limits: conservative for a calibration sweep with a tool on.
DEFAULT_VELOCITY_FRACTION = 0.5
DEFAULT_ACCELERATION = 2.0  # [rad/s^2]
DEFAULT_JERK = 15.0  # [rad/s^3]

#: The keys of a robot definition and of its sections (any other is refused: a typo is never ignored).
ROBOT_KEYS = ("name", "urdf", "sensor", "sweep_joints", "home", "locked_joints", "limits", "collision", "package_dirs", "accuracy")
ACCURACY_KEYS = ("encoder_resolution", "latency_s", "jitter_s", "mount_rotation")
SENSOR_KEYS = ("parent_frame", "xyz", "rpy", "name")
COLLISION_KEYS = ("ignore_links", "ignore_pairs", "srdf", "floor_z")
LIMIT_KEYS = ("velocity_fraction", "velocity", "acceleration", "jerk")

_PI_EXPR = re.compile(r"^\s*([+-])?\s*(?:(\d+(?:\.\d*)?)\s*\*\s*)?pi\s*(?:/\s*(\d+(?:\.\d*)?))?\s*$")


def parse_angle(value: Any, path: str | Path, field_name: str) -> float:
    """A number, or an expression ``[-][k*]pi[/n]``, as a float in [rad].

    Raises:
        FileFormatError: Anything else; names the field.
    """
    if isinstance(value, bool):
        raise FileFormatError(path, field_name, f"expected an angle in rad, got {value!r}")
    if isinstance(value, (int, float)):
        number = float(value)
    elif isinstance(value, str) and (match := _PI_EXPR.match(value)):
        sign, factor, divisor = match.groups()
        number = (-1.0 if sign == "-" else 1.0) * float(factor or 1.0) * math.pi / float(divisor or 1.0)
    else:
        try:
            number = float(value)
        except (TypeError, ValueError):
            raise FileFormatError(path, field_name, f"expected an angle in rad (a number or e.g. 'pi/2'), got {value!r}") from None
    if not math.isfinite(number):
        raise FileFormatError(path, field_name, f"is {number} but expected a finite angle")
    return number


@dataclass(frozen=True)
class SensorMount:
    """Where the sensor frame S sits on the robot.

    Attributes:
        parent_frame: URDF frame the sensor is attached to.
        xyz: Origin of S in the parent frame, in [m]. Shape (3,).
        rpy: Roll, pitch, yaw from the parent frame to S (URDF convention), in [rad]. Shape (3,).
        name: Name given to the sensor frame in the model.
    """

    parent_frame: str
    xyz: np.ndarray
    rpy: np.ndarray
    name: str = "ft_sensor"

    def __post_init__(self):
        owner = f"sensor mount on '{self.parent_frame}'"
        object.__setattr__(self, "xyz", frozen(validation.finite_array("xyz", as_matrix(self.xyz, (3,), "xyz"), owner)))
        if np.linalg.norm(self.xyz) > MAX_MOUNT_OFFSET:  # a sensor sits on its frame, centimetres away: these are mm
            reason = f"is {self.xyz.tolist()} m from the frame: it looks like mm; write metres, e.g. {(self.xyz / 1000).tolist()}"
            raise ConfigError("xyz", self.xyz.tolist(), f"an offset within {MAX_MOUNT_OFFSET:g} m", "m", owner, reason=reason)
        rpy = validation.finite_array("rpy", as_matrix(self.rpy, (3,), "rpy"), owner)
        if np.any(np.abs(rpy) > 2 * math.pi + 1e-9):  # no mount needs more than a turn: these are degrees
            reason = (
                f"is {rpy.tolist()} rad, beyond ±2π: it looks like degrees; write the angles in rad, "
                f"e.g. {[round(float(a), 4) for a in np.radians(rpy)]} or pi/2"
            )
            raise ConfigError("rpy", rpy.tolist(), "angles in rad within ±2π", "rad", owner, reason=reason)
        object.__setattr__(self, "rpy", frozen(rpy))


@dataclass(frozen=True)
class LimitSpec:
    """Motion limits as written in the robot definition (resolved against the URDF later).

    Attributes:
        velocity_fraction: Fraction of the URDF velocity limit, in (0, 1].
        velocity: Per-joint velocity limits in [rad/s] (override the fraction).
        acceleration: Per-joint limits in [rad/s^2]; key ``"*"`` applies to all joints.
        jerk: Per-joint limits in [rad/s^3]; key ``"*"`` applies to all joints.
    """

    velocity_fraction: float = DEFAULT_VELOCITY_FRACTION
    velocity: Mapping[str, float] = field(default_factory=dict)
    acceleration: Mapping[str, float] = field(default_factory=lambda: {"*": DEFAULT_ACCELERATION})
    jerk: Mapping[str, float] = field(default_factory=lambda: {"*": DEFAULT_JERK})

    def __post_init__(self):
        fraction = validation.positive("velocity_fraction", self.velocity_fraction, owner="limits")
        if fraction > 1.0:
            raise ConfigError("velocity_fraction", fraction, "a fraction in (0, 1]", owner="limits")
        object.__setattr__(self, "velocity_fraction", fraction)
        if "*" in self.velocity:
            reason = "must map joint -> rad/s (use velocity_fraction for all joints)"
            raise ConfigError("velocity", dict(self.velocity), "a mapping joint -> rad/s", owner="limits", reason=reason)
        for name in ("velocity", "acceleration", "jerk"):
            per_joint = {
                str(joint): validation.positive(name if joint == "*" else f"{name}.{joint}", value, owner="limits")
                for joint, value in getattr(self, name).items()
            }
            object.__setattr__(self, name, per_joint)


@dataclass(frozen=True)
class RobotAccuracy:
    """How well the robot knows where the sensor is, for the accuracy budget (section ``accuracy``).

    Attributes:
        encoder_resolution: Step of a joint reading, in [rad] (default 2π/2^20: a 20-bit
            encoder per turn); the error of a reading is uniform within +- half a step.
        latency_s: Bound of the error of the constant latency between the joint and
            channel streams after ``live.latency_s`` is applied, in [s] (uniform +-).
        jitter_s: Standard deviation of the timing error of each sample, in [s].
        mount_rotation: Bound of the sensor mount's rotation error about each axis of S,
            in [rad] (uniform +-; default 2e-4 rad, 0.011°: a dowel-pinned flange).
    """

    encoder_resolution: float = 2.0 * math.pi / 2**20
    latency_s: float = 0.002
    jitter_s: float = 0.001
    mount_rotation: float = 2.0e-4

    def __post_init__(self):
        for name, unit in (("encoder_resolution", "rad"), ("latency_s", "s"), ("jitter_s", "s"), ("mount_rotation", "rad")):
            object.__setattr__(self, name, validation.non_negative(f"accuracy.{name}", getattr(self, name), unit))


@dataclass(frozen=True)
class RobotDefinition:
    """A robot definition file, checked for form (see the module docstring).

    Attributes:
        name: Robot name.
        urdf: Resolved path of the URDF file.
        urdf_spec: The ``urdf`` field as written (e.g. 'example-robot-data:ur_description/...').
        sensor: The sensor mount.
        sweep_joints: The two joints to sweep, or None for the last two actuated joints.
        home: Base pose, joint name -> [rad], or None to plan one.
        locked_joints: Joints removed from the model, name -> value [rad or m].
        limits: Motion limits.
        ignore_links: Links whose collision geometry is left out.
        ignore_pairs: Pairs of links never checked against each other, as written in
            ``collision.ignore_pairs`` (their names are checked against the URDF's links).
        allowed_pairs: Pairs of links never checked against each other (from the SRDF's
            ``disable_collisions``: adjacent links, or links that never meet).
        floor_z: Height of the floor in the world frame, in [m].
        package_dirs: Folders searched for ``package://`` mesh paths.
        source: The YAML file, or None.
        accuracy: Encoder resolution, stream timing and mount tolerance (accuracy budget).
    """

    name: str
    urdf: Path
    sensor: SensorMount
    urdf_spec: str = ""
    sweep_joints: tuple[str, str] | None = None
    home: Mapping[str, float] | None = None
    locked_joints: Mapping[str, float] = field(default_factory=dict)
    limits: LimitSpec = field(default_factory=LimitSpec)
    ignore_links: tuple[str, ...] = ()
    ignore_pairs: tuple[tuple[str, str], ...] = ()
    allowed_pairs: frozenset[frozenset[str]] = frozenset()
    floor_z: float = 0.0
    package_dirs: tuple[Path, ...] = ()
    source: Path | None = None
    accuracy: RobotAccuracy = field(default_factory=RobotAccuracy)

    def where(self, field_name: str) -> str:
        """Where a field was written, for a message: ``FILE: field 'NAME'`` ('' for a definition built in Python)."""
        return f"{self.source}: field '{field_name}'" if self.source is not None else ""

    def __post_init__(self):
        owner = f"robot '{self.name}'"
        sweep = self.sweep_joints
        if sweep is not None:
            if len(sweep) != 2 or not all(isinstance(j, str) for j in sweep) or sweep[0] == sweep[1]:
                raise ConfigError("sweep_joints", sweep, "two different joint names", owner=owner)
            object.__setattr__(self, "sweep_joints", (sweep[0], sweep[1]))
        if self.home is not None:
            object.__setattr__(self, "home", {str(j): validation.number(f"home.{j}", v, "rad", owner) for j, v in self.home.items()})
        locked = {str(j): validation.number(f"locked_joints.{j}", v, owner=owner) for j, v in self.locked_joints.items()}
        object.__setattr__(self, "locked_joints", locked)
        object.__setattr__(self, "floor_z", validation.number("floor_z", self.floor_z, "m", owner))
        pairs = []
        for k, pair in enumerate(self.ignore_pairs):
            if isinstance(pair, str) or len(pair) != 2 or not all(isinstance(n, str) for n in pair) or pair[0] == pair[1]:
                raise ConfigError(f"ignore_pairs[{k}]", pair, "a pair of two different link names, e.g. [link_a, link_b]", owner=owner)
            pairs.append((pair[0], pair[1]))
        object.__setattr__(self, "ignore_pairs", tuple(pairs))

    @property
    def skipped_pairs(self) -> frozenset[frozenset[str]]:
        """Every pair of links never checked: the SRDF's ``disable_collisions`` and ``collision.ignore_pairs``."""
        return self.allowed_pairs | frozenset(frozenset(pair) for pair in self.ignore_pairs)


def resolve_urdf(spec: str, base: Path, path: Path) -> tuple[Path, tuple[Path, ...]]:
    """The URDF file of a ``urdf`` field, and the package folders its meshes need.

    Raises:
        FileFormatError: The file does not exist (the message gives the resolved path).
    """
    package_dirs: tuple[Path, ...] = ()
    if spec.startswith(ROBOT_DATA_PREFIX):
        data_dir = example_robot_data_dir()
        urdf = data_dir / "robots" / spec[len(ROBOT_DATA_PREFIX) :].lstrip("/")
        package_dirs = (data_dir.parent,)  # meshes are package://example-robot-data/robots/...
    else:
        urdf = (base / spec).resolve() if not Path(spec).is_absolute() else Path(spec)
    if not urdf.is_file():
        raise FileFormatError(path, "urdf", f"'{spec}' resolves to {urdf}, which does not exist")
    return urdf, package_dirs


def read_srdf_pairs(spec: str, base: Path, path: Path) -> frozenset[frozenset[str]]:
    """Link pairs of an SRDF's ``disable_collisions`` entries.

    Raises:
        FileFormatError: The SRDF does not exist or is not valid XML.
    """
    import xml.etree.ElementTree as ET

    if spec.startswith(ROBOT_DATA_PREFIX):
        srdf = example_robot_data_dir() / "robots" / spec[len(ROBOT_DATA_PREFIX) :].lstrip("/")
    else:
        srdf = (base / spec).resolve()
    if not srdf.is_file():
        raise FileFormatError(path, "collision.srdf", f"'{spec}' resolves to {srdf}, which does not exist")
    try:
        root = ET.parse(srdf).getroot()
    except ET.ParseError as exc:
        raise FileFormatError(path, "collision.srdf", f"{srdf} is not valid XML: {exc}") from None
    pairs = ((e.get("link1"), e.get("link2")) for e in root.iter("disable_collisions"))
    # an entry missing a link names no pair of links, so it could never match one: leave it out
    return frozenset(frozenset((a, b)) for a, b in pairs if a is not None and b is not None)


def _mapping(value: Any, path: Path, field_name: str) -> Mapping[str, Any]:
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise FileFormatError(path, field_name, f"expected a mapping joint -> value, got {value!r}")
    return value


def _per_joint(value: Any, path: Path, field_name: str, default: float | None) -> dict[str, float]:
    """One number for all joints (key ``"*"``) or a mapping joint -> number; LimitSpec checks the values."""
    if value is None:
        return {} if default is None else {"*": default}
    items = value.items() if isinstance(value, Mapping) else [("*", value)]
    out = {}
    for joint, raw in items:
        out[str(joint)] = read_number(raw, path, f"{field_name}.{joint}" if joint != "*" else field_name)
    return out


def _read_limits(raw: Any, path: Path) -> LimitSpec:
    raw = _mapping(raw, path, "limits")
    check_keys(raw, LIMIT_KEYS, path, "limits")
    fraction = raw.get("velocity_fraction", DEFAULT_VELOCITY_FRACTION)
    with fields_of(path, "limits."):
        return LimitSpec(
            velocity_fraction=read_number(fraction, path, "limits.velocity_fraction"),
            velocity=_per_joint(raw.get("velocity"), path, "limits.velocity", None),
            acceleration=_per_joint(raw.get("acceleration"), path, "limits.acceleration", DEFAULT_ACCELERATION),
            jerk=_per_joint(raw.get("jerk"), path, "limits.jerk", DEFAULT_JERK),
        )


def _link_pairs(raw: Any, path: Path) -> tuple[tuple[str, str], ...]:
    """``collision.ignore_pairs``: a list of pairs of two different link names.

    Raises:
        FileFormatError: Anything else; names the file, the field and the entry at fault.
    """
    if raw is None:
        return ()
    example = "e.g. [[link04, link06]]"
    if not isinstance(raw, list):
        raise FileFormatError(path, "collision.ignore_pairs", f"expected a list of pairs of link names ({example}), got {raw!r}")
    pairs = []
    for k, pair in enumerate(raw):
        if not isinstance(pair, list) or len(pair) != 2 or not all(isinstance(n, str) for n in pair):
            raise FileFormatError(path, f"collision.ignore_pairs[{k}]", f"expected a pair of two link names ({example}), got {pair!r}")
        if pair[0] == pair[1]:
            raise FileFormatError(path, f"collision.ignore_pairs[{k}]", f"names '{pair[0]}' twice: expected two different links")
        pairs.append((pair[0], pair[1]))
    return tuple(pairs)


def _angles(raw: Any, path: Path, field_name: str) -> dict[str, float]:
    return {str(k): parse_angle(v, path, f"{field_name}.{k}") for k, v in _mapping(raw, path, field_name).items()}


def _vector3(raw: Any, path: Path, field_name: str, angles: bool) -> np.ndarray:
    if not isinstance(raw, (list, tuple)) or len(raw) != 3:
        raise FileFormatError(path, field_name, f"expected 3 numbers, got {raw!r}")
    if angles:
        return np.array([parse_angle(v, path, f"{field_name}[{i}]") for i, v in enumerate(raw)])
    try:
        return np.array([float(v) for v in raw])  # finite: SensorMount checks
    except (TypeError, ValueError):
        raise FileFormatError(path, field_name, f"expected 3 numbers in m, got {raw!r}") from None


def load_robot(path: str | Path) -> RobotDefinition:
    """Read and check a robot definition file (see the module docstring).

    Args:
        path: The YAML file, or the name of a shipped robot (``"ur5"``: ``robots/ur5.yaml``,
            as ``--robot ur5`` on the command line).

    Raises:
        ResourceNotFound: A bare name that is neither a file nor a shipped robot (lists them).
        FileFormatError: A missing, unknown or malformed field (a sensor ``rpy`` in degrees),
            or a URDF that does not exist; the message names the file and the field. A URDF
            given in place of the robot file.
        RobotDataNotFound: The URDF is in example-robot-data, which is not installed.
    """
    path = locate(path, "robots")
    if path.suffix.lower() in (".urdf", ".xacro"):  # not "not valid YAML at line 310": say what the robot file is
        raise FileFormatError(path, None, URDF_GIVEN)
    data = load_yaml(path)
    check_keys(data, ROBOT_KEYS, path)
    base = path.resolve().parent
    urdf_spec = str(require(data, "urdf", path))
    urdf, package_dirs = resolve_urdf(urdf_spec, base, path)
    sensor_raw = require(data, "sensor", path)
    if not isinstance(sensor_raw, Mapping):
        raise FileFormatError(path, "sensor", "expected a mapping with parent_frame, xyz and rpy")
    check_keys(sensor_raw, SENSOR_KEYS, path, "sensor")
    parent_frame = str(require(sensor_raw, "parent_frame", path, "sensor."))
    xyz = _vector3(sensor_raw.get("xyz", [0, 0, 0]), path, "sensor.xyz", angles=False)
    rpy = _vector3(sensor_raw.get("rpy", [0, 0, 0]), path, "sensor.rpy", angles=True)
    with fields_of(path, "sensor."):
        sensor = SensorMount(parent_frame=parent_frame, xyz=xyz, rpy=rpy, name=str(sensor_raw.get("name", "ft_sensor")))
    sweep = data.get("sweep_joints")
    if sweep is not None:
        if not isinstance(sweep, list) or len(sweep) != 2 or not all(isinstance(j, str) for j in sweep) or sweep[0] == sweep[1]:
            raise FileFormatError(path, "sweep_joints", f"expected two different joint names, got {sweep!r}")
        sweep = (sweep[0], sweep[1])
    home = _angles(data["home"], path, "home") if data.get("home") is not None else None
    collision = _mapping(data.get("collision"), path, "collision")
    check_keys(collision, COLLISION_KEYS, path, "collision")
    ignore = collision.get("ignore_links") or []
    if not isinstance(ignore, list):
        raise FileFormatError(path, "collision.ignore_links", f"expected a list of link names, got {ignore!r}")
    pairs = _link_pairs(collision.get("ignore_pairs"), path)
    floor_z = read_number(collision.get("floor_z", 0.0), path, "collision.floor_z", "m")
    srdf = collision.get("srdf")
    allowed = read_srdf_pairs(str(srdf), base, path) if srdf else frozenset()
    extra_dirs = tuple((base / p).resolve() for p in (data.get("package_dirs") or []))
    name = str(require(data, "name", path))
    locked = _angles(data.get("locked_joints"), path, "locked_joints")
    limits = _read_limits(data.get("limits"), path)
    raw_accuracy = data.get("accuracy") or {}
    if not isinstance(raw_accuracy, Mapping):
        raise FileFormatError(path, "accuracy", f"expected a mapping of {', '.join(ACCURACY_KEYS)}, got {raw_accuracy!r}")
    check_keys(raw_accuracy, ACCURACY_KEYS, path, "accuracy")
    with fields_of(path):
        accuracy = RobotAccuracy(**{k: read_number(v, path, f"accuracy.{k}") for k, v in raw_accuracy.items()})
    with fields_of(path, "", {"floor_z": "collision.floor_z"}):
        return RobotDefinition(
            name=name,
            urdf=urdf,
            sensor=sensor,
            urdf_spec=urdf_spec,
            sweep_joints=sweep,
            home=home,
            locked_joints=locked,
            limits=limits,
            ignore_links=tuple(str(x) for x in ignore),
            ignore_pairs=pairs,
            allowed_pairs=allowed,
            floor_z=floor_z,
            package_dirs=package_dirs + extra_dirs + (urdf.parent,),
            source=path,
            accuracy=accuracy,
        )


def build_model(robot: RobotDefinition) -> pin.Model:
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


#: The frame types a sensor's parent frame is looked up as, in order: a URDF link first, then a joint's
#: frame (a URDF may name a link and a joint alike, the Unitree Z1's ``gripperStator``), then an added frame.
MOUNT_FRAME_TYPES = (pin.FrameType.BODY, pin.FrameType.JOINT, pin.FrameType.FIXED_JOINT, pin.FrameType.OP_FRAME, pin.FrameType.SENSOR)


def frame_id(model: pin.Model, name: str, types: tuple[pin.FrameType, ...], where: str = "", kind: str = "frame") -> int:
    """The id of frame ``name`` in ``model``: the first of ``types`` (in that order) that has a frame of that name.

    Always by type: a URDF link and a joint of one name are two frames of the model, and a
    lookup by name alone is ambiguous (Pinocchio's "Several frames match the filter").

    Args:
        model: The Pinocchio model.
        name: The frame's name.
        types: The frame types accepted, the preferred first.
        where: Where the name was written (``RobotDefinition.where(field)``), for the message.
        kind: What the name is, for the message: 'frame' or 'link'.

    Raises:
        FrameNotFound: No frame of these types has the name; the message names it, the file
            and field, the closest names and every frame of these types.
        ConfigError: Two frames of one type have the name (a model built in Python, never a URDF).
    """
    for frame_type in types:
        found = [k for k, frame in enumerate(model.frames) if frame.name == name and frame.type == frame_type]
        if len(found) == 1:
            return found[0]
        if found:
            reason = f"names {len(found)} frames of type {frame_type.name} (ids {found}): expected one"
            raise ConfigError(where or kind, name, f"the name of one {kind}", reason=reason)
    raise FrameNotFound(name, [f.name for f in model.frames if f.type in types], where, kind)


def link_frame_id(model: pin.Model, name: str, where: str = "") -> int:
    """The id of the frame of URDF link ``name`` (a ``BODY`` frame), never a joint's frame of the same name.

    Raises:
        FrameNotFound: No link has the name; the message lists the links and the closest names,
            and when the name is a joint's, the joint's child link.
    """
    body = pin.FrameType.BODY
    joints = [k for k, f in enumerate(model.frames) if f.name == name and f.type in (pin.FrameType.JOINT, pin.FrameType.FIXED_JOINT)]
    if joints and not any(f.name == name and f.type == body for f in model.frames):
        children = [f.name for f in model.frames if f.type == body and f.parentFrame in joints]
        note = f"'{name}' is a joint" + (f"; its child link is '{children[0]}'" if children else "")
        raise FrameNotFound(name, [f.name for f in model.frames if f.type == body], where, "link", note)
    return frame_id(model, name, (body,), where, "link")


def require_sweep_joints(robot: RobotDefinition, joint_names: tuple[str, ...]) -> None:
    """Refuse a robot with fewer than two actuated joints when the sweep joints are not named.

    Args:
        robot: The robot definition (its ``sweep_joints``, None for the last two).
        joint_names: The model's actuated joints, in order.

    Raises:
        JointError: Fewer than two actuated joints; the message names them.
    """
    if robot.sweep_joints is None and len(joint_names) < 2:  # the sweeps turn two joints: the last two by default
        found = ", ".join(f"'{name}'" for name in joint_names) or "none"
        message = (
            f"{robot.urdf} has {len(joint_names)} actuated joint(s) ({found}) but a calibration sweeps two "
            "(the last two actuated joints, or the robot file's sweep_joints)"
        )
        raise JointError(message, list(joint_names), [])

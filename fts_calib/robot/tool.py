r"""Wrench that a rigid tool exerts on the sensor, static (paper eqs 17-18) and moving.

Everything is expressed in the sensor frame S; the moment is about the origin of S; a
wrench is ``[Fx, Fy, Fz, Mx, My, Mz]`` in [N] and [N m].

Static (eqs 17-18), with ``g_sensor = R_world_sensor.T @ g_world``:

.. math::

    F = m\,g_S, \qquad M = c \times F

Moving (Newton-Euler on the tool body): with ``omega`` and ``alpha`` the angular velocity
and acceleration of S in the world, expressed in S, ``a`` the classical linear
acceleration of the origin of S expressed in S, and ``I_c`` the inertia about the centre
of mass in S,

.. math::

    a_c = a + \alpha \times c + \omega \times (\omega \times c), \qquad
    F = m\,(g_S - a_c), \qquad M = c \times F - (I_c\,\alpha + \omega \times I_c\,\omega)

At rest (omega = alpha = a = 0) the moving wrench equals the static one.

Calibration tools: configurations of known mass and centre of mass, and their wrench.

A tool file (YAML, ``configs/``) holds ``name``, optional ``gravity`` (magnitude in
[m/s^2], default 9.81) and ``configurations``: a list of ``{name, mass [kg], com [x, y, z]
[m, in the sensor frame S], inertia (optional 3x3 about the centre of mass, axes of S,
[kg m^2])}``, and optional ``shape`` ``{radius, length}`` [m]: the envelope used for
collision checks, a cylinder along X of S from the sensor out (default: around the
centres of mass), and optional ``tolerance`` ``{mass [kg], com [m], per_configuration: {mass
[kg], com [m]}}``: how well the tool is known, for the accuracy budget and the fit check
(:class:`ToolTolerance`: a part common to every configuration and one of each configuration's own;
without ``per_configuration`` each configuration's own part is bounded like the common one).
Any other key (a typo such as ``mas``) is refused with the known keys.

One quantity, two spellings, one rule: a file's keys are short because a tool file is in S
throughout (``com``, ``inertia``); in code the frame is in the name, as everywhere in
fts-calib (:attr:`ToolConfiguration.p_sensor_com`, ``inertia_com``). The loader maps
``com`` -> ``p_sensor_com`` and ``inertia`` -> ``inertia_com``, and an error about the
Python field names the file's key.

Identifiability (paper eqs 18-20): one centre of mass gives the estimator rank 4, two
give 6, and the full rank 7 needs three centres of mass that are not on one line.

The tool's wrench on the sensor along a motion: the one function every stage calls.

Session, simulation, validation, tare, demo and planning all get the calibration tool's
load from :func:`tool_load`: forward kinematics once (:class:`Kinematics`, the only forward
kinematics), gravity in the sensor frame, then the static wrench of each sample's tool
configuration (paper eqs 17-18) and, when joint rates are given, the Newton-Euler wrench of
the moving tool (:mod:`fts_calib.robot.tool`).

Frames and units: everything in the sensor frame S, moment about the origin of S;
``g_sensor = R_world_sensor.T @ g_world`` with ``|g_world|`` the tool file's gravity.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..core import arrays as validation
from ..core.arrays import as_matrix, as_samples, cross, frozen
from ..core.exceptions import ConfigError, FileFormatError, FtsCalibWarning, ShapeError, UnknownToolConfiguration
from ..core.files import atomic_write_text, check_keys, dump_yaml, fields_of, load_yaml, read_array, read_number, require
from ..core.resources import locate

if TYPE_CHECKING:  # the in-controller path (a tool for gravity compensation) loads no Pinocchio
    from .kinematics import Kinematics, SensorMotion


def wrench_matrix(mass: float, p_sensor_com) -> np.ndarray:
    """The (6, 3) matrix ``[m I; m [c]x]`` of eqs 17-18: ``W = wrench_matrix @ g_sensor``.

    Args:
        mass: Tool mass in [kg].
        p_sensor_com: Centre of mass of the tool in the sensor frame, in [m]. Shape (3,).
    """
    import pinocchio as pin  # here, not at the top: the in-controller path (service.reader) imports this module

    c = as_matrix(p_sensor_com, (3,), "p_sensor_com")
    return mass * np.vstack([np.eye(3), pin.skew(c)])


def apply_wrench_matrix(matrix: np.ndarray, g_sensor) -> np.ndarray:
    """``matrix @ g`` for one gravity vector (3,) or a batch (N, 3); shape (6,) or (N, 6)."""
    g = np.asarray(g_sensor, dtype=float)
    if g.shape == (3,):
        return matrix.dot(g)
    g, _ = as_samples(g, 3, "g_sensor")
    return g @ matrix.T


def static_wrench(mass: float, p_sensor_com, g_sensor) -> np.ndarray:
    """Wrench of a tool at rest on the sensor (paper eqs 17-18).

    Args:
        mass: Tool mass in [kg].
        p_sensor_com: Centre of mass of the tool in the sensor frame, in [m]. Shape (3,).
        g_sensor: Gravity in the sensor frame, in [m/s^2]. Shape (3,) or (N, 3).

    Returns:
        ``[F, c x F]`` in [N, N m]. Shape (6,) or (N, 6).
    """
    return apply_wrench_matrix(wrench_matrix(mass, p_sensor_com), g_sensor)


def dynamic_wrench(mass: float, p_sensor_com, inertia_com, g_sensor, omega_sensor, alpha_sensor, a_sensor) -> np.ndarray:
    """Wrench of a moving rigid tool on the sensor (Newton-Euler, see module docstring).

    Args:
        mass: Tool mass in [kg].
        p_sensor_com: Centre of mass in the sensor frame, in [m]. Shape (3,).
        inertia_com: Inertia about the centre of mass, axes of S, in [kg m^2]. Shape (3, 3).
        g_sensor: Gravity in S, in [m/s^2]. Shape (3,) or (N, 3).
        omega_sensor: Angular velocity of S, in S, in [rad/s]. Shape (3,) or (N, 3).
        alpha_sensor: Angular acceleration of S, in S, in [rad/s^2]. Shape (3,) or (N, 3).
        a_sensor: Classical linear acceleration of the origin of S, in S, in [m/s^2].
            Shape (3,) or (N, 3).

    Returns:
        ``[Fx, Fy, Fz, Mx, My, Mz]`` in [N, N m]. Shape (6,) or (N, 6).
    """
    c = as_matrix(p_sensor_com, (3,), "p_sensor_com")
    inertia = as_matrix(inertia_com, (3, 3), "inertia_com")
    g, single = as_samples(g_sensor, 3, "g_sensor")
    omega, _ = as_samples(omega_sensor, 3, "omega_sensor")
    al, _ = as_samples(alpha_sensor, 3, "alpha_sensor")
    a, _ = as_samples(a_sensor, 3, "a_sensor")
    a_com = a + cross(al, c) + cross(omega, cross(omega, c))
    force = mass * (g - a_com)
    torque = cross(c, force) - (al @ inertia.T + cross(omega, omega @ inertia.T))
    out = np.concatenate([force, torque], axis=1)
    return out[0] if single and out.shape[0] == 1 else out


#: Default magnitude of gravity in [m/s^2].
STANDARD_GRAVITY = 9.81

#: The keys of a tool file, of one of its configurations and of its shape (any other is refused).
TOOL_KEYS = ("name", "gravity", "shape", "configurations", "tolerance")
CONFIGURATION_KEYS = ("name", "mass", "com", "inertia")
SHAPE_KEYS = ("radius", "length")
TOLERANCE_KEYS = ("mass", "com", "per_configuration")
PER_CONFIGURATION_KEYS = ("mass", "com")


@dataclass(frozen=True)
class ToolTolerance:
    """How well the tool is known: bounds of its errors, +- each value, in two parts.

    A configuration's true mass is ``m_c + dm + dm_c`` and its true centre of mass
    ``c_c + dc + dc_c``: ``dm`` and ``dc`` (3,) are common to every configuration (one weight
    moved between positions, weighed once), ``dm_c`` and ``dc_c`` are each configuration's own
    (positions machined one by one); every error is uniform within +- its bound, per coordinate
    for the centre of mass. A fit absorbs most of a common error (a common centre-of-mass error
    is ``dW = A W``, absorbed by C_bar) and little of a configuration's own one, which stays in
    the residual: the fit check expects it, the budget holds both.

    Attributes:
        mass: Bound of the common mass error ``dm``, in [kg] (>= 0).
        com: Bound of the common error of each coordinate of the centre of mass ``dc``, in [m] (>= 0).
        own_mass: Bound of each configuration's own mass error ``dm_c``, in [kg] (>= 0), or None
            when the file does not say (a tool file without ``per_configuration``): then it is
            ``mass``, which covers any way the errors are drawn within +- ``mass`` per
            configuration, common, one by one or both (the conservative reading).
        own_com: Bound of each configuration's own error of each coordinate of the centre of
            mass ``dc_c``, in [m] (>= 0), or None: then it is ``com`` (as ``own_mass``).
    """

    mass: float = 0.0
    com: float = 0.0
    own_mass: float | None = None
    own_com: float | None = None

    def __post_init__(self):
        object.__setattr__(self, "mass", validation.non_negative("tolerance.mass", self.mass, "kg"))
        object.__setattr__(self, "com", validation.non_negative("tolerance.com", self.com, "m"))
        for name, key, unit in (("own_mass", "mass", "kg"), ("own_com", "com", "m")):
            if getattr(self, name) is not None:
                value = validation.non_negative(f"tolerance.per_configuration.{key}", getattr(self, name), unit)
                object.__setattr__(self, name, value)

    @property
    def configuration_mass(self) -> float:
        """Bound of each configuration's own mass error [kg] (``own_mass``, or ``mass`` when not stated)."""
        return self.mass if self.own_mass is None else self.own_mass

    @property
    def configuration_com(self) -> float:
        """Bound of each configuration's own error per coordinate of the centre of mass [m] (``own_com``, or ``com``)."""
        return self.com if self.own_com is None else self.own_com

    @property
    def total_mass(self) -> float:
        """Bound of a configuration's whole mass error, common and own [kg]."""
        return self.mass + self.configuration_mass

    @property
    def total_com(self) -> float:
        """Bound of a configuration's whole error per coordinate of the centre of mass, common and own [m]."""
        return self.com + self.configuration_com


@dataclass(frozen=True)
class ToolConfiguration:
    """One mounting of the calibration tool.

    Attributes:
        name: Configuration name (e.g. 'A'), as written in recordings.
        mass: Mass in [kg], > 0.
        p_sensor_com: Centre of mass in the sensor frame, in [m]. Shape (3,).
        inertia_com: Inertia about the centre of mass, axes of S, in [kg m^2]. Shape (3, 3),
            or None when unknown (then only the static wrench is available).
    """

    name: str
    mass: float
    p_sensor_com: np.ndarray
    inertia_com: np.ndarray | None = None

    def __post_init__(self):
        owner = f"configuration '{self.name}'"
        object.__setattr__(self, "mass", validation.positive("mass", self.mass, "kg", owner))
        com = validation.finite_array("p_sensor_com", as_matrix(self.p_sensor_com, (3,), "p_sensor_com"), owner)
        object.__setattr__(self, "p_sensor_com", frozen(com))
        if self.inertia_com is not None:
            inertia = validation.finite_array("inertia_com", as_matrix(self.inertia_com, (3, 3), "inertia_com"), owner)
            if not np.allclose(inertia, inertia.T, rtol=1e-9, atol=1e-12):
                raise ConfigError("inertia_com", inertia.tolist(), "a symmetric matrix", "kg·m²", owner, reason="is not symmetric")
            eig = np.linalg.eigvalsh(inertia)
            if eig[0] < 0 or eig[2] > eig[0] + eig[1] + 1e-12:
                moments = eig.round(6).tolist()
                reason = f"has principal moments {moments} kg·m², which are not physical (>= 0, triangle inequality)"
                raise ConfigError("inertia_com", moments, "physical principal moments", "kg·m²", owner, reason=reason)
            object.__setattr__(self, "inertia_com", frozen(inertia))
        # eqs 17-18 are linear in g: W = [m I; m [c]x] g, one product per sample
        object.__setattr__(self, "wrench_matrix", frozen(wrench_matrix(self.mass, self.p_sensor_com)))

    #: ``[m I; m [c]x]``, the (6, 3) matrix with ``W = wrench_matrix @ g_sensor`` (eqs 17-18).
    wrench_matrix: np.ndarray = field(init=False, repr=False)

    def static_wrench(self, g_sensor) -> np.ndarray:
        """Wrench at rest (eqs 17-18), ``[m g, c x m g]`` in [N, N m].

        Args:
            g_sensor: Gravity in the sensor frame, [m/s^2]. Shape (3,) or (N, 3).

        Returns:
            Shape (6,) or (N, 6).
        """
        return apply_wrench_matrix(self.wrench_matrix, g_sensor)

    def dynamic_wrench(self, g_sensor, omega_sensor, alpha_sensor, a_sensor) -> np.ndarray:
        """Wrench of the moving tool (Newton-Euler); see :func:`fts_calib.robot.tool.dynamic_wrench`.

        Without inertia the tool is treated as a point mass at its centre of mass.

        Args:
            g_sensor: Gravity in S, [m/s^2]. Shape (3,) or (N, 3).
            omega_sensor: Angular velocity of S in S, [rad/s]. Shape (3,) or (N, 3).
            alpha_sensor: Angular acceleration of S in S, [rad/s^2]. Shape (3,) or (N, 3).
            a_sensor: Classical acceleration of the origin of S in S, [m/s^2]. Shape (3,) or (N, 3).
        """
        inertia = np.zeros((3, 3)) if self.inertia_com is None else self.inertia_com
        return dynamic_wrench(self.mass, self.p_sensor_com, inertia, g_sensor, omega_sensor, alpha_sensor, a_sensor)


@dataclass(frozen=True)
class ToolShape:
    """The tool's envelope for collision checks: a cylinder along X of S, from the sensor out.

    Attributes:
        radius: Cylinder radius in [m].
        length: Cylinder length from the origin of S along +X, in [m].
    """

    radius: float
    length: float

    def __post_init__(self):
        object.__setattr__(self, "radius", validation.positive("radius", self.radius, "m", "tool shape"))
        object.__setattr__(self, "length", validation.positive("length", self.length, "m", "tool shape"))


@dataclass(frozen=True)
class Tool:
    """A calibration tool and its configurations.

    Attributes:
        name: Tool name.
        gravity: Magnitude of gravity in [m/s^2] where the tool is used.
        configurations: The configurations, in file order.
        shape: Envelope for collision checks.
        source: The file it was read from, or None.
        tolerance: How well the masses and centres of mass are known, or None when the
            file does not say (the accuracy budget then has no tool terms, and says so).
    """

    name: str
    gravity: float
    configurations: tuple[ToolConfiguration, ...]
    shape: ToolShape | None = None
    source: Path | None = None
    tolerance: ToolTolerance | None = None

    def __post_init__(self):
        owner = f"tool '{self.name}'"
        object.__setattr__(self, "gravity", validation.positive("gravity", self.gravity, "m/s²", owner))
        object.__setattr__(self, "configurations", tuple(self.configurations))
        if not self.configurations:
            raise ConfigError("configurations", [], "at least one configuration", owner=owner)
        names = self.names
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise ConfigError("configurations", names, "unique names", owner=owner, reason=f"has duplicate names {duplicates}")
        if self.shape is None:
            object.__setattr__(self, "shape", default_shape(self.configurations))
        if self.tolerance is not None:  # how well the tool is known: an error of the mass's size is a unit slip
            lightest = min(self.configurations, key=lambda c: c.mass)
            farthest = max(float(np.linalg.norm(c.p_sensor_com)) for c in self.configurations)
            tolerance = self.tolerance
            for key, mass, com in (
                ("tolerance.", tolerance.mass, tolerance.com),
                ("tolerance.per_configuration.", tolerance.own_mass, tolerance.own_com),
            ):
                if mass is not None and mass >= lightest.mass:
                    reason = (
                        f"is {mass:g} kg, not below the mass of configuration {lightest.name} ({lightest.mass:g} kg): "
                        "expected how well the masses are known, in kg (0.2 g is 2.0e-4)"
                    )
                    raise ConfigError(f"{key}mass", mass, "", owner=owner, reason=reason)
                if com is not None and farthest > 0 and com >= farthest:
                    reason = (
                        f"is {com:g} m, not below the farthest centre of mass ({farthest:g} m from the sensor): "
                        "expected how well the centres of mass are known, in m (20 µm is 2.0e-5)"
                    )
                    raise ConfigError(f"{key}com", com, "", owner=owner, reason=reason)

    @property
    def names(self) -> list[str]:
        """Configuration names, in order."""
        return [c.name for c in self.configurations]

    def configuration(self, name: str) -> ToolConfiguration:
        """The configuration called ``name``.

        Raises:
            UnknownToolConfiguration: No such name; lists the names that exist.
        """
        for configuration in self.configurations:
            if configuration.name == name:
                return configuration
        raise UnknownToolConfiguration(name, self.names)

    def com_rank(self) -> int:
        """Affine rank of the centres of mass: 0 (one point), 1 (on a line) or 2 (a plane or more).

        The estimator's full rank 7 needs 2 (paper eqs 18-20).
        """
        coms = np.array([c.p_sensor_com for c in self.configurations])
        if len(coms) < 2:
            return 0
        return int(np.linalg.matrix_rank(coms[1:] - coms[0], tol=1e-6))


def default_shape(configurations: Sequence[ToolConfiguration]) -> ToolShape:
    """An envelope around every centre of mass.

    Length 1.3 x the farthest X, radius 1.3 x the farthest off-axis distance, at least 8 cm
    long and 4 cm in radius.
    """
    coms = np.array([c.p_sensor_com for c in configurations])
    length = max(0.08, 1.3 * float(np.max(np.abs(coms[:, 0]))))
    radius = max(0.04, 1.3 * float(np.max(np.linalg.norm(coms[:, 1:], axis=1))))
    return ToolShape(radius=radius, length=length)


def _read_configuration(raw: object, index: int, path: Path) -> ToolConfiguration:
    field = f"configurations[{index}]"
    if not isinstance(raw, Mapping):
        raise FileFormatError(path, field, "expected a mapping with name, mass and com")
    check_keys(raw, CONFIGURATION_KEYS, path, field)
    name = require(raw, "name", path, field + ".")
    mass = read_number(require(raw, "mass", path, field + "."), path, field + ".mass", "kg")
    com = read_array(require(raw, "com", path, field + "."), (3,), path, field + ".com")
    inertia = None if raw.get("inertia") is None else read_array(raw["inertia"], (3, 3), path, field + ".inertia")
    with fields_of(path, field + ".", {"p_sensor_com": "com", "inertia_com": "inertia"}):
        return ToolConfiguration(name=str(name), mass=mass, p_sensor_com=com, inertia_com=inertia)


def _section(data: Mapping, key: str, keys: Sequence[str], path: Path, expected: str, prefix: str = "") -> Mapping | None:
    """An optional sub-mapping of a tool file with only known keys, or None when absent (``prefix``: its parent's field)."""
    raw = data.get(key)
    if raw is None:
        return None
    if not isinstance(raw, Mapping):
        raise FileFormatError(path, prefix + key, f"expected {expected}")
    check_keys(raw, keys, path, prefix + key)
    return raw


def load_tool(path: str | Path) -> Tool:
    """Read a tool file (see the module docstring).

    Warns (:class:`FtsCalibWarning`) when the centres of mass are collinear: the
    calibration can then reach rank 6 at most.

    Args:
        path: The YAML file, or the name of a shipped tool (``"paper_tool"``:
            ``configs/paper_tool.yaml``, as ``--tool paper_tool`` on the command line).

    Raises:
        ResourceNotFound: A bare name that is neither a file nor a shipped tool (lists them).
        FileFormatError: A missing field, an unknown key (e.g. ``mas``: the known keys are
            listed), a non-positive mass, a wrong shape, a duplicate configuration name; the
            message names the file and the field.
    """
    path = locate(path, "configs", "tool")
    data = load_yaml(path)
    check_keys(data, TOOL_KEYS, path)
    name = str(require(data, "name", path))
    gravity = read_number(data.get("gravity", STANDARD_GRAVITY), path, "gravity", "m/s²")
    raw_configs = require(data, "configurations", path)
    if not isinstance(raw_configs, list) or not raw_configs:
        raise FileFormatError(path, "configurations", "expected a non-empty list")
    configs = tuple(_read_configuration(raw, i, path) for i, raw in enumerate(raw_configs))
    shape = None
    raw_shape = _section(data, "shape", SHAPE_KEYS, path, "{radius: m, length: m}")
    if raw_shape is not None:
        radius = read_number(require(raw_shape, "radius", path, "shape."), path, "shape.radius", "m")
        length = read_number(require(raw_shape, "length", path, "shape."), path, "shape.length", "m")
        with fields_of(path, "shape."):
            shape = ToolShape(radius=radius, length=length)
    tolerance = None
    raw_tolerance = _section(data, "tolerance", TOLERANCE_KEYS, path, "{mass: kg, com: m, per_configuration: {mass: kg, com: m}}")
    if raw_tolerance is not None:
        units = (("mass", "kg"), ("com", "m"))
        bounds = {k: read_number(raw_tolerance.get(k, 0.0), path, f"tolerance.{k}", u) for k, u in units}
        own = _section(raw_tolerance, "per_configuration", PER_CONFIGURATION_KEYS, path, "{mass: kg, com: m}", "tolerance.")
        if own is not None:  # stated: a part it leaves out is 0
            key = "tolerance.per_configuration."
            bounds.update({f"own_{k}": read_number(own.get(k, 0.0), path, f"{key}{k}", u) for k, u in units})
        with fields_of(path):
            tolerance = ToolTolerance(**bounds)
    with fields_of(path):
        tool = Tool(name=name, gravity=gravity, configurations=configs, shape=shape, source=path, tolerance=tolerance)
    names = tool.names
    if len(configs) >= 3 and tool.com_rank() < 2:
        warnings.warn(
            f"{path}: the centres of mass of {names} are collinear; the calibration can reach rank 6 at most "
            "(paper eqs 19-20). Move one configuration off the line.",
            FtsCalibWarning,
            stacklevel=2,
        )
    return tool


def save_tool(tool: Tool, path: str | Path, header: str = "") -> Path:
    """Write a tool file (the format :func:`load_tool` reads), atomically.

    Args:
        tool: The tool.
        path: Destination.
        header: Comment lines written first (e.g. the standard errors of an identified payload).
    """
    data: dict = {"name": tool.name, "gravity": tool.gravity}
    if tool.shape is not None:
        data["shape"] = {"radius": tool.shape.radius, "length": tool.shape.length}
    if tool.tolerance is not None:
        tolerance = tool.tolerance
        data["tolerance"] = {"mass": tolerance.mass, "com": tolerance.com}
        if tolerance.own_mass is not None or tolerance.own_com is not None:
            data["tolerance"]["per_configuration"] = {"mass": tolerance.configuration_mass, "com": tolerance.configuration_com}
    data["configurations"] = []
    for c in tool.configurations:
        entry = {"name": c.name, "mass": c.mass, "com": c.p_sensor_com.tolist()}
        if c.inertia_com is not None:
            entry["inertia"] = c.inertia_com.tolist()
        data["configurations"].append(entry)
    comments = "".join(f"# {line}\n" for line in header.splitlines())
    return atomic_write_text(path, comments + dump_yaml(data))


@dataclass(frozen=True)
class ToolLoad:
    """The tool's load on the sensor at each sample.

    Attributes:
        g_sensor: Gravity in S, in [m/s^2]. Shape (N, 3).
        static: The weight alone (eqs 17-18), ``[F, c x F]`` in [N, N m]. Shape (N, 6).
        moving: The Newton-Euler wrench of the moving tool in [N, N m], shape (N, 6), or
            None when no joint rates were given.
        motion: The sensor's motion the moving wrench comes from (N rows), or None.
    """

    g_sensor: np.ndarray
    static: np.ndarray
    moving: np.ndarray | None = None
    motion: SensorMotion | None = None

    @property
    def w_sensor(self) -> np.ndarray:
        """The best-known wrench: ``moving`` when computed, else ``static``. Shape (N, 6)."""
        return self.static if self.moving is None else self.moving


def tool_load(
    kin: Kinematics,
    tool: Tool,
    joints: np.ndarray,
    configuration: np.ndarray | int | str,
    joint_velocity: np.ndarray | None = None,
    joint_acceleration: np.ndarray | None = None,
) -> ToolLoad:
    """The calibration tool's wrench on the sensor at each sample of a motion.

    Args:
        kin: Kinematics of the robot.
        tool: The tool (its gravity, and the mass, centre of mass and inertia of each
            configuration).
        joints: Joint readings in [rad]. Shape (N, n_joints).
        configuration: Index of each sample's tool configuration, shape (N,) int (every
            index valid), or one index or name for all samples.
        joint_velocity: Joint velocities in [rad/s], shape (N, n_joints), with
            ``joint_acceleration`` in [rad/s^2]: the moving wrench is computed too. None for
            the static wrench alone.
        joint_acceleration: See ``joint_velocity``.

    Returns:
        :class:`ToolLoad` with arrays of N rows.

    Raises:
        ShapeError: The arrays do not have one row per sample.
        UnknownToolConfiguration: A configuration name that is not in the tool file.
    """
    joints = np.asarray(joints, dtype=float)
    n = len(joints)
    if isinstance(configuration, str):
        configuration = tool.names.index(tool.configuration(configuration).name)
    codes = np.broadcast_to(np.asarray(configuration, dtype=np.int64), (n,))
    if n == 0:
        return ToolLoad(np.zeros((0, 3)), np.zeros((0, 6)), None if joint_velocity is None else np.zeros((0, 6)))
    if (joint_velocity is None) != (joint_acceleration is None):
        raise ShapeError("give both joint_velocity and joint_acceleration, or neither")
    if joint_velocity is None:
        g = kin.g_sensor(joints, tool.gravity).reshape(n, 3)
        return ToolLoad(g, weight_wrench(tool, g, codes))
    motion = kin.sensor_motion(joints, joint_velocity, joint_acceleration)
    g = np.einsum("nji,j->ni", motion.R_world_sensor.reshape(n, 3, 3), kin.g_world(tool.gravity))
    static = weight_wrench(tool, g, codes)
    if codes[0] == codes[-1] and np.all(codes == codes[0]):  # one configuration (the usual block): no copies
        moving = tool.configurations[int(codes[0])].dynamic_wrench(g, motion.omega, motion.alpha, motion.a)
        return ToolLoad(g, static, moving, motion)
    moving = np.zeros((n, 6))
    for k, tool_configuration in enumerate(tool.configurations):
        mine = codes == k
        if mine.any():
            moving[mine] = tool_configuration.dynamic_wrench(g[mine], motion.omega[mine], motion.alpha[mine], motion.a[mine])
    return ToolLoad(g, static, moving, motion)


def weight_wrench(tool: Tool, g_sensor: np.ndarray, configuration: np.ndarray) -> np.ndarray:
    """The weight alone of the tool's configurations (eqs 17-18): ``[m g; c x m g]``.

    Args:
        tool: The tool.
        g_sensor: Gravity in the sensor frame [m/s^2], shape (N, 3).
        configuration: Configuration index of each sample, shape (N,) int.

    Returns:
        Shape (N, 6), [N, N, N, N m, N m, N m].
    """
    matrices = np.stack([c.wrench_matrix for c in tool.configurations])  # (k, 6, 3): W = M g
    return np.einsum("nij,nj->ni", matrices[np.asarray(configuration, dtype=np.int64)], np.asarray(g_sensor, dtype=float).reshape(-1, 3))


def dynamic_fraction(tool: Tool, configuration: np.ndarray, dynamic_part: np.ndarray) -> np.ndarray:
    """How large the dynamic part of the tool's wrench is, relative to its weight.

    Args:
        tool: The tool (the weight and lever of each configuration).
        configuration: Configuration index of each sample, shape (N,).
        dynamic_part: The moving wrench less the static one [N, N m], shape (N, 6).

    Returns:
        Per sample, the larger of ``|force part| / (m g)`` and ``|moment part| / (m g |c|)``
        (``|c|`` at least 1 mm), shape (N,).
    """
    fraction = np.zeros(len(configuration))
    for c, tool_configuration in enumerate(tool.configurations):
        mine = configuration == c
        weight = tool_configuration.mass * tool.gravity
        lever = max(float(np.linalg.norm(tool_configuration.p_sensor_com)), 1e-3)
        fraction[mine] = np.maximum(
            np.linalg.norm(dynamic_part[mine, :3], axis=1) / weight, np.linalg.norm(dynamic_part[mine, 3:], axis=1) / (weight * lever)
        )
    return fraction


#: How far beyond the sensor's force full scale a tool's weight may be before it is refused: a
#: calibration load stays within the range (a 2.5 kg tool is 0.5 of a 50 N sensor's); ten times
#: it is no tool that sensor carries, while grams for kilograms make it a thousand times.
MAX_LOAD_RATIO = 10.0


def check_tool_load(tool: Tool, full_scale: np.ndarray) -> None:
    """Refuse a tool configuration whose weight is far beyond the sensor's force full scale.

    Args:
        tool: The calibration tool.
        full_scale: The sensor's full scale per wrench axis [N, N, N, N m, N m, N m]. Shape (6,).

    Raises:
        ConfigError: A configuration weighs more than :data:`MAX_LOAD_RATIO` times the largest
            force full scale; the message names it, its weight and what to check.
    """
    force = float(np.max(full_scale[:3]))
    for k, configuration in enumerate(tool.configurations):
        # [N] on Earth: the mass alone is judged here (a gravity in cm/s² is the fit check's to name)
        weight = configuration.mass * STANDARD_GRAVITY
        if weight > MAX_LOAD_RATIO * force:
            message = (
                f"tool '{tool.name}', configuration {configuration.name}: mass {configuration.mass:g} kg weighs about {weight:,.0f} N, "
                f"{weight / force:,.0f} times the sensor's full scale of {force:g} N: a calibration tool hangs on the sensor, "
                "so the mass is in another unit than kg (grams?) or the sensor is not the one given (--sensor, its full_scale)"
            )
            raise ConfigError(f"configurations[{k}].mass", configuration.mass, "a weight within the sensor's range", message=message)

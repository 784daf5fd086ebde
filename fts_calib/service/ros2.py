"""ros2_control parameters: the force/torque broadcaster's correction and the gravity compensation filter.

One YAML file for the node of ros2_controllers' ``force_torque_sensor_broadcaster``
(parameter names from its ``force_torque_sensor_broadcaster_parameters.yaml``):

- ``frame_id``, ``sensor_name``;
- ``offset.{force,torque}.{x,y,z}`` and ``multiplier.{force,torque}.{x,y,z}``. The
  broadcaster **adds** the offset to the reading and then multiplies it, per axis:
  ``out_i = multiplier_i (reading_i + offset_i)``. Our model is ``W = C_bar r + D`` for a
  ``wrench-6`` sensor (its reading r is the factory wrench), so ``multiplier_i = C_bar_ii``
  and ``offset_i = D_i / C_bar_ii``: a reading bias b (the reading at no load,
  ``-D_i / C_bar_ii``) is exported as ``-b``. The broadcaster has no cross terms: the
  off-diagonal part of C_bar is not applied, and the file says how large it is (a
  :class:`~fts_calib.core.exceptions.FtsCalibWarning` above :data:`MAX_COUPLING`). For any
  other layout the hardware interface computes ``C Delta`` (the C header's C) and the
  broadcaster adds D: ``offset = D``, ``multiplier = 1``.
- ``sensor_filter_chain.filter1``: control_toolbox's ``control_filters/GravityCompensationWrench``
  (parameter names from its ``gravity_compensation_filter_parameters.yaml``):
  ``world_frame``, ``sensor_frame``, ``tool.CoG`` (the payload's centre of mass in the
  sensor frame [m]), ``tool.mass`` [kg] and ``tool.gravity_field`` (gravity in the world
  frame [m/s^2], ``[0, 0, -g]`` for a world frame with z up). The filter subtracts the
  payload's weight ``m R_sensor_world g_field`` from the force and ``CoG x`` that force from
  the torque: the same convention as fts-calib's wrench (the load on the sensor, paper eqs
  17-18), so the numbers go across unchanged.

Units: N, N m, m, kg, m/s^2.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..core.arrays import frozen
from ..core.exceptions import ConfigError, FtsCalibWarning
from ..core.files import dump_yaml
from ..model.calibration import Calibration
from ..model.channels import WRENCH_AXES
from ..robot.tool import ToolConfiguration

#: Node name of the broadcaster (the controller's name in the controller manager).
BROADCASTER = "force_torque_sensor_broadcaster"
#: Plugin name of control_toolbox's gravity compensation filter for WrenchStamped.
FILTER_TYPE = "control_filters/GravityCompensationWrench"
#: Largest off-diagonal term of C_bar, relative to its row's diagonal one, left unapplied without a warning.
MAX_COUPLING = 1e-3
#: The broadcaster's six axes, in fts-calib's wrench order.
AXES = (("force", "x"), ("force", "y"), ("force", "z"), ("torque", "x"), ("torque", "y"), ("torque", "z"))


@dataclass(frozen=True)
class BroadcasterCorrection:
    """What the broadcaster applies per axis: ``out = multiplier * (reading + offset)``.

    Attributes:
        offset: Added to the reading, [N, N, N, N m, N m, N m]. Shape (6,).
        multiplier: Multiplies the sum, dimensionless. Shape (6,).
        coupling: Largest ``|C_bar_ij| / |C_bar_ii|`` (i != j) the broadcaster cannot apply
            (0 for a layout whose hardware interface applies C).
        reading: What the broadcaster's input must be, in words.
    """

    offset: np.ndarray
    multiplier: np.ndarray
    coupling: float
    reading: str

    def __post_init__(self):
        object.__setattr__(self, "offset", frozen(self.offset))
        object.__setattr__(self, "multiplier", frozen(self.multiplier))


def broadcaster_correction(calibration: Calibration) -> BroadcasterCorrection:
    """The broadcaster's offset and multiplier for a calibration (see the module docstring).

    Args:
        calibration: The calibration; ``wrench-6`` maps onto offset and multiplier, any other
            layout needs ``C Delta`` from the hardware interface.

    Returns:
        The correction; ``coupling`` says what a ``wrench-6`` correction leaves out.

    Raises:
        ConfigError: A ``wrench-6`` C_bar with a row whose diagonal term is not its largest
            (the sensor's axes rotated or permuted against S: no per-axis correction applies).
    """
    if calibration.layout.name != "wrench-6":
        reading = f"C times the {calibration.layout.n_channels} raw channels, computed by the hardware interface (the C header's C)"
        return BroadcasterCorrection(np.array(calibration.D), np.ones(6), 0.0, reading)
    diagonal = np.diag(calibration.C_bar).copy()
    off = np.abs(calibration.C_bar - np.diag(diagonal))
    weak = np.flatnonzero(np.abs(diagonal) <= np.max(off, axis=1))
    if len(weak):  # a per-axis gain cannot stand for a rotated or permuted reading (offset D / 0)
        i = int(weak[0])
        message = (
            f"C_bar's row {WRENCH_AXES[i]} is dominated by a cross term (|C_bar[{i}, {i}]| = {abs(diagonal[i]):.3g}, largest "
            f"cross term {np.max(off[i]):.3g}): the sensor's axes are not those of the sensor frame, which the broadcaster's "
            "per-axis offset and multiplier cannot apply; apply C_bar in the hardware interface (export --format c-header)"
        )
        raise ConfigError("format", "ros2", "a wrench-6 calibration whose C_bar is close to diagonal", message=message)
    coupling = float(np.max(off / np.abs(diagonal)[:, None]))
    return BroadcasterCorrection(calibration.D / diagonal, diagonal, coupling, "the sensor's factory wrench")


def _per_axis(values: np.ndarray) -> dict[str, dict[str, float]]:
    out: dict[str, dict[str, float]] = {"force": {}, "torque": {}}
    for (part, axis), value in zip(AXES, values, strict=True):
        out[part][axis] = float(value)
    return out


def ros2_parameters(
    calibration: Calibration,
    payload: ToolConfiguration,
    gravity: float,
    sensor_frame: str = "ft_sensor",
    world_frame: str = "world",
    node: str = BROADCASTER,
    sensor_name: str | None = None,
) -> str:
    """The parameter file of the broadcaster and its gravity compensation filter (YAML).

    Args:
        calibration: The sensor's calibration (offset and multiplier).
        payload: The payload to compensate: mass [kg] and centre of mass in the sensor frame [m].
        gravity: Magnitude of gravity [m/s^2]; the field is ``[0, 0, -gravity]`` in ``world_frame``.
        sensor_frame: TF name of the sensor frame (fts-calib's S); also the broadcaster's ``frame_id``.
        world_frame: TF name of a fixed frame whose z axis points up.
        node: Name of the broadcaster's node.
        sensor_name: The broadcaster's ``sensor_name`` (prefix of its state interfaces);
            ``sensor_frame`` when None.

    Warns:
        FtsCalibWarning: A ``wrench-6`` calibration with cross terms above
            :data:`MAX_COUPLING` that the broadcaster cannot apply.
    """
    calibration.require_linear("the ros2 export (the broadcaster's offset and multiplier)")
    correction = broadcaster_correction(calibration)
    params = {
        node: {
            "ros__parameters": {
                "frame_id": sensor_frame,
                "sensor_name": sensor_name or sensor_frame,
                "offset": _per_axis(correction.offset),
                "multiplier": _per_axis(correction.multiplier),
                "sensor_filter_chain": {
                    "filter1": {
                        "name": "gravity_compensation",
                        "type": FILTER_TYPE,
                        "params": {
                            "world_frame": world_frame,
                            "sensor_frame": sensor_frame,
                            "tool": {
                                "CoG": [float(v) for v in payload.p_sensor_com],
                                "mass": float(payload.mass),
                                "gravity_field": [0.0, 0.0, -float(gravity)],
                            },
                        },
                    }
                },
            }
        }
    }
    lines = [
        f"# ros2_control parameters written by fts-calib ({calibration.layout.name} calibration, payload '{payload.name}').",
        f"# {node}: out = multiplier * (reading + offset) per axis, the reading being {correction.reading};",
        "# offset in N and N·m, multiplier dimensionless.",
        f"# {FILTER_TYPE}: tool.CoG in {sensor_frame} [m], tool.mass [kg], tool.gravity_field in {world_frame} [m/s²], z up.",
    ]
    if correction.coupling > 0:
        lines.append(f"# Not applied: C_bar's cross terms, up to {correction.coupling:.3g} of a diagonal term; the broadcaster has none.")
    if correction.coupling > MAX_COUPLING:
        message = (
            f"the broadcaster applies only C_bar's diagonal: its cross terms (up to {correction.coupling:.3g} of a diagonal "
            "term) stay in the published wrench; apply C_bar in the hardware interface (export --format c-header) instead"
        )
        warnings.warn(message, FtsCalibWarning, stacklevel=2)
    return "\n".join(lines) + "\n" + dump_yaml(params)

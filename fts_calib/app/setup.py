"""The robot, the tool, the sensor and the pipeline settings a command names: loaded in one place."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..core import arrays as validation
from ..core.arrays import as_matrix
from ..core.exceptions import ConfigError
from ..core.resources import resolve
from ..filters.settings import PipelineConfig, load_pipeline_config
from ..model.channels import ChannelLayout
from ..model.prior import Prior
from ..model.sensor_config import SensorSpec, load_sensor_config
from ..robot.definition import load_robot
from ..robot.kinematics import Kinematics
from ..robot.orientation import orientation_kinematics
from ..robot.tool import Tool, load_tool
from ..service.ati import SUFFIX as ATI_SUFFIX
from ..service.ati import load_ati_calibration, read_calibration

#: The weight of a prior when --prior-weight is not given (as much as the data).
DEFAULT_PRIOR_WEIGHT = 1.0


class Setup(NamedTuple):
    """What a command works with.

    Attributes:
        kinematics: Kinematics of the robot.
        tool: The tool file's tool.
        settings: The pipeline settings.
    """

    kinematics: Kinematics
    tool: Tool
    settings: PipelineConfig


def load_settings(pipeline: str | Path = "pipeline") -> PipelineConfig:
    """The pipeline settings: a shipped name (``configs/NAME.yaml``) or a YAML path."""
    return load_pipeline_config(resolve(pipeline, "configs", "pipeline"))


def load_sensor(sensor: str | Path = "sensor") -> SensorSpec:
    """The sensor configuration: a shipped name (``configs/NAME.yaml``), a YAML path, or an ATI ``.cal`` file.

    Its ``channels`` key is the channel layout the command expects of the data (the paper's
    8 bridges for the shipped ``sensor``; ``factory_sensor`` is a 6-axis wrench). An ATI
    file gives the layout P = its factory matrix (n gauges in V) and its rated ranges as the
    full scale (:mod:`fts_calib.service.ati`).
    """
    if Path(sensor).suffix.lower() == ATI_SUFFIX:
        return load_ati_calibration(sensor).sensor_spec()
    return load_sensor_config(resolve(sensor, "configs", "sensor"))


def load_prior(prior: str | Path | None, weight: float, layout: ChannelLayout) -> Prior | None:
    """The prior of ``--prior FILE --prior-weight LAMBDA``: a calibration (YAML or ATI ``.cal``) to shrink toward.

    Args:
        prior: The calibration file, or None for no prior.
        weight: lambda >= 0 (:mod:`fts_calib.model.prior`).
        layout: The sensor's channel layout: the prior must have it (its C_bar is then comparable).

    Raises:
        ConfigError: The prior is of another channel layout, the weight is negative or not
            finite, or a weight other than 0 or the default 1 is given without a prior (it
            would weigh nothing: the user meant a prior).
    """
    if not math.isfinite(weight) or weight < 0:
        message = f"--prior-weight {weight} but expected a finite value >= 0 (0: no prior, 1: as much as the data)"
        raise ConfigError("prior_weight", weight, "a finite value >= 0", message=message)
    if prior is None:
        if weight not in (0.0, DEFAULT_PRIOR_WEIGHT):  # 0 is "no prior", which holds
            message = f"--prior-weight {weight:g} without --prior: name the calibration to shrink toward (--prior FILE)"
            raise ConfigError("prior_weight", weight, "--prior FILE with it", message=message)
        return None
    calibration = read_calibration(prior)
    if calibration.layout != layout:
        message = (
            f"--prior {prior} is a calibration of a {calibration.layout.name} sensor ({calibration.layout.n_channels} channels) "
            f"but the sensor is {layout.name} ({layout.n_channels} channels): give a prior of this sensor"
        )
        raise ConfigError("prior", str(prior), f"a calibration of the {layout.name} layout", message=message)
    return Prior(calibration.C_bar, weight, str(prior))


def load_kinematics(robot: str | Path) -> Kinematics:
    """Kinematics of a robot definition: a shipped name (``robots/NAME.yaml``) or a YAML path."""
    return Kinematics(load_robot(resolve(robot, "robots")))


def load_robot_or_orientation(robot: str | Path | None, mount_rpy: Sequence[float] | None = None) -> Kinematics:
    """The robot's kinematics, or without a robot the gimbal of a recording that gives orientations.

    Args:
        robot: Robot definition: a shipped name or a YAML path; None for the gimbal
            (:func:`fts_calib.robot.orientation.orientation_kinematics`).
        mount_rpy: Without a robot: roll, pitch, yaw [rad] from the frame the recording's
            orientation gives to the sensor, shape (3,); None for none.

    Raises:
        ConfigError: ``mount_rpy`` with a robot (its file declares the mount), or not 3 finite angles.
    """
    if robot is None:
        mount = validation.finite_array("mount", as_matrix(mount_rpy if mount_rpy is not None else np.zeros(3), (3,), "mount"))
        return orientation_kinematics(mount)
    if mount_rpy is not None:
        raise ConfigError("mount", list(mount_rpy), "no --mount with --robot: the robot file declares the sensor mount")
    return load_kinematics(robot)


def load_setup(
    robot: str | Path | None, tool: str | Path = "paper_tool", pipeline: str | Path = "pipeline", mount_rpy: Sequence[float] | None = None
) -> Setup:
    """Load the robot's kinematics, the tool and the pipeline settings a command names.

    Args:
        robot: Robot definition: a shipped name (e.g. 'ur5') or a YAML path; None for a
            recording that gives the sensor's orientation (:func:`fts_calib.robot.orientation.orientation_kinematics`).
        tool: Tool file: a shipped name (``configs/NAME.yaml``) or a YAML path.
        pipeline: Pipeline settings: a shipped name or a YAML path.
        mount_rpy: Without a robot: roll, pitch, yaw [rad] from the frame the recording's
            orientation gives to the sensor; None for none.

    Raises:
        ResourceNotFound: A name that is neither a file nor shipped.
        FileFormatError: A file with a missing or wrong field.
        ConfigError: ``mount_rpy`` with a robot (its file declares the mount), or not 3 finite angles.
    """
    kin = load_robot_or_orientation(robot, mount_rpy)
    return Setup(kin, load_tool(resolve(tool, "configs", "tool")), load_settings(pipeline))

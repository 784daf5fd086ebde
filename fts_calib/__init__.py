"""fts-calib: in-situ calibration of six-axis strain-gauge force/torque sensors.

The sensor stays on the robot arm; the arm sweeps its last two joints while a calibration
tool of known mass hangs on the sensor in three centre-of-mass configurations, and an
online least-squares estimator recovers the calibration matrix C (6 x n: 6 x 8 for the
paper's sensor) and the offsets D (see ``docs/method.md``: W = C Delta + D, C = C_bar P).

Conventions: SI units; wrenches ``[Fx, Fy, Fz, Mx, My, Mz]`` on the sensor, in the sensor
frame S; sample axis first; ``channels`` are raw sensor readings, ``joints`` joint
readings [rad].

The names below are loaded on first use (PEP 562), so that the in-controller path
(``from fts_calib import Calibration, WrenchReader``) imports neither Pinocchio nor
pandas, ruckig, matplotlib or rosbags. Everything else stays importable from its stage,
e.g. ``from fts_calib.planning.sizing import size_motion``.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from ._version import __version__
from .core.deprecation import install_moved_modules

install_moved_modules()  # the module paths of the release before the stage layout, for one release

if TYPE_CHECKING:  # type checkers and IDEs see the names; at run time __getattr__ loads them
    from .core.exceptions import (
        ConfigError,
        FileFormatError,
        FrameNotFound,
        FtsCalibError,
        FtsCalibWarning,
        InsufficientExcitation,
        PoorFit,
        RecordingError,
        ResourceNotFound,
        ShapeError,
        TrajectoryError,
        UnknownToolConfiguration,
    )
    from .model.calibration import Calibration, Quality, load_calibration
    from .model.channels import ChannelLayout
    from .model.estimator import OnlineEstimator
    from .model.sensor_config import SensorSpec, load_sensor_config
    from .payload.estimate import PayloadEstimate
    from .payload.identify import identify_payload
    from .planning.trajectory_run import plan_trajectories
    from .robot.definition import RobotDefinition, load_robot
    from .robot.kinematics import Kinematics
    from .robot.tool import Tool, ToolConfiguration, load_tool, tool_load
    from .service.exports import export
    from .service.reader import GravityCompensator, WrenchReader
    from .session.calibration_run import calibrate
    from .session.session import CalibrationSession
    from .sim.runs import simulate_batches
    from .sim.sensor import SimulatedSensor, load_simulated_sensor
    from .sources.batch import SampleBatch

#: Where each public name lives: name -> module (relative to the package).
_WHERE = {
    "Calibration": ".model.calibration",
    "CalibrationSession": ".session.session",
    "ChannelLayout": ".model.channels",
    "ConfigError": ".core.exceptions",
    "FileFormatError": ".core.exceptions",
    "FrameNotFound": ".core.exceptions",
    "FtsCalibError": ".core.exceptions",
    "FtsCalibWarning": ".core.exceptions",
    "GravityCompensator": ".service.reader",
    "InsufficientExcitation": ".core.exceptions",
    "Kinematics": ".robot.kinematics",
    "OnlineEstimator": ".model.estimator",
    "PayloadEstimate": ".payload.estimate",
    "PoorFit": ".core.exceptions",
    "Quality": ".model.calibration",
    "RecordingError": ".core.exceptions",
    "ResourceNotFound": ".core.exceptions",
    "RobotDefinition": ".robot.definition",
    "SampleBatch": ".sources.batch",
    "SensorSpec": ".model.sensor_config",
    "ShapeError": ".core.exceptions",
    "SimulatedSensor": ".sim.sensor",
    "Tool": ".robot.tool",
    "ToolConfiguration": ".robot.tool",
    "TrajectoryError": ".core.exceptions",
    "UnknownToolConfiguration": ".core.exceptions",
    "WrenchReader": ".service.reader",
    "calibrate": ".session.calibration_run",
    "export": ".service.exports",
    "identify_payload": ".payload.identify",
    "load_calibration": ".model.calibration",
    "load_robot": ".robot.definition",
    "load_sensor_config": ".model.sensor_config",
    "load_simulated_sensor": ".sim.sensor",
    "load_tool": ".robot.tool",
    "plan_trajectories": ".planning.trajectory_run",
    "simulate_batches": ".sim.runs",
    "tool_load": ".robot.tool",
}

__all__ = [
    "Calibration",
    "CalibrationSession",
    "ChannelLayout",
    "ConfigError",
    "FileFormatError",
    "FrameNotFound",
    "FtsCalibError",
    "FtsCalibWarning",
    "GravityCompensator",
    "InsufficientExcitation",
    "Kinematics",
    "OnlineEstimator",
    "PayloadEstimate",
    "PoorFit",
    "Quality",
    "RecordingError",
    "ResourceNotFound",
    "RobotDefinition",
    "SampleBatch",
    "SensorSpec",
    "ShapeError",
    "SimulatedSensor",
    "Tool",
    "ToolConfiguration",
    "TrajectoryError",
    "UnknownToolConfiguration",
    "WrenchReader",
    "__version__",
    "calibrate",
    "export",
    "identify_payload",
    "load_calibration",
    "load_robot",
    "load_sensor_config",
    "load_simulated_sensor",
    "load_tool",
    "plan_trajectories",
    "simulate_batches",
    "tool_load",
]


def __getattr__(name: str) -> Any:
    """Load a public name from its stage on first use (PEP 562) and keep it."""
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module 'fts_calib' has no attribute {name!r}")
    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value  # later look-ups skip __getattr__
    return value


def __dir__() -> list[str]:
    """The public names and the module's own attributes."""
    return sorted(set(globals()) | set(__all__))

"""fts-calib: in-situ calibration of six-axis strain-gauge force/torque sensors.

The sensor stays on the robot arm; the arm sweeps its last two joints while a calibration
tool of known mass hangs on the sensor in three centre-of-mass configurations, and an
online least-squares estimator recovers the calibration matrix C (6 x n: 6 x 8 for the
paper's sensor) and the offsets D (see ``paper.md``: W = C Delta + D, C = C_bar P).

Conventions: SI units; wrenches ``[Fx, Fy, Fz, Mx, My, Mz]`` on the sensor, in the sensor
frame S; sample axis first.
"""

from ._version import __version__
from .core.exceptions import (
    BagError,
    ConfigError,
    FeedTimeout,
    FileFormatError,
    FrameNotFound,
    FtsCalibError,
    FtsCalibWarning,
    InsufficientExcitation,
    JointError,
    LimitError,
    PayloadError,
    PoorFit,
    ProtocolError,
    RecordingError,
    ResourceNotFound,
    RobotDataNotFound,
    ShapeError,
    StructureError,
    TrajectoryError,
    UnknownToolConfiguration,
    UnsupportedJoint,
)
from .feeds.bag import BagReader
from .feeds.bag_log import BagTopics
from .feeds.batch import SampleBatch
from .feeds.rtde import RtdePoller, connect_ur
from .model.budget import AccuracyBudget
from .model.calibration import Calibration, Quality, load_calibration, save_calibration
from .model.channels import MALTESE_CROSS_8, WRENCH_6, ChannelLayout, channel_layout
from .model.estimator import OnlineEstimator
from .model.jig import jig_calibration
from .model.least_squares import information_rank
from .model.offset_basis import OFFSET_MODELS, OffsetBasis, evaluate_offsets
from .model.offsets import OffsetEstimate, estimate_offsets
from .model.prior import Prior
from .model.sensor import WRENCH_AXES, P, c_bar_from_c, c_from_c_bar, project, wrench_from_strain
from .model.sensor_config import SensorSpec, SimulationSpec, load_sensor_config
from .pipeline.latency import LatencyEstimate, estimate_latency
from .pipeline.session import CalibrationSession
from .planning.accuracy import KeptSamples, measured_budget, plan_budget
from .planning.sizing import SizedPlan, size_plan
from .robot.definition import load_robot
from .robot.kinematics import Kinematics
from .robot.load import ToolLoad, tool_load
from .robot.tool import Tool, ToolConfiguration, load_tool, save_tool
from .robot.wrench import dynamic_wrench, static_wrench
from .service.ati import AtiCalibration, load_ati_calibration, read_calibration
from .service.export import export
from .service.payload import PayloadEstimate, identify_payload
from .service.reader import GravityCompensator, WrenchReader
from .sim.sensor import SimulatedSensor, load_simulated_sensor

__all__ = [
    "AccuracyBudget",
    "AtiCalibration",
    "BagError",
    "BagReader",
    "BagTopics",
    "Calibration",
    "CalibrationSession",
    "ChannelLayout",
    "ConfigError",
    "FeedTimeout",
    "FileFormatError",
    "FrameNotFound",
    "FtsCalibError",
    "FtsCalibWarning",
    "GravityCompensator",
    "InsufficientExcitation",
    "JointError",
    "KeptSamples",
    "Kinematics",
    "LatencyEstimate",
    "LimitError",
    "MALTESE_CROSS_8",
    "OFFSET_MODELS",
    "OffsetBasis",
    "OffsetEstimate",
    "OnlineEstimator",
    "P",
    "PayloadError",
    "PayloadEstimate",
    "PoorFit",
    "Prior",
    "ProtocolError",
    "Quality",
    "RecordingError",
    "ResourceNotFound",
    "RobotDataNotFound",
    "RtdePoller",
    "SampleBatch",
    "SensorSpec",
    "ShapeError",
    "SimulatedSensor",
    "SimulationSpec",
    "SizedPlan",
    "StructureError",
    "Tool",
    "ToolConfiguration",
    "ToolLoad",
    "TrajectoryError",
    "UnknownToolConfiguration",
    "UnsupportedJoint",
    "WRENCH_6",
    "WRENCH_AXES",
    "WrenchReader",
    "__version__",
    "c_bar_from_c",
    "c_from_c_bar",
    "channel_layout",
    "connect_ur",
    "dynamic_wrench",
    "estimate_latency",
    "estimate_offsets",
    "evaluate_offsets",
    "export",
    "identify_payload",
    "information_rank",
    "jig_calibration",
    "load_ati_calibration",
    "load_calibration",
    "load_robot",
    "load_sensor_config",
    "load_simulated_sensor",
    "load_tool",
    "measured_budget",
    "plan_budget",
    "project",
    "read_calibration",
    "save_calibration",
    "save_tool",
    "size_plan",
    "static_wrench",
    "tool_load",
    "wrench_from_strain",
]

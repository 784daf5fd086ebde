"""What a command names, built once from its options: its :class:`Setup`, its source, its outputs.

- :class:`Setup`: the robot (its kinematics), the tool mounted, the sensor file and the pipeline
  settings, with what the command line changes of them (the filter, the models, a prior, the
  live timing, the tool's envelope, the full scale). Each is loaded when first asked for, once:
  a command checks its outputs before anything is read.
- :class:`SourceOptions`: what the command reads (the SOURCE arguments: recordings, bags,
  ``udp://HOST:PORT``, ``ur://HOST``; :func:`fts_calib.sources.source.open_source`) and how.
- :class:`OutputOptions`: what it writes (the output, a report, JSON, a plot, the checkpoint).

The command line fills them by field name from the options (:func:`fts_calib.app.cli.run_command`);
from Python they are made directly, e.g. ``calibrate.run(Setup(robot_file="ur5", tool_file="paper_tool"),
SourceOptions(["recording.csv"]), OutputOptions("calibration.yaml"))``.

The loaders (:func:`load_setup`, :func:`load_sensor`, ...) load one file each.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from ..core import arrays as validation
from ..core.arrays import as_matrix
from ..core.exceptions import ConfigError, FtsCalibError, FtsCalibWarning
from ..core.files import file_sha256
from ..core.resources import resolve, shipped
from ..filters.settings import FILTER_MODES, NO_FILTER, PipelineConfig, load_pipeline_config
from ..model.channels import ChannelLayout
from ..model.prior import Prior
from ..model.sensor_config import SensorSpec, load_sensor_config
from ..robot.definition import load_robot
from ..robot.kinematics import Kinematics
from ..robot.orientation import orientation_kinematics
from ..robot.tool import Tool, ToolShape, load_tool
from ..service.ati import SUFFIX as ATI_SUFFIX
from ..service.ati import load_ati_calibration, read_calibration
from ..sources.bag import BagTopics
from ..sources.source import DEVICE_SCHEMES, LIVE_SCHEMES, recording_paths
from ..sources.ur import TIMEOUT_S

#: The weight of a prior when --prior-weight is not given (as much as the data).
DEFAULT_PRIOR_WEIGHT = 1.0


#: The tool of a command whose --tool is optional and not given.
DEFAULT_TOOL = "paper_tool"


class Loaded(NamedTuple):
    """The robot's kinematics, a tool and the pipeline settings (:func:`load_setup`).

    Attributes:
        kinematics: Kinematics of the robot.
        tool: The tool file's tool.
        settings: The pipeline settings.
    """

    kinematics: Kinematics
    tool: Tool
    settings: PipelineConfig


@dataclass(frozen=True)
class Setup:
    """The robot, the tool, the sensor and the pipeline settings of a command, and what its options change of them.

    The files are named as a user does (a shipped name or a path); each is loaded when first
    asked for (:attr:`kinematics`, :attr:`tool`, :attr:`sensor`, :attr:`settings`,
    :attr:`prior`), once.

    Attributes:
        robot_file: Robot definition (a shipped name such as 'ur5', or a YAML path); None for
            a source that gives the sensor's orientation (:mod:`fts_calib.robot.orientation`).
        mount_rpy: Without a robot: roll, pitch, yaw [rad] from the frame the source's
            orientation gives to the sensor, shape (3,); None for none.
        tool_file: The tool mounted during the recording; None: :data:`DEFAULT_TOOL` where the
            command has a default (a command that needs it says so).
        configuration: The configuration of the tool mounted throughout; None: the source's
            (or nothing mounted, where the command says so).
        sensor_file: The sensor file: a shipped name, a YAML path or an ATI ``.cal``.
        pipeline_file: The pipeline settings: a shipped name or a YAML path.
        filter_mode: The sample filter ('quasi-static', 'dynamic', or 'none': every valid
            sample); None: the pipeline file's.
        model: The sensor model ('auto', 'linear', 'quadratic', 'cubic'); None: the sensor file's.
        offsets: The offset model ('auto', 'constant', 'per-configuration', 'drift'); None: the pipeline file's.
        prior_file: A calibration to shrink C_bar toward (:mod:`fts_calib.model.prior`); None for none.
        prior_weight: The prior's weight lambda, relative to the data.
        dynamic: The tool's moving wrench (Newton-Euler); False: its weight alone.
        latency_s: How late the joint stamps are behind the channels' [s]; None: the pipeline's.
        max_gap_s: Longest joint gap interpolated across [s]; None: the pipeline's.
        joint_noise: Noise of the joint readings [rad]; None: the pipeline's ``filter.joint_noise``.
        latency_uncertainty_s: Standard deviation of the stream latency [s]; None: the pipeline's.
        inertia_tolerance: Each inertia element known to this fraction of the largest principal
            moment; None: the pipeline's.
        noise_std: Noise per channel [raw units]; None: the sensor file's.
        tool_radius: Radius of the tool's collision envelope [m]; None: the tool file's.
        tool_length: Length of the tool's collision envelope [m]; None: the tool file's.
        full_scale_force: Full scale of the forces [N]; None: the sensor file's.
        full_scale_moment: Full scale of the moments [N m]; None: the sensor file's.
    """

    robot_file: str | Path | None = None
    mount_rpy: Sequence[float] | None = None
    tool_file: str | Path | None = None
    configuration: str | None = None
    sensor_file: str | Path = "sensor"
    pipeline_file: str | Path = "pipeline"
    filter_mode: str | None = None
    model: str | None = None
    offsets: str | None = None
    prior_file: str | Path | None = None
    prior_weight: float = DEFAULT_PRIOR_WEIGHT
    dynamic: bool = True
    latency_s: float | None = None
    max_gap_s: float | None = None
    joint_noise: float | None = None
    latency_uncertainty_s: float | None = None
    inertia_tolerance: float | None = None
    noise_std: float | None = None
    tool_radius: float | None = None
    tool_length: float | None = None
    full_scale_force: float | None = None
    full_scale_moment: float | None = None

    @cached_property
    def kinematics(self) -> Kinematics:
        """The robot's kinematics, or without a robot the gimbal of a source that gives orientations (:func:`load_robot_or_orientation`)."""
        return load_robot_or_orientation(self.robot_file, self.mount_rpy)

    @property
    def robot_path(self) -> Path:
        """The robot definition's file (a shipped name resolved)."""
        return resolve(self.robot_file if self.robot_file is not None else "", "robots")

    @property
    def tool_path(self) -> Path:
        """The tool file (a shipped name resolved; :data:`DEFAULT_TOOL` when none is named)."""
        return resolve(self.tool_file if self.tool_file is not None else DEFAULT_TOOL, "configs", "tool")

    @cached_property
    def tool(self) -> Tool:
        """The tool mounted, with the envelope of ``tool_radius`` and ``tool_length`` when given."""
        tool = load_tool(self.tool_path)
        if (self.tool_radius is not None or self.tool_length is not None) and tool.shape is not None:
            shape = ToolShape(self.tool_radius or tool.shape.radius, self.tool_length or tool.shape.length)
            tool = dataclasses.replace(tool, shape=shape)
        return tool

    @cached_property
    def sensor(self) -> SensorSpec:
        """The sensor file's spec, with the full scale given (a full scale <= 0 or not finite is refused)."""
        spec = load_sensor(self.sensor_file)
        if self.full_scale_force is None and self.full_scale_moment is None:
            return spec
        full_scale = spec.full_scale.copy()
        if self.full_scale_force is not None:
            full_scale[:3] = self.full_scale_force
        if self.full_scale_moment is not None:
            full_scale[3:] = self.full_scale_moment
        return dataclasses.replace(spec, full_scale=full_scale)

    @cached_property
    def settings(self) -> PipelineConfig:
        """The pipeline file's settings with what the options change (filter mode, offsets, timing, uncertainties)."""
        settings = load_settings(self.pipeline_file).with_offsets(self.offsets)
        if self.filter_mode in FILTER_MODES:
            settings = settings.with_filter_mode(self.filter_mode)
        live: dict[str, Any] = {
            key: value for key, value in (("latency_s", self.latency_s), ("max_gap_s", self.max_gap_s)) if value is not None
        }
        known = (
            ("joint_noise", self.joint_noise),
            ("latency_uncertainty_s", self.latency_uncertainty_s),
            ("inertia_tolerance", self.inertia_tolerance),
        )
        motion: dict[str, Any] = {key: value for key, value in known if value is not None}
        if live:
            settings = dataclasses.replace(settings, live=dataclasses.replace(settings.live, **live))
        if motion:
            settings = dataclasses.replace(settings, filter=dataclasses.replace(settings.filter, **motion))
        return settings

    @property
    def use_filter(self) -> bool:
        """Whether a sample filter keeps the samples (``filter_mode`` 'none': every valid one)."""
        return self.filter_mode != NO_FILTER

    @cached_property
    def prior(self) -> Prior | None:
        """The prior (:func:`load_prior`) of the sensor's layout, or None."""
        return load_prior(self.prior_file, self.prior_weight, self.sensor.layout)

    @property
    def sensor_model(self) -> str:
        """The sensor model setting: ``model``, or the sensor file's."""
        return self.model or self.sensor.model

    def recorded(self, provenance: Mapping[str, Any], calibration: str | Path, *, robot: bool = True, tool: bool = True) -> Setup:
        """This setup with the robot file and the tool file a calibration records, where no option names them.

        A calibration records the files it was made with (:func:`fts_calib.session.provenance.file_provenance`):
        a user's file by absolute path and SHA-256, a shipped one by name. ``--robot`` and
        ``--tool`` stay overrides: one that names other content than the recorded file is
        said (a line on stdout). A recorded user's file that is no longer there, or whose
        content changed since, is refused (:class:`ConfigError` naming it and the option that
        overrides it): the calibration's tool masses and mount were those of its bytes. A
        shipped file changed by another fts-calib version is used with a warning.

        Args:
            provenance: The calibration's ``provenance`` section.
            calibration: The calibration file, as the user named it (for the messages).
            robot: Fill ``robot_file`` (else left as it is; left too when ``mount_rpy`` is given).
            tool: Fill ``tool_file``; a calibration that records none (an older file, an ATI
                ``.cal``) is refused then: no other tool is assumed.

        Raises:
            ConfigError: A recorded file moved or changed; no tool recorded and none given.
        """
        changes: dict[str, Any] = {}
        robot_unknown = False
        if robot and self.mount_rpy is None:  # a mount given: the orientation's gimbal, no robot
            given, entry = self.robot_file, _entry(provenance, "robot")
            found = (
                _recorded_file(entry, "robots", "robot", "--robot", calibration)
                if given is None
                else _override(given, entry, "robots", "robot", "--robot", calibration)
            )
            if given is None and found is not _UNKNOWN:
                changes["robot_file"] = found
            robot_unknown = given is None and found is _UNKNOWN
        if tool:
            given, entry = self.tool_file, _entry(provenance, "tools")
            found = (
                _recorded_file(entry, "configs", "tool", "--tool", calibration)
                if given is None
                else _override(given, entry, "configs", "tool", "--tool", calibration)
            )
            if given is None:
                if found is _UNKNOWN or found is None:
                    files, give = (
                        ("the robot file and the tool file", "--robot ROBOT and --tool FILE")
                        if robot_unknown
                        else ("the tool file", "--tool FILE")
                    )
                    message = (
                        f"{calibration} does not record {files} it was made with (written before calibrations recorded them, "
                        f"typed in, or an ATI .cal): give {give}, those of the recording"
                    )
                    raise ConfigError("tool", None, "the tool file of the recording", message=message)
                changes["tool_file"] = found
        return dataclasses.replace(self, **changes) if changes else self

    def inputs(self) -> dict[str, str | Path | None]:
        """The files named, by what they are (for the check that no output overwrites one)."""
        named = {
            "the robot file": self.robot_file,
            "the tool file": self.tool_file,
            "the pipeline file": self.pipeline_file,
            "the sensor file": self.sensor_file,
        }
        return {**named, **({"the prior": self.prior_file} if self.prior_file is not None else {})}


@dataclass(frozen=True)
class SourceOptions:
    """What a command reads and how: the SOURCE arguments (:mod:`fts_calib.sources.source`).

    Attributes:
        names: Recordings (CSV, patterns, ROS 2 bags ``BAG[:CONFIGURATION]``), or live sources
            ``udp://HOST:PORT`` and ``ur://HOST``, as a user types them (one, or a sequence).
        joint_unit: The recording's joint columns: 'auto' (degrees detected from the data), 'rad' or 'deg'.
        joints_topic: A bag's sensor_msgs/msg/JointState topic.
        pose_topic: Without a robot: a bag's geometry_msgs/msg/PoseStamped topic of the sensor's orientation.
        channels_topic: A bag's std_msgs/msg/Float64MultiArray or geometry_msgs/msg/WrenchStamped topic.
        configuration_topic: A bag's std_msgs/msg/String topic of the tool configuration.
        joint_stamps: A bag's joint times: 'header' (their header stamps) or 'log' (the bag's log time).
        listen_any: Let ``udp://`` bind every interface (a wildcard host).
        ur_wrench: With ``ur://`` and ``udp://``: the channels are the built-in sensor's wrench
            anyway (with ``ur://`` alone they are).
        ur_timeout_s: With ``ur://``: the longest wait for the controller [s].
        idle_timeout_s: A live source ends after this long without data [s]; None: never.
        window_s: How long a live source is read [s]; None: the command's own (``tare``: 2 s, ``payload``: to the sender's end).
        rate_hz: The source's sample rate [Hz]; None: measured from its time stamps.
    """

    names: str | Path | Sequence[str | Path] | None = None
    joint_unit: str = "auto"
    joints_topic: str = BagTopics.joints
    pose_topic: str = BagTopics.pose
    channels_topic: str = BagTopics.channels
    configuration_topic: str = BagTopics.configuration
    joint_stamps: str = BagTopics.joint_stamps
    listen_any: bool = False
    ur_wrench: bool = False
    ur_timeout_s: float = TIMEOUT_S
    idle_timeout_s: float | None = None
    window_s: float | None = None
    rate_hz: float | None = None

    @property
    def given(self) -> list[str | Path]:
        """The names given, as a list."""
        if self.names is None:
            return []
        return [self.names] if isinstance(self.names, (str, Path)) else list(self.names)

    @property
    def topics(self) -> BagTopics:
        """The topic names of a bag."""
        return BagTopics(self.joints_topic, self.channels_topic, self.configuration_topic, self.joint_stamps, self.pose_topic)

    @property
    def live(self) -> dict[str, str]:
        """The live sources given, by scheme (``udp``, ``ur``); empty for recordings.

        Raises:
            ConfigError: Live sources mixed with recordings, or two of one scheme.
        """
        found: dict[str, str] = {}
        for name in self.given:
            scheme = str(name).split("://", 1)[0].lower() if "://" in str(name) else ""
            if scheme not in LIVE_SCHEMES:
                continue
            if scheme in found:
                message = f"two {scheme}:// sources ({found[scheme]} and {name}): give one (ur://HOST with udp://HOST:PORT reads both)"
                raise ConfigError("source", [str(n) for n in self.given], f"one {scheme}:// source", message=message)
            found[scheme] = str(name)
        if found and len(found) != len(self.given):
            message = f"{', '.join(map(str, self.given))}: a live feed (udp://, ur://) is read alone, not with recordings"
            raise ConfigError("source", [str(n) for n in self.given], "recordings, or live sources", message=message)
        return found

    def paths(self) -> list[str | Path]:
        """The recordings' paths, each pattern (``'poses/*.csv'``) replaced by its matches."""
        return recording_paths(self.given)


def channel_device(live: dict[str, str], command: str, joints: bool = True) -> str | None:
    """The channel device of the live sources given (``serial://``, ``netft://``), or None; checked.

    Args:
        live: The live sources by scheme (:attr:`SourceOptions.live`).
        command: The command, for the messages.
        joints: The command needs the joints: a device comes with ``udp://`` or ``ur://``.

    Raises:
        ConfigError: Two devices, or a device without the joints' source when ``joints``
            (the message says what to add).
    """
    devices = [live[kind] for kind in DEVICE_SCHEMES if kind in live]
    if len(devices) > 1:
        message = f"{' and '.join(devices)}: one channel device at a time"
        raise ConfigError("source", devices, "one channel device", message=message)
    if devices and joints and "udp" not in live and "ur" not in live:
        message = f"{devices[0]} gives the channels: {command} needs the joints too: add ur://HOST or udp://HOST:PORT (joint datagrams)"
        raise ConfigError("source", devices, "a channel device and the joints' source", message=message)
    if devices and joints and "udp" in live and "ur" in live:
        message = f"{devices[0]} gives the channels: the joints come from ur://HOST or from udp://HOST:PORT, not both"
        raise ConfigError("source", list(live.values()), "one joints' source", message=message)
    if devices and not joints and len(live) > 1:
        message = f"{' '.join(live.values())}: {command} reads the channels alone ({devices[0]}): give it alone"
        raise ConfigError("source", list(live.values()), "the channel device alone", message=message)
    return devices[0] if devices else None


@dataclass(frozen=True)
class OutputOptions:
    """What a command writes (each None: not written, or the command's default).

    Attributes:
        output: The file (or folder) the command writes.
        report: An HTML report (:mod:`fts_calib.report.html`).
        json_path: The results as JSON, for scripts.
        plot_path: A plot (PNG, PDF, SVG).
        checkpoint: The checkpoint file, written every few seconds.
        resume: Continue from ``checkpoint``.
        restart: Start afresh over an existing ``checkpoint``; without it or ``resume``, an
            existing checkpoint is refused: its samples are never lost silently.
        quiet: No progress bar or status line.
    """

    output: str | Path | None = None
    report: str | Path | None = None
    json_path: str | Path | None = None
    plot_path: str | Path | None = None
    checkpoint: str | Path | None = None
    resume: bool = False
    restart: bool = False
    quiet: bool = False


#: What :func:`_recorded_file` returns for a calibration that does not say which file it was made with.
_UNKNOWN: Any = object()


def _entry(provenance: Mapping[str, Any], key: str) -> Mapping[str, Any]:
    """The provenance's ``robot`` or ``tools`` mapping ({} when absent or malformed)."""
    entry = provenance.get(key) if isinstance(provenance, Mapping) else None
    return entry if isinstance(entry, Mapping) else {}


def _role(kind: str, role: str) -> str | None:
    """The role :func:`resolve` takes: a tool's among the configs, None for a robot (its folder holds robots alone)."""
    return role if kind == "configs" else None


def _short(digest: object) -> str:
    return f"{str(digest)[:12]}…"


def _recorded_file(entry: Mapping[str, Any], kind: str, role: str, option: str, calibration: str | Path) -> Any:
    """The file a calibration's provenance entry names: a shipped name, a path, None (made without a file) or :data:`_UNKNOWN`.

    Raises:
        ConfigError: The recorded user's file is not there any more, or its content changed
            (its SHA-256 differs from the recorded one); a shipped name this version lacks.
    """
    if "shipped" in entry:
        name = str(entry["shipped"])
        if name not in shipped(kind, _role(kind, role)):
            message = f"{calibration} was made with the shipped {role} '{name}', which this fts-calib does not ship: give {option} FILE"
            raise ConfigError(option.lstrip("-"), name, f"a shipped {role}", message=message)
        digest = file_sha256(resolve(name, kind, _role(kind, role)))
        if entry.get("sha256") and entry["sha256"] != digest:
            warnings.warn(
                f"the shipped {role} '{name}' has changed since {calibration} was made (another fts-calib version: SHA-256 "
                f"{_short(entry['sha256'])} then, {_short(digest)} now); it is used as it is now ({option} FILE to use another)",
                FtsCalibWarning,
                stacklevel=3,
            )
        return name
    if "file" not in entry:  # written before files were recorded: an older robot entry names its robot only
        old = str(entry.get("name") or "")
        return old if kind == "robots" and old in shipped(kind) else _UNKNOWN
    if entry["file"] is None:
        return None
    path = Path(str(entry["file"]))
    if not path.is_file():
        message = (
            f"{calibration} was made with the {role} file {path}, which is not there any more (moved or deleted): "
            f"give {option} FILE, the {role} file of the recording"
        )
        raise ConfigError(option.lstrip("-"), str(path), f"the {role} file", message=message)
    recorded = entry.get("sha256")
    if recorded:
        digest = file_sha256(path)
        if digest != recorded:
            message = (
                f"{calibration} was made with the {role} file {path}, whose content has changed since (SHA-256 {_short(recorded)} "
                f"then, {_short(digest)} now): give {option} {path} to use it as it is now, or {option} FILE as it was"
            )
            raise ConfigError(option.lstrip("-"), str(path), f"the {role} file as it was", message=message)
    return str(path)


def _override(given: str | Path, entry: Mapping[str, Any], kind: str, role: str, option: str, calibration: str | Path) -> Any:
    """Say (on stdout) when ``given`` holds other content than the file the calibration records; returns ``given``."""
    recorded = entry.get("sha256")
    where = entry.get("file") or (f"the shipped {role} '{entry['shipped']}'" if "shipped" in entry else None)
    if not recorded or not where:
        return given
    try:
        digest = file_sha256(resolve(given, kind, _role(kind, role)))
    except (FtsCalibError, OSError):  # its loader names what is wrong with it
        return given
    if digest != recorded:
        print(f"note: {option} {given} overrides the {role} file {calibration} was made with ({where}; other content)")
    return given


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
    robot: str | Path | None, tool: str | Path = DEFAULT_TOOL, pipeline: str | Path = "pipeline", mount_rpy: Sequence[float] | None = None
) -> Loaded:
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
    return Loaded(kin, load_tool(resolve(tool, "configs", "tool")), load_settings(pipeline))

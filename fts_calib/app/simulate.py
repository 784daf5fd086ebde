"""The ``simulate`` command: a recording from planned trajectories, through the simulated sensor."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.exceptions import ConfigError, FileFormatError
from ..core.files import check_outputs
from ..core.resources import locate_trajectory, resolve
from ..model.sensor_config import load_sensor_config
from ..planning.trajectory_files import TrajectoryFile, read_trajectory
from ..robot.tool import Tool
from ..sim.pose_files import MIN_POSE_S, simulate_pose_files, still_poses
from ..sim.runs import simulate_recording
from ..sim.sensor import simulated_sensor
from .exit_codes import ExitCode, writing
from .setup import Setup


def trajectory_files(trajectory: str | Path) -> list[Path]:
    """The trajectory files a ``--trajectory`` names: a folder's ``*.csv`` and ``*.csv.gz``, or the one file."""
    folder = Path(trajectory)
    return sorted(folder.glob("*.csv")) + sorted(folder.glob("*.csv.gz")) if folder.is_dir() else [folder]


def trajectories_for(tool: Tool, trajectory: str | Path) -> list[TrajectoryFile]:
    """The first trajectory file for each configuration of ``tool``, in the tool's order.

    Args:
        tool: The tool whose configurations the files must name.
        trajectory: A folder of trajectory files (``*.csv``, ``*.csv.gz``), or one file.

    Raises:
        FileFormatError: No trajectory file, or none for a configuration of the tool.
    """
    folder = Path(trajectory)
    files = trajectory_files(trajectory)
    if not files:
        raise FileFormatError(folder, None, "no trajectory file (*.csv, *.csv.gz) in this folder")
    found: dict[str, TrajectoryFile] = {}
    for path in files:
        traj = read_trajectory(path)
        if traj.tool in tool.names:
            found.setdefault(traj.tool, traj)
    if not found:
        raise FileFormatError(folder, None, f"no trajectory for the configurations {tool.names} of '{tool.name}'")
    return [found[name] for name in tool.names if name in found]


@dataclass(frozen=True)
class Playback:
    """How the planned trajectories are played into a recording.

    Attributes:
        seed: Seed of the noise.
        noiseless: No noise at all.
        drift_rate: Offset drift of every bridge, in raw units per [s]; the sensor file's when None.
        tool_change_s: Pause between configurations, in [s].
        poses_only: Record only the samples where the arm holds still at a stop: a static-pose
            recording (poses separated by gaps).
        pose_files: Like ``poses_only``, but one file per pose: the output is then a folder
            that receives ``pose_01.csv``, ``pose_02.csv``, ... each starting at time 0
            (:mod:`fts_calib.sim.pose_files`).
    """

    seed: int = 0
    noiseless: bool = False
    drift_rate: float | None = None
    tool_change_s: float = 2.0
    poses_only: bool = False
    pose_files: bool = False


def run(setup: Setup, playback: Playback | None = None, *, trajectory: str | Path, output: str | Path) -> int:
    """Write a recording of planned trajectories, in the format a robot produces (``fts-calib simulate``).

    Args:
        setup: The robot, the tool, the sensor file with a ``simulation`` section (its noise
            per channel, or ``noise_std`` in raw units) and ``dynamic`` (the tool's full
            dynamic wrench; False: its static weight only).
        playback: The noise's seed, the drift, the pause between configurations, still poses only.
        trajectory: Folder of trajectory CSVs (one per configuration), or one file; or a shipped
            plan by name ('ur5', 'ur5/A.csv.gz': :func:`~fts_calib.core.resources.locate_trajectory`).
        output: Recording to write (.csv or .csv.gz); a folder with ``playback.pose_files``.

    Returns:
        0.

    Raises:
        ConfigError: ``output`` is one of the trajectory files (or the robot, tool or sensor file); still poses asked
            for (``poses_only``, ``pose_files``) of trajectories that never hold still.
        OSError: ``output`` cannot be written (checked before the simulation runs).
    """
    playback = playback or Playback()
    trajectory = locate_trajectory(trajectory)  # a shipped plan by name ('ur5') from any folder
    pose_files, poses_only, seed = playback.pose_files, playback.poses_only, playback.seed
    inputs = {f"the trajectory file {path.name}": path for path in trajectory_files(trajectory)}
    first = Path(output) / "pose_01.csv" if pose_files else output  # the folder's first file stands for it
    named = {"the robot file": setup.robot_file, "the tool file": setup.tool_file, "the sensor file": setup.sensor_file}
    check_outputs({"-o": first}, {**inputs, **named})
    kin, loaded = setup.kinematics, setup.tool
    sensor_path = resolve(setup.sensor_file, "configs")
    spec = load_sensor_config(sensor_path)
    simulated = simulated_sensor(spec, sensor_path)
    if setup.noise_std is not None:
        simulated = dataclasses.replace(simulated, noise_std=np.full(np.shape(simulated.noise_std), setup.noise_std, dtype=float))
    if playback.drift_rate is not None:
        simulated = dataclasses.replace(simulated, drift_rate=np.full(np.shape(simulated.drift_rate), playback.drift_rate, dtype=float))
    trajectories = trajectories_for(loaded, trajectory)
    if (poses_only or pose_files) and not still_poses(trajectories):
        option = "--pose-files" if pose_files else "--poses-only"
        message = (
            f"{option}: the trajectories of {trajectory} never hold still for {MIN_POSE_S:g} s (a continuous or smooth plan has "
            "no stops), so there is no static pose to record; plan with 'fts-calib trajectory --motion stop', or leave out "
            f"{option} to record the motion"
        )
        raise ConfigError(option, True, "trajectories with stops", message=message)
    missing = [name for name in loaded.names if name not in {t.tool for t in trajectories}]
    rng = None if playback.noiseless else np.random.default_rng(seed)
    with writing(output):
        if pose_files:
            files = simulate_pose_files(output, kin, loaded, trajectories, simulated, rng, playback.tool_change_s, setup.dynamic)
            path = f"{len(files)} pose files in {output} ({files[0].name} ... {files[-1].name}, each from time 0)"
        else:
            written = simulate_recording(
                output,
                kin,
                loaded,
                trajectories,
                simulated,
                rng,
                tool_change_s=playback.tool_change_s,
                dynamic=setup.dynamic,
                poses_only=poses_only,
            )
            path = str(written)
    rows = sum(len(t.time) for t in trajectories)
    if poses_only or pose_files:
        rows = sum(int(np.sum(np.all(t.qd == 0.0, axis=1) & np.all(t.qdd == 0.0, axis=1))) for t in trajectories)
    noise = "none" if rng is None else f"up to {simulated.noise_std.max():.2g} {spec.strain_unit} per channel (seed {seed})"
    wrench = "moving (Newton-Euler)" if setup.dynamic else "static"
    print(
        f"wrote {path}: {rows:,} rows, configurations {', '.join(t.tool for t in trajectories)}"
        + (f" (no trajectory for {missing})" if missing else "")
        + f"; tool wrench {wrench}, noise {noise}, "
        + (f"{simulated.adc_bits}-bit ADC" if simulated.adc_bits else "no quantization")
        + (f", {_nonlinearity(simulated)}" if simulated.quadratic or simulated.cubic else "")
        + ("; still at the stops only (a static-pose recording)" if poses_only or pose_files else "")
    )
    return ExitCode.OK


def _nonlinearity(sensor) -> str:
    """The simulated sensor's nonlinearity in words, e.g. 'quadratic 3 % FS at full load'."""
    terms = [f"{name} {100 * value:g} %" for name, value in (("quadratic", sensor.quadratic), ("cubic", sensor.cubic)) if value]
    return "nonlinearity " + " + ".join(terms) + " of full scale at full load"

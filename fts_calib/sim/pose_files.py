"""A simulated static-pose dataset of one file per pose, as a user records by hand.

The samples of :func:`fts_calib.sim.runs.simulate_batches` with ``poses_only`` (the arm
still at each stop of the planned trajectories) are cut into poses: a pose is a run of
samples of one configuration with no gap longer than :data:`GAP_PERIODS` sample periods.
Each pose is written to its own CSV recording (``pose_01.csv``, ``pose_02.csv``, ... in the
order recorded, numbered over the configurations), its time restarting at 0 as a logger
started for each pose writes it; a still stretch shorter than :data:`MIN_POSE_S` (the lone
first sample of a trajectory) is not a pose and gets no file. Read back together (``fts-calib calibrate 'poses/*.csv'``:
:mod:`fts_calib.sources.recording_set`), they are the same samples as the one-file
recording, each file a held-out unit.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path

import numpy as np

from ..core.exceptions import ConfigError
from ..planning.trajectory_files import TrajectoryFile
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool
from ..sources.batch import SampleBatch
from ..sources.recording import RecordingWriter
from .drift import OffsetDrift
from .runs import simulate_batches
from .sensor import SimulatedSensor

#: Samples further apart than this many sample periods belong to two poses.
GAP_PERIODS = 1.5
#: A still stretch shorter than this is a trajectory's first sample, not a pose: no file, [s].
MIN_POSE_S = 0.1

#: The names of the pose files: ``pose_`` and a number.
POSE_FILE = re.compile(r"pose_\d+\.csv(\.gz)?$")


def still_poses(trajectories: Sequence[TrajectoryFile]) -> int:
    """How many poses the trajectories hold still for: runs of rows of zero planned speed and acceleration, :data:`MIN_POSE_S` or longer.

    Args:
        trajectories: The planned trajectories (time [s], qd [rad/s], qdd [rad/s^2]).
    """
    count = 0
    for t in trajectories:
        still = np.all(t.qd == 0.0, axis=1) & np.all(t.qdd == 0.0, axis=1)
        edges = np.flatnonzero(np.diff(np.concatenate([[0], still.astype(np.int8), [0]])))
        starts, stops = edges[::2], edges[1::2] - 1  # each run of still rows: its first and last row
        count += int(np.count_nonzero(t.time[stops] - t.time[starts] >= MIN_POSE_S))
    return count


def split_poses(batches: Iterable[SampleBatch], period_s: float) -> Iterator[SampleBatch]:
    """The samples of ``batches`` (in time order) cut into poses (see the module docstring).

    Args:
        batches: Samples in time order, each batch of one configuration.
        period_s: The sample period [s].

    Yields:
        One batch per pose, its times as recorded [s].
    """
    parts: list[SampleBatch] = []

    def joined() -> SampleBatch:
        return SampleBatch.concatenate(parts)

    for batch in batches:
        cuts = np.flatnonzero(np.diff(batch.time) > GAP_PERIODS * period_s) + 1
        for a, b in zip([0, *cuts], [*cuts, len(batch)], strict=True):
            piece = batch.select(np.arange(a, b))
            if parts and (
                piece.time[0] - parts[-1].time[-1] > GAP_PERIODS * period_s or piece.configuration[0] != parts[-1].configuration[-1]
            ):
                yield joined()
                parts = []
            parts.append(piece)
    if parts:
        yield joined()


def simulate_pose_files(
    folder: str | Path,
    kin: Kinematics,
    tool: Tool,
    trajectories: Sequence[TrajectoryFile],
    sensor: SimulatedSensor,
    rng: np.random.Generator | None,
    tool_change_s: float = 2.0,
    dynamic: bool = True,
    drift: OffsetDrift | None = None,
) -> list[Path]:
    """Write a static-pose dataset of the trajectories' stops, one file per pose (see the module docstring).

    Args:
        folder: Folder to write ``pose_NN.csv`` into (created when missing).
        kin: Kinematics of the robot the trajectories are for.
        tool: The tool; each trajectory's ``tool`` names its configuration.
        trajectories: One trajectory per configuration, in the order they are run.
        sensor: The simulated sensor.
        rng: Random generator for the sensor noise (noiseless when None).
        tool_change_s: Pause between configurations [s].
        dynamic: Use the moving tool's wrench (True) or the static one.
        drift: Offsets that move, and a ``temperature`` column; constant offsets when None
            (as :func:`fts_calib.sim.runs.simulate_recording`).

    Returns:
        The files written, in the order recorded.

    Raises:
        ConfigError: ``folder`` already holds pose files (a glob over it would mix two datasets).
    """
    folder = Path(folder)
    old = sorted(p.name for p in folder.glob("pose_*") if POSE_FILE.match(p.name)) if folder.is_dir() else []
    if old:
        raise ConfigError(
            "-o",
            str(folder),
            "a folder without pose files",
            message=f"{folder} already holds pose files ({old[0]}, ... {len(old)} in all): a pattern over it would mix two "
            "datasets; remove them, or write to another folder",
        )
    period = min(float(np.median(np.diff(t.time))) for t in trajectories)
    poses = split_poses(simulate_batches(kin, tool, trajectories, sensor, rng, tool_change_s, 0.0, dynamic, drift, True), period)
    still = [np.all(t.qd == 0.0, axis=1) & np.all(t.qdd == 0.0, axis=1) for t in trajectories]
    count = sum(int(s[0]) + int(np.sum(s[1:] & ~s[:-1])) for s in still if len(s))  # runs of still rows: the poses
    width = max(2, len(str(count)))
    written = []
    kept = (pose for pose in poses if pose.time[-1] - pose.time[0] >= MIN_POSE_S)
    for k, pose in enumerate(kept, 1):  # one pose in memory at a time
        path = folder / f"pose_{k:0{width}d}.csv"
        with RecordingWriter(path, kin.joint_names, sensor.layout.n_channels, temperature=drift is not None) as writer:
            name = tool.names[int(pose.configuration[0])]
            writer.write(pose.time - pose.time[0], pose.joints, pose.channels, name, pose.temperature)
        written.append(path)
    return written

"""The one place a recording argument becomes a reader: a CSV recording or ROS 2 bags, by name.

- ``RUN.csv`` or ``RUN.csv.gz``: :class:`fts_calib.sources.recording.RecordingReader`; several
  of them (a static-pose dataset of one file per pose; patterns such as ``'poses/*.csv'``
  are expanded here): :class:`fts_calib.sources.recording_set.RecordingSet`;
- ``RUN.mcap``, ``RUN.db3``, a bag folder (with its ``metadata.yaml``), or several of them,
  each optionally ``:CONFIGURATION`` (the tool configuration it holds throughout):
  :class:`fts_calib.sources.bag.BagReader`.

Both readers yield :class:`fts_calib.sources.batch.SampleBatch` es and count what they skip
(``skipped``, ``rows_read``, ``bytes_read`` of ``size``, ``notes()``), so the jobs that read
recordings (calibrate, validate, replay) take either without knowing which.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..core.exceptions import RecordingError
from .bag import BagReader, BagTopics, is_bag, parse_bag_argument
from .recording_set import RecordingSet, expand_patterns

if TYPE_CHECKING:
    from .recording import RecordingReader


#: The smallest share of a recording's channel samples a job must use for its result to stand
#: (validate compares them, replay sends them): below it the result describes a sliver of the
#: recording (joint stamps on another clock, a tool never announced) and the job fails.
MIN_COVERAGE = 0.5

#: Suffixes of a CSV recording.
CSV_SUFFIXES = (".csv", ".gz")

#: The accepted kinds of recording, in words (for errors and help texts).
ACCEPTED = (
    "a CSV recording (.csv, .csv.gz), or ROS 2 bags (.mcap, .db3 or a bag folder with metadata.yaml, each optionally BAG:CONFIGURATION)"
)


def recording_paths(recording: str | Path | Sequence[str | Path]) -> list[str | Path]:
    """A recording argument as a list of paths: one, or several, each pattern (``'poses/*.csv'``) replaced by its matches.

    Raises:
        RecordingError: A pattern matches no file (:func:`fts_calib.sources.recording_set.expand_patterns`).
    """
    return expand_patterns([recording] if isinstance(recording, (str, Path)) else list(recording))


def open_recording(
    recording: str | Path | Sequence[str | Path],
    joint_names: Sequence[str] | None,
    tool_names: Sequence[str] | None,
    max_abs_channel: float | None = None,
    topics: BagTopics | None = None,
    continuous: Sequence[bool] | np.ndarray | None = None,
    max_gap_s: float = 0.05,
    latency_s: float = 0.0,
) -> RecordingReader | RecordingSet | BagReader:
    """The reader of a recording (see the module docstring).

    Args:
        recording: One or more CSV paths (or patterns), or one or more bags (``PATH`` or ``PATH:CONFIGURATION``).
        joint_names: The robot's joints, in its order; None for the file's.
        tool_names: The tool's configuration names, in order; None to accept any.
        max_abs_channel: Largest plausible channel magnitude, raw units (CSV notes rows beyond it).
        topics: Topic names of a bag (the defaults when None).
        continuous: Which joints are continuous, shape (n_joints,) (a bag's synchronizer).
        max_gap_s: Longest joint gap a bag's synchronizer interpolates across [s].
        latency_s: How late a bag's joint stamps are relative to its channel stamps [s].

    Raises:
        RecordingError: Not one of the accepted kinds (the message lists them), CSV files
            and bags mixed, a pattern that matches nothing, a set of CSV files that do not
            fit together (:class:`~fts_calib.sources.recording_set.RecordingSet`), or the reader's own errors (a
            :class:`~fts_calib.core.exceptions.BagError` for a bag).
    """
    paths = recording_paths(recording)
    if not paths:
        raise RecordingError(Path("."), None, None, f"no recording given: expected {ACCEPTED}")
    parts = [parse_bag_argument(p) for p in paths]
    if all(is_bag(part.path) for part in parts):
        return BagReader(parts, joint_names, tool_names, topics, continuous, max_gap_s, latency_s)
    if any(is_bag(part.path) for part in parts):
        other = next(p.path for p in parts if not is_bag(p.path))
        raise RecordingError(
            other, None, None, f"several recordings are either all CSV files or all ROS 2 bags, and this is not a bag: expected {ACCEPTED}"
        )
    for path in map(Path, paths):
        if path.suffix not in CSV_SUFFIXES and not path.exists():  # a missing CSV is the CSV reader's "file not found"
            raise RecordingError(path, None, None, f"file or folder not found (expected {ACCEPTED})")
        if path.is_dir():
            raise RecordingError(path, None, None, f"a folder without a metadata.yaml is not a ROS 2 bag: expected {ACCEPTED}")
        if path.suffix not in CSV_SUFFIXES:
            raise RecordingError(path, None, None, f"unknown kind of recording '{path.suffix or path.name}': expected {ACCEPTED}")
    from ..robot.orientation import GIMBAL_JOINTS
    from .recording import RecordingReader

    def open_csv(path: Path) -> RecordingReader:
        if joint_names is not None and tuple(joint_names) == GIMBAL_JOINTS:  # no robot: the file gives orientations
            from .orientation_recording import open_orientation_recording

            return open_orientation_recording(path, tool_names, max_abs_channel)
        return RecordingReader(path, joint_names, tool_names, max_abs_channel=max_abs_channel)

    if len(paths) == 1:
        return open_csv(Path(paths[0]))
    return RecordingSet(paths, open_csv)


def orientation_source(reader: RecordingReader | RecordingSet | BagReader, joint_names: Sequence[str] | None) -> str | None:
    """What gives the sensor's orientation in a run without a robot, for the words of a diagnosis.

    Args:
        reader: The reader :func:`open_recording` gave.
        joint_names: The joints it was opened with (the gimbal's in a run without a robot).

    Returns:
        A key of :data:`fts_calib.robot.orientation.ORIENTATION_FORMS` ('quaternion', 'roll-pitch-yaw',
        'tcp') for a CSV, 'pose topic' for bags, or None: a robot's joints.
    """
    from .bag import is_pose_run

    if not is_pose_run(joint_names):
        return None
    if isinstance(reader, BagReader):
        return "pose topic"
    from ..robot.orientation import orientation_form

    return orientation_form(reader.columns)

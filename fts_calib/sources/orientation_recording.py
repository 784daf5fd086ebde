"""A CSV recording that gives the sensor's orientation instead of joint angles (:mod:`fts_calib.robot.orientation`)."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from ..robot.orientation import GIMBAL_JOINTS, ORIENTATION_FORMS, missing_orientation, orientation_form, orientation_joints
from .batch import SampleBatch
from .recording import MAX_NOTES, RecordingReader

#: Largest accepted departure of a recorded quaternion's norm from 1 (as for bags and datagrams): a row beyond it is skipped.
MAX_QUATERNION_NORM_ERROR = 1e-3


class OrientationReader(RecordingReader):
    """A CSV reader whose joints are the gimbal's ``[yaw, pitch, roll]`` [rad], from a quaternion or a TCP rotation vector.

    A quaternion whose norm is more than :data:`MAX_QUATERNION_NORM_ERROR` from 1 is not a rotation
    written with a few digits but another quantity: its row is skipped (counted with the
    non-finite values) and the first such rows are noted with their line.

    Args:
        path: The CSV recording.
        form: ``'quaternion'`` or ``'tcp'`` (a key of :data:`fts_calib.robot.orientation.ORIENTATION_FORMS`).
        tool_names: The tool's configuration names; None to accept any.
        max_abs_channel: Largest plausible channel magnitude, raw units.
    """

    def __init__(self, path: str | Path, form: str, tool_names: Sequence[str] | None, max_abs_channel: float | None = None):
        super().__init__(path, ORIENTATION_FORMS[form], tool_names, max_abs_channel=max_abs_channel)
        self.form = form

    def __iter__(self) -> Iterator[SampleBatch]:
        for chunk in super().__iter__():
            joints = np.full((len(chunk), len(GIMBAL_JOINTS)), np.nan)
            finite = np.all(np.isfinite(chunk.joints), axis=1)  # a NaN stays a NaN: the checks skip and count it
            finite[finite] = np.linalg.norm(chunk.joints[finite], axis=1) > 0  # a zero quaternion too
            joints[finite] = orientation_joints(self.form, chunk.joints[finite])
            yield dataclasses.replace(chunk, joints=joints)

    def _note_values(self, table: np.ndarray, numbers: np.ndarray) -> None:
        """Note the rows the checks will skip, and blank (NaN) the quaternions that are not unit ones, noting them."""
        super()._note_values(table, numbers)
        if self.form != "quaternion" or not len(table):
            return
        q = table[:, 1 : 1 + len(self.joint_names)]
        norm = np.linalg.norm(q, axis=1)
        bad = np.isfinite(norm) & (np.abs(norm - 1.0) > MAX_QUATERNION_NORM_ERROR)
        for row in np.nonzero(bad)[0][:MAX_NOTES]:
            detail = f"columns 'qw,qx,qy,qz': the quaternion's norm is {norm[row]:.6g}, expected 1 (within {MAX_QUATERNION_NORM_ERROR:g})"
            self._notes.note(int(numbers[row]), detail + ": the sample is skipped", "orientation")
        self._notes.count(max(int(bad.sum()) - MAX_NOTES, 0), "orientation")
        q[bad] = np.nan  # in place: the checks skip and count the row


def open_orientation_recording(path: Path, tool_names: Sequence[str] | None, max_abs_channel: float | None = None) -> RecordingReader:
    """The reader of a CSV read with the gimbal's kinematics: its ``roll,pitch,yaw`` columns, or a quaternion or TCP pose.

    Raises:
        RecordingError: The header gives no orientation form (the message lists the forms).
    """
    with RecordingReader(path, None, tool_names, max_abs_channel=max_abs_channel) as probe:
        columns = list(probe.columns)
    form = orientation_form(columns)
    if form is None:
        raise missing_orientation(path, columns)
    if form == "roll-pitch-yaw":  # the gimbal's own joints, R = Rz(yaw) Ry(pitch) Rx(roll)
        return RecordingReader(path, GIMBAL_JOINTS, tool_names, max_abs_channel=max_abs_channel)
    return OrientationReader(path, form, tool_names, max_abs_channel)

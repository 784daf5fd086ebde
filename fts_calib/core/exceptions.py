"""Exceptions and warnings of fts-calib.

Every error the library raises on purpose derives from :class:`FtsCalibError`, so a
controller can catch one class; the subclasses carry the data a caller needs to react
(the frame names that exist, the rank reached, the file and line at fault). Soft
problems that do not stop a run (a reading outside the joint limits, a sample skipped)
are warnings of one class, :class:`FtsCalibWarning`, and are also counted in the
result's quality.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path


class FtsCalibError(Exception):
    """Root of every error raised by fts-calib."""


class FtsCalibWarning(UserWarning):
    """A soft problem: the run goes on, and the problem is counted."""


class ShapeError(FtsCalibError, ValueError):
    """An array has the wrong shape; the message gives the shape received and expected."""


class StructureError(FtsCalibError, ValueError):
    """A 6x8 calibration matrix is not of the form C = C_bar P (paper eq 7).

    Attributes:
        residual: Largest absolute entry of C - C_bar P, in the units of C.
        tolerance: The largest residual that would have been accepted.
    """

    def __init__(self, residual: float, tolerance: float):
        self.residual = residual
        self.tolerance = tolerance
        super().__init__(
            f"C is not of the form C_bar @ P (paper eq 7): the largest entry of "
            f"C - (C @ pinv(P)) @ P is {residual:.3g}, above the tolerance {tolerance:.3g}. "
            "The columns of C must satisfy c1 - c3 + c5 - c7 = 0 and c2 - c4 + c6 - c8 = 0; "
            "check the bridge order and signs."
        )


class InsufficientExcitation(FtsCalibError):
    """The data do not determine every coefficient: the information matrix is singular.

    Attributes:
        rank: Numerical rank reached so far (0 to ``full``).
        missing: How many independent directions are missing (``full - rank``).
        detail: What to do about it, in words.
        full: The rank that determines every coefficient (7 online: C_bar and D; 6 for
            the jig, whose offsets are removed beforehand).
    """

    def __init__(self, rank: int, missing: int, detail: str = "", full: int = 7):
        self.rank = rank
        self.missing = missing
        self.detail = detail
        self.full = full
        text = f"insufficient excitation: the information matrix has rank {rank} of {full}, {missing} independent direction(s) missing."
        super().__init__(text + (" " + detail if detail else ""))


class FileFormatError(FtsCalibError, ValueError):
    """A file (calibration, robot, tool, config) has a missing or wrong field.

    Attributes:
        path: The file at fault.
        field: The field at fault (dotted path), or None for the whole file.
    """

    def __init__(self, path: str | Path, field: str | None, message: str):
        self.path = Path(path)
        self.field = field
        where = f"{self.path}" + (f": field '{field}'" if field else "")
        super().__init__(f"{where}: {message}")


class RecordingError(FtsCalibError, ValueError):
    """A recording cannot be read at all (missing column, empty file, unreadable).

    Attributes:
        path: The recording.
        line: 1-based line number, or None.
        column: Column name, or None.
    """

    def __init__(self, path: str | Path, line: int | None, column: str | None, message: str):
        self.path = Path(path)
        self.line = line
        self.column = column
        where = str(self.path)
        if line is not None:
            where += f", line {line}"
        if column is not None:
            where += f", column '{column}'"
        super().__init__(f"{where}: {message}")


class FrameNotFound(FtsCalibError, KeyError):
    """A frame name is not in the robot model.

    Attributes:
        name: The frame asked for.
        available: The frames that exist.
    """

    def __init__(self, name: str, available: Sequence[str]):
        self.name = name
        self.available = list(available)
        super().__init__(name)

    def __str__(self) -> str:  # KeyError would print only repr(name)
        return f"frame '{self.name}' is not in the model; frames that exist: {', '.join(self.available)}"


class JointError(FtsCalibError, KeyError):
    """A joint name is unknown or missing, or a reading has the wrong length.

    Attributes:
        names: The offending joint names (unknown or missing), possibly empty.
        expected: The joint names the robot definition expects, in order.
    """

    def __init__(self, message: str, names: Sequence[str], expected: Sequence[str]):
        self.names = list(names)
        self.expected = list(expected)
        self.message = message
        super().__init__(message)

    def __str__(self) -> str:
        return f"{self.message}; expected joints, in order: {', '.join(self.expected)}"


class TrajectoryError(FtsCalibError):
    """Planning or verifying a calibration trajectory failed.

    Attributes:
        result: The ruckig result or check that failed, as text (e.g. 'ErrorInvalidInput').
    """

    def __init__(self, message: str, result: str | None = None):
        self.result = result
        super().__init__(message)

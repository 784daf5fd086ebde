"""Exceptions and warnings of fts-calib.

Every error the library raises on purpose derives from :class:`FtsCalibError`, so a
controller can catch one class; the subclasses carry the data a caller needs to react
(the frame names that exist, the rank reached, the file and line at fault). Soft
problems that do not stop a run (a reading outside the joint limits, a sample skipped)
are warnings of one class, :class:`FtsCalibWarning`, and are also counted in the
result's quality.

Every exception class of fts-calib is defined here (and exported by the package), so a
caller finds them in one place; they hold data only and import nothing of the other
stages.
"""

from __future__ import annotations

import difflib
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


class PoorFit(FtsCalibError):
    """The data do not fit the model at the noise level they show: the calibration is refused.

    Attributes:
        check: The fit check (:class:`fts_calib.session.fit.FitCheck`): verdict, residuals
            per configuration and axis, the expected noise and the diagnosis.
        calibration: The refused calibration (with the verdict in its quality), for a caller
            that decides to keep it anyway; None when the data determine none.
    """

    def __init__(self, check, calibration):
        self.check = check
        self.calibration = calibration
        super().__init__(
            f"the calibration does not fit its data: {check.summary()}. No calibration written; "
            "fix the cause, or accept it knowingly (--accept-poor-fit, accept_poor_fit=True)"
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
        if rank == 0 and detail:  # nothing to count directions of: say what is wrong, not 'rank 0 of 7'
            super().__init__(f"insufficient data: {detail}")
            return
        text = f"insufficient excitation: the information matrix has rank {rank} of {full}, {missing} independent direction(s) missing."
        super().__init__(text + (" " + detail if detail else ""))


class ModelNotDetermined(InsufficientExcitation):
    """A nonlinear sensor model the loads cannot determine beyond themselves (``--model quadratic`` on the paper's jig).

    Attributes:
        family: The family asked for ('quadratic' or 'cubic').
        rank: Its feature directions the loads fix (beyond the offsets).
        full: The most a jig of weights can fix.
        detail: What the jig lacks, in words.
    """

    def __init__(self, family: str, rank: int, full: int, detail: str):
        self.family = family
        FtsCalibError.__init__(
            self,
            f"no {family} model: the loads of this calibration cannot determine it beyond themselves ({detail}). "
            f"A {family} model fitted here would be free off the loads it saw (another tool, a push, a contact); "
            "'--model auto' keeps the linear model, and 'fts-calib trajectory --tool TOOL --model "
            f"{family}' names a jig that determines it",
        )
        self.rank, self.missing, self.detail, self.full = rank, max(full - rank, 0), detail, full


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


class BagError(RecordingError):
    """A ROS 2 bag cannot be read as a robot log (a topic missing or of another type, a joint missing).

    Attributes:
        path: The bag (a storage file or a bag folder).
        topic: The topic at fault, or None.
    """

    def __init__(self, path: str | Path, topic: str | None, message: str):
        self.topic = topic
        where = f", topic '{topic}'" if topic is not None else ""
        FtsCalibError.__init__(self, f"{path}{where}: {message}")
        self.path, self.line, self.column = Path(path), None, None


class FrameNotFound(FtsCalibError, KeyError):
    """A frame (or a link) name is not in the robot model.

    Attributes:
        name: The frame asked for.
        available: The frames that exist (of the kind asked for), each name once.
        where: Where the name was written (a robot file and its field), or ''.
        kind: What the name should be: 'frame' (any frame of the model) or 'link' (a URDF link).
        note: What the name is instead, if anything (e.g. a joint, with its child link), or ''.
    """

    def __init__(self, name: str, available: Sequence[str], where: str = "", kind: str = "frame", note: str = ""):
        self.name = name
        self.available = list(dict.fromkeys(available))  # a URDF link and joint of one name: listed once
        self.where = where
        self.kind = kind
        self.note = note
        super().__init__(name)

    def __str__(self) -> str:  # KeyError would print only repr(name)
        close = difflib.get_close_matches(self.name, self.available, 3)
        hint = f" (did you mean {' or '.join(repr(c) for c in close)}?)" if close else ""
        hint += f" ({self.note})" if self.note else ""
        head = f"{self.where}: " if self.where else ""
        return f"{head}{self.kind} '{self.name}' is not in the model{hint}; {self.kind}s that exist: {', '.join(self.available)}"


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
        if not self.expected:  # the message says what was expected
            return self.message
        return f"{self.message}; expected joints, in order: {', '.join(self.expected)}"


class TrajectoryError(FtsCalibError):
    """Planning or verifying a calibration trajectory failed.

    Attributes:
        result: The ruckig result or check that failed, as text (e.g. 'ErrorInvalidInput').
    """

    def __init__(self, message: str, result: str | None = None):
        self.result = result
        super().__init__(message)


class ConfigError(FtsCalibError, ValueError):
    """A setting, option or argument has a value fts-calib cannot use.

    The configuration dataclasses raise it from ``__post_init__``, so the Python API
    refuses what the file loaders refuse; a loader re-raises it as :class:`FileFormatError`
    naming the file and the field, with :attr:`reason` as the message.

    The message reads ``"{owner}: {field}={value} {unit} but expected {expected}"``
    (``"configuration 'A': mass=-1.0 kg but expected a finite value > 0"``), or
    ``"{owner}: {field} {reason}"`` when a reason is given, or ``message`` itself.

    Attributes:
        field: The field or argument at fault, as the raiser names it (e.g. 'gravity',
            'filter.max_joint_speed'); a loader prefixes the section it was read from.
        value: The value received.
        expected: What was expected, in words (e.g. 'a finite value > 0').
        reason: The problem without the field's name, as a loader shows it after the file
            and field: 'is 0.0 m/s² but expected a finite value > 0' unless given.
    """

    def __init__(
        self,
        field: str,
        value: object,
        expected: str,
        unit: str = "",
        owner: str = "",
        *,
        reason: str | None = None,
        message: str | None = None,
    ):
        self.field = field
        self.value = value
        self.expected = expected
        shown = (repr(value) if isinstance(value, str) else str(value)) + (f" {unit}" if unit else "")
        self.reason = reason or message or f"is {shown} but expected {expected}"
        text = message or (f"{field} {reason}" if reason else f"{field}={shown} but expected {expected}")
        super().__init__(f"{owner}: {text}" if owner else text)


class UnknownToolConfiguration(FtsCalibError, KeyError):
    """A tool configuration name is not in the tool file.

    Attributes:
        name: The name asked for.
        available: The configuration names of the tool.
    """

    def __init__(self, name: str, available: Sequence[str]):
        self.name = name
        self.available = list(available)
        super().__init__(name)

    def __str__(self) -> str:
        return f"tool configuration '{self.name}' is not in the tool file; configurations: {', '.join(self.available)}"


class UnsupportedJoint(FtsCalibError):
    """The URDF has a joint type the calibration cannot read from one number per joint."""


class ProtocolError(FtsCalibError, ValueError):
    """A datagram that is not a valid message.

    Attributes:
        reason: 'oversized' or 'malformed'.
    """

    def __init__(self, reason: str, detail: str):
        self.reason = reason
        super().__init__(f"{reason} datagram: {detail}")


class LimitError(FtsCalibError, ValueError):
    """An input beyond a limit of :mod:`fts_calib.core.bounded` (depth, digits, an alias); the message says which.

    The readers re-raise it naming their file (:class:`FileFormatError`) or count it (a
    datagram: :class:`ProtocolError`).
    """


class FeedTimeout(FtsCalibError):
    """A network peer (a robot controller, a sender) did not answer within its timeout.

    Attributes:
        what: What was waited for, in words (e.g. 'the RTDE handshake of the UR at 10.0.0.7:30004').
        timeout_s: How long it was waited for [s].
    """

    def __init__(self, what: str, timeout_s: float, hint: str = ""):
        self.what = what
        self.timeout_s = timeout_s
        super().__init__(f"no answer within {timeout_s:g} s: waited for {what}" + (f"; {hint}" if hint else ""))


class DeviceLost(ConnectionError):
    """A channel device cannot be opened, or stopped giving samples (the cable pulled); a run ends with what it has.

    A :class:`ConnectionError`: before any sample it exits 14 (the system refused a file or a socket).
    """


class PayloadError(FtsCalibError):
    """The orientations cannot determine the payload; the message says which are missing or too close."""


class ResourceNotFound(FtsCalibError, FileNotFoundError):
    """Neither a file nor a shipped name.

    Attributes:
        name: What was asked for.
        available: The shipped names of that kind.
    """

    def __init__(self, name: str, kind: str, available: list[str]):
        self.name = name
        self.available = available
        super().__init__(f"no file '{name}' and no shipped {kind} of that name; shipped: {', '.join(available) or 'none'}")


class RobotDataNotFound(FtsCalibError, FileNotFoundError):
    """The example-robot-data folder cannot be found; the message says what to install."""


class OutputInUse(FtsCalibError):
    """Another run is writing the same output file (it holds the output's lock).

    Attributes:
        path: The output both runs would write.
        pid: The process id of the run that holds the lock, or None when it did not say.
    """

    def __init__(self, path: str | Path, pid: int | None):
        self.path = Path(path)
        self.pid = pid
        who = f"process {pid}" if pid is not None else "another process"
        super().__init__(
            f"{self.path} is being written by another fts-calib run ({who}): two runs writing one file would lose one of them; "
            "wait for it to end, or give another output file"
        )


class ResultRefused(FtsCalibError):
    """The data do not support the result a command would write; nothing was written.

    Raised before a file is touched: a tare window that is not still, or whose load does not
    fit the one assumed (nothing mounted, or the named tool configuration; ``monitor --auto-tare``
    too); a payload identified heavier than the sensor's range.

    Attributes:
        reason: Why, in words (with the measured figures and what was expected).
    """

    def __init__(self, reason: str):
        self.reason = reason
        super().__init__(reason)


class NotARotation(ShapeError):
    """A matrix given as a rotation is not one: the Frobenius norm of ``R^T R - I`` above 1e-6, or ``det R <= 0``."""

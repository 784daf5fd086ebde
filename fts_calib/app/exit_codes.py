"""Exit codes of ``fts-calib``: one table, one code per family of errors.

Every error a user can cause is an :class:`~fts_calib.core.exceptions.FtsCalibError`
subclass; the command line prints it as one line on standard error
(``fts-calib COMMAND: error: ...``) and exits with the code of its family below, so a
script can tell a wrong file from a recording that lacks a column without reading the
message. :data:`EXIT_CODES` is the table the README documents; :func:`exit_code` looks an
error up in it.
"""

from __future__ import annotations

import contextlib
import enum
from dataclasses import dataclass
from pathlib import Path

from ..core.exceptions import (
    ConfigError,
    FeedTimeout,
    FileFormatError,
    FrameNotFound,
    FtsCalibError,
    InsufficientExcitation,
    JointError,
    LimitError,
    OutputInUse,
    PayloadError,
    PoorFit,
    ProtocolError,
    RecordingError,
    ResourceNotFound,
    ResultRefused,
    RobotDataNotFound,
    ShapeError,
    StructureError,
    TrajectoryError,
    UnknownToolConfiguration,
    UnsupportedJoint,
)


class ExitCode(enum.IntEnum):
    """The exit status of ``fts-calib``; :data:`EXIT_CODES` says what each means."""

    OK = 0
    CHECK_FAILED = 1
    USAGE = 2
    CONFIG = 3
    FILE = 4
    RECORDING = 5
    ROBOT = 6
    TOOL_CONFIGURATION = 7
    EXCITATION = 8
    TRAJECTORY = 9
    PAYLOAD = 10
    PROTOCOL = 11
    ARRAY = 12
    OTHER = 13
    FILE_ACCESS = 14
    POOR_FIT = 15
    OUTPUT_IN_USE = 16
    RESULT_REFUSED = 17
    TIMEOUT = 18
    INTERRUPTED = 130


@dataclass(frozen=True)
class ExitCodeEntry:
    """One row of the exit-code table.

    Attributes:
        code: The exit status.
        errors: The exception classes that exit with it (empty: not an exception).
        meaning: What it means, in words.
    """

    code: ExitCode
    errors: tuple[type[BaseException], ...]
    meaning: str


#: The exit codes, in the order an error is looked up: the first row whose classes match
#: wins, so the catch-all rows (any other FtsCalibError, then OSError) come last.
EXIT_CODES: tuple[ExitCodeEntry, ...] = (
    ExitCodeEntry(ExitCode.OK, (), "success"),
    ExitCodeEntry(
        ExitCode.CHECK_FAILED,
        (),
        "the job ran but its result failed a check: a validation error above --max-error, a failed trajectory "
        "check, a live run to which no data came",
    ),
    ExitCodeEntry(
        ExitCode.USAGE,
        (),
        "command-line usage: an unknown option, a missing argument, a malformed value (argparse; a numeric option "
        "given text that is not a number, --x=-- too)",
    ),
    ExitCodeEntry(
        ExitCode.CONFIG,
        (ConfigError,),
        "a setting, option or argument has a value fts-calib cannot use (a numeric option given nan or inf)",
    ),
    ExitCodeEntry(
        ExitCode.FILE,
        (FileFormatError, ResourceNotFound, LimitError),
        "a file or a shipped name does not resolve, or a file (robot, tool, calibration, settings) has a missing or wrong field, "
        "or is beyond a limit of size, depth or number",
    ),
    ExitCodeEntry(ExitCode.RECORDING, (RecordingError,), "a recording cannot be read (missing, empty, a missing column)"),
    ExitCodeEntry(
        ExitCode.ROBOT,
        (FrameNotFound, JointError, UnsupportedJoint, RobotDataNotFound),
        "the robot definition does not match its URDF (frame, joint, joint type), or the URDF's package is missing",
    ),
    ExitCodeEntry(ExitCode.TOOL_CONFIGURATION, (UnknownToolConfiguration,), "a tool configuration name is not in the tool file"),
    ExitCodeEntry(
        ExitCode.EXCITATION,
        (InsufficientExcitation,),
        "no calibration: the data cannot determine every coefficient (centres of mass missing, weak excitation; the message names which)",
    ),
    ExitCodeEntry(
        ExitCode.POOR_FIT,
        (PoorFit,),
        "the calibration does not fit its data at their noise level: refused, no file written (the diagnosis names the likely cause)",
    ),
    ExitCodeEntry(
        ExitCode.OUTPUT_IN_USE,
        (OutputInUse,),
        "another run is writing the same output file (its lock is held; the message names its pid): nothing written",
    ),
    ExitCodeEntry(
        ExitCode.RESULT_REFUSED,
        (ResultRefused,),
        "the data do not support the result the command would write (a tare window that moves, or whose load is not "
        "the one assumed, also monitor's re-tare; a payload heavier than the sensor's range): refused before any file was touched",
    ),
    ExitCodeEntry(ExitCode.TRAJECTORY, (TrajectoryError,), "planning or verifying a trajectory failed"),
    ExitCodeEntry(ExitCode.PAYLOAD, (PayloadError,), "the orientations of a payload recording cannot determine the payload"),
    ExitCodeEntry(ExitCode.PROTOCOL, (ProtocolError,), "a live-protocol datagram is not a valid message"),
    ExitCodeEntry(
        ExitCode.TIMEOUT,
        (FeedTimeout,),
        "a network peer did not answer within its timeout (a UR controller that accepts the connection and sends nothing: --ur-timeout)",
    ),
    ExitCodeEntry(ExitCode.ARRAY, (ShapeError, StructureError), "an array has the wrong shape, or C is not of the form C_bar P"),
    ExitCodeEntry(ExitCode.OTHER, (FtsCalibError,), "any other fts-calib error"),
    ExitCodeEntry(ExitCode.FILE_ACCESS, (OSError,), "the system refused to read or write a file or a socket"),
    ExitCodeEntry(ExitCode.INTERRUPTED, (KeyboardInterrupt,), "interrupted (Ctrl-C)"),
)


def exit_code(error: BaseException) -> ExitCode:
    """The exit code of an error: the first row of :data:`EXIT_CODES` whose classes match.

    Raises:
        TypeError: ``error`` belongs to no family (a bug, not a user error).
    """
    for entry in EXIT_CODES:
        if entry.errors and isinstance(error, entry.errors):
            return entry.code
    raise TypeError(f"{type(error).__name__} has no exit code") from error


def error_line(error: BaseException) -> str:
    """The message of an error on one line (an OSError says what it could not do)."""
    if isinstance(error, OSError) and not isinstance(error, FtsCalibError):
        reason = error.strerror or str(error)
        text = reason if error.filename is None else f"cannot access {error.filename}: {reason}"
    else:
        text = str(error)
    return " ".join(part.strip() for part in text.splitlines() if part.strip()) or type(error).__name__


def writing(path: str | Path) -> contextlib.AbstractContextManager[None]:
    """Say which file could not be written: :func:`fts_calib.core.files.writing` (imported when used: this module stays light)."""
    from ..core import files

    return files.writing(path)


def using_udp(host: str, port: int) -> contextlib.AbstractContextManager[None]:
    """Say which address could not be used: an OSError inside becomes ``cannot use udp://HOST:PORT: reason``."""
    from ..core import files

    return files.naming(f"use udp://{host}:{port}")

"""Output paths checked before a job starts: never one of its inputs, and writable.

A job that reads a recording for minutes must neither replace one of its inputs with its
result (``-o recording.csv``) nor fail at its last step because the result cannot be
written (``-o`` an existing folder, a read-only folder). Both are checked before any work,
and refused in one line: :func:`check_distinct` raises :class:`ConfigError`,
:func:`check_writable` an :class:`OSError` that says which file it could not write.
"""

from __future__ import annotations

import errno
import os
import tempfile
from collections.abc import Mapping
from pathlib import Path

from .exceptions import ConfigError
from .outputs import STDOUT, written_directly

PathLike = str | Path


def same_file(a: PathLike, b: PathLike) -> bool:
    """Whether two paths name the same file (through links and ``..``), existing or not."""
    a, b = Path(a), Path(b)
    try:
        if a.exists() and b.exists():
            return os.path.samefile(a, b)
    except OSError:
        pass
    return a.resolve() == b.resolve()


def check_distinct(outputs: Mapping[str, PathLike | None], inputs: Mapping[str, PathLike | None]) -> None:
    """Refuse an output that is one of the inputs, or another output.

    Args:
        outputs: Option (e.g. '-o', '--checkpoint') -> the file it writes; None entries are skipped.
        inputs: What an input is, in words (e.g. 'the recording') -> its file; None entries,
            and names that are no existing file (a shipped robot name, a recording that the
            reader will report missing), are skipped.

    Raises:
        ConfigError: An output is an input or another output; the message names both.
    """
    given = [(flag, Path(path)) for flag, path in outputs.items() if path is not None and str(path) != STDOUT]
    sources = [(what, Path(path)) for what, path in inputs.items() if path is not None and Path(path).is_file()]
    for k, (flag, path) in enumerate(given):
        clash = [what + ("" if source == path else f" ({source})") for what, source in sources if same_file(path, source)]
        clash += [f"the file of {other}" for other, source in given[:k] if same_file(path, source)]
        if clash:
            raise ConfigError(
                flag.lstrip("-"),
                str(path),
                "a file that is not an input",
                message=f"{flag} {path} is {clash[0]}: writing it would destroy it; choose another file",
            )


def check_writable(path: PathLike) -> Path:
    """Check that ``path`` can be written (atomically: a file created beside it, then renamed).

    Standard output (``-``), a character device or a FIFO is written directly: it must be
    writable. A folder that does not exist yet is fine when its nearest existing ancestor is a
    writable folder (the atomic writer creates it). The check creates and removes an empty
    temporary file there: what the system really allows, whoever runs it.

    Args:
        path: The file a job will write.

    Returns:
        ``path``.

    Raises:
        OSError: ``path`` is a folder, lies under a file, or its folder cannot be written;
            the message reads ``cannot write PATH: reason``.
    """
    if written_directly(path):  # standard output, a device or a FIFO: written in place, never replaced
        if str(path) != STDOUT and not os.access(path, os.W_OK):
            raise OSError(errno.EACCES, f"cannot write {path}: permission denied")
        return Path(path)
    path = Path(path)
    if path.is_dir():
        raise OSError(errno.EISDIR, f"cannot write {path}: it is a folder; give the name of a file (in it, or elsewhere)")
    folder = path.parent
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    if not folder.is_dir():
        raise OSError(errno.ENOTDIR, f"cannot write {path}: {folder} is a file, not a folder")
    try:
        fd, probe = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".probe", dir=folder)
    except OSError as exc:
        raise OSError(exc.errno, f"cannot write {path}: {exc.strerror or exc} (in {folder})") from None
    os.close(fd)
    os.unlink(probe)
    return path


def check_outputs(outputs: Mapping[str, PathLike | None], inputs: Mapping[str, PathLike | None]) -> None:
    """Before a job starts: every output is no input (:func:`check_distinct`) and can be written (:func:`check_writable`).

    Raises:
        ConfigError: An output is an input or another output.
        OSError: An output cannot be written.
    """
    check_distinct(outputs, inputs)
    for path in outputs.values():
        if path is not None:
            check_writable(path)

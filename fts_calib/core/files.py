"""The one output guard of the package: every file fts-calib writes goes through it.

Every file fts-calib writes (calibrations, exports, plots, trajectories, recordings,
checkpoints, reports) goes through :class:`AtomicFile`, which applies three rules:

- *whole files only*: a regular file is written to a temporary file in the same folder,
  flushed to disk, then renamed over the target: a crash leaves either the old file or the
  new one, never half a file; on any failure (a disk that fills, an interrupt) the temporary
  file is removed;
- *nothing that is not ours is replaced*: standard output (``-``), a character device
  (``/dev/null``, a serial port) or a FIFO is written directly, never renamed over; a block
  device or a socket is refused;
- *one writer per file*: while a file is being written, its lock (:class:`OutputLock`, an
  ``flock`` on ``.NAME.lock`` beside it, holding the writer's pid) is held; a second process
  that wants to write the same file is refused with :class:`OutputInUse` naming the first.
  Long writers (``live``, ``calibrate``) hold the lock of their output and checkpoint for
  the whole run. The kernel releases the lock when the process ends, even on a crash.

YAML reading shared by every file kind, and the writers' import path of the output guard.

Files are written through :mod:`fts_calib.core.files` (whole files only, devices and FIFOs
written in place, one writer per file); its writers are importable from here too.
PyYAML is imported on the first YAML read or write, not with this module: the
in-controller path (:mod:`fts_calib.service.reader`) never needs it.

Output paths checked before a job starts: never one of its inputs, and writable.

A job that reads a recording for minutes must neither replace one of its inputs with its
result (``-o recording.csv``) nor fail at its last step because the result cannot be
written (``-o`` an existing folder, a read-only folder). Both are checked before any work,
and refused in one line: :func:`check_distinct` raises :class:`ConfigError`,
:func:`check_writable` an :class:`OSError` that says which file it could not write.
"""

from __future__ import annotations

import contextlib
import difflib
import errno
import hashlib
import math
import os
import stat
import sys
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any

import numpy as np

from .bounded import parse_yaml, read_bounded_text
from .exceptions import ConfigError, FileFormatError, FtsCalibError, OutputInUse
from .tables import utf8_safe

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX: outputs are written unlocked
    fcntl = None  # type: ignore[assignment]

#: The output name that means standard output.
STDOUT = "-"


@contextmanager
def naming(what: str) -> Iterator[None]:
    """An OSError inside becomes ``cannot WHAT: reason`` (an fts-calib error passes as it is)."""
    try:
        yield
    except OSError as exc:
        if isinstance(exc, FtsCalibError):
            raise
        raise OSError(exc.errno, f"cannot {what}: {exc.strerror or exc}") from exc


def writing(path: str | Path) -> contextlib.AbstractContextManager[None]:
    """Say which file could not be written: an OSError inside becomes ``cannot write PATH: reason``.

    The atomic writer works on a temporary file beside ``path``; the user asked for
    ``path``, so that is the name the message shows.
    """
    return naming(f"write {path}")


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` through the output guard (see the module docstring).

    Args:
        path: Destination file; its folder is created when missing. ``-`` is standard
            output; an existing character device or FIFO is written directly.
        text: Content, written as UTF-8 (the undecodable bytes of a file name in it as
            backslash escapes: :func:`fts_calib.core.tables.utf8_safe`).

    Returns:
        The destination path.
    """
    return atomic_write_bytes(path, utf8_safe(text).encode("utf-8"))


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` through the output guard; see :func:`atomic_write_text`."""
    with AtomicFile(path) as target:
        target.handle.write(data)
    return target.path


def written_directly(path: str | Path) -> bool:
    """Whether an output is written directly rather than replaced: ``-`` (standard output), a character device or a FIFO.

    Raises:
        OSError: ``path`` is a block device or a socket (never an output); the message
            reads ``cannot write PATH: ...``.
    """
    if str(path) == STDOUT:
        return True
    try:
        mode = os.stat(path).st_mode
    except OSError:  # missing (or unreachable: the writer will say why)
        return False
    if stat.S_ISBLK(mode) or stat.S_ISSOCK(mode):
        kind = "a block device" if stat.S_ISBLK(mode) else "a socket"
        raise OSError(errno.EINVAL, f"cannot write {path}: it is {kind}, not a file; give a file name")
    return stat.S_ISCHR(mode) or stat.S_ISFIFO(mode)


def lock_path(path: str | Path) -> Path:
    """The lock file of an output: ``.NAME.lock`` in the same folder."""
    path = Path(path)
    return path.with_name(f".{path.name}.lock")


#: Locks this process holds: resolved output -> [lock file descriptor, depth]. A process
#: takes the lock of an output once; nested writers (a checkpoint written during a run that
#: holds its lock) count up.
_HELD: dict[str, list[int]] = {}


class OutputLock:
    """The lock of an output file, held by one process at a time (see the module docstring).

    An ``flock`` on ``.NAME.lock`` beside the output; the file holds the holder's pid, which
    a refused run names. Re-entrant within a process. Without ``fcntl`` (not POSIX) it does
    nothing.

    Args:
        path: The output file.
    """

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self._key = os.path.realpath(self.path)
        self._taken = False

    def acquire(self) -> OutputLock:
        """Take the lock.

        Raises:
            OutputInUse: Another process holds it; the exception carries its pid.
            OSError: The lock file cannot be created (the folder is not writable).
        """
        if fcntl is None or self._taken:
            return self
        held = _HELD.get(self._key)
        if held is not None:
            held[1] += 1
            self._taken = True
            return self
        lock = lock_path(self.path)
        while True:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT | getattr(os, "O_CLOEXEC", 0), 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                pid = _read_pid(fd)
                os.close(fd)
                raise OutputInUse(self.path, pid) from None
            # its holder may have removed the file between our open and flock: lock the file at the path
            try:
                here = os.stat(lock)
                mine = os.fstat(fd)
                if (here.st_dev, here.st_ino) == (mine.st_dev, mine.st_ino):
                    break
            except FileNotFoundError:
                pass
            os.close(fd)
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        _HELD[self._key] = [fd, 1]
        self._taken = True
        return self

    def release(self) -> None:
        """Give the lock back (the lock file is removed by its last holder)."""
        if not self._taken:
            return
        self._taken = False
        held = _HELD.get(self._key)
        if held is None:
            return
        held[1] -= 1
        if held[1] == 0:
            del _HELD[self._key]
            try:
                os.unlink(lock_path(self.path))  # while still holding it: a waiting run then locks a fresh file
            except OSError:
                pass
            os.close(held[0])

    def __enter__(self) -> OutputLock:
        return self.acquire()

    def __exit__(self, exc_type, exc, tb) -> None:
        self.release()


@contextmanager
def holding_outputs(paths: Iterable[str | Path | None]) -> Iterator[None]:
    """Hold the lock of each output for the whole of a run (``live``, ``calibrate``: their ``-o`` and checkpoint).

    Standard output, devices, FIFOs and outputs whose folder does not exist yet are skipped
    (:class:`AtomicFile` locks those when it creates them); an output whose lock cannot be
    created is left to the writer to report.

    Raises:
        OutputInUse: Another process is writing one of them (it names its pid).
    """
    locks = []
    try:
        for path in paths:
            if path is None or written_directly(path) or not Path(path).parent.is_dir():
                continue
            lock = OutputLock(path)
            try:
                lock.acquire()
            except OutputInUse:
                raise
            except OSError:  # e.g. a read-only folder: the output check says it in the user's words
                continue
            locks.append(lock)
        yield
    finally:
        for lock in reversed(locks):
            lock.release()


def _read_pid(fd: int) -> int | None:
    try:
        text = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
        return int(text) if text.isdigit() else None
    except OSError:
        return None


class AtomicFile:
    """A file that appears at ``path`` only when complete: the output guard every writer uses (see the module docstring).

    For a regular (or new) file, bytes go to a temporary file in the same folder (``handle``,
    binary) while the output's lock is held; :meth:`commit` flushes and fsyncs it, gives it
    the mode of the file it replaces (or of a plain ``open``), and renames it over ``path``;
    :meth:`abort` removes it. Standard output (``-``), a character device or a FIFO is
    written directly (``handle`` is the stream itself). As a context manager it commits on
    success and aborts on an exception, so a crash never leaves half a file, nor a
    temporary one.

    Args:
        path: Destination file; its folder is created when missing.

    Raises:
        OutputInUse: Another process is writing ``path``.
        OSError: The file cannot be written (a block device, a folder in the way, no space).
    """

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self._tmp: str | None = None
        self._lock: OutputLock | None = None
        self._direct = written_directly(path)
        self.handle: IO[bytes]
        if self._direct:
            if str(path) == STDOUT:
                sys.stdout.flush()  # what was printed before comes first
                self.handle = sys.stdout.buffer
            else:
                self.handle = open(self.path, "wb")  # closed by commit or abort
            return
        blocking = next((folder for folder in reversed(self.path.parents) if folder.exists() and not folder.is_dir()), None)
        if blocking is not None:  # mkdir would say "File exists", of the file the user did not name
            raise NotADirectoryError(errno.ENOTDIR, f"{blocking} is a file, not a folder")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._lock = OutputLock(self.path).acquire()
        try:
            fd, self._tmp = tempfile.mkstemp(prefix=f".{self.path.name}.", suffix=".tmp", dir=self.path.parent)
            self.handle = os.fdopen(fd, "wb")
        except BaseException:
            self._cleanup()
            raise

    def commit(self) -> Path:
        """Flush, fsync and rename into place (a direct output: flush); returns the destination."""
        try:
            self.handle.flush()
            if self._direct:
                if self.handle is not sys.stdout.buffer:
                    self.handle.close()
                return self.path
            os.fsync(self.handle.fileno())
            self.handle.close()
            # mkstemp makes the file private: give it the mode of the file it replaces, or the
            # mode a plain open() would give
            tmp = str(self._tmp)
            os.chmod(tmp, self.path.stat().st_mode & 0o7777 if self.path.exists() else new_file_mode())
            os.replace(tmp, self.path)
            self._tmp = None
        except BaseException:
            self.abort()
            raise
        self._cleanup()
        return self.path

    def abort(self) -> None:
        """Drop the temporary file (nothing is left behind); a direct output is closed as it is."""
        try:
            if not (self._direct and self.handle is sys.stdout.buffer):
                self.handle.close()  # may flush a buffer into a full disk: the file goes all the same
        except (OSError, ValueError):
            pass
        finally:
            self._cleanup()

    def _cleanup(self) -> None:
        if self._tmp is not None:
            Path(self._tmp).unlink(missing_ok=True)
            self._tmp = None
        if self._lock is not None:
            self._lock.release()
            self._lock = None

    def __enter__(self) -> AtomicFile:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.commit()
        else:
            self.abort()


def new_file_mode() -> int:
    """The mode ``open()`` gives a new file under the current umask (0o666 less the umask)."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


_DUMPERS: list[Any] = []  # the YAML dumper class, made on first use (PyYAML imported then)


def _flow_dumper() -> Any:
    """YAML dumper that writes lists of scalars on one line (matrix rows stay readable)."""
    if not _DUMPERS:
        import yaml

        class FlowDumper(yaml.SafeDumper):
            """No aliases in what we write: the loader refuses them."""

            def ignore_aliases(self, data: Any) -> bool:  # noqa: D102
                return True

        def represent_list(dumper: yaml.SafeDumper, data: list) -> yaml.Node:
            flow = all(not isinstance(item, (list, dict, tuple)) for item in data)
            return dumper.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=flow)

        FlowDumper.add_representer(list, represent_list)
        _DUMPERS.append(FlowDumper)
    return _DUMPERS[0]


def to_plain(value: Any) -> Any:
    """Convert numpy arrays and scalars, tuples and mappings into plain YAML-safe types (text: :func:`~fts_calib.core.tables.utf8_safe`)."""
    if isinstance(value, np.ndarray):
        return to_plain(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Mapping):
        return {utf8_safe(str(k)): to_plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_plain(v) for v in value]
    if isinstance(value, Path):
        return utf8_safe(str(value))
    if isinstance(value, str):
        return utf8_safe(value)
    return value


def dump_yaml(data: Mapping[str, Any]) -> str:
    """Render a mapping as YAML text, with numeric rows in flow style, keys in given order."""
    import yaml

    return yaml.dump(to_plain(data), Dumper=_flow_dumper(), sort_keys=False, allow_unicode=True, width=120)


def load_yaml(path: str | Path) -> dict[str, Any]:
    """Read a YAML file whose top level is a mapping, within the limits of :mod:`fts_calib.core.bounded`.

    Raises:
        FileFormatError: The file is missing, larger than the limit, binary, not valid YAML
            or beyond a limit (anchors, depth, numbers; the message gives line and column),
            or its top level is not a mapping.
    """
    path = Path(path)
    data = parse_yaml(read_bounded_text(path, "YAML"), path)
    if not isinstance(data, dict):
        raise FileFormatError(path, None, f"expected a mapping at the top level, got {type(data).__name__}")
    return data


#: A top-level key that only one kind of fts-calib file has, and that kind: named when such a
#: file is given where another kind is expected.
FILE_KINDS = {
    "configurations": "a tool file",
    "urdf": "a robot definition",
    "C_bar": "a calibration file",
    "strain_unit": "a sensor configuration",
    "filter": "a pipeline configuration",
    "duration_s": "a plan file",
}


def check_keys(data: Mapping[str, Any], known: Iterable[str], path: str | Path, section: str | None = None) -> None:
    """Refuse the keys of a file's mapping that the loader does not know (a typo such as ``mas``).

    Args:
        data: The mapping read from the file.
        known: The keys the file format has.
        path: The file, for the message.
        section: The field the mapping was read from (e.g. 'configurations[0]'), or None for
            the top level.

    Raises:
        FileFormatError: Some keys are unknown; the message lists them and the known keys.
    """
    names = list(known)
    unknown = [str(key) for key in data if key not in names]
    if unknown:
        hint = "".join(f" ('{key}': did you mean '{close[0]}'?)" for key in unknown if (close := difflib.get_close_matches(key, names, 1)))
        kind = next((FILE_KINDS[key] for key in unknown if key in FILE_KINDS), None) if section is None else None
        if kind is not None:  # a whole file of another kind, given to the wrong option (--sensor paper_tool)
            hint = f" (it looks like {kind}, not the kind of file expected here)"
        raise FileFormatError(path, section, f"unknown keys {unknown}{hint}; known keys: {', '.join(names)}")


def require(data: Mapping[str, Any], key: str, path: str | Path, prefix: str = "") -> Any:
    """Return ``data[key]`` or raise FileFormatError naming the missing field."""
    if key not in data:
        raise FileFormatError(path, prefix + key, "missing (required)")
    return data[key]


def read_array(value: Any, shape: tuple[int, ...], path: str | Path, field: str) -> np.ndarray:
    """Convert a YAML value into a finite float array of exactly ``shape``.

    Raises:
        FileFormatError: Not numeric, wrong shape (received and expected given), or not finite.
    """
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise FileFormatError(path, field, f"expected numbers of shape {shape}, got {value!r}") from None
    if array.shape != shape:
        raise FileFormatError(path, field, f"shape {array.shape} but expected {shape}")
    if not np.all(np.isfinite(array)):
        raise FileFormatError(path, field, "contains NaN or inf")
    return array


def read_number(value: Any, path: str | Path, field: str, unit: str = "") -> float:
    """Convert a YAML value into a float; its range is for the dataclass it goes into to check.

    Args:
        value: The raw value.
        path: The file, for the message.
        field: The field, for the message.
        unit: Unit text for the message (e.g. 'kg'), or empty.

    Raises:
        FileFormatError: Not a number (the message shows the value).
    """
    try:
        return float(value)
    except (TypeError, ValueError, OverflowError):
        raise FileFormatError(path, field, f"expected a number{' in ' + unit if unit else ''}, got {value!r}") from None


def read_positive(value: Any, path: str | Path, field: str, unit: str = "") -> float:
    """Convert a YAML value into a finite number > 0, for a file field that no dataclass field holds.

    Args:
        value: The raw value.
        path: The file, for the message.
        field: The field, for the message.
        unit: Unit text for the message (e.g. 'kg'), or empty.

    Raises:
        FileFormatError: Not a number, or not finite and > 0 (the message shows the value).
    """
    suffix = f" {unit}" if unit else ""
    number = read_number(value, path, field, unit)
    if not (math.isfinite(number) and number > 0):
        raise FileFormatError(path, field, f"is {number}{suffix} but expected a finite value > 0")
    return number


@contextmanager
def fields_of(path: str | Path, prefix: str = "", names: Mapping[str, str] | None = None) -> Iterator[None]:
    """Re-raise the ConfigError of a dataclass built from a file as FileFormatError naming the file and field.

    The dataclass checks its values (``__post_init__``); the loader only says where they
    came from: ``with fields_of(path, "configurations[0].", {"p_sensor_com": "com"}): ...``.

    Args:
        path: The file the values were read from.
        prefix: The section of the file the dataclass was read from (e.g. 'limits.'), or empty.
        names: The file's name of each dataclass field named differently, e.g.
            ``{"p_sensor_com": "com"}``; the first part of a dotted field is mapped.

    Raises:
        FileFormatError: Instead of the ConfigError, with its reason as the message.
    """
    try:
        yield
    except ConfigError as exc:
        head, dot, rest = exc.field.partition(".")
        field = (names or {}).get(head, head) + dot + rest
        raise FileFormatError(path, prefix + field, exc.reason) from None


def is_number(text: str) -> bool:
    """Whether ``float(text)`` succeeds (for error messages that point at the bad cell)."""
    try:
        float(text)
    except ValueError:
        return False
    return True


PathLike = str | Path


def file_sha256(path: PathLike) -> str:
    """The SHA-256 of a whole file's bytes, as 64 hex digits (read 1 MiB at a time).

    Raises:
        OSError: The file cannot be read (missing, a folder, no permission).
    """
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


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

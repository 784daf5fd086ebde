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
"""

from __future__ import annotations

import errno
import os
import stat
import sys
import tempfile
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO

from .exceptions import OutputInUse
from .text import utf8_safe

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX: outputs are written unlocked
    fcntl = None  # type: ignore[assignment]

#: The output name that means standard output.
STDOUT = "-"


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` through the output guard (see the module docstring).

    Args:
        path: Destination file; its folder is created when missing. ``-`` is standard
            output; an existing character device or FIFO is written directly.
        text: Content, written as UTF-8 (the undecodable bytes of a file name in it as
            backslash escapes: :func:`fts_calib.core.text.utf8_safe`).

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

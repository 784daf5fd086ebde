"""Atomic writes and YAML reading shared by every file kind.

A file is written to a temporary file in the same folder, flushed to disk, then renamed
over the target: a crash leaves either the old file or the new one, never half a file.
"""

from __future__ import annotations

import difflib
import errno
import math
import os
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from .bounded import parse_yaml, read_bounded_text
from .exceptions import ConfigError, FileFormatError
from .text import utf8_safe


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically (temporary file in the same folder, then rename).

    Args:
        path: Destination file; its folder is created when missing.
        text: Content, written as UTF-8 (the undecodable bytes of a file name in it as
            backslash escapes: :func:`fts_calib.core.text.utf8_safe`).

    Returns:
        The destination path.
    """
    return atomic_write_bytes(path, utf8_safe(text).encode("utf-8"))


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically; see :func:`atomic_write_text`."""
    with AtomicFile(path) as target:
        target.handle.write(data)
    return target.path


class AtomicFile:
    """A file that appears at ``path`` only when complete: the one atomic writer of the package.

    Bytes go to a temporary file in the same folder (``handle``, binary); :meth:`commit`
    flushes and fsyncs it, gives it the mode of the file it replaces (or of a plain
    ``open``), and renames it over ``path``; :meth:`abort` removes it. As a context manager
    it commits on success and aborts on an exception, so a crash never leaves half a file.

    Args:
        path: Destination file; its folder is created when missing.
    """

    def __init__(self, path: str | Path):
        self.path = Path(path)
        blocking = next((folder for folder in reversed(self.path.parents) if folder.exists() and not folder.is_dir()), None)
        if blocking is not None:  # mkdir would say "File exists", of the file the user did not name
            raise NotADirectoryError(errno.ENOTDIR, f"{blocking} is a file, not a folder")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd, self._tmp = tempfile.mkstemp(prefix=f".{self.path.name}.", suffix=".tmp", dir=self.path.parent)
        self.handle = os.fdopen(fd, "wb")

    def commit(self) -> Path:
        """Flush, fsync and rename into place; returns the destination."""
        try:
            self.handle.flush()
            os.fsync(self.handle.fileno())
            self.handle.close()
            # mkstemp makes the file private: give it the mode of the file it replaces, or the
            # mode a plain open() would give
            os.chmod(self._tmp, self.path.stat().st_mode & 0o7777 if self.path.exists() else new_file_mode())
            os.replace(self._tmp, self.path)
        except BaseException:
            self.abort()
            raise
        return self.path

    def abort(self) -> None:
        """Drop the temporary file (nothing is left behind)."""
        self.handle.close()
        Path(self._tmp).unlink(missing_ok=True)

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


class _FlowDumper(yaml.SafeDumper):
    """YAML dumper that writes lists of scalars on one line (matrix rows stay readable), and no aliases (the loader refuses them)."""

    def ignore_aliases(self, data: Any) -> bool:  # noqa: D102
        return True


def _represent_list(dumper: yaml.SafeDumper, data: list) -> yaml.Node:
    flow = all(not isinstance(item, (list, dict, tuple)) for item in data)
    return dumper.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=flow)


_FlowDumper.add_representer(list, _represent_list)


def to_plain(value: Any) -> Any:
    """Convert numpy arrays and scalars, tuples and mappings into plain YAML-safe types (text: :func:`~fts_calib.core.text.utf8_safe`)."""
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
    return yaml.dump(to_plain(data), Dumper=_FlowDumper, sort_keys=False, allow_unicode=True, width=120)


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

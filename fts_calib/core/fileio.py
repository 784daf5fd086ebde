"""YAML reading shared by every file kind, and the writers' import path of the output guard.

Files are written through :mod:`fts_calib.core.outputs` (whole files only, devices and FIFOs
written in place, one writer per file); its writers are importable from here too.
PyYAML is imported on the first YAML read or write, not with this module: the
in-controller path (:mod:`fts_calib.service.reader`) never needs it.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from .bounded import parse_yaml, read_bounded_text
from .exceptions import ConfigError, FileFormatError
from .outputs import STDOUT, AtomicFile, atomic_write_bytes, atomic_write_text, new_file_mode  # noqa: F401 (re-exported)
from .text import utf8_safe

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

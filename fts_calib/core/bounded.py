"""Bounded parsing: every file and datagram is read within stated limits, or refused in one line.

A hostile or careless input must not make a reader die (a recursion error, an overflow),
hang, or ask for gigabytes. Every reader of the package goes through this module, whose
limits are far above what a real file holds (a calibration file is about 15 kB and nests
five levels deep; a datagram nests two) and far below what hurts:

- :data:`MAX_TEXT_BYTES`: the size of a YAML, JSON or XML file, checked before reading it;
- :data:`MAX_DEPTH`: how deep lists and mappings nest, checked while composing (YAML) or
  before parsing (JSON, by counting brackets outside strings);
- YAML anchors and aliases (``&name``, ``*name``, ``<<: *name``) are refused: no fts-calib
  file needs them, and nested aliases expand exponentially ("billion laughs");
- :data:`MAX_INT_DIGITS`: the digits of an integer; a float literal beyond the float range
  (``1.0e400``), or JSON's ``NaN`` and ``Infinity``, are refused;
- :data:`MAX_CHANNELS` and :data:`MAX_COLUMNS`: the channels of a sensor and the columns of a
  recording, checked before any work that grows with their square or cube (an SVD, a search
  for repeated columns).
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from .exceptions import FileFormatError, LimitError

#: Largest YAML, JSON or XML file read, in [bytes] (16 MiB; a calibration file is about 15 kB).
MAX_TEXT_BYTES = 16 << 20
#: Deepest nesting of lists and mappings in a file or datagram (a calibration file nests 5 deep).
MAX_DEPTH = 64
#: Most digits of an integer in a file or datagram (a 64-bit integer has at most 19).
MAX_INT_DIGITS = 20
#: Most channels of a sensor (a channel layout, an ATI file, a recording's strain columns).
MAX_CHANNELS = 64
#: Most columns in a recording's header (time, joints, channels, tool, temperature, extras).
MAX_COLUMNS = 1024


def read_bounded(path: str | Path, kind: str, limit: int = MAX_TEXT_BYTES) -> bytes:
    """The bytes of a file, refused when it is larger than ``limit`` (checked before reading).

    Args:
        path: The file.
        kind: What the file should be, for the message (e.g. 'YAML').
        limit: Largest size accepted [bytes].

    Raises:
        FileFormatError: Missing, a folder, unreadable, or larger than ``limit``.
    """
    path = Path(path)
    try:
        with open(path, "rb") as handle:
            data = handle.read(limit + 1)
    except FileNotFoundError:
        raise FileFormatError(path, None, "file not found") from None
    except IsADirectoryError:
        raise FileFormatError(path, None, f"is a folder, not a {kind} file") from None
    except OSError as exc:
        raise FileFormatError(path, None, f"cannot read: {exc.strerror}") from None
    if len(data) > limit:
        raise FileFormatError(path, None, f"larger than {_size(limit)}, the most a {kind} file of fts-calib may be: not such a file")
    return data


def _size(n: int) -> str:
    return f"{n / (1 << 20):g} MiB" if n >= 1 << 20 else f"{n:,} bytes"


def read_bounded_text(path: str | Path, kind: str, limit: int = MAX_TEXT_BYTES) -> str:
    """:func:`read_bounded`, decoded as UTF-8; a binary file is named as such.

    Raises:
        FileFormatError: As :func:`read_bounded`, or not UTF-8 text (the byte and its offset).
    """
    data = read_bounded(path, kind, limit)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:  # a binary file (or a compressed one) given for a text file
        byte = data[exc.start : exc.start + 1].hex()
        raise FileFormatError(path, None, f"not a text file (byte 0x{byte} at offset {exc.start} is not UTF-8): expected {kind}") from None


# -- YAML --------------------------------------------------------------------------------


def _where(node_or_event) -> str:
    mark = getattr(node_or_event, "start_mark", None)
    return f"line {mark.line + 1}, column {mark.column + 1}: " if mark is not None else ""


def _yaml() -> tuple[Any, type, type]:
    """PyYAML, its fastest safe loader, and that loader with this module's number limits.

    Made on first use: PyYAML is not imported with this module (the in-controller path never
    reads YAML). libyaml's parser is about ten times faster than PyYAML's own, when built in.
    """
    if not _YAML:
        import yaml

        safe: type = getattr(yaml, "CSafeLoader", yaml.SafeLoader)

        class BoundedLoader(safe):
            """The safe loader with the number limits of this module (depth and aliases: :func:`_check_events`)."""

            def construct_yaml_int(self, node):  # noqa: D102
                digits = sum(c.isdigit() for c in node.value)
                if digits > MAX_INT_DIGITS:
                    raise LimitError(f"{_where(node)}an integer of {digits} digits (at most {MAX_INT_DIGITS}): '{node.value[:24]}...'")
                return super().construct_yaml_int(node)

            def construct_yaml_float(self, node):  # noqa: D102
                value = super().construct_yaml_float(node)
                if not math.isfinite(value) and not node.value.lower().lstrip("+-").startswith((".inf", ".nan")):
                    raise LimitError(f"{_where(node)}the number {node.value[:40]} is beyond the float range (about 1.8e308)")
                return value

        BoundedLoader.add_constructor("tag:yaml.org,2002:int", BoundedLoader.construct_yaml_int)
        BoundedLoader.add_constructor("tag:yaml.org,2002:float", BoundedLoader.construct_yaml_float)
        _YAML.append((yaml, safe, BoundedLoader))
    return _YAML[0]


_YAML: list[tuple[Any, type, type]] = []


def _check_events(text: str) -> None:
    """Refuse aliases and nesting beyond :data:`MAX_DEPTH`, from the parser's event stream.

    The events come one at a time (the parser keeps an explicit stack, it does not recurse),
    so this runs before the composer, which does recurse, ever sees a deep document.
    """
    yaml, safe, _ = _yaml()
    depth = 0
    for event in yaml.parse(text, Loader=safe):
        if isinstance(event, yaml.AliasEvent):
            raise LimitError(
                f"{_where(event)}a YAML alias (*{event.anchor}) is not accepted: fts-calib files use no anchors or aliases; "
                "write the values out"
            )
        if isinstance(event, (yaml.SequenceStartEvent, yaml.MappingStartEvent)):
            depth += 1
            if depth > MAX_DEPTH:
                raise LimitError(f"{_where(event)}nested more than {MAX_DEPTH} levels deep: not an fts-calib file")
        elif isinstance(event, (yaml.SequenceEndEvent, yaml.MappingEndEvent)):
            depth -= 1


def parse_yaml(text: str, path: str | Path) -> Any:
    """Parse YAML text within the limits of this module (see the module docstring).

    Args:
        text: The file's text.
        path: The file, for the message.

    Raises:
        FileFormatError: Not valid YAML, an anchor or alias, nested deeper than
            :data:`MAX_DEPTH`, or a number out of bounds; the message gives line and column.
    """
    yaml, _, loader = _yaml()
    try:
        _check_events(text)
        return yaml.load(text, Loader=loader)  # noqa: S506 (a SafeLoader, bounded)
    except LimitError as exc:
        raise FileFormatError(path, None, str(exc)) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(exc, "problem", None) or str(exc)
        raise FileFormatError(path, None, f"not valid YAML{where}: {problem}") from None


# -- JSON --------------------------------------------------------------------------------

_JSON_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"', re.DOTALL)
_OPEN = np.frombuffer(b"[{", dtype=np.uint8)
_CLOSE = np.frombuffer(b"]}", dtype=np.uint8)


def json_depth(data: bytes) -> int:
    """How deep the lists and objects of a JSON text nest (brackets inside strings do not count).

    Cheap: counting the brackets answers for any text with few of them (a datagram has two or
    three); otherwise the strings are cut out and the depth is a running sum, both vectorised.
    """
    if data.count(b"[") + data.count(b"{") <= 1:
        return int(b"[" in data or b"{" in data)
    codes = np.frombuffer(_JSON_STRING.sub(b"", data), dtype=np.uint8)
    steps = np.isin(codes, _OPEN).astype(np.int64) - np.isin(codes, _CLOSE)
    return int(np.cumsum(steps).max(initial=0))


def _refuse_constant(name: str) -> float:
    raise LimitError(f"{name} is not a number fts-calib accepts (expected a finite number)")


def _bounded_int(text: str) -> int:
    if len(text.lstrip("-")) > MAX_INT_DIGITS:
        raise LimitError(f"an integer of {len(text.lstrip('-'))} digits (at most {MAX_INT_DIGITS})")
    return int(text)


#: The decoders (made once: ``json.loads`` with hooks would make one per call, on the live path's hot loop).
_FINITE = json.JSONDecoder(parse_int=_bounded_int, parse_constant=_refuse_constant)
_ANY = json.JSONDecoder(parse_int=_bounded_int)


def loads_json(data: bytes | str, max_depth: int = MAX_DEPTH, finite: bool = True) -> Any:
    """Parse JSON within the limits of this module: depth checked first, long integers and NaN/Infinity refused.

    A float beyond the float range (``1e400``) parses as inf: the caller checks that the
    numbers it uses are finite.

    Args:
        data: The JSON text (UTF-8 bytes or str).
        max_depth: Deepest nesting accepted.
        finite: Refuse ``NaN`` and ``Infinity`` (a file of our own, which Python's writer may
            give them, passes False).

    Raises:
        LimitError: Nested deeper than ``max_depth``, an integer of more than
            :data:`MAX_INT_DIGITS` digits, or NaN / Infinity when ``finite``.
        ValueError: Not JSON (``json.JSONDecodeError``, or not UTF-8).
    """
    raw = data.encode("utf-8") if isinstance(data, str) else data
    # no more brackets than the depth allowed: nothing to measure (every datagram, in two C-speed counts)
    if raw.count(b"[") + raw.count(b"{") > max_depth and (depth := json_depth(raw)) > max_depth:
        raise LimitError(f"nested {depth} levels deep (at most {max_depth})")
    text = data if isinstance(data, str) else data.decode("utf-8")
    return (_FINITE if finite else _ANY).decode(text)


def load_json_file(path: str | Path, kind: str, limit: int = MAX_TEXT_BYTES, finite: bool = True) -> Any:
    """A JSON file, read and parsed within the limits of this module.

    Args:
        path: The file.
        kind: What the file should be, for the message (e.g. 'checkpoint').
        limit: Largest size accepted [bytes].
        finite: Refuse ``NaN`` and ``Infinity`` (see :func:`loads_json`).

    Raises:
        FileFormatError: Missing, too large, not UTF-8, not JSON, or beyond a limit.
    """
    data = read_bounded(path, kind, limit)
    try:
        return loads_json(data, finite=finite)
    except LimitError as exc:
        raise FileFormatError(path, None, f"not a {kind}: {exc}") from None
    except ValueError as exc:  # JSONDecodeError, UnicodeDecodeError
        raise FileFormatError(path, None, f"not a {kind}: {exc}") from None

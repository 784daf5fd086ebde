"""Command-line interface: ``fts-calib <command> --help`` shows each command with an example.

Argparse and dispatch only: the parser is :mod:`fts_calib.app.parser`, and each command
``NAME`` is the function ``fts_calib.app.NAME.run`` (``live``, an old spelling of ``calibrate``:
calibrate's). The parsed options fill the dataclasses ``run`` takes, by field name (its
:class:`~fts_calib.app.setup.Setup`, :class:`~fts_calib.app.setup.SourceOptions`, ...), and the
rest are its keyword arguments. An error is printed as one line, ``fts-calib NAME: error: ...``,
and exits with the code of its family (:mod:`fts_calib.app.exit_codes`); a warning as
``fts-calib: warning: ...``, an old spelling's too.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import io
import os
import sys
import typing
import warnings
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from ..core.exceptions import FtsCalibError
from .exit_codes import ExitCode, error_line, exit_code

if TYPE_CHECKING:
    import argparse


__all__ = ["build_parser", "main", "run_command"]

#: Threads of the BLAS numpy loads, unless the environment says otherwise. The stages multiply tall
#: thin arrays block by block (N x 3 by 3 x 3, N x 8 by 8 x 6, ...): a second thread only waits
#: for the first, and on a busy machine its waiting costs more CPU than the product (one thread:
#: `calibrate --filter dynamic` 22 s of CPU for 3.6 M rows instead of 26-31 s, the same C;
#: docs/benchmarks.md).
BLAS_THREADS = "1"


def build_parser() -> argparse.ArgumentParser:
    """The parser of ``fts-calib`` (:mod:`fts_calib.app.parser`), imported on first use.

    Numpy and the stages then load inside :func:`main`, where a Ctrl-C is caught, not while the script starts.
    """
    from .parser import build_parser as build

    return build()


#: Commands that are old spellings of another: their ``run`` is the other's.
RUNS = {"live": "calibrate"}


def run_command(command: str, options: dict[str, Any]) -> int:
    """Run sub-command ``command``: ``fts_calib.app.<command>.run`` with ``options`` (:func:`arguments`); returns the exit status.

    The command holds the lock of its output file and checkpoint (``output``, ``checkpoint``)
    from start to end: a second run writing the same file is refused, naming the first
    (:func:`fts_calib.core.files.holding_outputs`).
    """
    from ..core.files import holding_outputs  # with numpy: after the script started, where a Ctrl-C is caught

    module = importlib.import_module(f".{RUNS.get(command, command)}", __package__)  # lazily: only the command run loads its modules
    with holding_outputs([options.get("output"), options.get("checkpoint")]):
        return int(module.run(**arguments(module.run, options)))


def parts(run: Callable[..., Any]) -> dict[str, type]:
    """The parameters of ``run`` that take a dataclass (its Setup, SourceOptions, ...), with the class."""
    found = {}
    for name, parameter in inspect.signature(run).parameters.items():
        kind = parameter.annotation
        if isinstance(kind, str):  # postponed annotations: the class, in the run function's module
            try:
                kind = eval(kind, run.__globals__)  # noqa: S307 - an annotation of this package's own code
            except Exception:  # noqa: BLE001 - a type that is no class of its own (a union, a name for type checkers)
                continue
        kinds = [kind, *typing.get_args(kind)]  # a dataclass, or a dataclass | None
        made = [k for k in kinds if isinstance(k, type) and dataclasses.is_dataclass(k)]
        if made:
            found[name] = made[0]
    return found


def arguments(run: Callable[..., Any], options: dict[str, Any]) -> dict[str, Any]:
    """The keyword arguments of ``run`` from the parsed ``options``: each dataclass of the options named as its fields, the rest as is."""
    left = dict(options)
    made = {}
    for name, kind in parts(run).items():
        fields = {field.name for field in dataclasses.fields(kind) if field.init}
        made[name] = kind(**{key: left.pop(key) for key in list(left) if key in fields})
    return {**made, **left}


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    print(f"fts-calib: warning: {message}", file=sys.stderr)


def _printable_output() -> None:
    """Let the printouts show what the terminal cannot encode (a file name that is not UTF-8) as escapes, not die on it."""
    for stream in (sys.stdout, sys.stderr):
        if isinstance(stream, io.TextIOWrapper) and stream.errors == "strict":
            stream.reconfigure(errors="backslashreplace")


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``fts-calib`` command; returns the exit status (:mod:`fts_calib.app.exit_codes`).

    Sets ``OPENBLAS_NUM_THREADS`` to :data:`BLAS_THREADS` when the environment does not set it (it
    takes effect when numpy is first imported: in this process, after this call).
    """
    os.environ.setdefault("OPENBLAS_NUM_THREADS", BLAS_THREADS)
    try:
        return _main(argv)
    except KeyboardInterrupt:  # while the modules load or the options are read: one line, as during a command
        print("fts-calib: interrupted", file=sys.stderr)
        return int(ExitCode.INTERRUPTED)


def _main(argv: list[str] | None) -> int:
    _printable_output()
    parser = build_parser()
    command = None
    try:
        with warnings.catch_warnings():  # warnings as 'fts-calib: warning: ...', for this command only (old spellings too)
            warnings.simplefilter("default")
            warnings.simplefilter("ignore", ResourceWarning)  # a file the collector closes late is no advice to a user
            warnings.showwarning = _show_warning
            args = parser.parse_args(argv)  # a usage error exits with 2 (argparse)
            if args.command is None:
                parser.print_help()
                return int(ExitCode.USAGE)
            command = args.command
            options = {key: value for key, value in vars(args).items() if key not in ("command", "old_given")}
            if command in RUNS:
                _warn_old_command(command, getattr(args, "old_given", []), options)
            return run_command(command, options)
    except BrokenPipeError:  # output piped into `head` and the like: stop quietly
        sys.stderr.close()
        return int(ExitCode.OK)
    except KeyboardInterrupt:
        print(f"fts-calib {command}: interrupted" if command else "fts-calib: interrupted", file=sys.stderr)
        return int(ExitCode.INTERRUPTED)
    except (FtsCalibError, OSError) as exc:  # a user error, or the system refusing a file: one line, no traceback
        command = command or next((word for word in argv or sys.argv[1:] if not word.startswith("-")), None)  # while parsing
        print(f"fts-calib {command}: error: {error_line(exc)}" if command else f"fts-calib: error: {error_line(exc)}", file=sys.stderr)
        return int(exit_code(exc))


def _warn_old_command(command: str, given: list[str], options: dict[str, Any]) -> None:
    """Warn that an old command (and the old options that gave its sources) is now ``RUNS[command]`` with SOURCE arguments."""
    from ..core.deprecation import warn_old_spelling

    sources = " ".join(str(name) for name in options.get("names") or [])
    old = " ".join([f"'fts-calib {command}", *given]) + "'"
    warn_old_spelling(old, f"'fts-calib {RUNS[command]} {sources}' (the sources as SOURCE arguments)", f"'{command}'")


if __name__ == "__main__":
    sys.exit(main())

"""Command-line interface: ``fts-calib <command> --help`` shows each command with an example.

Argparse and dispatch only: the parser is :mod:`fts_calib.app.parser`, and each command
``NAME`` is the function ``fts_calib.app.NAME.run``, called with the parsed options as
keyword arguments. An error is printed as one line, ``fts-calib NAME: error: ...``, and
exits with the code of its family (:mod:`fts_calib.app.exit_codes`).
"""

from __future__ import annotations

import importlib
import io
import os
import sys
import warnings
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


def run_command(command: str, options: dict[str, Any]) -> int:
    """Run sub-command ``command``: ``fts_calib.app.<command>.run(**options)``; returns the exit status.

    The command holds the lock of its output file and checkpoint (``output``, ``checkpoint``)
    from start to end: a second run writing the same file is refused, naming the first
    (:func:`fts_calib.core.files.holding_outputs`).
    """
    from ..core.files import holding_outputs  # with numpy: after the script started, where a Ctrl-C is caught

    module = importlib.import_module(f".{command}", __package__)  # lazily: only the command run loads its modules
    with holding_outputs([options.get("output"), options.get("checkpoint")]):
        return int(module.run(**options))


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
    args = parser.parse_args(argv)  # a usage error exits with 2 (argparse)
    if args.command is None:
        parser.print_help()
        return int(ExitCode.USAGE)
    options = {key: value for key, value in vars(args).items() if key != "command"}
    try:
        with warnings.catch_warnings():  # warnings as 'fts-calib: warning: ...', for this command only
            warnings.simplefilter("default")
            warnings.showwarning = _show_warning
            return run_command(args.command, options)
    except BrokenPipeError:  # output piped into `head` and the like: stop quietly
        sys.stderr.close()
        return int(ExitCode.OK)
    except KeyboardInterrupt:
        print(f"fts-calib {args.command}: interrupted", file=sys.stderr)
        return int(ExitCode.INTERRUPTED)
    except (FtsCalibError, OSError) as exc:  # a user error, or the system refusing a file: one line, no traceback
        print(f"fts-calib {args.command}: error: {error_line(exc)}", file=sys.stderr)
        return int(exit_code(exc))


if __name__ == "__main__":
    sys.exit(main())

"""Old names kept working for one release, with a :class:`DeprecationWarning`: keywords and module paths.

One implementation for every renamed argument (``strain`` -> ``channels``, ``readings`` ->
``joints``, ...): :func:`renamed` wraps a function so that a call with the old keyword
warns and passes the value on under the new name. A positional call costs one test of an
empty mapping, so the wrapper stays on a 1 kHz path.

One for every moved module: the stage layout of this release moved modules (``fts_calib.pipeline.session``
is ``fts_calib.session.session``); :data:`MOVED_MODULES` maps each old path to the new one, and
:func:`install_moved_modules` lets ``import`` of an old path warn and give the module it moved to
(the same object: what it holds is what the new path holds).

One for every old spelling on the command line (``--out`` for ``-o/--output``, ``--no-filter`` for
``--filter none``, ``--listen HOST:PORT`` for the source ``udp://HOST:PORT``): an :class:`OldFlag`
declares it beside the option it stands for, :class:`OldSpelling` is the argparse action that
reads it, and :func:`apply_old_spellings` stores what it stands for once the line is read and
warns with :func:`warn_old_spelling`, which an old command's warning uses too.
"""

from __future__ import annotations

import argparse
import functools
import importlib
import importlib.abc
import importlib.machinery
import sys
import types
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

F = TypeVar("F", bound=Callable[..., Any])

#: The release that removes the old names.
REMOVED_IN = "0.2"


def renamed(**old_to_new: str) -> Callable[[F], F]:
    """Decorator: accept each old keyword name, warn, and pass its value as the new one.

    Args:
        **old_to_new: Old keyword name -> new keyword name, e.g. ``strain="channels"``.

    Returns:
        The decorator; the wrapped function raises TypeError when a call gives both names.

    Example::

        @renamed(strain="channels")
        def wrench(self, channels): ...
    """

    def wrap(func: F) -> F:
        @functools.wraps(func)
        def inner(*args: Any, **kwargs: Any) -> Any:
            if kwargs:
                for old, new in old_to_new.items():
                    if old in kwargs:
                        if new in kwargs:
                            raise TypeError(f"{func.__qualname__}() got both '{old}' and '{new}': give '{new}' only")
                        warnings.warn(
                            f"{func.__qualname__}(): the argument '{old}' is now '{new}'; '{old}' goes in fts-calib {REMOVED_IN}",
                            DeprecationWarning,
                            stacklevel=2,
                        )
                        kwargs[new] = kwargs.pop(old)
            return func(*args, **kwargs)

        return inner  # type: ignore[return-value]

    return wrap


def renamed_method(old: str, new: Callable[..., Any]) -> Callable[..., Any]:
    """An alias of a renamed method that warns once per call and calls the new one.

    Args:
        old: The old method name (for the message).
        new: The new method (a function defined in the class body).

    Returns:
        A function to assign to the old name in the class body.
    """

    @functools.wraps(new)
    def alias(*args: Any, **kwargs: Any) -> Any:
        warnings.warn(
            f"{old}() is now {new.__name__}(); {old}() goes in fts-calib {REMOVED_IN}",
            DeprecationWarning,
            stacklevel=2,
        )
        return new(*args, **kwargs)

    alias.__doc__ = f"Deprecated alias of :meth:`{new.__name__}` (kept for one release)."
    return alias


#: Module paths of the release before the stage layout -> where each moved (several merged into one module).
MOVED_MODULES = {
    "fts_calib.app.arguments": "fts_calib.app.parser",
    "fts_calib.app.demo_drift": "fts_calib.app.demo",
    "fts_calib.app.feed_arguments": "fts_calib.app.options",
    "fts_calib.app.monitor_arguments": "fts_calib.app.parser",
    "fts_calib.app.monitor_offsets": "fts_calib.app.monitor",
    "fts_calib.app.offset_arguments": "fts_calib.app.options",
    "fts_calib.app.payload_motion": "fts_calib.app.payload",
    "fts_calib.app.plots": "fts_calib.report.plots",
    "fts_calib.app.report_arguments": "fts_calib.app.options",
    "fts_calib.app.report_compare": "fts_calib.report.compare",
    "fts_calib.app.report_content": "fts_calib.report.content",
    "fts_calib.app.report_html": "fts_calib.report.html",
    "fts_calib.app.report_region": "fts_calib.report.html",
    "fts_calib.app.report_svg": "fts_calib.report.svg",
    "fts_calib.app.sensor_arguments": "fts_calib.app.options",
    "fts_calib.app.service_arguments": "fts_calib.app.parser",
    "fts_calib.core.fileio": "fts_calib.core.files",
    "fts_calib.core.outputs": "fts_calib.core.files",
    "fts_calib.core.paths": "fts_calib.core.files",
    "fts_calib.core.text": "fts_calib.core.tables",
    "fts_calib.core.validation": "fts_calib.core.arrays",
    "fts_calib.feeds": "fts_calib.sources",
    "fts_calib.feeds.bag": "fts_calib.sources.bag",
    "fts_calib.feeds.bag_checks": "fts_calib.sources.bag",
    "fts_calib.feeds.bag_log": "fts_calib.sources.bag",
    "fts_calib.feeds.bag_pose": "fts_calib.sources.bag",
    "fts_calib.feeds.batch": "fts_calib.sources.batch",
    "fts_calib.feeds.orientation_reader": "fts_calib.sources.orientation_recording",
    "fts_calib.feeds.protocol": "fts_calib.sources.udp",
    "fts_calib.feeds.recording": "fts_calib.sources.recording",
    "fts_calib.feeds.recording_set": "fts_calib.sources.recording_set",
    "fts_calib.feeds.recording_writer": "fts_calib.sources.writer",
    "fts_calib.feeds.replay": "fts_calib.sources.sender",
    "fts_calib.feeds.row_notes": "fts_calib.sources.recording",
    "fts_calib.feeds.rtde": "fts_calib.sources.ur",
    "fts_calib.feeds.source": "fts_calib.sources.source",
    "fts_calib.feeds.sync": "fts_calib.sources.synchronizer",
    "fts_calib.feeds.udp": "fts_calib.sources.udp",
    "fts_calib.model.budget": "fts_calib.budget.propagation",
    "fts_calib.model.estimator_state": "fts_calib.model.estimator",
    "fts_calib.model.health": "fts_calib.model.parity",
    "fts_calib.model.jig": "fts_calib.model.offline",
    "fts_calib.model.model_fit": "fts_calib.model.estimator",
    "fts_calib.model.offset_basis": "fts_calib.model.offset_models",
    "fts_calib.model.offset_trace": "fts_calib.model.offset_models",
    "fts_calib.model.offsets": "fts_calib.model.retare",
    "fts_calib.model.quality": "fts_calib.model.calibration",
    "fts_calib.model.sensor": "fts_calib.model.channels",
    "fts_calib.model.unit_sums": "fts_calib.model.model_choice",
    "fts_calib.pipeline.advice": "fts_calib.session.diagnosis",
    "fts_calib.pipeline.budget": "fts_calib.budget.measured",
    "fts_calib.pipeline.calibrate": "fts_calib.session.calibration_run",
    "fts_calib.pipeline.checkpoint": "fts_calib.session.checkpoint",
    "fts_calib.pipeline.checks": "fts_calib.filters.sample_checks",
    "fts_calib.pipeline.clock": "fts_calib.filters.clock",
    "fts_calib.pipeline.derivatives": "fts_calib.filters.joint_rates",
    "fts_calib.pipeline.diagnosis": "fts_calib.session.diagnosis",
    "fts_calib.pipeline.dynamic": "fts_calib.filters.dynamic",
    "fts_calib.pipeline.fit": "fts_calib.session.fit",
    "fts_calib.pipeline.fit_tolerance": "fts_calib.session.fit",
    "fts_calib.pipeline.frame_rotation": "fts_calib.session.frame_rotation",
    "fts_calib.pipeline.health": "fts_calib.session.session",
    "fts_calib.pipeline.kept_sums": "fts_calib.session.session",
    "fts_calib.pipeline.latency": "fts_calib.filters.latency",
    "fts_calib.pipeline.latency_fit": "fts_calib.filters.latency",
    "fts_calib.pipeline.live": "fts_calib.session.calibration_run",
    "fts_calib.pipeline.progress": "fts_calib.session.session",
    "fts_calib.pipeline.provenance": "fts_calib.session.session",
    "fts_calib.pipeline.qsfilter": "fts_calib.filters.quasi_static",
    "fts_calib.pipeline.remaining": "fts_calib.session.plan_progress",
    "fts_calib.pipeline.resume": "fts_calib.session.checkpoint",
    "fts_calib.pipeline.session": "fts_calib.session.session",
    "fts_calib.pipeline.settings": "fts_calib.filters.settings",
    "fts_calib.pipeline.still": "fts_calib.filters.quasi_static",
    "fts_calib.pipeline.tool_load": "fts_calib.session.session",
    "fts_calib.pipeline.tool_plausibility": "fts_calib.session.fit",
    "fts_calib.pipeline.trust": "fts_calib.filters.dynamic",
    "fts_calib.pipeline.units": "fts_calib.session.held_out",
    "fts_calib.planning.accuracy": "fts_calib.budget.predicted",
    "fts_calib.planning.continuous": "fts_calib.planning.sizing",
    "fts_calib.planning.drift_excitation": "fts_calib.planning.excitation",
    "fts_calib.planning.dynamic_accuracy": "fts_calib.budget.predicted",
    "fts_calib.planning.payload_excitation": "fts_calib.payload.inertia_motion",
    "fts_calib.planning.smooth_sizing": "fts_calib.planning.sizing",
    "fts_calib.planning.trajectory": "fts_calib.planning.trajectory_run",
    "fts_calib.planning.trajectory_io": "fts_calib.planning.trajectory_files",
    "fts_calib.robot._batch": "fts_calib.robot.kinematics",
    "fts_calib.robot.dynamic_sensitivities": "fts_calib.budget.sensitivities",
    "fts_calib.robot.load": "fts_calib.robot.tool",
    "fts_calib.robot.load_errors": "fts_calib.budget.sensitivities",
    "fts_calib.robot.motion": "fts_calib.robot.kinematics",
    "fts_calib.robot.sensitivities": "fts_calib.budget.sensitivities",
    "fts_calib.robot.tool_wrench": "fts_calib.robot.tool",
    "fts_calib.robot.urdf": "fts_calib.robot.definition",
    "fts_calib.robot.wrench": "fts_calib.robot.tool",
    "fts_calib.service.export": "fts_calib.service.exports",
    "fts_calib.service.health": "fts_calib.monitor.health",
    "fts_calib.service.offset_watch": "fts_calib.monitor.offset_watch",
    "fts_calib.service.payload": "fts_calib.payload.identify",  # identify_payload and PayloadEstimate, as the release before
    "fts_calib.service.payload_live": "fts_calib.payload.samples",
    "fts_calib.service.payload_motion": "fts_calib.payload.moving",
    "fts_calib.service.payload_motion_recording": "fts_calib.payload.samples",
    "fts_calib.service.payload_recording": "fts_calib.payload.samples",
    "fts_calib.service.tare": "fts_calib.service.retare_job",
    "fts_calib.service.validate": "fts_calib.service.validation",
    "fts_calib.service.validate_offsets": "fts_calib.service.validation",
    "fts_calib.sim.bag": "fts_calib.sim.robot_log",
    "fts_calib.sim.payload_motion": "fts_calib.sim.payload_run",
    "fts_calib.sim.recording": "fts_calib.sim.runs",
    "fts_calib.sim.service": "fts_calib.sim.service_run",
}
#: Old subpackages that are gone: importable as empty packages, so that their old modules resolve.
GONE_PACKAGES = ("fts_calib.pipeline",)


class _MovedModules(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds the old module paths of :data:`MOVED_MODULES` and loads the module each moved to, with a warning."""

    def find_spec(self, fullname: str, path: Sequence[str] | None, target: types.ModuleType | None = None):
        """A spec for an old path; None for every other module."""
        if fullname in MOVED_MODULES or fullname in GONE_PACKAGES:
            return importlib.machinery.ModuleSpec(fullname, self, is_package=fullname in GONE_PACKAGES)
        return None

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> types.ModuleType:
        """The module the old path moved to (an empty package for a gone subpackage)."""
        if spec.name in GONE_PACKAGES:
            module = types.ModuleType(spec.name, f"{spec.name}: gone; its modules moved (fts_calib.core.deprecation.MOVED_MODULES)")
            module.__path__ = []
            return module
        new = MOVED_MODULES[spec.name]
        warnings.warn(f"{spec.name} is now {new}; the old path goes in fts-calib {REMOVED_IN}", DeprecationWarning, stacklevel=2)
        return importlib.import_module(new)

    def exec_module(self, module: types.ModuleType) -> None:
        """Nothing to run: the module is the new one, already loaded."""


def install_moved_modules() -> None:
    """Let the old module paths import (once per process; :mod:`fts_calib` calls it)."""
    if not any(isinstance(finder, _MovedModules) for finder in sys.meta_path):
        sys.meta_path.append(_MovedModules())


# --- old spellings on the command line ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class OldFlag:
    """An old spelling of a command-line option, kept for one release.

    Attributes:
        flag: The old flag, e.g. ``--out``.
        says: The new spelling in words, with ``{value}`` for the value it stands for (e.g.
            ``-o/--output {value}``).
        value: What a flag without a value stands for (``--no-filter``: ``none``); None: the
            flag takes the value the new option takes (``to`` turns it into the new one's).
        to: The new value of the value given (``--listen HOST:PORT``: ``udp://HOST:PORT``).
        type: The type of the value given (as argparse's).
        nargs: Argparse's nargs of the value given ('?': optional, then ``const``).
        const: The value of a bare flag with nargs '?'.
        metavar: Its metavar (never shown: an old spelling has no help).
        of_command: It belongs to an old command, whose one warning names it and the new
            spelling of the whole line (:func:`warn_old_spelling`); no warning of its own.
        example: A value it may be given, for :meth:`described` (e.g. ``("HOST", "PORT")``).
    """

    flag: str
    says: str
    value: Any = None
    to: Callable[[Any], Any] | None = None
    type: Callable[[str], Any] | None = None
    nargs: Any = None
    const: Any = None
    metavar: str | None = None
    of_command: bool = False
    example: Any = None

    def described(self) -> str:
        """The new spelling in words, for a reference page: ``{value}`` left out, or shown with :attr:`example`."""
        if "{value}" not in self.says:
            return self.says
        if self.to is None or self.example is None:
            return self.says.replace(" {value}", "").replace("{value}", "")
        return self.says.format(value=self.to(self.example))

    @property
    def renames(self) -> bool:
        """Whether it is the new option under another name (the same value, no conversion)."""
        return self.value is None and self.to is None and self.nargs is None


def warn_old_spelling(old: str, new: str, goes: str = "") -> None:
    """Warn that ``old`` (an option or a command as given) is now ``new``, and that ``goes`` (its first word) goes in the next release."""
    warnings.warn(f"{old} is now {new}; {goes or old.split()[0]} goes in fts-calib {REMOVED_IN}", DeprecationWarning, stacklevel=2)


class OldSpelling(argparse.Action):
    """The one argparse action of every old spelling: it stores what the new spelling stores, and the warning names it.

    An old flag that renames an option (:attr:`OldFlag.renames`: ``--out`` for ``--output``) is
    routed to the new option's action itself, made with this class (one action: a required
    option given by its old flag is given; the old flag stays out of the help). An old flag that
    stands for a value (``--no-filter``: ``--filter none``) is an action of its own, with its
    ``target`` the new option's destination. Either way what it stands for is stored, and the
    warning said, once the command line is read (:func:`apply_old_spellings`): a source given the
    old way (``--listen HOST:PORT``) then joins the SOURCE arguments, whatever their order.

    Args:
        old: The old flags this action reads.
        target: The destination the old flags store into (default: ``dest``).
    """

    def __init__(self, option_strings, dest, old: Sequence[OldFlag] = (), target: str | None = None, **kwargs):
        self.old = {spelling.flag: spelling for spelling in old}
        self.target = target or dest
        super().__init__(option_strings, dest, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        """Store a new spelling's value now; note an old spelling's, stored and warned by :func:`apply_old_spellings`."""
        spelling = self.old.get(option_string or "")
        if spelling is None:  # the new spelling of a renamed option
            setattr(namespace, self.dest, values)
            return
        value = spelling.value if spelling.value is not None and values in (None, [], ()) else values
        value = spelling.to(value) if spelling.to is not None else value
        shown = " ".join([option_string or spelling.flag, *_words(values)])
        said = "" if spelling.of_command else spelling.says.format(value=value)
        namespace.__dict__.setdefault("_old_spellings", []).append((self.target, value, shown, said))


def add_old_flag(parser, spelling: OldFlag, target: str) -> argparse.Action:
    """Add an old flag that stands for a value to ``parser`` (or an argument group), storing into ``target``; hidden from the help."""
    extra: dict[str, Any] = {"nargs": 0 if spelling.value is not None and spelling.nargs is None else spelling.nargs}
    for key in ("type", "const", "metavar"):
        if getattr(spelling, key) is not None:
            extra[key] = getattr(spelling, key)
    return parser.add_argument(
        spelling.flag,
        dest=f"old_{spelling.flag.strip('-').replace('-', '_')}",
        action=OldSpelling,
        old=(spelling,),
        target=target,
        default=argparse.SUPPRESS,
        help=argparse.SUPPRESS,
        **extra,
    )


def _words(values) -> list[str]:
    """The value of an option as given, in words (HOST:PORT for an address)."""
    if values is None or isinstance(values, bool):
        return []
    if isinstance(values, tuple) and len(values) == 2 and isinstance(values[1], int):  # HOST:PORT
        return [f"{values[0]}:{values[1]}"]
    return [str(v) for v in values] if isinstance(values, list) else [str(values)]


#: The destination of the SOURCE arguments: a value an old spelling gives it joins them.
SOURCES_DEST = "names"


def apply_old_spellings(namespace: argparse.Namespace) -> list[str]:
    """Store what the old spellings given stand for and warn for each; return those an old command's warning names (as given).

    A source (``udp://...``, ``ur://...`` for :data:`SOURCES_DEST`) joins the SOURCE arguments,
    in place of one of its scheme.
    """
    unsaid = []
    for dest, value, shown, said in namespace.__dict__.pop("_old_spellings", []):
        if dest == SOURCES_DEST:
            value = with_source(getattr(namespace, dest, None), value)
        setattr(namespace, dest, value)
        if said:
            warn_old_spelling(shown, said)
        else:
            unsaid.append(shown)
    return unsaid


def with_source(names: str | Sequence[str] | None, source: str) -> list[str]:
    """The SOURCE arguments with ``source`` (``udp://...``, ``ur://...``) in place of one of its scheme, or added."""
    current = [] if names is None else [names] if isinstance(names, str) else list(names)
    scheme = source.split("://", 1)[0] + "://"
    return [*(name for name in current if not str(name).startswith(scheme)), source]

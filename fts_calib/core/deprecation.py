"""Old names kept working for one release, with a :class:`DeprecationWarning`: keywords and module paths.

One implementation for every renamed argument (``strain`` -> ``channels``, ``readings`` ->
``joints``, ...): :func:`renamed` wraps a function so that a call with the old keyword
warns and passes the value on under the new name. A positional call costs one test of an
empty mapping, so the wrapper stays on a 1 kHz path.

One for every moved module: the stage layout of this release moved modules (``fts_calib.pipeline.session``
is ``fts_calib.session.session``); :data:`MOVED_MODULES` maps each old path to the new one, and
:func:`install_moved_modules` lets ``import`` of an old path warn and give the module it moved to
(the same object: what it holds is what the new path holds).
"""

from __future__ import annotations

import functools
import importlib
import importlib.abc
import importlib.machinery
import sys
import types
import warnings
from collections.abc import Callable, Sequence
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

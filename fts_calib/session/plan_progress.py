"""How far a live run is through its sized plan: the motion still to run and the configuration to mount next.

A plan sized to an accuracy target (``fts-calib trajectory``, its ``plan.yaml``) says how
many quasi-static samples each tool configuration gives (a continuous plan: how many moving
samples the dynamic filter keeps, ``excitation.dynamic_samples``) and how long its motion takes.
During ``live`` the session's kept samples per configuration, against those, tell a person
how much robot time is left before the target is reached and which configuration to mount
next. Times in [s].
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path

from ..core.exceptions import FileFormatError
from ..core.files import load_yaml, read_number, read_positive, require
from ..core.resources import locate_trajectory
from .session import Progress

#: Fields of a plan file, one of which a plan has (a file with none is another kind of file).
PLAN_KEYS = ("duration_s", "rate_hz", "excitation")
_DONE = 0.9  # a configuration with this fraction of its planned samples is done (simulated runs keep 97-98 %)


@dataclass(frozen=True)
class PlanProgress:
    """What a sized plan expects of a run.

    Attributes:
        duration_s: Motion per configuration [s].
        expected: Configuration name -> quasi-static samples the plan gives, at the channel rate.
        target_percent: The accuracy target the plan was sized to, [% of full scale], or None.
        robot: The name of the robot the plan was made for, or None (not stated).
        rate_hz: The channel rate [Hz] the counts of ``expected`` are at, or None (unknown:
            :meth:`at_rate` leaves them).
    """

    duration_s: float
    expected: Mapping[str, float]
    target_percent: float | None = None
    robot: str | None = None
    rate_hz: float | None = None

    def at_rate(self, rate_hz: float | None) -> PlanProgress:
        """The same plan with its sample counts at another channel rate [Hz]: the rate the stream shows.

        A sensor file's nominal rate is a first guess; a 100 Hz replay of a 1 kHz sensor's
        plan would otherwise never reach its counts. None or a rate not above zero: unchanged.
        """
        if self.rate_hz is None or rate_hz is None or not rate_hz > 0:
            return self
        scale = rate_hz / self.rate_hz
        return replace(self, expected={name: n * scale for name, n in self.expected.items()}, rate_hz=float(rate_hz))

    def fractions(self, progress: Progress) -> dict[str, float]:
        """Per configuration, the fraction of its planned samples kept so far (at most 1)."""
        kept = progress.kept_by_configuration
        return {name: min(1.0, kept.get(name, 0) / n) if n > 0 else 1.0 for name, n in self.expected.items()}

    def remaining_s(self, progress: Progress) -> float:
        """Motion still to run [s] (tool changes not counted)."""
        return sum(self.duration_s * (1.0 - f) for f in self.fractions(progress).values())

    def next_configuration(self, progress: Progress) -> str | None:
        """The configuration to mount next (the first in plan order not yet done), or None when all are."""
        fractions = self.fractions(progress)
        started = [name for name, f in fractions.items() if 0 < f < _DONE]
        todo = [name for name, f in fractions.items() if f == 0]
        if started:
            later = [name for name in todo if name != started[0]]
            return later[0] if later else None
        return todo[0] if todo else None

    def status(self, progress: Progress) -> str:
        """A few words for the status line: the time left and what to mount."""
        fractions = self.fractions(progress)
        if all(f >= _DONE for f in fractions.values()):
            target = f" ({self.target_percent:g} % of full scale)" if self.target_percent is not None else ""
            return f"plan done: the target{target} is reached when the fit is solved"
        text = f"~{self.remaining_s(progress):.0f} s of motion left"
        running = [name for name, f in fractions.items() if 0 < f < _DONE]
        if running:
            text += f" ({running[0]} {100 * fractions[running[0]]:.0f} %)"
        following = self.next_configuration(progress)
        if following is not None:
            text += f"; mount {following} next" if running else f"; mount {following}"
        return text


def load_plan_progress(path: str | Path, rate_hz: float) -> PlanProgress:
    """Read the expectations of a run from a ``plan.yaml`` written by ``fts-calib trajectory``.

    Args:
        path: The plan file, the folder that holds it, or a shipped plan by name ('ur5':
            :func:`~fts_calib.core.resources.locate_trajectory`).
        rate_hz: The channels' sample rate [Hz] (the plan counts samples at its own rate).

    Raises:
        FileFormatError: A missing or malformed field (a duration or rate that is not > 0);
            names the file and the field.
    """
    path = locate_trajectory(path)
    if path.is_dir():
        path = path / "plan.yaml"
    data = load_yaml(path)
    if not any(key in data for key in PLAN_KEYS):
        fields = ", ".join(PLAN_KEYS)
        raise FileFormatError(
            path, None, f"not a plan: expected the plan.yaml that 'fts-calib trajectory' writes beside its CSVs ({fields})"
        )
    duration = read_positive(require(data, "duration_s", path), path, "duration_s", "s")
    plan_rate = read_positive(require(data, "rate_hz", path), path, "rate_hz", "Hz")  # divides the counts below
    excitation = require(data, "excitation", path)
    # a continuous plan (no dwell) counts the moving samples the dynamic filter keeps instead
    key = "dynamic_samples" if isinstance(excitation, Mapping) and "dynamic_samples" in excitation else "quasi_static_samples"
    counts = excitation.get(key) if isinstance(excitation, Mapping) else None
    if not isinstance(counts, Mapping) or not counts:
        raise FileFormatError(path, f"excitation.{key}", "expected a mapping configuration -> samples")
    expected = {str(name): read_number(n, path, f"excitation.{key}.{name}") * rate_hz / plan_rate for name, n in counts.items()}
    target = data.get("target_error_percent_fs")
    target_percent = None if target is None else read_number(target, path, "target_error_percent_fs", "%")
    return PlanProgress(duration, expected, target_percent, None if data.get("robot") is None else str(data["robot"]), rate_hz)

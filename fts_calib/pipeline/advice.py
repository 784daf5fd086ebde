"""What a calibration still needs, in words: the one advice text of the session and live progress.

Identifiability (paper eqs 18-20): one tool centre of mass gives rank 4, two give 6, three
not on one line give 7; within each configuration, gravity must be seen from directions
that span 3-D.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ..feeds.batch import UNKNOWN_TOOL
from ..robot.tool import Tool
from .checks import BACKWARDS, NON_FINITE, OUTSIDE_LIMITS

#: Kept samples of a configuration before it counts in the advice.
MIN_SAMPLES = 10
#: The advice when nothing specific is missing.
GENERIC = "more quasi-static samples"
#: What to look at when the checks refused every sample, by the reason they counted.
REFUSED = {
    OUTSIDE_LIMITS: "joint readings in degrees? they must be in rad: joints_in_degrees=True, --joints-in-degrees",
    NON_FINITE: "NaN or infinite joints or channels",
    BACKWARDS: "the times must not decrease",
    UNKNOWN_TOOL: "the configuration names must be those of the tool file",
}


def missing_words(
    tool: Tool,
    kept: Sequence[int] | np.ndarray,
    directions: np.ndarray,
    undetermined: Sequence[Sequence[str]] = (),
    cause: str = "",
    refused: str = "",
) -> str:
    """What is missing for full rank, in words, the real cause first ('more quasi-static samples' when nothing specific).

    Args:
        tool: The calibration tool.
        kept: Kept samples per configuration, the tool's order. Length k.
        directions: Per configuration, the sum of ``[u; 1][u; 1]^T`` over the kept samples,
            ``u`` the unit gravity direction in the sensor frame. Shape (k, 4, 4).
        undetermined: Offset-model columns the data cannot separate, per missing direction
            (:func:`undetermined_words`); named before the tool's advice, which replaces
            the generic words.
        cause: A known cause, said first (e.g. a configuration none of whose rows could be read).
        refused: Why no sample reached the filter (:func:`refused_words`); when given, it
            replaces the rest, which would describe samples that were never kept.
    """
    if refused:
        return "; ".join(w for w in (cause, refused) if w)
    apart, words = undetermined_words(undetermined), _tool_words(tool, kept, directions)
    return "; ".join(w for w in (cause, apart, "" if apart and words == GENERIC else words) if w)


def _tool_words(tool: Tool, kept: Sequence[int] | np.ndarray, directions: np.ndarray) -> str:
    names = tool.names
    seen = [k for k in range(len(names)) if kept[k] >= MIN_SAMPLES]
    if not seen:
        return "no quasi-static sample yet: hold the arm still at the stops of the sweep"
    few = [names[k] for k in seen if np.linalg.matrix_rank(directions[k], tol=1e-6 * max(1.0, kept[k])) < 4]
    words = []
    if few:
        words.append(f"configuration {', '.join(few)}: gravity seen from too few directions so far (keep sweeping)")
    coms = np.array([c.p_sensor_com for c in tool.configurations])
    others = [k for k in range(len(names)) if k not in seen]
    label = " and ".join(names[k] for k in seen)
    span = int(np.linalg.matrix_rank(coms[seen] - coms[seen[0]], tol=1e-6))
    if span == 0:  # one centre of mass (one configuration, or several that share it)
        share = f"configuration {label}" if len(seen) == 1 else f"configurations {label} share it"
        mount = f"{_listed([names[k] for k in others])} of the tool file" if others else "the tool file has no other configuration"
        words.append(f"one centre of mass ({share}); mount two more, not on one line with it ({mount})")
    elif span == 1:
        base = coms[seen] - coms[seen[0]]
        off = [names[k] for k in others if np.linalg.matrix_rank(np.vstack([base, coms[k] - coms[seen[0]]]), tol=1e-6) == 2]
        if off:
            mount = f"mount one more off that line ({' or '.join(off)} of the tool file)"
            words.append(f"centres of mass on one line (configurations {label}); {mount}")
        else:
            words.append(
                f"the centres of mass of {label} and every other configuration lie on one line: the tool "
                "needs a configuration off that line (paper eqs 19-20)"
            )
    return "; ".join(words) or GENERIC


def _listed(names: Sequence[str]) -> str:
    """'B', 'B and C', 'B, C and D'."""
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]


#: Share of the samples the quasi-static filter refused for moving above which a continuous motion may be named.
MOVING_SHARE = 0.9
#: Still stretches per configuration up to which the motion is continuous (at rest before and after it only);
#: a stop-and-go sweep has one at every stop, and refuses as large a share of a 1 kHz recording.
MAX_CONTINUOUS_STILLS = 2.0


def moving_words(rejected: Mapping[str, int], seen: int, kept: int, stills_per_configuration: float) -> str:
    """The quasi-static filter's advice for a recording that moves without stopping ('' otherwise).

    Args:
        rejected: Samples the quasi-static filter refused, by rule ('joint speed', ...).
        seen: Samples given.
        kept: Samples kept.
        stills_per_configuration: Still stretches of the kept samples (apart by more than a gap),
            per configuration that has any.
    """
    moving = max(rejected.get("joint speed", 0), rejected.get("joint acceleration", 0))
    if not seen or moving < MOVING_SHARE * seen or stills_per_configuration > MAX_CONTINUOUS_STILLS:
        return ""
    return (
        f"the arm moves without stopping ({moving / seen:.0%} of the samples refused for joint speed or acceleration, "
        f"{kept:,} kept): calibrate it with --filter dynamic (moving samples with the tool's dynamics), or record stops"
    )


def refused_words(skipped: Mapping[str, int], seen: int, kept: int) -> str:
    """Why nothing was kept when the checks refused most samples, in words: their largest counts ('' otherwise).

    Args:
        skipped: Samples the checks refused, by reason (:attr:`SampleChecks.skipped`).
        seen: Samples given.
        kept: Samples kept.
    """
    refused = sum(skipped.values())
    if kept or 2 * refused < seen:  # nothing kept for lack of stillness or excitation: the tool's advice says what
        return ""
    if not seen:
        return "no sample was given"
    top = sorted(((n, reason) for reason, n in skipped.items() if n), reverse=True)[:2]
    parts = [f"{reason} {n:,}" + (f" ({REFUSED[reason]})" if reason in REFUSED else "") for n, reason in top]
    share = "none" if refused >= seen else f"{seen - refused:,}"
    return f"{share} of the {seen:,} samples passed the checks: " + ", ".join(parts)


def undetermined_words(groups: Sequence[Sequence[str]]) -> str:
    """The offset columns the data cannot determine, and why, in words ('' when none).

    Args:
        groups: Per missing direction, the offset-model columns it mixes, largest weight
            first (:meth:`fts_calib.model.estimator.OnlineEstimator.undetermined`), e.g.
            ``[['time^1', 'temperature']]``.
    """
    words = []
    for group in groups:
        quoted = " and ".join(f"'{name}'" for name in group)
        if len(group) == 1:
            words.append(f"the offset column {quoted} is undetermined: the kept samples give it no variation of its own")
            continue
        timed = any(name.startswith("time^") for name in group)
        if "temperature" in group and timed:
            why = (
                "the temperature followed time over the kept samples (a warm-up), so a drift with time and one with temperature look alike"
            )
        elif timed and any(name.startswith("offset ") for name in group):
            why = "a configuration's kept samples span too little of the run to tell its offset from a drift with time"
        else:
            why = "they move together over the kept samples (one is a linear function of the others)"
        words.append(
            f"the offset columns {quoted} cannot be told apart: {why}; --offsets auto fits a drift model without one of them, "
            "or record a run over which they part"
        )
    return "; ".join(words)

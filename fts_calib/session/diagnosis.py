"""What a calibration still needs, in words: the one advice text of the session and live progress.

Identifiability (paper eqs 18-20): one tool centre of mass gives rank 4, two give 6, three
not on one line give 7; within each configuration, gravity must be seen from directions
that span 3-D.

The cause of a poor fit or of a missing rank, named in a fixed order before any guess.

A fit the noise does not explain (:mod:`fts_calib.session.fit`) has one cause that the data
can show; the causes are tried in this order, and the first that the data support is named:

1. **Missing centres of mass** (:func:`missing_centres`): the configurations recorded give
   one centre of mass, or centres on one line, while the tool file has more. The rank the
   recording lacks is named with the configurations to mount (an
   :class:`~fts_calib.core.exceptions.InsufficientExcitation`: ``calibrate`` exits 8, EXCITATION),
   whatever the fit.
2. How the orientations are read: first **joint units** (:func:`joint_units`): the kept
   samples' joints read in the other unit (degrees for rad, or rad for degrees) fit the tool's
   model at the noise. A unit mistake also shrinks the orientations seen, so it is tried before
   the weak excitation it causes. Then **the sensor mount** (:func:`mount`): gravity turned by a
   constant rotation of the sensor frame (``--mount``, ``sensor.rpy``, orientation columns of
   another frame) fits at the noise (:mod:`fts_calib.session.frame_rotation`), by more than a
   declared tolerance can mimic; named with the mount that removes it. A turn leaves residuals
   that a bend or a drift absorbs in part, so it is
   tried before them; a tool file's alternative (cause 5) that fits as well is named with it (for
   the paper's tool, labels B and C swapped are a half turn of the frame). Not on a weakly excited
   recording (cause 3): there a turn absorbs what the weak axis leaves (12 s of the short plan,
   a 3 % FS bend: a 15 deg turn fits at 1.95x).
3. **Weak excitation** (:func:`weak_excitation`): the information of the known loads
   ``[W; b]`` (scaled to a unit diagonal, as the estimator's rank) has a condition number
   above :data:`WEAK_CONDITION`, or a missing direction: the wrench axis the loads vary least
   on its own is named, with the spread of gravity seen along it and the motion that varies it
   (a missing direction stays an ``InsufficientExcitation``; a poor conditioning diagnoses a poor fit).
4. **A nonlinear sensor** (:func:`nonlinear`): the quadratic family of
   :mod:`fts_calib.model.features` (``u``, every ``u_i u_j``) fitted to the kept samples
   leaves a residual at the noise (at most :data:`~fts_calib.session.fit.MAX_RATIO` times
   it, per configuration and axis) where the linear model does not. ``--model quadratic`` is
   suggested only when the loads determine that model beyond themselves
   (:mod:`fts_calib.model.determination`); otherwise the jig that would is named. Or **drifting offsets**
   (:func:`drifting`): the drift offset model with every time power does. A quadratic in the
   channels absorbs a part of a drift along a sweep (and the reverse), so when both fit the
   one with the smaller residual is named.
5. The tool file's alternatives of :func:`fts_calib.session.fit.check_fit` (labels permuted,
   centres of mass in mm or cm, one mass mistyped), each named only when it fits at the noise
   and clearly better than the stated tool; then the collinear tool file, then the generic advice.

Units: gravity in [m/s^2], wrenches in [N, N m], channels raw.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ..budget.measured import STOP_GAP_S, KeptSamples
from ..budget.sensitivities import stops
from ..filters.dynamic import DynamicFilter
from ..filters.quasi_static import QuasiStaticFilter
from ..filters.sample_checks import BACKWARDS, NON_FINITE, OUTSIDE_LIMITS
from ..filters.settings import PipelineConfig
from ..model.channels import WRENCH_AXES, ChannelLayout
from ..model.determination import Determination, LoadSums, determine
from ..model.estimator import OnlineEstimator
from ..model.features import features
from ..model.least_squares import load_information
from ..model.offset_models import candidates
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool, tool_load
from ..sources.bag import is_pose_run
from ..sources.batch import UNKNOWN_TOOL
from .fit import CLEARLY_BETTER, MAX_RATIO, FitAllowance, FitCheck, _ratios, fit_rows, implausible_tool, model_fit_sums, robot_allowance
from .frame_rotation import beside, fitting_turns, mimicked_turn, mount_words, rotation_angle


class Diagnosed(Protocol):
    """What the diagnosis reads of a calibration session (:class:`~fts_calib.session.session.Diagnosed` is one).

    The session's tool, kinematics, estimator, layout and settings; its filter (its noise floor);
    per configuration the kept samples' counts, fit sums and gravity directions
    (:func:`~fts_calib.session.session.add_kept`), the kept samples themselves, the sensor's full
    scale [N, N m] (6,), and what gives the orientation (``feeds.source``) or None.
    """

    kin: Kinematics
    tool: Tool
    estimator: OnlineEstimator
    layout: ChannelLayout
    settings: PipelineConfig
    kept: np.ndarray
    full_scale: np.ndarray
    fit_sums: np.ndarray
    directions: np.ndarray
    kept_samples: KeptSamples
    orientation_source: str | None
    joints_in_degrees: bool

    @property
    def filter(self) -> QuasiStaticFilter | DynamicFilter | None:
        """The session's filter (its noise floor), or None."""


#: Kept samples of a configuration before it counts in the advice.
MIN_SAMPLES = 10
#: The advice when nothing specific is missing: for the quasi-static filter, and for the dynamic one.
GENERIC = "more quasi-static samples"
GENERIC_DYNAMIC = "more moving samples the dynamic filter trusts"
#: What to look at when the checks refused every sample, by the reason they counted.
REFUSED = {
    OUTSIDE_LIMITS: "joint readings in degrees? they must be in rad: --joint-unit deg, joints_in_degrees=True",
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
    dynamic: bool = False,
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
        dynamic: The samples are the dynamic filter's (moving ones): never the advice to hold still.
    """
    if refused:
        return "; ".join(w for w in (cause, refused) if w)
    apart, words = undetermined_words(undetermined), _tool_words(tool, kept, directions, dynamic)
    return "; ".join(w for w in (cause, apart, "" if apart and words in (GENERIC, GENERIC_DYNAMIC) else words) if w)


def _tool_words(tool: Tool, kept: Sequence[int] | np.ndarray, directions: np.ndarray, dynamic: bool = False) -> str:
    names = tool.names
    seen = [k for k in range(len(names)) if kept[k] >= MIN_SAMPLES]
    if not seen and dynamic:
        return (
            "no moving sample the dynamic filter trusts yet: move through the plan's motion (a motion too fast or jerky for "
            "the joint readings' noise and latency is not trusted: filter.max_error_ratio)"
        )
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
    return "; ".join(words) or (GENERIC_DYNAMIC if dynamic else GENERIC)


def _listed(names: Sequence[str]) -> str:
    """'B', 'B and C', 'B, C and D'."""
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]


#: Share of the samples the quasi-static filter refused for moving above which a continuous motion may be named.
MOVING_SHARE = 0.9
#: Still stretches per configuration up to which the motion is continuous (at rest before and after it only);
#: a stop-and-go sweep has one at every stop, and refuses as large a share of a 1 kHz recording.
MAX_CONTINUOUS_STILLS = 2.0


def moving_words(rejected: Mapping[str, int], seen: int, kept: int, stills_per_configuration: float) -> str:
    """That a recording moves without stopping, in words, for the quasi-static filter ('' otherwise).

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
    return f"the arm moves without stopping ({moving / seen:.0%} of the samples refused for joint speed or acceleration, {kept:,} kept)"


#: The quasi-static filter's advice for a recording that moves without stopping (:func:`moving_words` first).
MOVING_ADVICE = "calibrate it with --filter dynamic (moving samples with the tool's dynamics), or record stops"


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


#: Condition number of the known loads' information (scaled to a unit diagonal) above which an
#: axis counts as weakly excited. A plan of ``fts-calib trajectory`` reads 50 to 700.
WEAK_CONDITION = 1e4
#: Kinds of cause (:attr:`Cause.kind`) that a recording, not a file, explains: a missing rank stays one (exit 8).
RECORDING_KINDS = ("weak excitation", "unexplained")
#: A turned sensor frame is named only beyond this many times the turn a declared tolerance can mimic: the robot
#: file's ``accuracy.mount_rotation``, or the tool file's ``tolerance.com`` over the centres of mass' spread (a tool
#: declared to 0.5 mm with centres 0.5 mm off in each configuration fits turns up to 0.9 deg: 8 of 100 seeds) ...
MOUNT_TOLERANCES = 3.0
#: ... and beyond this angle [rad] (0.5 deg: a mount known to a tenth of a degree is not worth naming).
MIN_MOUNT_ERROR = math.radians(0.5)
_AXES = "xyz"


@dataclass(frozen=True)
class Cause:
    """A named cause.

    Attributes:
        kind: 'missing centres', 'joint units', 'mount', 'weak excitation', 'nonlinear', 'drift', 'tool file'
            (an alternative, an implausible value or a collinear file), 'repeatability' or 'unexplained'.
        text: The diagnosis, in words.
        ratio: The largest residual-to-noise ratio of the model it names (mount, drift, nonlinear), else NaN.
    """

    kind: str
    text: str
    ratio: float = math.nan


def _seen_span(session: Diagnosed) -> tuple[int, int, np.ndarray]:
    """(affine rank of the seen configurations' centres of mass, configurations seen, every centre of mass (k, 3))."""
    coms = np.array([c.p_sensor_com for c in session.tool.configurations])
    seen = [k for k in range(len(coms)) if session.kept[k] >= MIN_SAMPLES]
    return (_span(coms[seen]) if seen else -1), len(seen), coms


def missing_centres(session: Diagnosed) -> bool:
    """Whether the configurations recorded lack the centres of mass that the tool file has (cause 1).

    True when the seen configurations' centres of mass are one point or lie on one line, and
    either only one configuration was recorded or the tool file has one off that line.

    Args:
        session: The session (its kept counts per configuration and its tool).
    """
    span, seen, coms = _seen_span(session)
    if span < 0 or span >= 2:
        return False
    return seen == 1 or _span(coms) > span


def _span(points: np.ndarray) -> int:
    """Affine rank of centres of mass (0: one point, 1: a line, 2: a plane or more)."""
    return int(np.linalg.matrix_rank(points - points[0], tol=1e-6)) if len(points) > 1 else 0


def weak_excitation(session: Diagnosed) -> Cause | None:
    """The weakly excited wrench axis, its condition number and the motion that excites it (cause 3), or None.

    Centres of mass on one line leave a direction that no motion excites (a tool file's
    matter, causes 1 and 5): then None.

    Args:
        session: The session (the estimator's sums of the offset model in use; the gravity
            directions seen per configuration).
    """
    if _seen_span(session)[0] < 2:
        return None
    est = session.estimator
    chosen = est.model_in_use()[0]
    rank, condition = load_information(est.model_sums(chosen))[:2]
    if condition <= WEAK_CONDITION:
        return None
    constant = est.model_sums(est._constant())
    plain = load_information(constant)[1]
    if rank < len(chosen.A) + 6 and plain <= WEAK_CONDITION:  # only the offset model's columns are missing: their words say which
        return None
    axis = _weak_axis(constant)
    name, i = WRENCH_AXES[axis], axis % 3
    others = " or ".join(f"its {a} axis" for a in _AXES if a != _AXES[i])
    if axis < 3:
        directions = session.directions.sum(axis=0)  # sum of [u; 1][u; 1]^T over the configurations
        n = max(directions[3, 3], 1.0)
        spread = math.sqrt(max(directions[i, i] / n - (directions[i, 3] / n) ** 2, 0.0))
        seen = f"; gravity's {_AXES[i]} component in the sensor frame has a standard deviation of {spread:.2g} g"
        motion = f"tilt the sensor's {_AXES[i]} axis up and down (rotate it about {others}) so that gravity's {_AXES[i]} component changes"
    else:
        seen = ""
        motion = f"rotate the sensor about its {_AXES[i]} axis, and tilt it, with the tool's centre of mass off that axis"
    full = len(chosen.A) + 6
    how = f"rank {rank} of {full}" if rank < full else f"condition number {condition:.2g}"
    level = "does not vary" if rank < full else "barely varies"
    offsets = "" if chosen.model == "constant" else f" with {chosen.model} offsets"
    text = f"weak excitation: {name} {level} over the kept samples ({how}{offsets}{seen}): {motion}"
    if offsets and plain <= WEAK_CONDITION:  # the offset model's columns follow the motion, not the loads alone
        text += f" while the orientations are revisited as time goes on (with constant offsets the condition number is {plain:.3g})"
    return Cause("weak excitation", text)


def _weak_axis(sums: np.ndarray) -> int:
    """The wrench axis (0-5) that the loads vary least on its own, with constant offsets.

    With full rank, the largest variance inflation ``(S^-1)_jj`` of a wrench column in the
    scaled information (how little of it the other columns leave); below full rank, the
    wrench column with the largest weight in a missing direction.
    """
    rank, _, eig, vec = load_information(sums)
    if rank < len(eig):
        return int(np.argmax(np.abs(vec[:6, 0])))
    inflation = np.einsum("ij,j,ij->i", vec[:6], 1.0 / eig, vec[:6])  # diag of the inverse, wrench columns
    return int(np.argmax(inflation))


def _kept(session: Diagnosed):
    """The kept samples ``(time, W, channels, configuration, joints)``, or None when not all are at hand (a resumed session)."""
    arrays = session.kept_samples.arrays()
    return arrays if len(arrays[0]) and len(arrays[0]) == int(session.kept.sum()) else None


def session_allowance(session: Diagnosed) -> FitAllowance:
    """What the robot file's mount and encoder tolerances and ``fit.floor`` add to the expected residual of the session's fit."""
    kin = session.kin
    settings = session.settings
    return robot_allowance(kin.robot.accuracy, kin.n_joints, session.full_scale, settings.fit.floor, settings.repeatability)


def _noise_cov(session: Diagnosed) -> np.ndarray | None:
    noise = None if session.filter is None else session.filter.noise_floor
    return None if noise is None else session.layout.projected_noise(noise)


def joint_units(session: Diagnosed, check: FitCheck, per_configuration: bool, joints_in_degrees: bool) -> Cause | None:
    """The joint columns in the other unit, when read so the kept samples fit at the noise (cause 2), or None.

    Args:
        session: The session (its kinematics, tool, kept samples and noise floor).
        check: The fit check of the joints as read.
        per_configuration: The offset model in use has one offset per configuration.
        joints_in_degrees: The joints were converted from degrees (then rad is tried), else degrees are.
    """
    kept, noise_cov = _kept(session), _noise_cov(session)
    if kept is None or noise_cov is None:
        return None
    time, _, channels, codes, joints = kept
    factor = math.degrees(1.0) if joints_in_degrees else math.radians(1.0)
    joints = joints * factor
    still = _still(time, joints, session.settings.filter.max_joint_speed)  # the filter judged the joints as read
    if still.sum() < MIN_SAMPLES:
        return None
    channels, codes, joints = channels[still], codes[still], joints[still]
    g = tool_load(session.kin, session.tool, joints, codes).g_sensor
    rows = fit_rows(g, channels, session.layout)
    k = len(session.tool.configurations)
    sums = np.zeros((k, rows.shape[1], rows.shape[1]))
    for c in range(k):
        mine = rows[codes == c]
        sums[c] = mine.T @ mine
    counts = sums[:, 9, 9]
    matrices = [c.wrench_matrix for c in session.tool.configurations]
    judged = _ratios(session.tool, matrices, sums, counts, noise_cov, per_configuration, session_allowance(session))
    if judged is None or not _clearly_fits(float(judged[0].max()), check.max_ratio):
        return None
    if joints_in_degrees:
        return Cause("joint units", "the joint columns are in rad already: give --joint-unit rad (joints_in_degrees=False)")
    return Cause("joint units", "the joint columns are in degrees: give --joint-unit deg (joints_in_degrees=True)")


def _still(time: np.ndarray, joints: np.ndarray, max_speed: float, window_s: float = 0.2, most: int = 64) -> np.ndarray:
    """Samples whose joints move by at most ``max_speed`` [rad/s] to every sample within ``window_s`` [s] either side, shape (N,).

    The quasi-static filter judged the joints as read; read in another unit, a sample at the
    start or end of a motion is not still: it is left out (up to ``most`` neighbours a side).
    """
    still = np.ones(len(time), dtype=bool)
    for d in range(1, min(most, len(time) - 1) + 1):
        dt = time[d:] - time[:-d]
        near = dt <= window_s
        if not near.any():
            break
        fast = near & (np.max(np.abs(joints[d:] - joints[:-d]), axis=1) > max_speed * np.maximum(dt, 1e-9))
        still[d:] &= ~fast
        still[:-d] &= ~fast
    return still


def _clearly_fits(ratio: float, stated: float) -> bool:
    """An alternative fits at the noise, and clearly better than the stated model."""
    return ratio <= MAX_RATIO and ratio * CLEARLY_BETTER <= stated


def mount(session: Diagnosed, check: FitCheck, per_configuration: bool) -> Cause | None:
    """A sensor frame turned from the one assumed, when the turn makes the kept samples fit at the noise (cause 2), or None.

    The rotation ``R_sensor_assumed`` is found on the fit sums (:mod:`fts_calib.session.frame_rotation`):
    named only when the kept samples then fit at the noise and clearly better than as given, and the
    turn is more than :data:`MOUNT_TOLERANCES` times what the declared tolerances can mimic (the robot
    file's ``accuracy.mount_rotation``, the tool file's ``tolerance.com``) and more than
    :data:`MIN_MOUNT_ERROR`. The words say what to change: the robot file's ``sensor.rpy``,
    ``--mount``, or the orientation columns (``session.orientation_source``).

    Args:
        session: The session (its fit sums, tool, noise floor, kinematics and orientation source).
        check: The fit check of the model in use, poor.
        per_configuration: The offset model in use has one offset per configuration.
    """
    noise_cov = _noise_cov(session)
    if noise_cov is None:
        return None
    est, tool = session.estimator, session.tool
    chosen = est.model_in_use()[0]
    sums = model_fit_sums(session.fit_sums, chosen.model, chosen.columns, est.basis.n_configurations)[0]
    allowance = session_allowance(session)
    turns = fitting_turns(tool, sums, noise_cov, per_configuration, allowance, check.expected, lambda r: _clearly_fits(r, check.max_ratio))
    if not turns:
        return None
    coms = np.array([c.p_sensor_com for c in tool.configurations])[sums[:, 9, 9] > 0]
    mimicked = mimicked_turn(coms, 0.0 if tool.tolerance is None else tool.tolerance.com, session.kin.robot.accuracy.mount_rotation)
    R, ratio = turns[0].R_sensor_assumed, turns[0].ratio
    if rotation_angle(R) <= max(MOUNT_TOLERANCES * mimicked, MIN_MOUNT_ERROR):
        return None
    robot, mounted, source = not is_pose_run(session.kin.joint_names), session.kin.robot.sensor.rpy, session.orientation_source
    fit = f"then the kept samples fit at the noise: largest residual {ratio:.3g}x the expected noise, as given {check.max_ratio:.3g}x"
    text = mount_words(R, mounted, robot, source, fit)
    if others := beside(turns):  # the data fit a turn and its twin alike
        also = "; ".join(mount_words(other, mounted, robot, source) for other in others)
        text += f"; as well: {also} (a half turn about the normal of the centres of mass' plane: the data cannot tell them apart)"
    return Cause("mount", text, ratio)


def drifting(session: Diagnosed, check: FitCheck) -> Cause | None:
    """Offsets that drift during the run, when the drift model with every time power fits at the noise (with cause 4), or None.

    Args:
        session: The session (its fit sums with the offset basis's drift columns, noise floor).
        check: The fit check of the offset model in use (constant or per-configuration).
    """
    est, noise_cov = session.estimator, _noise_cov(session)
    drifts = [c for c in candidates(est.basis, est._present(), "drift") if c.model == "drift"]
    if not drifts or noise_cov is None or est.model_in_use()[0].model == "drift":
        return None
    sums = model_fit_sums(session.fit_sums, "drift", drifts[-1].columns, est.basis.n_configurations)[0]
    matrices = [c.wrench_matrix for c in session.tool.configurations]
    judged = _ratios(session.tool, matrices, sums, session.fit_sums[:, 9, 9], noise_cov, True, session_allowance(session))
    if judged is None or not _clearly_fits(ratio := float(judged[0].max()), check.max_ratio):
        return None
    text = (
        f"offsets that drift during the run (warm-up, temperature): drifting offsets fit at the noise (largest residual "
        f"{ratio:.3g}x the expected noise, the offsets in use {check.max_ratio:.3g}x): --offsets auto or drift models them"
    )
    return Cause("drift", text, ratio)


def nonlinear(session: Diagnosed, check: FitCheck, per_configuration: bool) -> Cause | None:
    """A quadratic model of the kept samples that fits at the noise where the linear one does not (cause 4), or None.

    Args:
        session: The session (its kept samples, channel layout and noise floor).
        check: The linear model's fit check (its expected residual per axis, its largest ratio).
        per_configuration: One offset per configuration (the offset model in use), else one for all.
    """
    kept = _kept(session)
    if kept is None or _noise_cov(session) is None:
        return None
    _, W, channels, codes, _ = kept
    u = session.layout.project(channels).reshape(-1, 6)
    names = session.tool.names
    offsets = np.eye(len(names))[codes] if per_configuration else np.ones((len(W), 1))
    X = np.hstack([features(u - u.mean(axis=0), 2), offsets])
    if len(X) < 3 * X.shape[1]:
        return None
    scale = np.linalg.norm(X, axis=0)
    scale[scale == 0] = 1.0
    theta = np.linalg.lstsq(X / scale, W, rcond=None)[0]
    residual = W - (X / scale) @ theta
    worst = 0.0
    for c in np.unique(codes):
        rms = np.sqrt(np.mean(residual[codes == c] ** 2, axis=0))
        worst = max(worst, float(np.max(rms / check.expected)))
    if not _clearly_fits(worst, check.max_ratio):
        return None
    found = quadratic_determination(session, per_configuration)
    fits = f"(largest residual {worst:.3g}x the expected noise, the linear model's {check.max_ratio:.3g}x)"
    if found.determined:
        return Cause("nonlinear", f"the sensor is nonlinear: a quadratic model fits at the noise {fits}: --model quadratic or auto", worst)
    m, c = found.requirement
    text = (
        f"the sensor is nonlinear: a quadratic model fits these loads at the noise {fits}, but these loads cannot determine it "
        f"beyond themselves ({found.lacks(session.tool.names)}): calibrate it with a jig of {m} masses at {c} centres of mass "
        "each ('fts-calib trajectory --tool TOOL --model quadratic' names one for this tool), or keep the linear model knowingly "
        "(--accept-poor-fit: its budget then holds the misfit)"
    )
    return Cause("nonlinear", text, worst)


def quadratic_determination(session: Diagnosed, per_configuration: bool) -> Determination:
    """What the session's loads determine of a quadratic model (:mod:`fts_calib.model.determination`).

    The estimator's own sums of the weight-only loads when it keeps them (a model other than the
    linear one), else those of the kept samples' known wrenches.

    Args:
        session: The session.
        per_configuration: One offset per configuration (the offset model in use), else one for all.
    """
    units = session.estimator.units
    if units is not None and units.loads.degree >= 2:
        return determine(units.loads.sums, "quadratic", per_configuration)
    loads = LoadSums(2)
    kept = session.kept_samples.arrays()
    if len(kept[0]):
        loads.add(kept[1], kept[3])
    return determine(loads.sums, "quadratic", per_configuration)


def cause(
    session: Diagnosed, check: FitCheck, per_configuration: bool, unexplained: str, joints_in_degrees: bool, linear: bool = True
) -> Cause:
    """The cause of a poor fit, in the order of the module docstring (causes 2 to 5).

    Args:
        session: The session.
        check: The linear model's poor fit check; its diagnosis is cause 5 (the tool file's
            alternatives, the collinear file) or the generic advice.
        per_configuration: The offset model in use has one offset per configuration.
        unexplained: The start of :func:`~fts_calib.session.fit.check_fit`'s generic advice
            (no alternative fits), or of the hint that replaces it.
        joints_in_degrees: The joints were converted from degrees.
        linear: The model in use is the linear one (else a nonlinear one is, and cause 4 is not tried).
    """
    if implausible_tool(session.tool):  # a value no residual shows: certain whatever the fit
        return Cause("tool file", check.diagnosis)
    generic = not check.diagnosis or check.diagnosis.startswith(unexplained)
    found = joint_units(session, check, per_configuration, joints_in_degrees)
    weak = None if found is not None else weak_excitation(session)
    # a weak axis lets a turn absorb a bend or a drift, as it lets the tool file's alternatives: the turn is not tried then
    if found is None and weak is None and (found := mount(session, check, per_configuration)) is not None and not generic:
        # the tool file's alternative fits as well (for the paper's tool, labels B and C swapped are a half turn of the frame)
        found = Cause("tool file", f"{check.diagnosis}; or, fitting as well: {found.text}")
    if found is not None or (found := weak) is not None:
        return found
    # the sensor's own behaviour: a bend with the load or a drift with time, the one that fits the better
    behaviours = [c for c in (drifting(session, check), nonlinear(session, check, per_configuration) if linear else None) if c is not None]
    if behaviours:
        return min(behaviours, key=lambda c: c.ratio)
    if generic and (found := nonrepeating(session, per_configuration)) is not None:
        return found
    return Cause("unexplained" if generic else "tool file", check.diagnosis)


#: Pose means must scatter this many times more than the noise within a pose explains before a sensor is said not to repeat.
SCATTER_BEYOND_NOISE = 3.0
#: Share of the pose means' scatter that a smooth function of gravity per configuration, a quadratic (what a tool file's
#: error, a turned mount or a bend leaves), must leave unexplained, degrees of freedom counted, for it to be a sensor's.
RANDOM_SHARE = 0.7
#: Two still poses of one configuration whose gravity directions are this close [deg] visit one orientation twice.
REVISIT_DEG = 1.0
#: Kept samples a still pose needs to count in the figures, and poses a configuration needs (a quadratic in gravity
#: has 9 free coefficients: 18 poses leave as many degrees of freedom).
POSE_SAMPLES, CONFIGURATION_POSES = 3, 18
_PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))  # the products of gravity's components


@dataclass(frozen=True)
class Repeatability:
    """What the kept samples show of a sensor's repeatability, per axis, [N, N, N, N m, N m, N m].

    Attributes:
        within: The noise within a still pose (the residual's standard deviation about the pose's mean). Shape (6,).
        between: The scatter between poses (the standard deviation of the poses' mean residuals). Shape (6,).
        random_share: Per axis, what a quadratic function of gravity per configuration leaves of the pose means'
            scatter, degrees of freedom counted (1: none explained, as for a random offset per pose; near 0: a
            smooth error such as a tool file's). Shape (6,).
        poses: Still poses counted.
        revisited: The scatter between two visits of one orientation (within :data:`REVISIT_DEG`, one configuration),
            per axis, shape (6,); None when no orientation was visited twice. A sensor that does not repeat reads
            a revisited orientation differently (about ``between``); a bend or any error of the orientation alone
            reads it alike (about the noise).
    """

    within: np.ndarray
    between: np.ndarray
    random_share: np.ndarray
    poses: int
    revisited: np.ndarray | None = None

    def shown(self) -> bool:
        """The data show a sensor that does not repeat: the pose means scatter beyond the noise, at random, on every axis they do."""
        beyond = self.between > SCATTER_BEYOND_NOISE * np.maximum(self.within / math.sqrt(POSE_SAMPLES), 1e-300)
        if self.revisited is not None:  # the one test a function of the orientation cannot pass
            beyond &= self.revisited > RANDOM_SHARE * self.between
        return bool(beyond.any() and np.all(self.random_share[beyond] >= RANDOM_SHARE))

    def words(self) -> str:
        """The two figures, forces and moments, e.g. 'within a still pose 0.021 N and 0.0013 N·m, between poses 1.5 N and ...'."""
        w, b, again = self.within, self.between, self.revisited
        text = (
            f"within a still pose its noise is {w[:3].max():.2g} N and {w[3:].max():.2g} N·m, between poses its readings "
            f"scatter by {b[:3].max():.2g} N and {b[3:].max():.2g} N·m (standard deviations, largest axis, {self.poses} poses)"
        )
        if again is not None:
            text += f"; one orientation visited twice reads {again[:3].max():.2g} N and {again[3:].max():.2g} N·m apart"
        return text


def pose_scatter(time, W, channels, codes, layout: ChannelLayout, per_configuration: bool) -> Repeatability | None:
    """The noise within still poses and the scatter between them of a linear fit's residual (see :class:`Repeatability`).

    Args:
        time: Kept samples' times [s], shape (N,); a gap longer than the budget's stop gap starts a new pose.
        W: Their known wrenches [N, N m], shape (N, 6).
        channels: Their raw channels, shape (N, n).
        codes: Their configuration indices, shape (N,).
        layout: The sensor's channel layout.
        per_configuration: One offset per configuration (the offset model in use), else one for all.

    Returns:
        The figures, or None when too few poses hold enough samples.
    """
    u = layout.project(channels).reshape(-1, 6)
    offsets = np.eye(int(codes.max()) + 1)[codes] if per_configuration else np.ones((len(W), 1))
    X = np.hstack([u - u.mean(axis=0), offsets])
    scale = np.linalg.norm(X, axis=0)
    scale[scale == 0] = 1.0
    residual = W - (X / scale) @ np.linalg.lstsq(X / scale, W, rcond=None)[0]
    pose = stops(time, codes, STOP_GAP_S)
    counts = np.bincount(pose)
    full = counts >= POSE_SAMPLES
    if full.sum() < 2 * CONFIGURATION_POSES:
        return None
    sums = np.zeros((len(counts), 6))
    np.add.at(sums, pose, residual)
    means = sums / np.maximum(counts, 1)[:, None]
    deviation = residual - means[pose]
    within = np.sqrt(np.sum(deviation[full[pose]] ** 2, axis=0) / max(int(np.sum(counts[full] - 1)), 1))
    pose_code = np.zeros(len(counts), dtype=np.int64)
    pose_code[pose] = codes
    gravity = np.zeros((len(counts), 3))
    np.add.at(gravity, pose, W[:, :3])
    gravity /= np.maximum(counts, 1)[:, None]
    left, total, dof = np.zeros(6), np.zeros(6), 0
    for c in np.unique(pose_code[full]):
        mine = full & (pose_code == c)
        if mine.sum() < CONFIGURATION_POSES:
            continue
        g = gravity[mine] / np.maximum(np.linalg.norm(gravity[mine], axis=1, keepdims=True), 1e-300)
        A = np.hstack([np.ones((len(g), 1)), g, np.stack([g[:, i] * g[:, j] for i, j in _PAIRS], axis=1)])
        solution, _, rank, _ = np.linalg.lstsq(A, means[mine], rcond=1e-9)
        left += np.sum((means[mine] - A @ solution) ** 2, axis=0)
        total += np.sum(means[mine] ** 2, axis=0)
        dof += int(mine.sum()) - int(rank)
    if dof <= 0 or not np.all(total > 0):
        return None
    share = np.sqrt(left / dof) / np.sqrt(total / int(full.sum()))  # per axis
    between = np.sqrt(np.mean(means[full] ** 2, axis=0))
    return Repeatability(within, between, np.minimum(share, 1.0), int(full.sum()), _revisited(means, gravity, pose_code, full))


def _revisited(means: np.ndarray, gravity: np.ndarray, pose_code: np.ndarray, full: np.ndarray) -> np.ndarray | None:
    """The scatter of the pose means between two visits of one orientation, per axis, shape (6,); None without a revisit."""
    unit = gravity / np.maximum(np.linalg.norm(gravity, axis=1, keepdims=True), 1e-300)
    close = (unit @ unit.T > math.cos(math.radians(REVISIT_DEG))) & (pose_code[:, None] == pose_code[None, :])
    close &= full[:, None] & full[None, :] & np.triu(np.ones_like(close), 1)
    first, second = np.nonzero(close)
    if not len(first):
        return None
    return np.sqrt(np.mean((means[first] - means[second]) ** 2, axis=0) / 2.0)


def nonrepeating(session: Diagnosed, per_configuration: bool) -> Cause | None:
    """A sensor that does not repeat from pose to pose (hysteresis, creep), when the kept samples show one, or None.

    The residual of a linear fit to the kept samples, per still pose: its mean scatters between
    poses far beyond what the noise within the poses explains, and at random (a quadratic function
    of gravity per configuration, which a tool file's error or a bend leaves, explains little of
    it; each configuration needs :data:`CONFIGURATION_POSES` poses for that test): named with its
    two figures and the sensor file's field that declares it.

    Args:
        session: The session (its kept samples and channel layout).
        per_configuration: One offset per configuration (the offset model in use), else one for all.
    """
    kept = _kept(session)
    if kept is None:
        return None
    time, W, channels, codes, _ = kept
    found = pose_scatter(time, W, channels, codes, session.layout, per_configuration)
    if found is None or not found.shown():
        return None
    force, moment = float(found.between[:3].max()), float(found.between[3:].max())
    text = (
        f"the sensor does not repeat from pose to pose (hysteresis, creep): {found.words()}, and no model of the tool "
        f"file, the mount, a bend or a drift fits better: declare it in the sensor file, repeatability: {{force: {force:.2g}, "
        f"moment: {moment:.2g}}} (N, N·m); the fit check then expects it and the accuracy budget holds it"
    )
    if found.revisited is None:  # without a revisit, a bend no polynomial follows scatters alike
        text += (
            "; no orientation was visited twice, so a sensor whose response bends with the load in a way these loads "
            "cannot show would scatter alike (a jig of 2 masses, each at 5 centres of mass, would show it: 'fts-calib "
            "trajectory --tool TOOL --model quadratic' names one; --return-pass visits every stop twice and tells them apart)"
        )
    return Cause("repeatability", text)

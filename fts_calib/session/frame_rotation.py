r"""The constant rotation of the sensor frame that best explains the kept samples: a mount or frame mistake.

A wrong mount (``--mount``, a robot file's ``sensor.rpy``, orientation columns that are not the
sensor frame's) turns the gravity the sensor feels. The pipeline computes ``g``, gravity in the
frame it *assumes* is the sensor's; the sensor felt gravity in its own frame,

.. math::

    g_{sensor} = R_{sensor,assumed}\, g_{assumed}, \qquad W_c = M_c\, R_{sensor,assumed}\, g_{assumed},

with ``R_sensor_assumed`` constant and ``M_c = m_c [I; [c_c]x]`` (eqs 17-18, centres of mass in
the true sensor frame). The fit check's sums of ``y = [g; P Delta; 1; drift]`` per configuration
(:mod:`fts_calib.session.fit`) judge that hypothesis without reading the data again: ``y`` becomes
``T y`` with ``T = diag(R, I)``, so each sum becomes ``T S_c T^T`` (:func:`rotated_sums`).

**Search.** The residual the fit leaves, weighted per axis, ``f(R) = sum_{c,j} RSS_{c,j}(R) / (n_c
sigma_j^2)``, is a quadratic form ``r^T Q r`` of the nine entries ``r`` of R (the wrench is linear
in R and the fitted ``[C_bar, D]`` projects it): ``Q`` (9 x 9) comes from the residual of the
unit changes ``M_c E_a`` and their pairwise sums
(:func:`fts_calib.session.fit.projected_rss`, polarisation). The 24 rotations that
swap or flip axes (the frame mistakes people make) are tried first; from the best of them and
from the identity, Gauss-Newton on ``R exp([delta]x)`` refines the rotation vector.

**Twin.** With three configurations the centres of mass lie in one plane, of normal ``n``. A
half turn about ``n`` maps them onto themselves up to a sign and a shift (``Rot(n, pi)^T c = -c +
t``, ``t = 2 (c . n) n``), a linear map of the wrench that ``C_bar`` absorbs: ``R`` and
``Rot(n, pi) R`` fit alike, the second with the force noise carried into the moments by ``t``
(:func:`half_turn`). That noise also dilutes a misfit (a tool file's centres of mass 0.5 mm off
in each configuration: a twin fitted at the noise in 8 of 20 seeds), so a pair is judged by the
worse of its two ratios, and the member nearer a swap of axes is named (:func:`fitting_turns`).

**Size.** A turn by ``theta`` moves the centres of mass relative to one another by ``theta |c -
c_mean|`` (the rest, a common shift and the turn of the forces, a calibration absorbs): a centre
of mass off by the tool file's tolerance mimics a small turn (0.5 mm off in each configuration:
turns of 0.4-0.9 deg fit in 8 of 100 seeds). :func:`mimicked_turn` is the turn a declared
tolerance can mimic.

**Words.** The sensor frame's orientation in the frame assumed is ``R_assumed_sensor =
R_sensor_assumed^T``; the mount that gives it from the frame the robot file or the recording
gives (the flange) composes the mount in use with it, ``R_flange_sensor = R_flange_assumed
R_assumed_sensor``: the ``--mount`` or ``sensor.rpy`` named replaces the one given, it is not
added to it (:func:`mount_words`).

Units: rad; gravity in [m/s^2]; the sums as the fit check keeps them.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..robot.orientation import ORIENTATION_FORMS, mount_rpy
from ..robot.tool import Tool
from .fit import FitAllowance, _embeddings, _ratios, projected_rss

#: Two rotations closer than this are one candidate [rad].
SAME_ROTATION = math.radians(0.1)
#: A second turn that fits is named beside the first unless it is this much farther [rad] from a swap of axes.
CLEARLY_FARTHER = math.radians(10.0)
_STEPS = 30  # Gauss-Newton iterations at most; a quadratic form on SO(3) converges in 3 to 8


@functools.cache
def axis_aligned() -> np.ndarray:
    """The 24 rotations that swap and flip axes (signed permutations of determinant +1), identity first; shape (24, 3, 3), read-only."""
    out = []
    for order in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            R = np.zeros((3, 3))
            R[range(3), order] = signs
            if np.linalg.det(R) > 0:
                out.append(R)
    rotations = np.array(out)
    rotations.setflags(write=False)
    return rotations


def rotation_angle(R: np.ndarray) -> float:
    """The angle of a rotation ``R`` (3, 3), in [rad], in [0, pi]."""
    return float(np.linalg.norm(pin.log3(np.asarray(R, dtype=float))))


def nearest_axis_aligned(R: np.ndarray) -> tuple[np.ndarray, float]:
    """The rotation that swaps or flips axes nearest to a rotation.

    Args:
        R: A rotation, shape (3, 3).

    Returns:
        ``(A (3, 3), angle [rad])``: the nearest of :func:`axis_aligned` and the angle of ``A^T R``.
    """
    rotations = axis_aligned()
    angles = [rotation_angle(A.T @ R) for A in rotations]
    k = int(np.argmin(angles))
    return rotations[k], angles[k]


def rotated_sums(sums: np.ndarray, R_sensor_assumed: np.ndarray) -> np.ndarray:
    """The fit sums of the samples with their gravity turned into the sensor frame, ``T S_c T^T`` with ``T = diag(R, I)``.

    Args:
        sums: Per configuration the sum of ``y y^T``, ``y = [g_assumed; P Delta; 1; drift]``, shape (k, q, q).
        R_sensor_assumed: The assumed frame's orientation in the sensor frame, shape (3, 3).

    Returns:
        Shape (k, q, q).
    """
    T = np.eye(sums.shape[1])
    T[:3, :3] = R_sensor_assumed
    return T @ sums @ T.T


def residual_form(matrices: Sequence[np.ndarray], sums: np.ndarray, per_configuration: bool, sigma: np.ndarray) -> np.ndarray:
    """``Q`` (9, 9) with ``f(R) = vec(R)^T Q vec(R)`` the weighted residual the fit leaves (see the module docstring).

    Args:
        matrices: The wrench matrices ``M_c`` of the tool file, shape (6, 3) each.
        sums: Per configuration the fit sums, shape (k, q, q); ``sums[c, 9, 9]`` is its sample count.
        per_configuration: One offset per configuration, else one for all.
        sigma: The expected residual per axis [N, N, N, N m, N m, N m], shape (6,): each axis's weight is ``1 / sigma^2``.

    Returns:
        Symmetric, positive semi-definite, in units of squared ratios per unit entry of R; zeros when the
        regressors do not determine the fit. ``vec`` is row-major (``R.reshape(9)``).
    """
    unit = np.eye(9).reshape(9, 3, 3)
    pairs = [(a, b) for a in range(9) for b in range(a, 9)]
    M = np.stack([np.asarray(m, dtype=float) for m in matrices])
    changes = np.stack([np.einsum("cij,jk->cik", M, unit[a] + (unit[b] if b != a else 0.0)) for a, b in pairs])
    rss = projected_rss(changes, sums, _embeddings(sums, per_configuration))  # (P, k, 6)
    counts = np.maximum(sums[:, 9, 9], 1.0)
    value = dict(zip(pairs, np.einsum("pcj,c,j->p", rss, 1.0 / counts, 1.0 / np.asarray(sigma, dtype=float) ** 2), strict=True))
    Q = np.zeros((9, 9))
    for a, b in pairs:  # polarisation: f(E_a + E_b) = Q_aa + Q_bb + 2 Q_ab
        Q[a, b] = Q[b, a] = value[a, a] if a == b else (value[a, b] - value[a, a] - value[b, b]) / 2.0
    return Q


def _value(Q: np.ndarray, R: np.ndarray) -> float:
    r = R.reshape(9)
    return float(r @ Q @ r)


def refine(Q: np.ndarray, R: np.ndarray) -> np.ndarray:
    """The rotation near a start that minimises ``vec(R)^T Q vec(R)``: Gauss-Newton on ``R exp([delta]x)``.

    Each step solves the linearised form in ``delta`` (rad, about the 3 axes of the turned frame) and
    halves it until the value decreases.

    Args:
        Q: The residual's quadratic form (:func:`residual_form`), shape (9, 9).
        R: The start, a rotation, shape (3, 3).

    Returns:
        A rotation, shape (3, 3).
    """
    value = _value(Q, R)
    for _ in range(_STEPS):
        J = np.stack([(R @ pin.skew(e)).reshape(9) for e in np.eye(3)], axis=1)  # d vec(R exp(delta)) / d delta at 0
        delta = -np.linalg.lstsq(J.T @ Q @ J, J.T @ Q @ R.reshape(9), rcond=None)[0]
        step = 1.0
        while step > 1e-6:
            trial = R @ pin.exp3(step * delta)
            if (new := _value(Q, trial)) <= value:
                break
            step /= 2.0
        else:
            break
        moved = step * float(np.linalg.norm(delta))
        R, value = trial, new
        if moved < 1e-12:
            break
    return R


def half_turn(coms: np.ndarray) -> np.ndarray | None:
    """The half turn about the normal of the plane the centres of mass lie in: the twin of a turn ``R`` is ``H R``.

    Args:
        coms: Centres of mass in the sensor frame [m], shape (k, 3).

    Returns:
        ``H`` (3, 3); None when they do not span exactly a plane (one point, a line, or a volume: no twin).
    """
    if len(coms) < 3:
        return None
    _, s, vt = np.linalg.svd(coms - coms.mean(axis=0))
    if s[0] <= 0 or s[1] <= 1e-6 * s[0] or (len(s) > 2 and s[2] > 1e-6 * s[0]):
        return None
    return pin.exp3(math.pi * vt[2])


def frame_rotations(
    matrices: Sequence[np.ndarray], sums: np.ndarray, per_configuration: bool, sigma: np.ndarray, half: np.ndarray | None
) -> list[np.ndarray]:
    """Rotations ``R_sensor_assumed`` that explain the sums (see the module docstring), one per pair of twins, best first.

    Args:
        matrices: The wrench matrices ``M_c`` of the tool file, shape (6, 3) each.
        sums: Per configuration the fit sums of the samples as computed, shape (k, q, q).
        per_configuration: One offset per configuration, else one for all.
        sigma: The expected residual per axis [N, N m], shape (6,) (the weights).
        half: The half turn ``H`` of the centres of mass' plane (:func:`half_turn`), shape (3, 3), or None.

    Returns:
        Rotations (3, 3), refined from the best of the 24 axis-aligned ones and from the identity: one of
        each pair ``R, H R`` (closer than :data:`SAME_ROTATION` is the same), by increasing ``f``.
    """
    Q = residual_form(matrices, sums, per_configuration, sigma)
    coarse = axis_aligned()
    found = [refine(Q, R) for R in (coarse[int(np.argmin([_value(Q, R) for R in coarse]))], np.eye(3))]
    found.sort(key=lambda R: _value(Q, R))
    distinct: list[np.ndarray] = []
    for R in found:
        same = [R] if half is None else [R, half @ R]
        if all(rotation_angle(other.T @ S) > SAME_ROTATION for other in distinct for S in same):
            distinct.append(R)
    return distinct


@dataclass(frozen=True)
class Turn:
    """A turn of the sensor frame that fits the kept samples.

    Attributes:
        R_sensor_assumed: The frame assumed, in the sensor frame (``g_sensor = R g_assumed``), shape (3, 3).
        ratio: The largest residual-to-noise ratio with it (the worse of it and its twin).
        distance: The angle to the nearest rotation that swaps or flips axes [rad].
        twin: The turn the data cannot tell from it (:func:`half_turn`), shape (3, 3), or None.
    """

    R_sensor_assumed: np.ndarray
    ratio: float
    distance: float
    twin: np.ndarray | None


def fitting_turns(
    tool: Tool,
    sums: np.ndarray,
    noise_cov: np.ndarray,
    per_configuration: bool,
    allowance: FitAllowance,
    sigma: np.ndarray,
    fits: Callable[[float], bool],
) -> list[Turn]:
    """The turns of the sensor frame that fit the sums, one per pair of twins, nearest a swap of axes first.

    A pair is judged by the worse of its two ratios (the twin's moments carry force noise that dilutes a
    misfit). Of a pair, the member nearer a rotation that swaps or flips axes is kept, or that rotation
    itself when it fits too: the mistake people make.

    Args:
        tool: The tool file (its wrench matrices and centres of mass).
        sums: Per configuration the fit sums of the offset model in use, shape (k, q, q).
        noise_cov: Covariance of ``P Delta`` of one sample, shape (6, 6).
        per_configuration: One offset per configuration, else one for all.
        allowance: The declared tolerances and the floor.
        sigma: The expected residual per axis of the fit as given [N, N m], shape (6,) (the search's weights).
        fits: Whether a ratio fits (at the noise, and clearly better than as given), ``float -> bool``.

    Returns:
        By increasing distance, then ratio.
    """
    counts = sums[:, 9, 9]
    matrices = [c.wrench_matrix for c in tool.configurations]
    half = half_turn(np.array([c.p_sensor_com for c in tool.configurations])[counts > 0])

    def judge(R: np.ndarray) -> float:
        worst = 0.0
        for turn in [R] if half is None else [R, half @ R]:
            ratios = _ratios(tool, matrices, rotated_sums(sums, turn), counts, noise_cov, per_configuration, allowance)
            worst = max(worst, math.inf if ratios is None else float(ratios[0].max()))
        return worst

    out: list[Turn] = []
    for R in frame_rotations(matrices, sums, per_configuration, sigma, half):
        member = min([R] if half is None else [R, half @ R], key=lambda M: nearest_axis_aligned(M)[1])
        nearest, distance = nearest_axis_aligned(member)
        for turn, d in ((nearest, 0.0), (member, distance)):
            if fits(ratio := judge(turn)):
                if all(rotation_angle(turn.T @ other.R_sensor_assumed) > SAME_ROTATION for other in out):
                    out.append(Turn(turn, ratio, d, None if half is None else half @ turn))
                break
    return sorted(out, key=lambda turn: (turn.distance, turn.ratio))


def beside(turns: Sequence[Turn]) -> list[np.ndarray]:
    """The turns to name beside the first of :func:`fitting_turns`: its twin and the others, unless clearly farther from a swap of axes.

    Args:
        turns: The turns that fit, the first named.

    Returns:
        Rotations ``R_sensor_assumed`` (3, 3) no more than :data:`CLEARLY_FARTHER` farther than the first from a swap of axes.
    """
    first = turns[0]
    others = ([] if first.twin is None else [first.twin]) + [turn.R_sensor_assumed for turn in turns[1:]]
    return [R for R in others if nearest_axis_aligned(R)[1] < first.distance + CLEARLY_FARTHER]


def mimicked_turn(coms: np.ndarray, com_tolerance: float, mount_tolerance: float) -> float:
    """The turn that a declared tolerance can mimic: the mount's, or a centre of mass off by the tool's tolerance.

    A turn by ``theta`` moves the centres of mass relative to their mean by ``theta |c - c_mean|`` (the rest a
    calibration absorbs): the nearest one, off by ``sqrt(3)`` times the tolerance per coordinate, looks like a
    turn by that over its distance.

    Args:
        coms: Centres of mass of the configurations recorded, in the sensor frame [m], shape (k, 3).
        com_tolerance: The tool file's ``tolerance.com`` [m] per coordinate.
        mount_tolerance: The robot file's ``accuracy.mount_rotation`` [rad].

    Returns:
        [rad].
    """
    lever = float(np.min(np.linalg.norm(coms - coms.mean(axis=0), axis=1))) if len(coms) else 0.0
    return max(mount_tolerance, math.sqrt(3.0) * com_tolerance / lever if lever > 0 else 0.0)


def mount_words(R_sensor_assumed: np.ndarray, mount_in_use: np.ndarray, robot: bool, source: str | None, fits: str = "") -> str:
    """A sensor frame turned by ``R_sensor_assumed``, and the mount that removes it, in the words of what gives the orientation.

    Args:
        R_sensor_assumed: The frame assumed, in the sensor frame (``g_sensor = R g_assumed``), shape (3, 3).
        mount_in_use: Roll, pitch, yaw [rad] from the flange (or the frame a recording gives) to the frame
            assumed: the robot file's ``sensor.rpy`` or ``--mount``, shape (3,).
        robot: A robot file places the sensor (else a recording or feed gives the orientation).
        source: Without a robot, what gives the orientation: a key of
            :data:`fts_calib.robot.orientation.ORIENTATION_FORMS`, 'pose topic', or None (not known).
        fits: How the kept samples then fit, in words ('' for none).
    """
    R_assumed_sensor = np.asarray(R_sensor_assumed, dtype=float).T
    turn = _degrees(mount_rpy(R_assumed_sensor))
    new = mount_rpy(pin.rpy.rpyToMatrix(*mount_in_use) @ R_assumed_sensor)
    flag = f"--mount {' '.join(_number(v) for v in new)}"
    given = bool(np.any(np.asarray(mount_in_use) != 0))
    instead = " instead" if given else ""
    said = f" ({fits})" if fits else ""
    if robot:
        values = ", ".join(_number(v) for v in new)
        axes = f"about its own axes; {fits}" if fits else "about its own axes"
        return f"the robot file's sensor.rpy is off by a turn of the sensor frame of {turn} ({axes}): use sensor.rpy: [{values}] (rad)"
    if source == "tcp" and given:
        return f"the sensor frame is turned by {turn} from the one --mount gives{said}: pass {flag} instead (rad, flange to sensor)"
    if source == "tcp":
        return (
            f"the sensor frame is turned by {turn} from the TCP's{said}: pass {flag} (rad, the flange-to-sensor rotation; "
            "without it the TCP frame is taken as the sensor frame)"
        )
    if source in ORIENTATION_FORMS:
        return (
            f"the orientation columns are not the sensor frame's: it is turned by {turn} from the frame they give"
            f"{' with --mount' if given else ''}{said}: rotate them by {_degrees(new)} (R_world_sensor = R_columns "
            f"Rz(yaw) Ry(pitch) Rx(roll){', without --mount' if given else ''}), or pass {flag}{instead} (rad)"
        )
    if source == "pose topic":
        return f"the pose topic's orientation is not the sensor frame's: it is turned by {turn} from it{said}: pass {flag}{instead} (rad)"
    return (
        f"the orientations given are not the sensor frame's: it is turned by {turn} from them{said}: pass {flag}{instead} (rad; "
        f"with a TCP pose, the flange-to-sensor rotation), or rotate the orientations by {_degrees(new)}"
    )


def _degrees(rpy: np.ndarray) -> str:
    """'roll -90.0°, pitch -90.0°, yaw 0.0°' of roll, pitch, yaw [rad] (3,)."""
    return ", ".join(f"{name} {round(math.degrees(v), 1) + 0.0:.1f}°" for name, v in zip(("roll", "pitch", "yaw"), rpy, strict=True))


def _number(angle: float) -> str:
    """An angle [rad] to 4 decimals, as a user types it: '-1.5708', '0'."""
    return f"{round(float(angle), 4) + 0.0:g}"

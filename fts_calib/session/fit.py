r"""What the tolerances declared in the tool and robot files leave in the fit check's residuals.

A tool is known to a tolerance (the tool file's ``tolerance: {mass, com}``) and the sensor's
mount and joint readings to the robot file's ``accuracy`` (``mount_rotation``,
``encoder_resolution``): the accuracy budget's own terms (:mod:`fts_calib.budget.sensitivities`).
An error within them changes the known wrench of every sample, and the part of that change the
fit cannot absorb into ``[C_bar, D]`` shows as residual. The fit check
(:mod:`fts_calib.session.fit`) expects it, beside the strain noise:

- the errors are the budget's: one mount rotation (3 axes) for the run; the tool's mass and
  centre of mass (3 coordinates) in two parts, one error common to every configuration (one body
  moved between configurations) and one of each configuration's own (positions machined one by
  one: the tool file's ``tolerance.per_configuration``, bounded like the common part when the file
  does not say, :class:`fts_calib.robot.tool.ToolTolerance`), each independent and uniform within
  its bound (standard deviation bound / sqrt(3));
- they enter the known wrench linearly in gravity, so each is a change of every
  configuration's wrench matrix ``M_c`` (eqs 17-18) per unit error: the mass,
  ``dM_c = M_c / m_c``; a coordinate ``a`` of the centre of mass, ``dM_c = [0; m_c [e_a]x]``;
  the mount rotated about axis ``a`` of S, ``dM_c = M_c [e_a]x``;
- each is fitted on the same sums as the fit itself (``[C_bar, D]`` from ``sum_c dM_c S_gx,c``
  and ``S_XX``, the offset model's columns included), and what it leaves is its residual sum of
  squares per configuration and axis, ``RSS_p,c,j`` for a unit error p: the error projected off
  the fitted model's column space, exactly. The centre-of-mass error leaves nothing (a common
  lever is ``dW = A W``: C_bar absorbs it, it is a budget term, not a residual), nor does a mass
  error when the masses are equal (a scale); a rotated mount on centres of mass that differ
  leaves some, and so does one configuration's own error (the fit cannot absorb it into one
  ``[C_bar, D]``). A centre of mass off in one configuration beyond its own bound is not what the
  file declares: the budget does not cover it, and the check refuses it beyond this allowance.
  The tolerance part of configuration c, axis j, is the standard deviation of the residual the
  errors leave, ``sigma_T,c,j^2 = sum_p sigma_p^2 RSS_p,c,j / n_c``;
- a joint-reading error is a new draw at every stop (the budget's encoder term): the fit
  absorbs little of it, so it enters unprojected, as a rotation of gravity by
  ``sqrt(n_joints / 12)`` encoder steps: ``|row_j M_c| |g| resolution sqrt(n_joints / 12)``.
  Stream latency and jitter act on moving samples only, which the quasi-static filter keeps
  few of: they are not in the allowance;
- a sensor that does not repeat from pose to pose (the sensor file's ``repeatability``, a new
  offset at every still pose) enters as it is, per axis: the fit absorbs little of it.

Per axis the tolerance part is the largest over the configurations. The fit check adds it in
quadrature to the strain noise, ``sigma_j = sqrt(sigma_W,j^2 + sigma_T,j^2)``, and keeps its
limit of 3 such standard deviations: for one or a few dominant errors that covers the worst
corner of the declared box (sqrt(3) sigma for one), while an error 5 times a tolerance is
refused (5 sqrt(3) ~ 8.7 sigma; one configuration's centre of mass 5 tolerances off: 29-32 times
with the tolerance declared common alone, tests/tolerance_sweep.py; 4.4-8.5 times with each
configuration's own part declared too, bench/bench_jig_tolerance.py). Beside it, an absolute floor (the pipeline setting
``fit.floor``, 0.01 % of each axis's full scale by default): a residual RMS below it never
refuses. Units: N for forces, N m for moments, rad, m, kg.

The values of a tool file that no residual shows: the magnitude of gravity and the size of the centres of mass.

Two mistakes of a tool file scale C without leaving a residual (a wrong gravity scales every
wrench; a uniform scale of every centre of mass scales the moment rows), so the fit check
(:mod:`fts_calib.session.fit`) judges their values instead: a centre of mass beyond
:data:`MAX_COM_M` (mm or cm written for m) and a gravity outside :data:`GRAVITY_RANGE`.

Fit checks after every solve: do the data fit the model, at the noise level they show?

A calibration always fits *something*; the check asks whether the residual of each wrench
axis, within each tool configuration, is what the strain noise measured in the same data
explains. Per configuration ``c`` the session keeps the sums of ``y y^T`` with
``y = [g_sensor; P Delta; 1]`` (10 x 10), so any hypothesis about the tool (its wrench
matrices ``M_c = m_c [I; [c_c]x]``, eqs 17-18) is solved and judged without reading the
data again:

.. math::

    [\bar C, D] = \Big(\sum_c M_c S_{gx,c}\Big)\Big(\sum_c S_{xx,c}\Big)^{-1}, \qquad
    \mathrm{RSS}_c = \mathrm{diag}\big(M_c S_{gg,c} M_c^T - 2\,\Theta S_{gx,c}^T M_c^T
    + \Theta S_{xx,c} \Theta^T\big)

The expected residual is the strain noise through C, ``sigma_W = sqrt(diag(C Sigma C^T))``
with ``Sigma`` the filter's noise floor per channel (the scatter of the still windows, never
below a quantized channel's step / sqrt(12), :attr:`QuasiStaticFilter.noise_floor`: at a
still pose the rounding error of a channel with sub-count noise is a constant of that pose,
a noise across poses), **plus**, in quadrature, ``sigma_T``: what the tolerances the tool and
robot files declare leave after the fit (tool mass and centre of mass, mount, encoders: the
accuracy budget's terms, :mod:`fts_calib.session.fit`). It is at least ``1e-6``
of the tool's weight (and of its moment ``m g |c|``: noiseless or quantized data) and at least
the absolute floor ``fit.floor`` (0.01 % of each axis's full scale) / :data:`MAX_RATIO`, so
that a residual RMS below that floor never refuses. A fit is *consistent* when every ratio
``rms_c / sigma`` is at most :data:`MAX_RATIO`; otherwise it is *poor*, and the cheap
alternatives are tried on the same sums: configuration labels permuted, centres of mass
written in mm or cm (only when the result is a plausible tool's), one configuration's mass
mistyped, and a collinear tool file (which no strain data can fit when the mounted tool was
not collinear). The best that fits at the noise, and at least :data:`CLEARLY_BETTER` times
better than the stated tool, is named in the diagnosis; causes the data show before these
(joint units, weak excitation, a nonlinear sensor) are tried first by
:mod:`fts_calib.session.diagnosis`. Two mistakes scale C without leaving a residual, so their values
are checked instead: a centre of mass beyond 1 m (mm or cm for m) and a gravity outside
9.7-9.9 m/s^2 (:mod:`fts_calib.session.fit`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..filters.settings import DEFAULT_FLOOR_PERCENT
from ..model.channels import MALTESE_CROSS_8, WRENCH_AXES, WRENCH_UNITS, ChannelLayout
from ..robot.definition import RobotAccuracy
from ..robot.tool import Tool, wrench_matrix

#: Largest accepted ratio of a configuration's residual RMS to the expected residual (noise and tolerances), per axis.
#: A consistent fit over hundreds of samples gives 1 +- a few %: 3 leaves room for the
#: unmodelled dynamics the filter lets through, wrong data give 1e3 to 1e7.
MAX_RATIO = 3.0
#: Floor of the expected residual, relative to the tool's weight (forces) and moment (moments).
RELATIVE_FLOOR = 1e-6


@dataclass(frozen=True)
class FitAllowance:
    """What the fit check allows beside the strain noise and the tool file's tolerance.

    Attributes:
        mount_rotation: Bound of the sensor mount's rotation error about each axis of S [rad]
            (the robot file's ``accuracy.mount_rotation``); 0 for none.
        encoder_resolution: Step of a joint reading [rad] (``accuracy.encoder_resolution``); 0 for none.
        n_joints: Joints whose readings place the sensor.
        floor: Absolute floor of the residual RMS per axis, [N, N, N, N m, N m, N m], shape (6,):
            below it a residual never refuses; None for none.
        repeatability: The sensor's scatter from one still pose to another per axis (the sensor
            file's ``repeatability``), [N, N, N, N m, N m, N m], shape (6,); None for none.
    """

    mount_rotation: float = 0.0
    encoder_resolution: float = 0.0
    n_joints: int = 0
    floor: np.ndarray | None = None
    repeatability: np.ndarray | None = None


def robot_allowance(
    accuracy: RobotAccuracy, n_joints: int, full_scale, floor_percent: float = DEFAULT_FLOOR_PERCENT, repeatability=None
) -> FitAllowance:
    """The allowance of a robot file's accuracy and a sensor's full scale and repeatability.

    Args:
        accuracy: The robot file's ``accuracy`` (mount tolerance [rad], encoder step [rad]).
        n_joints: Joints of the robot.
        full_scale: Full scale per axis [N, N, N, N m, N m, N m], shape (6,).
        floor_percent: The setting ``fit.floor``, in % of each axis's full scale.
        repeatability: The sensor file's ``repeatability`` per axis [N, N m], shape (6,), or None.
    """
    floor = np.asarray(full_scale, dtype=float).reshape(6) * floor_percent / 100.0
    scatter = None if repeatability is None else np.asarray(repeatability, dtype=float).reshape(6)
    return FitAllowance(accuracy.mount_rotation, accuracy.encoder_resolution, int(n_joints), floor, scatter)


def _cross(axis: int) -> np.ndarray:
    """``[e_axis]x`` (3, 3)."""
    return np.cross(np.eye(3)[axis], np.eye(3)).T  # column i: e_axis x e_i


def unit_errors(tool: Tool, matrices: Sequence[np.ndarray], mount_rotation: float) -> tuple[np.ndarray, np.ndarray]:
    """The declared errors as changes of the wrench matrices (see the module docstring).

    Args:
        tool: The tool file (its ``tolerance``; none when None).
        matrices: The wrench matrices ``M_c`` judged, shape (6, 3) each (a hypothesis's: the mass is ``M_c[0, 0]``).
        mount_rotation: Bound of the mount's rotation about each axis [rad].

    Returns:
        ``(sigma (P,), dM (P, k, 6, 3))``: each error's standard deviation (uniform within its bound) and the change
        of every configuration's matrix per unit of it; P = 0 when nothing is declared.
    """
    k = len(matrices)
    sigmas: list[float] = []
    changes: list[np.ndarray] = []
    tolerance = tool.tolerance
    masses = [float(M[0, 0]) for M in matrices]
    own = np.eye(k)[:, :, None, None]  # configuration c's change alone, (k, k, 1, 1)

    def add(common: float, each: float, change: np.ndarray) -> None:  # one error for every configuration, then one each
        if common > 0:
            changes.append(change)
            sigmas.append(common / math.sqrt(3.0))
        if each > 0:
            changes.extend(own * change[None])
            sigmas.extend([each / math.sqrt(3.0)] * k)

    if tolerance is not None and min(masses) > 0:
        add(tolerance.mass, tolerance.configuration_mass, np.stack([M / m for M, m in zip(matrices, masses, strict=True)]))
    for axis in range(3):
        if tolerance is not None:
            add(tolerance.com, tolerance.configuration_com, np.stack([np.vstack([np.zeros((3, 3)), m * _cross(axis)]) for m in masses]))
        if mount_rotation > 0:  # one mount rotation, every configuration
            changes.append(np.stack([M @ _cross(axis) for M in matrices]))
            sigmas.append(mount_rotation / math.sqrt(3.0))
    return np.array(sigmas), np.array(changes).reshape(len(changes), k, 6, 3)


def projected_rss(changes: np.ndarray, sums: np.ndarray, embeddings: Sequence[np.ndarray]) -> np.ndarray:
    """What the fit leaves of each change of the wrench matrices: its residual sum of squares.

    Args:
        changes: ``dM`` per error and configuration, shape (P, k, 6, 3).
        sums: Per configuration the fit sums ``sum y y^T``, ``y = [g_sensor; P Delta; 1; drift]``, shape (k, q, q).
        embeddings: Per configuration the map of its ``[P Delta; 1; drift]`` into the joint regressor
            (:func:`fts_calib.session.fit._embeddings`).

    Returns:
        Per error, configuration and axis, shape (P, k, 6), in [N^2, N^2 m^2 per unit error^2]; zeros when the
        regressors do not determine the fit.
    """
    P, k = changes.shape[:2]
    if P == 0:
        return np.zeros((0, k, 6))
    S_gg = np.stack([s[:3, :3] for s in sums])
    S_gx = np.stack([s[:3, 3:] @ e.T for s, e in zip(sums, embeddings, strict=True)])
    S_xx = np.stack([e @ s[3:, 3:] @ e.T for s, e in zip(sums, embeddings, strict=True)])
    S_XX = S_xx.sum(axis=0)
    S_WX = np.einsum("pcij,cjk->pik", changes, S_gx)  # (P, 6, r)
    scale = 1.0 / np.sqrt(np.maximum(np.diag(S_XX), 1e-300))
    try:
        inverse = np.linalg.inv(S_XX * scale[:, None] * scale[None, :]) * scale[:, None] * scale[None, :]
    except np.linalg.LinAlgError:
        return np.zeros((P, k, 6))
    theta = S_WX @ inverse  # (P, 6, r): [C_bar, D, ...] fitted to the change alone
    own = np.einsum("pcij,cjl,pcil->pci", changes, S_gg, changes)
    cross = np.einsum("pir,pcij,cjr->pci", theta, changes, S_gx)
    quad = np.einsum("pir,crs,pis->pci", theta, S_xx, theta)
    return np.maximum(own - 2.0 * cross + quad, 0.0)


def tolerance_residual(
    tool: Tool,
    matrices: Sequence[np.ndarray],
    sums: np.ndarray,
    embeddings: Sequence[np.ndarray],
    counts: np.ndarray,
    allowance: FitAllowance | None,
) -> np.ndarray:
    """The residual RMS the declared tolerances leave, per axis (see the module docstring).

    Args:
        tool: The tool file (its ``tolerance`` and ``gravity``).
        matrices: The wrench matrices judged, shape (6, 3) each.
        sums: Per configuration the fit sums, shape (k, q, q).
        embeddings: Per configuration the map into the joint regressor.
        counts: Samples per configuration, shape (k,).
        allowance: The robot's mount and encoders (None: the tool's tolerance alone).

    Returns:
        The standard deviation per axis, the largest over the configurations with samples,
        [N, N, N, N m, N m, N m], shape (6,).
    """
    allowance = allowance or FitAllowance()
    counts = np.asarray(counts, dtype=float)
    sigma, changes = unit_errors(tool, matrices, allowance.mount_rotation)
    rss = projected_rss(changes, sums, embeddings)
    variance = np.einsum("p,pcj->cj", sigma**2, rss) / np.maximum(counts, 1.0)[:, None]
    if allowance.encoder_resolution > 0 and allowance.n_joints > 0:
        angle = allowance.encoder_resolution * math.sqrt(allowance.n_joints / 12.0)
        rows = np.linalg.norm(np.stack([np.asarray(M, dtype=float) for M in matrices]), axis=2)  # |row_j M_c|, (k, 6)
        variance = variance + (rows * tool.gravity * angle) ** 2
    if allowance.repeatability is not None:  # a sensor that does not repeat: a new offset at every pose, little of it absorbed
        variance = variance + allowance.repeatability**2
    seen = counts > 0
    return np.sqrt(variance[seen].max(axis=0)) if seen.any() else np.zeros(6)


def noise_residual(C_bar: np.ndarray, noise_cov: np.ndarray) -> np.ndarray:
    """The residual the strain noise explains per axis, ``sqrt(diag(C_bar Sigma_P C_bar^T))``; shape (6,), [N, N m].

    Args:
        C_bar: Modified calibration matrix (a nonlinear model's slope), shape (6, 6).
        noise_cov: Covariance of ``P Delta`` of one sample, shape (6, 6).
    """
    return np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", C_bar, noise_cov, C_bar), 0.0))


def expected_residual(tool: Tool, C_bar: np.ndarray, noise_cov: np.ndarray, tolerance=None, floor=None) -> np.ndarray:
    """The residual expected per axis: noise and declared tolerances in quadrature, floored; shape (6,), [N, N m].

    ``max(sqrt(sigma_W^2 + sigma_T^2), RELATIVE_FLOOR x weight (moment), floor / MAX_RATIO)`` with
    ``sigma_W`` the noise (:func:`noise_residual`) and ``sigma_T`` the tolerance part: a residual RMS below
    ``floor`` never gives a ratio above :data:`MAX_RATIO`.

    Args:
        tool: The tool file (its weight and moment set the relative floor, :data:`RELATIVE_FLOOR`).
        C_bar: Modified calibration matrix (a nonlinear model's slope), shape (6, 6).
        noise_cov: Covariance of ``P Delta`` of one sample, shape (6, 6).
        tolerance: What the declared tolerances leave per axis
            (:func:`fts_calib.session.fit.tolerance_residual`), shape (6,); None for none.
        floor: The absolute floor ``fit.floor`` per axis [N, N m], shape (6,); None for none.
    """
    sigma = noise_residual(C_bar, noise_cov)
    if tolerance is not None:
        sigma = np.hypot(sigma, np.asarray(tolerance, dtype=float))
    weight = max(c.mass for c in tool.configurations) * tool.gravity
    moment = max(c.mass * float(np.linalg.norm(c.p_sensor_com)) for c in tool.configurations) * tool.gravity
    relative = RELATIVE_FLOOR * np.array([weight] * 3 + [max(moment, 1e-3 * weight)] * 3)
    absolute = np.zeros(6) if floor is None else np.asarray(floor, dtype=float) / MAX_RATIO
    return np.maximum.reduce([sigma, relative, absolute])


def expected_words(worst: str, expected: np.ndarray, noise, tolerance, floor) -> str:
    """What the expected residual of the worst axis is made of, when more than the noise; '' otherwise.

    Args:
        worst: Where the largest ratio is ('configuration B, Mx').
        expected: The expected residual per axis [N, N m], shape (6,).
        noise: Its noise part, shape (6,), or None.
        tolerance: Its tolerance part, shape (6,), or None.
        floor: The absolute floor ``fit.floor``, shape (6,), or None.

    Returns:
        E.g. ': noise 0.00023 N·m and declared tolerances 0.0011 N·m'.
    """
    axis = next((k for k, name in enumerate(WRENCH_AXES) if worst.endswith(f", {name}")), None)
    if axis is None or noise is None:
        return ""
    unit, sigma = WRENCH_UNITS[axis], float(noise[axis])
    parts = []
    if tolerance is not None and float(tolerance[axis]) > 0.1 * sigma:
        parts.append(f"noise {sigma:.2g} {unit} and declared tolerances {float(tolerance[axis]):.2g} {unit}")
    if floor is not None and MAX_RATIO * float(expected[axis]) <= float(floor[axis]) * (1.0 + 1e-9):
        parts.append(f"a residual below fit.floor, {float(floor[axis]):.2g} {unit}, never refuses")
    return ": " + "; ".join(parts) if parts else ""


#: Largest plausible distance of a calibration tool's centre of mass from the sensor, in [m].
MAX_COM_M = 1.0
#: Smallest distance a unit correction may bring it to, in [m] (below, the unit is not guessed).
MIN_COM_M = 0.005
#: A typical calibration tool's centre of mass distance, in [m]: picks mm or cm when both are plausible.
TYPICAL_COM_M = 0.1
#: The range accepted for the magnitude of gravity, in [m/s^2] (9.78 to 9.83 on Earth's surface).
GRAVITY_RANGE = (9.7, 9.9)


def implausible_gravity(tool: Tool) -> str:
    """Why the tool file's gravity cannot be the Earth's, or ''.

    A wrong magnitude of gravity scales every wrench, so C absorbs it and the residuals do not
    show it; only its value does. On Earth it is 9.78 to 9.83 m/s^2.

    Args:
        tool: The tool file (its ``gravity`` in [m/s^2]).

    Returns:
        The reason in words, naming a likely unit (cm/s^2, g), or '' when plausible.
    """
    low, high = GRAVITY_RANGE
    if low <= tool.gravity <= high:
        return ""
    unit = (
        " (it looks like cm/s^2)" if low <= tool.gravity / 100 <= high else " (it looks like g, not m/s^2)" if tool.gravity == 1.0 else ""
    )
    return f"the tool file's gravity is {tool.gravity:g} m/s^2, expected {low:g} to {high:g} m/s^2 on Earth{unit}"


def implausible_geometry(tool: Tool) -> str:
    """Why the tool file's centres of mass cannot be a calibration tool's, or ''.

    Scaling every centre of mass by the same factor scales the moment rows of C and fits the
    data as well: the mistake shows only in the size. A centre of mass beyond
    :data:`MAX_COM_M` is taken for mm or cm when that unit brings it to a plausible size.

    Args:
        tool: The tool file (its configurations' centres of mass in S, in [m], shape (3,) each).

    Returns:
        The reason in words, naming the likely unit and its factor, or '' when plausible.
    """
    largest = max(float(np.linalg.norm(c.p_sensor_com)) for c in tool.configurations)
    if largest <= MAX_COM_M:
        return ""
    plausible = [(unit, f) for unit, f in (("mm", 1e-3), ("cm", 1e-2)) if MIN_COM_M <= largest * f <= MAX_COM_M]
    if plausible:  # the unit that brings it nearest a typical tool's 0.1 m (log scale)
        unit, factor = min(plausible, key=lambda u: abs(math.log(largest * u[1] / TYPICAL_COM_M)))
        return (
            f"the centres of mass of the tool file are in {unit}, not m: the largest is {largest:g} m from the sensor "
            f"(divide them by {1 / factor:g})"
        )
    return f"the tool file's largest centre of mass is {largest:g} m from the sensor: expected at most {MAX_COM_M:g} m"


def implausible_tool(tool: Tool) -> str:
    """Why the tool file's gravity or centres of mass cannot be right, or '' (gravity first).

    Args:
        tool: The tool file (gravity in [m/s^2], centres of mass in [m]).

    Returns:
        :func:`implausible_gravity`, else :func:`implausible_geometry`.
    """
    return implausible_gravity(tool) or implausible_geometry(tool)


#: Tool configurations up to which every permutation of the labels is tried.
MAX_PERMUTED = 4
#: An alternative of the tool file is named only when its largest ratio is at most MAX_RATIO and this
#: many times below the stated tool's (:mod:`fts_calib.session.diagnosis`): a fit at the noise, never a least-bad guess.
CLEARLY_BETTER = 2.0
#: The start of the advice given when no alternative fits.
UNEXPLAINED = "no simple alternative fits"
#: Mass factors tried for one configuration (0.01x to 100x).
_MASS_FACTORS = np.logspace(-2, 2, 161)


@dataclass(frozen=True)
class FitCheck:
    """The verdict on a fit.

    Attributes:
        verdict: 'consistent', 'poor', or 'unchecked' (no noise level was measured).
        max_ratio: The largest residual-to-noise ratio over axes and configurations.
        residual_rms: Per configuration name, the residual RMS per axis in
            [N, N, N, N m, N m, N m], shape (6,) each.
        expected: The expected residual per axis, shape (6,): the noise part and the tolerance
            part in quadrature, at least the floors; every ratio is ``residual / expected``.
        diagnosis: The likely cause of a poor fit, in words ('' when consistent or unknown).
        worst: Where the largest ratio is ('configuration B, Mx').
        noise: The noise part per axis (strain noise through C), shape (6,), or None.
        tolerance: The tolerance part per axis (what the declared tolerances leave,
            :mod:`fts_calib.session.fit`), shape (6,), or None.
        floor: The absolute floor per axis (``fit.floor``: below it a residual never refuses), shape (6,), or None.
    """

    verdict: str
    max_ratio: float
    residual_rms: dict[str, np.ndarray]
    expected: np.ndarray
    diagnosis: str = ""
    worst: str = field(default="")
    noise: np.ndarray | None = None
    tolerance: np.ndarray | None = None
    floor: np.ndarray | None = None

    @property
    def ok(self) -> bool:
        """True unless the fit is poor."""
        return self.verdict != "poor"

    def as_dict(self) -> dict:
        """Plain data for the calibration file's quality."""
        return {
            "verdict": self.verdict,
            "max_ratio": float(self.max_ratio),
            "max_ratio_allowed": MAX_RATIO,
            "worst": self.worst,
            "expected_residual": self.expected.tolist(),
            "noise_residual": None if self.noise is None else self.noise.tolist(),
            "tolerance_residual": None if self.tolerance is None else self.tolerance.tolist(),
            "floor": None if self.floor is None else self.floor.tolist(),
            "residual_rms_by_configuration": {k: v.tolist() for k, v in self.residual_rms.items()},
            "diagnosis": self.diagnosis,
        }

    def summary(self) -> str:
        """One line for a person: the verdict, the worst ratio and where it is."""
        if not math.isfinite(self.max_ratio):
            return "fit unchecked: " + (self.diagnosis or "no sample to judge")
        if self.verdict == "unchecked" and not self.diagnosis:
            measured = "no noise level was measured: no filter, or a fixed max_strain_std"
            return f"fit unchecked ({measured}); largest residual {self.max_ratio:.3g}x the floor"
        text = f"fit {self.verdict}: largest residual {self.max_ratio:.3g}x the expected noise"
        text += f" ({self.worst}{expected_words(self.worst, self.expected, self.noise, self.tolerance, self.floor)})" if self.worst else ""
        return text + (f"; likely cause: {self.diagnosis}" if self.diagnosis else "")


def fit_rows(g_sensor: np.ndarray, channels: np.ndarray, layout: ChannelLayout = MALTESE_CROSS_8, drift=None) -> np.ndarray:
    """The rows ``y = [g_sensor; P Delta; 1; drift]`` whose outer products the fit check sums.

    Args:
        g_sensor: Gravity in the sensor frame, in [m/s^2]. Shape (N, 3).
        channels: Raw channels. Shape (N, n), n = ``layout.n_channels``.
        layout: The sensor's channel layout (its P).
        drift: The drift columns of the estimator's offset basis (time powers, temperature),
            shape (N, m); none when None.

    Returns:
        Shape (N, 10 + m).
    """
    extra = np.zeros((len(g_sensor), 0)) if drift is None else np.asarray(drift, dtype=float).reshape(len(g_sensor), -1)
    return np.hstack([g_sensor, layout.project(channels).reshape(-1, 6), np.ones((len(g_sensor), 1)), extra])


def model_fit_sums(sums: np.ndarray, model: str, columns: Sequence[int], n_configurations: int) -> tuple[np.ndarray, bool]:
    """The fit sums of one offset model: the drift columns it uses, and whether its offsets are per configuration.

    Args:
        sums: The session's sums of :func:`fit_rows`, shape (k, 10 + m, 10 + m).
        model: The offset model ('constant', 'per-configuration' or 'drift').
        columns: Its columns in the estimator's offset basis (:class:`fts_calib.model.offset_models.Candidate`).
        n_configurations: K, the basis's configuration columns (the drift columns follow them).

    Returns:
        ``(sums (k, 10 + m', 10 + m'), per_configuration)`` for :func:`check_fit`.
    """
    keep = list(range(10)) + [10 + i - n_configurations for i in columns if i >= n_configurations]
    return sums[:, keep][:, :, keep], model != "constant"


def _embeddings(sums: np.ndarray, per_configuration: bool) -> list[np.ndarray]:
    """Per configuration, the map E_c of its ``x = [P Delta; 1; drift]`` into the joint regressor.

    The joint regressor is ``[P Delta; offsets; drift]`` with one offset column (constant
    offsets) or one per configuration seen; a configuration's 1 goes to its own column.
    """
    k, p = len(sums), sums.shape[1] - 3  # p = 7 + m drift columns
    seen = [c for c in range(k) if sums[c, 9, 9] > 0]  # entry 9 of y is the 1: the sample count
    n_off = len(seen) if per_configuration else 1
    out = []
    for c in range(k):
        E = np.zeros((p - 1 + n_off, p))
        E[:6, :6] = np.eye(6)
        E[6 + (seen.index(c) if per_configuration and c in seen else 0), 6] = 1.0
        E[6 + n_off :, 7:] = np.eye(p - 7)
        out.append(E)
    return out


def _solve(matrices: Sequence[np.ndarray], sums: np.ndarray, per_configuration: bool = False) -> tuple[np.ndarray, np.ndarray] | None:
    """(Theta (6, 7 + ...), RSS per configuration and axis (k, 6)) for wrench matrices M_c; None when singular."""
    E = _embeddings(sums, per_configuration)
    S_WX = sum(M @ s[:3, 3:] @ e.T for M, s, e in zip(matrices, sums, E, strict=True))
    S_XX = sum(e @ s[3:, 3:] @ e.T for s, e in zip(sums, E, strict=True))
    scale = 1.0 / np.sqrt(np.maximum(np.diag(S_XX), 1e-300))
    try:
        theta = np.linalg.solve((S_XX * scale[:, None] * scale[None, :]).T, (S_WX * scale[None, :]).T).T * scale[None, :]
    except np.linalg.LinAlgError:
        return None
    per_config = []
    for M, s, e in zip(matrices, sums, E, strict=True):
        S_gg, S_gx, S_xx = s[:3, :3], s[:3, 3:] @ e.T, e @ s[3:, 3:] @ e.T
        W_x = M @ S_gx  # this configuration's S_WX
        per_config.append(np.diag(M @ S_gg @ M.T) - 2.0 * np.einsum("ij,ij->i", theta, W_x) + np.einsum("ij,jk,ik->i", theta, S_xx, theta))
    return theta, np.maximum(np.array(per_config), 0.0)


def _ratios(
    tool: Tool, matrices, sums, counts, noise_cov, per_configuration=False, allowance: FitAllowance | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(ratio (k, 6), rms (k, 6), expected (6,)) of a hypothesis; None when it cannot be solved.

    ``noise_cov`` is the covariance of the projected channels ``P Delta``, ``P Sigma P^T`` (6, 6). With an
    ``allowance`` the expected residual holds the declared tolerances and the floor (:func:`expected_residual`);
    without, the noise alone.
    """
    solved = _solve(matrices, sums, per_configuration)
    if solved is None:
        return None
    theta, rss = solved
    seen = counts > 0
    rms = np.sqrt(rss / np.maximum(counts, 1)[:, None])
    tolerance = None
    if allowance is not None:
        tolerance = tolerance_residual(tool, matrices, sums, _embeddings(sums, per_configuration), counts, allowance)
    expected = expected_residual(tool, theta[:, :6], noise_cov, tolerance, None if allowance is None else allowance.floor)
    ratio = np.where(seen[:, None], rms / expected[None, :], 0.0)
    return ratio, rms, expected


def check_model_fit(
    tool: Tool, residual_rms: dict[str, np.ndarray], C_bar: np.ndarray, noise_std, layout: ChannelLayout, linear: FitCheck
) -> FitCheck:
    """The fit check of a model other than the linear one, from its residual per configuration.

    The verdict compares each configuration's residual RMS with the noise through the model's
    slope at the centre of the data, as :func:`check_fit` does; a poor fit takes the linear check's diagnosis (the
    alternatives of the tool file are tried on the linear model). The tolerance part and the floor are the linear
    check's: a model with more columns absorbs at least as much of a declared error, so the linear model's tolerance
    part bounds its own.

    Args:
        tool: The tool file.
        residual_rms: Per configuration name, the model's residual RMS per axis, [N, N m], shape (6,) each.
        C_bar: The model linearised at the centre of the data, in the layout, shape (6, 6).
        noise_std: Channel noise measured in the data (raw units, (n,)), or None (unchecked).
        layout: The channel layout.
        linear: The check of the linear model on the same samples.
    """
    if not residual_rms:
        return linear
    noise_cov = layout.projected_noise(0.0 if noise_std is None else noise_std)
    expected = expected_residual(tool, C_bar, noise_cov, linear.tolerance, linear.floor)
    parts = {"noise": noise_residual(C_bar, noise_cov), "tolerance": linear.tolerance, "floor": linear.floor}
    names = list(residual_rms)
    ratio = np.array([residual_rms[k] / expected for k in names])
    k, axis = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
    worst = f"configuration {names[k]}, {WRENCH_AXES[axis]}"
    implausible = implausible_tool(tool)
    if implausible:
        return FitCheck("poor", float(ratio.max()), residual_rms, expected, implausible, worst, **parts)
    if noise_std is None:
        return FitCheck("unchecked", float(ratio.max()), residual_rms, expected, "", worst, **parts)
    if ratio.max() <= MAX_RATIO:
        return FitCheck("consistent", float(ratio.max()), residual_rms, expected, "", worst, **parts)
    return FitCheck("poor", float(ratio.max()), residual_rms, expected, linear.diagnosis, worst, **parts)


def _golden(f, low: float, high: float, iterations: int = 60) -> tuple[float, float]:
    """Minimum of a unimodal ``f`` on [low, high] by golden-section search: (argument, value)."""
    ratio = (math.sqrt(5.0) - 1.0) / 2.0
    a, b = low, high
    c, d = b - ratio * (b - a), a + ratio * (b - a)
    fc, fd = f(c), f(d)
    for _ in range(iterations):
        if fc < fd:
            b, d, fd = d, c, fc
            c = b - ratio * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + ratio * (b - a)
            fd = f(d)
    return (c, fc) if fc < fd else (d, fd)


def _alternatives(
    tool: Tool, sums: np.ndarray, counts: np.ndarray, noise_cov, per_configuration=False, allowance: FitAllowance | None = None
) -> list[tuple[str, float]]:
    """(cause in words, its largest ratio) of each alternative that fits, best first."""
    names = tool.names
    configs = tool.configurations
    fits: list[tuple[str, float]] = []

    def judge(label: str, matrices) -> None:
        judged = _ratios(tool, matrices, sums, counts, noise_cov, per_configuration, allowance)
        if judged is not None and judged[0].max() <= MAX_RATIO:
            fits.append((label, float(judged[0].max())))

    if len(configs) <= MAX_PERMUTED:
        for order in itertools.permutations(range(len(configs))):
            if order != tuple(range(len(configs))):
                moved = ", ".join(f"the data labelled {names[k]} fit configuration {names[j]}" for k, j in enumerate(order) if k != j)
                judge(f"configuration labels permuted: {moved}", [configs[j].wrench_matrix for j in order])
    largest = max(float(np.linalg.norm(c.p_sensor_com)) for c in configs)
    for unit, factor in (("mm", 1e-3), ("cm", 1e-2)):
        if largest * factor < MIN_COM_M:  # centres of mass within millimetres of the sensor: no calibration tool
            continue
        judge(
            f"the centres of mass of the tool file are in {unit}, not m (divide them by {1 / factor:g})",
            [wrench_matrix(c.mass, c.p_sensor_com * factor) for c in configs],
        )
    for k, config in enumerate(configs):

        def worst(log_factor: float, k: int = k) -> float:
            f = math.exp(log_factor)
            matrices = [c.wrench_matrix * (f if j == k else 1.0) for j, c in enumerate(configs)]
            judged = _ratios(tool, matrices, sums, counts, noise_cov, per_configuration, allowance)
            return math.inf if judged is None else float(judged[0].max())

        grid = np.log(_MASS_FACTORS)
        start = int(np.argmin([worst(x) for x in grid]))
        log_factor, ratio = _golden(worst, grid[max(start - 1, 0)], grid[min(start + 1, len(grid) - 1)])
        factor = math.exp(log_factor)
        if ratio <= MAX_RATIO and not math.isclose(factor, 1.0, rel_tol=1e-3):
            fits.append((f"the mass of configuration {names[k]} is about {factor * config.mass:.4g} kg, not {config.mass:g} kg", ratio))
    return sorted(fits, key=lambda item: item[1])


def check_fit(
    tool: Tool,
    sums: np.ndarray,
    counts: np.ndarray,
    noise_std: np.ndarray | None,
    hint: str = "",
    layout: ChannelLayout = MALTESE_CROSS_8,
    per_configuration: bool = False,
    allowance: FitAllowance | None = None,
) -> FitCheck:
    """Judge the fit of the tool's model to the kept samples (see the module docstring).

    Args:
        tool: The tool file in use.
        sums: Per configuration, the sum of ``y y^T`` over its kept samples (:func:`fit_rows`).
            Shape (k, 10, 10).
        counts: Kept samples per configuration. Shape (k,).
        noise_std: Channel noise measured in the data (raw units, shape (n,)), or None when
            none was measured (then the verdict is 'unchecked').
        hint: Added to the diagnosis of a poor fit that no alternative explains (e.g. a
            command-line option that may be wrong).
        layout: The sensor's channel layout (n channels, its P).
        per_configuration: One offset per configuration (the per-configuration and drift
            offset models) instead of one for all; drift columns are those of ``sums``
            (:func:`model_fit_sums`).
        allowance: The robot's mount and encoder tolerances and the floor ``fit.floor``
            (:func:`fts_calib.session.fit.robot_allowance`); None: the tool file's tolerance alone,
            no floor but the relative one.

    Returns:
        The verdict; its diagnosis names the best alternative that fits at the noise, clearly better than the stated tool.
    """
    counts = np.asarray(counts, dtype=float)
    if not counts.sum() > 0:  # no sample in the sums: nothing to judge
        return FitCheck("unchecked", math.nan, {}, np.full(6, math.nan))
    noise_cov = layout.projected_noise(0.0 if noise_std is None else noise_std)  # covariance of P Delta, (6, 6)
    implausible = implausible_tool(tool)
    allowance = allowance or FitAllowance()
    matrices = [c.wrench_matrix for c in tool.configurations]
    judged = _ratios(tool, matrices, sums, counts, noise_cov, per_configuration, allowance)
    if judged is None:
        return FitCheck("unchecked", math.nan, {}, np.full(6, math.nan))
    ratio, rms, expected = judged
    parts = _parts(tool, matrices, sums, counts, noise_cov, per_configuration, allowance)
    residual = {name: rms[k] for k, name in enumerate(tool.names) if counts[k] > 0}
    k, axis = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
    worst = f"configuration {tool.names[k]}, {WRENCH_AXES[axis]}"
    if implausible:  # a uniform scale of every centre of mass fits any data: only its size shows it
        return FitCheck("poor", float(ratio.max()), residual, expected, implausible, worst, **parts)
    if noise_std is None:
        return FitCheck("unchecked", float(ratio.max()), residual, expected, "", worst, **parts)
    if ratio.max() <= MAX_RATIO:
        return FitCheck("consistent", float(ratio.max()), residual, expected, "", worst, **parts)
    alternatives = _alternatives(tool, sums, counts, noise_cov, per_configuration, allowance)
    causes = [c for c in alternatives if c[1] * CLEARLY_BETTER <= ratio.max()]
    if causes:
        diagnosis = causes[0][0]
    elif tool.com_rank() < 2:
        diagnosis = (
            "the tool file's centres of mass lie on one line (paper eqs 19-20) while the strains determine every "
            "coefficient: the tool mounted is not the one in the file"
        )
    else:
        diagnosis = hint or (
            f"{UNEXPLAINED}: check the tool file (masses, centres of mass in m in the sensor frame), the "
            "configuration labels, the joint units and the sensor mount; offsets that drift during the run (warm-up, "
            "temperature) or move at a tool change also leave such residuals (--offsets auto or drift models them), and "
            "so does a sensor whose response bends with the load in a way these loads cannot show (a jig of 2 masses, "
            "each at 5 centres of mass, would: 'fts-calib trajectory --tool TOOL --model quadratic' names one)"
        )
    return FitCheck("poor", float(ratio.max()), residual, expected, diagnosis, worst, **parts)


def _parts(tool: Tool, matrices, sums, counts, noise_cov, per_configuration: bool, allowance: FitAllowance) -> dict:
    """The noise part, the tolerance part and the floor of the expected residual (FitCheck's fields), shape (6,) each."""
    solved = _solve(matrices, sums, per_configuration)
    noise = np.full(6, math.nan) if solved is None else noise_residual(solved[0][:, :6], noise_cov)
    tolerance = tolerance_residual(tool, matrices, sums, _embeddings(sums, per_configuration), counts, allowance)
    return {"noise": noise, "tolerance": tolerance, "floor": allowance.floor}

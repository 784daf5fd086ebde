r"""Fit checks after every solve: do the data fit the model, at the noise level they show?

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
accuracy budget's terms, :mod:`fts_calib.pipeline.fit_tolerance`). It is at least ``1e-6``
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
:mod:`fts_calib.pipeline.diagnosis`. Two mistakes scale C without leaving a residual, so their values
are checked instead: a centre of mass beyond 1 m (mm or cm for m) and a gravity outside
9.7-9.9 m/s^2 (:mod:`fts_calib.pipeline.tool_plausibility`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..model.channels import MALTESE_CROSS_8, ChannelLayout
from ..model.sensor import WRENCH_AXES
from ..robot.tool import Tool
from ..robot.wrench import wrench_matrix
from .fit_tolerance import MAX_RATIO, FitAllowance, expected_residual, expected_words, noise_residual, tolerance_residual
from .tool_plausibility import MIN_COM_M, implausible_tool

#: Tool configurations up to which every permutation of the labels is tried.
MAX_PERMUTED = 4
#: An alternative of the tool file is named only when its largest ratio is at most MAX_RATIO and this
#: many times below the stated tool's (:mod:`fts_calib.pipeline.diagnosis`): a fit at the noise, never a least-bad guess.
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
            :mod:`fts_calib.pipeline.fit_tolerance`), shape (6,), or None.
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
        columns: Its columns in the estimator's offset basis (:class:`fts_calib.model.offset_basis.Candidate`).
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
            (:func:`fts_calib.pipeline.fit_tolerance.robot_allowance`); None: the tool file's tolerance alone,
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

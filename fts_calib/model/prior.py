r"""A prior for weak excitation: ridge regression of C_bar toward a previous or factory calibration.

When the motion cannot determine every coefficient (a tool with fewer centres of mass, a
short run, a sensor mounted where gravity sweeps little of the sphere), the normal
equations are singular or ill conditioned. As robotology's in-situ calibration tools do,
the solve can then shrink C_bar toward a known one, ``C_bar0`` (the factory matrix, the last
calibration), with a weight ``lambda`` that is relative to the data's own information:

.. math::

    \Theta\,(S_{XX} + M) = S_{WX} + \Theta_0 M, \qquad
    M = \lambda \begin{bmatrix} \mathrm{diag}(S_{XX,\bar C}) & 0 \\ 0 & 0 \end{bmatrix}

(``Theta = [C_bar, offset terms]``, ``Theta_0 = [C_bar0, 0]``). Only the C_bar block is
shrunk: the offsets stay the data's. ``lambda = 0`` is the plain least squares, ``lambda =
1`` makes the prior weigh, coefficient by coefficient, as much as the data, ``lambda ->
infinity`` returns C_bar0. The quality reports the prior (its source and weight) and how
much of the solution the data determine: the effective number of parameters
``tr(S_XX (S_XX + M)^-1)`` out of p, and the shrinkage ``1 - that / p`` (0: the data alone,
1: the prior alone). The standard errors are those of the ridge estimate,
``sigma^2 (S + M)^-1 S (S + M)^-1``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core import arrays as validation
from ..core.arrays import as_matrix, frozen
from ..core.exceptions import ConfigError
from .least_squares import information_rank, solve_normal

#: Largest prior weight lambda: at 1e12 the data pull C_bar 1e-12 of the way from the prior (the prior to
#: rounding); far beyond it ``S_XX + M`` overflows (at 1e308 no eigenvalue solver converges).
MAX_WEIGHT = 1e12


@dataclass(frozen=True)
class Prior:
    """The calibration to shrink toward, and how strongly.

    Attributes:
        C_bar: The prior's modified calibration matrix (same channel layout as the data).
            Shape (6, 6).
        weight: lambda, 0 to :data:`MAX_WEIGHT` (1e12), relative to the data's information (see
            the module docstring).
        source: Where it came from (a file name), for the quality report.
    """

    C_bar: np.ndarray
    weight: float
    source: str = ""

    def __post_init__(self):
        object.__setattr__(self, "C_bar", frozen(validation.finite_array("prior C_bar", as_matrix(self.C_bar, (6, 6), "C_bar"))))
        weight = validation.non_negative("prior_weight", self.weight)
        if weight > MAX_WEIGHT:
            message = (
                f"--prior-weight {weight:g} but expected at most {MAX_WEIGHT:g}: there the result is already the prior's C_bar "
                "to rounding (a larger weight only overflows the solve); to use the prior as it is, use that calibration"
            )
            raise ConfigError("prior_weight", weight, f"0 to {MAX_WEIGHT:g}", message=message)
        object.__setattr__(self, "weight", weight)

    def solve(self, S_XX: np.ndarray, S_WX: np.ndarray, rcond: float):
        """Solve the shrunk normal equations.

        Args:
            S_XX: Sum of ``x x^T``, shape (p, p), the C_bar block first.
            S_WX: Sum of ``W x^T``, shape (6, p).
            rcond: Rank threshold (:func:`fts_calib.model.least_squares.information_rank`).

        Returns:
            ``(Theta (6, p), rank, condition, covariance / sigma^2 (p, p), report)`` with
            the rank and condition of ``S_XX + M``, or Theta None when even that is singular
            (an offset term no sample determines).
        """
        p = S_XX.shape[0]
        M = np.zeros((p, p))
        M[:6, :6] = self.weight * np.diag(np.diag(S_XX)[:6])
        target = np.zeros((6, p))
        target[:, :6] = self.C_bar
        theta, rank, condition, A_inv = solve_normal(S_XX + M, S_WX + target @ M, rcond, False)
        data_rank, _ = information_rank(S_XX, rcond)
        if theta is None:
            return None, rank, condition, None, None
        effective = float(np.trace(S_XX @ A_inv))
        report: dict[str, Any] = {
            "source": self.source,
            "weight": self.weight,
            "effective_parameters": effective,
            "parameters": p,
            "shrinkage": max(0.0, 1.0 - effective / p),
            "rank_without_prior": data_rank,
        }
        return theta, rank, condition, A_inv @ S_XX @ A_inv, report


def describe(report: dict[str, Any] | None) -> str:
    """One line for a person: the prior, its weight and how much of the solution the data determine."""
    if not report:
        return ""
    return (
        f"prior {report['source'] or '(given)'}, weight {report['weight']:g}: the data determine "
        f"{report['effective_parameters']:.2f} of {report['parameters']} parameters per axis (shrinkage "
        f"{100 * report['shrinkage']:.1f} %; rank {report['rank_without_prior']} without the prior)"
    )

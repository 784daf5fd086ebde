r"""Sensor model of the paper (eqs 1-7): projection P, C = C_bar P and W = C Delta + D.

Frames and units: a wrench is ``[Fx, Fy, Fz, Mx, My, Mz]`` in [N] and [N m], the load the
tool exerts on the sensor, expressed in the sensor frame S (X orthogonal to the sensor
plane, Y and Z along the cross beams), moment about the origin of S. Strains are the raw
readings of the 8 half-bridges, in whatever unit the sensor delivers; C carries the
conversion.

.. math::

    W = C \Delta + D, \qquad C = \bar C P, \qquad \bar\Delta = P \Delta

P is the paper's 6x8 projection (eq 6; the paper's "8x6" is a typo). Its rows are
orthogonal, so ``pinv(P) = P.T @ inv(P @ P.T)`` with ``P @ P.T = diag(4, 2, 2, 4, 2, 2)``.
Its null space holds the two strain patterns the sensor model ignores,
``[1, 0, -1, 0, 1, 0, -1, 0]`` and ``[0, 1, 0, -1, 0, 1, 0, -1]``; a matrix C has the form
``C_bar @ P`` exactly when C maps both to zero.
"""

from __future__ import annotations

import numpy as np

from ..core.arrays import as_matrix, as_samples, frozen
from ..core.deprecation import renamed
from ..core.exceptions import ShapeError, StructureError

#: Projection of the 8 bridge strains onto the 6 wrench-like combinations (paper eq 6).
P = frozen(
    [
        [0, -1, 0, -1, 0, -1, 0, -1],
        [0, 0, +1, 0, 0, 0, -1, 0],
        [+1, 0, 0, 0, -1, 0, 0, 0],
        [+1, 0, +1, 0, +1, 0, +1, 0],
        [0, 0, 0, -1, 0, 0, 0, +1],
        [0, -1, 0, 0, 0, +1, 0, 0],
    ]
)

#: Moore-Penrose pseudo-inverse of P, shape (8, 6).
P_PINV = frozen(P.T / np.sum(P * P, axis=1))

#: Unit basis of the null space of P, shape (2, 8): strain patterns no wrench produces.
P_NULL = frozen(np.array([[1, 0, -1, 0, 1, 0, -1, 0], [0, 1, 0, -1, 0, 1, 0, -1]]) / 2.0)

#: Names of the wrench components, in order.
WRENCH_AXES = ("Fx", "Fy", "Fz", "Mx", "My", "Mz")

#: Unit of each wrench component.
WRENCH_UNITS = ("N", "N", "N", "N·m", "N·m", "N·m")


@renamed(strain="channels")
def project(channels) -> np.ndarray:
    """Project raw strains onto the paper's six combinations (eq 5): ``Delta_bar = P Delta``.

    Args:
        channels: Raw bridge strains, in sensor units. Shape (8,) or (N, 8).

    Returns:
        Projected strains, shape (6,) or (N, 6).
    """
    batch, single = as_samples(channels, 8, "channels")
    out = batch @ P.T
    return out[0] if single else out


def c_from_c_bar(C_bar) -> np.ndarray:
    """Full calibration matrix from the modified one (eq 7): ``C = C_bar P``.

    Args:
        C_bar: Modified calibration matrix, in [N or N m per strain unit]. Shape (6, 6).

    Returns:
        Calibration matrix C, shape (6, 8).
    """
    return as_matrix(C_bar, (6, 6), "C_bar") @ P


def c_bar_from_c(C, rtol: float = 1e-6, projection=None) -> np.ndarray:
    """Modified calibration matrix from a full one: ``C_bar = C pinv(P)``, with a structure check.

    The check refuses a C that does not satisfy the two column identities of ``C = C_bar P``
    (see the module docstring): the largest entry of ``C - C_bar P`` must not exceed
    ``rtol * max|C|``. Table 1 of the paper, printed to 4 decimals, passes with a residual
    below 5e-5 (its rounding), about 2e-7 of its largest entry.

    Args:
        C: Calibration matrix, in [N or N m per strain unit]. Shape (6, n): (6, 8) for the
            paper's P.
        rtol: Accepted residual, relative to the largest absolute entry of C.
        projection: The layout's P, shape (6, n); the paper's when None.

    Returns:
        C_bar, shape (6, 6).

    Raises:
        StructureError: C is not of the form C_bar P; carries the residual.
    """
    projection = P if projection is None else np.asarray(projection, dtype=float)
    C = as_matrix(C, projection.shape, "C")
    C_bar = C @ (P_PINV if projection is P else np.linalg.pinv(projection))
    residual = float(np.max(np.abs(C - C_bar @ projection)))
    tolerance = rtol * float(np.max(np.abs(C)))
    if not residual <= tolerance:
        raise StructureError(residual, tolerance)
    return C_bar


@renamed(strain="channels")
def wrench_from_strain(C, channels, D=None) -> np.ndarray:
    """Wrench from raw strains (eq 3): ``W = C Delta + D``.

    Args:
        C: Calibration matrix, in [N or N m per channels unit]. Shape (6, n), n channels
            (8 for the paper's sensor).
        channels: Raw channel readings. Shape (n,) or (N, n).
        D: Wrench offsets in [N, N, N, N m, N m, N m]. Shape (6,); zero when None.

    Returns:
        Wrench on the sensor in S, ``[Fx, Fy, Fz, Mx, My, Mz]``. Shape (6,) or (N, 6).
    """
    C = np.asarray(C, dtype=float)
    if C.ndim != 2 or C.shape[0] != 6:
        raise ShapeError(f"C.shape={C.shape} but expected (6, n)")
    batch, single = as_samples(channels, C.shape[1], "channels")
    out = batch @ C.T
    if D is not None:
        out = out + as_matrix(D, (6,), "D")
    return out[0] if single else out

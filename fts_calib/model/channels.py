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

Channel layouts: how a sensor's n raw channels map onto the six wrench-like combinations.

The sensor model is ``W = C Delta + D`` with ``C = C_bar P`` (paper eq 7), where P is a
6 x n projection of full row rank and C_bar is 6 x 6. The layout is part of the sensor
configuration (the sensor YAML's ``channels`` key) and of every calibration file:

- ``maltese-cross-8`` (default): the paper's 8 half-bridges and its P (eq 6).
- ``wrench-6``: P = I. The channels already are a wrench (a factory-calibrated sensor,
  e.g. ATI, Robotiq, Bota or a UR's built-in one, in [N, N, N, N m, N m, N m]); the result
  is the 6 x 6 correction C_bar and the offsets.
- ``projection``: an explicit 6 x n matrix for any other strain-gauge layout.

The estimator regresses W on ``P Delta``, so everything downstream of the projection is
six-dimensional whatever n is.
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.arrays import as_matrix, as_samples, frozen
from ..core.bounded import MAX_CHANNELS
from ..core.deprecation import renamed
from ..core.exceptions import ConfigError, ShapeError, StructureError

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


#: Names a layout can have, in the order the documentation gives them.
LAYOUT_NAMES = ("maltese-cross-8", "wrench-6", "projection")


@dataclass(frozen=True, eq=False)
class ChannelLayout:
    """A channel layout: its name and its 6 x n projection of full row rank.

    Attributes:
        name: One of :data:`LAYOUT_NAMES`.
        projection: P, shape (6, n): ``P @ channels`` are the six wrench-like combinations.
        pinv: Moore-Penrose pseudo-inverse of P, shape (n, 6) (derived).
        null_basis: Orthonormal basis of the null space of P, shape (n - 6, n) (derived):
            channel patterns no wrench produces (the paper's two patterns for its sensor).

    Raises:
        ConfigError: Unknown name, or a projection that is not 6 x n with 6 <= n <=
            :data:`~fts_calib.core.bounded.MAX_CHANNELS` (64), not finite, or not of full row rank 6.
    """

    name: str
    projection: np.ndarray
    pinv: np.ndarray = field(init=False, repr=False)
    null_basis: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        if self.name not in LAYOUT_NAMES:
            raise ConfigError("channels", self.name, f"one of {', '.join(LAYOUT_NAMES)}")
        projection = np.asarray(self.projection, dtype=float)
        if projection.ndim != 2 or projection.shape[0] != 6 or projection.shape[1] < 6:
            expected = "a 6 x n matrix with n >= 6 (one column per channel)"
            raise ConfigError("projection", projection.shape, expected, reason=f"has shape {projection.shape} but expected {expected}")
        if projection.shape[1] > MAX_CHANNELS:  # before the SVDs, whose cost grows with the cube of n
            expected = f"at most {MAX_CHANNELS} channels (columns)"
            raise ConfigError(
                "projection", projection.shape, expected, reason=f"has {projection.shape[1]:,} columns but expected {expected}"
            )
        if not np.all(np.isfinite(projection)):
            raise ConfigError(
                "projection", "a NaN or inf entry", "finite numbers", reason="has a NaN or inf entry but expected finite numbers"
            )
        singular = np.linalg.svd(projection, compute_uv=False)
        if singular[-1] <= 1e-9 * singular[0]:
            rank = int(np.sum(singular > 1e-9 * singular[0]))
            expected = "full row rank 6 (six independent rows)"
            raise ConfigError("projection", rank, expected, reason=f"has rank {rank} but expected {expected}")
        object.__setattr__(self, "projection", frozen(projection))
        object.__setattr__(self, "pinv", frozen(np.linalg.pinv(projection)))
        if np.array_equal(projection, P):
            null = P_NULL  # the paper's two patterns, in the paper's own basis
        else:
            null = np.linalg.svd(projection)[2][6:]  # the right singular vectors beyond rank 6
        object.__setattr__(self, "null_basis", frozen(null))

    @property
    def n_channels(self) -> int:
        """Number of raw channels n."""
        return int(self.projection.shape[1])

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, ChannelLayout):
            return NotImplemented
        return self.name == other.name and np.array_equal(self.projection, other.projection)

    def __hash__(self) -> int:
        return hash((self.name, self.projection.tobytes()))

    def project(self, channels) -> np.ndarray:
        """The six combinations ``P Delta`` of raw channels.

        Args:
            channels: Raw channel readings. Shape (n,) or (N, n).

        Returns:
            Shape (6,) or (N, 6).
        """
        batch, single = as_samples(channels, self.n_channels, "channels")
        out = batch @ self.projection.T
        return out[0] if single else out

    def projected_noise(self, noise_std) -> np.ndarray:
        """Covariance of ``P Delta`` for white channel noise, ``P diag(sigma^2) P^T``, shape (6, 6).

        Args:
            noise_std: Noise standard deviation per channel, raw units. Shape (n,) or one number.
        """
        variance = np.broadcast_to(np.asarray(noise_std, dtype=float) ** 2, (self.n_channels,))
        return (self.projection * variance) @ self.projection.T

    def c_from_c_bar(self, C_bar) -> np.ndarray:
        """Full calibration matrix ``C = C_bar P``, shape (6, n), in [N or N m per channel unit]."""
        return as_matrix(C_bar, (6, 6), "C_bar") @ self.projection

    def c_bar_from_c(self, C, rtol: float = 1e-6) -> np.ndarray:
        """C_bar from a full C (``C pinv(P)``), refusing a C that is not of the form C_bar P.

        Args:
            C: Calibration matrix, shape (6, n).
            rtol: Accepted largest entry of ``C - C_bar P``, relative to max|C|.

        Raises:
            StructureError: C is not of the form C_bar P; carries the residual.
        """
        return c_bar_from_c(C, rtol, self.projection)

    def to_config(self) -> Any:
        """The sensor-YAML / calibration-file value: the name, or ``{"projection": rows}``."""
        if self.name == "projection":
            return {"projection": self.projection.tolist()}
        return self.name


#: The paper's sensor: 8 half-bridges on a Maltese cross (eq 6).
MALTESE_CROSS_8 = ChannelLayout("maltese-cross-8", P)
#: A sensor whose channels already are a wrench: P = I.
WRENCH_6 = ChannelLayout("wrench-6", np.eye(6))


def channel_layout(value: Any = None, also: tuple[str, ...] = ()) -> ChannelLayout:
    """The layout named by a sensor-YAML ``channels`` value.

    Args:
        value: None or ``"maltese-cross-8"`` (the default), ``"wrench-6"``, a 6 x n list of
            rows, ``{"projection": rows}``, or a :class:`ChannelLayout` (returned as is).
        also: Other names the caller reads before this (the sensor file's ``full``): an
            error lists them with the layouts, and a typo of one is named.

    Raises:
        ConfigError: An unknown name or a bad matrix; the message says what is expected.
    """
    if isinstance(value, ChannelLayout):
        return value
    if value is None or (isinstance(value, str) and value == "maltese-cross-8"):
        return MALTESE_CROSS_8
    if isinstance(value, str) and value == "wrench-6":
        return WRENCH_6
    if isinstance(value, Mapping):
        if set(value) != {"projection"}:
            raise ConfigError("channels", dict(value), "maltese-cross-8, wrench-6 or {projection: 6 x n rows}")
        value = value["projection"]
    if isinstance(value, (str, int, float)):  # a typo of a name, or a channel count instead of a layout
        close = difflib.get_close_matches(str(value), [*LAYOUT_NAMES, *also], 1)
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        names = ", ".join(["maltese-cross-8", "wrench-6", *also])
        raise ConfigError("channels", value, f"{names} or {{projection: 6 x n rows}}" + hint)
    rows = value if isinstance(value, list) and all(isinstance(row, list) for row in value) else None
    if rows is not None and len({len(row) for row in rows}) > 1:
        lengths = [len(row) for row in rows]
        raise ConfigError("projection", lengths, "", reason=f"has rows of {lengths} numbers but expected 6 rows of n numbers each")
    bad = [x for row in rows or [] for x in row if isinstance(x, bool) or not isinstance(x, (int, float))]
    if bad:
        raise ConfigError("projection", bad[0], "", reason=f"has the entry {bad[0]!r} but expected numbers")
    try:
        matrix = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError("channels", value, "maltese-cross-8, wrench-6 or {projection: 6 x n rows}") from None
    return ChannelLayout("projection", matrix)


#: What to do about data of another width, when the layout is the sensor file's (calibrate, live).
SENSOR_HINT = ("the sensor's layout", "select the sensor with --sensor FILE, from Python sensor=FILE (its 'channels' key)")
#: What to do about data of another width, when the layout is a calibration's (validate, tare, payload).
CALIBRATION_HINT = ("the calibration's layout", "give the calibration of this sensor (--calibration FILE)")


def check_channels(layout: ChannelLayout, n: int, where: str, hint: tuple[str, str] = SENSOR_HINT) -> None:
    """Refuse data with another number of channels than the layout's.

    Args:
        layout: The sensor's layout.
        n: Number of channels the data have.
        where: What carries the data, for the message (e.g. 'run.csv').
        hint: Whose layout it is and what to do, in words: :data:`SENSOR_HINT` or
            :data:`CALIBRATION_HINT`.

    Raises:
        ShapeError: ``n`` differs from ``layout.n_channels``.
    """
    if n != layout.n_channels:
        raise ShapeError(f"{where} has {n} channels but {hint[0]} {layout.name} has {layout.n_channels}; {hint[1]}")

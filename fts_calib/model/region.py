r"""The load region a calibration was fitted on: the wrenches of the samples that entered its least squares.

A sensor model is determined only on the loads it was fitted on. A quadratic or cubic model
can bend anywhere else, and even the linear model was checked only there. The region travels
with the calibration file (its ``region`` section) so that ``validate`` can report the error
inside and outside it, ``monitor`` can count the loads of the service that leave it, and
:meth:`fts_calib.model.calibration.Calibration.wrench` can warn when a nonlinear model is
evaluated outside it.

Rule: a wrench ``w = [F; M]`` lies inside the region when

.. math::

    low_j - margin_j \le w_j \le high_j + margin_j \quad (j = 1 \dots 6),\qquad
    |F| \le force\_max + |margin_F|,\qquad |M| \le moment\_max + |margin_M|,\qquad
    |F \cdot M| \le coupling\_max + |margin_F|\,moment\_max + |margin_M|\,force\_max

with ``low``, ``high`` the per-axis smallest and largest known wrench of the kept samples,
``force_max`` and ``moment_max`` the largest force and moment magnitudes, ``coupling_max`` the
largest ``|F . M|`` (0 for every weight, paper eq 20: a push or a contact off the sensor's axis is
beyond it; absent from files written before it, then not checked), and ``margin`` a
tolerance per axis (by default :data:`MARGIN_SHARE`, 1 % of the sensor's full scale) so that
a load a hair outside, by noise or rounding, is not "outside". That is a box over the six axes
cut by two magnitude caps; it is not the set of loads the calibration saw. A calibration tool
of one mass puts every force on a sphere ``|F| = m g``: the box also contains every load
between those spheres (no load at all, a lighter tool), which the fit never saw. That is why
``validate`` reports the error inside and outside the region rather than claiming more, and
the region's job is to flag the loads plainly beyond what the fit saw.

Frames and units: wrenches ``[Fx, Fy, Fz, Mx, My, Mz]`` on the sensor in its frame S, in
[N, N, N, N m, N m, N m]; ``force_max`` in [N], ``moment_max`` in [N m], ``coupling_max`` in [N^2 m].
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..core import arrays as validation
from ..core.arrays import as_matrix, as_samples, frozen
from ..core.exceptions import ConfigError, FileFormatError
from ..core.files import fields_of, read_array, read_number, require

#: The default margin of a region on each axis, as a share of the sensor's full scale on that axis (1 %).
MARGIN_SHARE = 0.01

_UNITS = {"wrench": "N, N, N, N·m, N·m, N·m", "force_max": "N", "moment_max": "N·m", "coupling_max": "N²·m"}
_RULE = (
    "inside: low - margin <= w <= high + margin on every axis, |F| <= force_max + |margin of Fx Fy Fz|, "
    "|M| <= moment_max + |margin of Mx My Mz|, |F.M| <= coupling_max + |margin of F| moment_max + |margin of M| force_max"
)


@dataclass(frozen=True)
class LoadRegion:
    """The wrenches a calibration was fitted on, as a box of the axes and two magnitude caps (see the module docstring).

    Attributes:
        low: Smallest known wrench per axis over the kept samples, [N, N, N, N m, N m, N m]. Shape (6,).
        high: Largest known wrench per axis, same units. Shape (6,).
        force_max: Largest force magnitude |F| of the kept samples, in [N].
        moment_max: Largest moment magnitude |M| of the kept samples, in [N m].
        margin: Tolerance per axis, same units as ``low`` (1 % of the sensor's full scale by
            default, :data:`MARGIN_SHARE`). Shape (6,).
        samples: Samples the region was computed from (>= 1).
        coupling_max: Largest ``|F . M|`` of the kept samples, in [N^2 m] (0 for weights), or
            None (a file written before it: not checked).

    Raises:
        ShapeError: ``low``, ``high`` or ``margin`` is not 6 numbers.
        ConfigError: A value is not finite, ``low > high`` on an axis, a negative magnitude
            or margin, or fewer than one sample; the error names the field.
    """

    low: np.ndarray
    high: np.ndarray
    force_max: float
    moment_max: float
    margin: np.ndarray
    samples: int
    coupling_max: float | None = None

    def __post_init__(self):
        for name in ("low", "high", "margin"):
            value = validation.finite_array(name, as_matrix(getattr(self, name), (6,), name))
            object.__setattr__(self, name, frozen(value))
        if np.any(self.low > self.high):
            axes = [j for j in range(6) if self.low[j] > self.high[j]]
            raise ConfigError("low", self.low.tolist(), f"low <= high on every axis (not on axes {axes} of Fx Fy Fz Mx My Mz)")
        if np.any(self.margin < 0):
            raise ConfigError("margin", self.margin.tolist(), "values >= 0")
        object.__setattr__(self, "force_max", validation.non_negative("force_max", self.force_max, "N"))
        object.__setattr__(self, "moment_max", validation.non_negative("moment_max", self.moment_max, "N·m"))
        samples = validation.number("samples", self.samples)
        if samples != int(samples) or samples < 1:
            raise ConfigError("samples", self.samples, "a whole number >= 1")
        object.__setattr__(self, "samples", int(samples))
        if self.coupling_max is not None:
            object.__setattr__(self, "coupling_max", validation.non_negative("coupling_max", self.coupling_max, "N²·m"))

    @property
    def lower(self) -> np.ndarray:
        """Lowest wrench per axis still inside: ``low - margin``, shape (6,)."""
        return self.low - self.margin

    @property
    def upper(self) -> np.ndarray:
        """Highest wrench per axis still inside: ``high + margin``, shape (6,)."""
        return self.high + self.margin

    @property
    def force_limit(self) -> float:
        """Largest force magnitude still inside: ``force_max + |margin[:3]|``, in [N]."""
        return self.force_max + float(np.linalg.norm(self.margin[:3]))

    @property
    def moment_limit(self) -> float:
        """Largest moment magnitude still inside: ``moment_max + |margin[3:]|``, in [N m]."""
        return self.moment_max + float(np.linalg.norm(self.margin[3:]))

    @property
    def coupling_limit(self) -> float:
        """Largest ``|F . M|`` still inside, in [N^2 m]: the rule's, infinite without ``coupling_max``."""
        if self.coupling_max is None:
            return float("inf")
        forces, moments = float(np.linalg.norm(self.margin[:3])), float(np.linalg.norm(self.margin[3:]))
        return self.coupling_max + forces * self.moment_max + moments * self.force_max

    def contains(self, w_sensor) -> np.ndarray:
        """Whether each wrench lies inside the region (the rule of the module docstring; NaN is outside).

        Args:
            w_sensor: Wrenches on the sensor in S, [N, N, N, N m, N m, N m]. Shape (6,) or (N, 6).

        Returns:
            One bool per wrench, shape (N,) (shape (1,) for one wrench).

        Raises:
            ShapeError: ``w_sensor`` is not (6,) or (N, 6).
        """
        W, _ = as_samples(w_sensor, 6, "w_sensor")
        box = np.all((W >= self.lower) & (W <= self.upper), axis=1)
        force = np.einsum("ij,ij->i", W[:, :3], W[:, :3]) <= self.force_limit**2
        moment = np.einsum("ij,ij->i", W[:, 3:], W[:, 3:]) <= self.moment_limit**2
        coupling = np.abs(np.einsum("ij,ij->i", W[:, :3], W[:, 3:])) <= self.coupling_limit
        return box & force & moment & coupling

    def describe(self) -> str:
        """The region in a few words with units.

        Example: '|F| <= 19.62 N, |M| <= 2.354 N·m, |F·M| <= 1.2e-14 N²·m, each axis within its range over 4,035 samples, margin ...'.
        """
        return (
            f"|F| <= {self.force_max:.4g} N, |M| <= {self.moment_max:.4g} N·m"
            + ("" if self.coupling_max is None else f", |F·M| <= {self.coupling_max:.3g} N²·m")
            + ", each axis within its range over "
            f"{self.samples:,} samples, margin {_axes_text(self.margin)}"
        )

    def as_dict(self) -> dict[str, Any]:
        """The ``region`` section of a calibration file (plain data, units and the rule included)."""
        return {
            "units": dict(_UNITS),
            "rule": _RULE,
            "low": self.low.tolist(),
            "high": self.high.tolist(),
            "force_max": self.force_max,
            "moment_max": self.moment_max,
            "margin": self.margin.tolist(),
            "samples": self.samples,
            **({} if self.coupling_max is None else {"coupling_max": self.coupling_max}),
        }


def region_from_dict(data: Any, path: str | Path) -> LoadRegion:
    """The region of a calibration file's ``region`` section (as :meth:`LoadRegion.as_dict` writes it).

    Fields this version does not know (``units``, ``rule``, a newer version's) are ignored.

    Args:
        data: The section as read from the file.
        path: The file, for the messages.

    Raises:
        FileFormatError: Not a mapping, a field missing, of the wrong shape, not finite, or
            refused by :class:`LoadRegion` (``low > high``, a negative margin); the message
            names the field (``region.low``).
    """
    if not isinstance(data, Mapping):
        raise FileFormatError(path, "region", f"expected a mapping (low, high, force_max, moment_max, margin, samples), got {data!r}")
    low, high, margin = (
        read_array(require(data, name, path, "region."), (6,), path, f"region.{name}") for name in ("low", "high", "margin")
    )
    force_max, moment_max, samples = (
        read_number(require(data, name, path, "region."), path, f"region.{name}") for name in ("force_max", "moment_max", "samples")
    )
    coupling = None if data.get("coupling_max") is None else read_number(data["coupling_max"], path, "region.coupling_max")
    with fields_of(path, "region."):
        return LoadRegion(low, high, force_max, moment_max, margin, samples, coupling)  # type: ignore[arg-type]  # samples: whole, checked there


class RegionBuilder:
    """Grows a :class:`LoadRegion` batch by batch, as a calibration session keeps samples.

    Args:
        full_scale: The sensor's full scale per axis, [N, N, N, N m, N m, N m]. Shape (6,).
        share: The region's margin per axis as a share of ``full_scale`` (1 %: :data:`MARGIN_SHARE`).

    Attributes:
        margin: The margin per axis, ``share * full_scale``. Shape (6,).
        samples: Samples added so far.

    Example::

        builder = RegionBuilder([50, 50, 50, 5, 5, 5])  # [N, N m]
        builder.add(w_sensor)                          # (N, 6), each batch of kept samples
        region = builder.region()                      # None before the first sample
    """

    def __init__(self, full_scale, share: float = MARGIN_SHARE):
        full_scale = as_matrix(full_scale, (6,), "full_scale")
        share = validation.non_negative("share", share)
        self.margin = frozen(share * full_scale)
        self.samples = 0
        self._low = np.full(6, np.inf)
        self._high = np.full(6, -np.inf)
        self._force_max = 0.0
        self._moment_max = 0.0
        self._coupling_max = 0.0

    def add(self, w_sensor) -> None:
        """Add the known wrenches of samples that entered the least squares.

        Args:
            w_sensor: Wrenches on the sensor in S, [N, N, N, N m, N m, N m]. Shape (6,) or (N, 6).

        Raises:
            ShapeError: Not (6,) or (N, 6).
        """
        W, _ = as_samples(w_sensor, 6, "w_sensor")
        if not len(W):
            return
        np.minimum(self._low, W.min(axis=0), out=self._low)
        np.maximum(self._high, W.max(axis=0), out=self._high)
        self._force_max = max(self._force_max, float(np.sqrt(np.einsum("ij,ij->i", W[:, :3], W[:, :3]).max())))
        self._moment_max = max(self._moment_max, float(np.sqrt(np.einsum("ij,ij->i", W[:, 3:], W[:, 3:]).max())))
        self._coupling_max = max(self._coupling_max, float(np.abs(np.einsum("ij,ij->i", W[:, :3], W[:, 3:])).max()))
        self.samples += len(W)

    def merge(self, other: RegionBuilder) -> None:
        """Add everything ``other`` holds (the same region as one pass over both streams; the margin stays this one's)."""
        self._low = np.minimum(self._low, other._low)
        self._high = np.maximum(self._high, other._high)
        self._force_max = max(self._force_max, other._force_max)
        self._moment_max = max(self._moment_max, other._moment_max)
        self._coupling_max = max(self._coupling_max, other._coupling_max)
        self.samples += other.samples

    def region(self) -> LoadRegion | None:
        """The region of every sample added so far, or None before the first."""
        if not self.samples:
            return None
        return LoadRegion(
            self._low.copy(), self._high.copy(), self._force_max, self._moment_max, self.margin, self.samples, self._coupling_max
        )

    def state(self) -> dict[str, Any]:
        """What a checkpoint holds of the builder: plain types, safe to write as JSON (no infinity)."""
        if not self.samples:
            return {"samples": 0}
        return {
            "samples": self.samples,
            "low": self._low.tolist(),
            "high": self._high.tolist(),
            "force_max": self._force_max,
            "moment_max": self._moment_max,
            "coupling_max": self._coupling_max,
        }

    def restore(self, state: Mapping[str, Any] | None) -> None:
        """Continue from :meth:`state` (None or no sample: nothing to restore).

        Raises:
            KeyError, TypeError, ValueError: A damaged state (the checkpoint reader names the file).
        """
        if not state or not int(state["samples"]):
            return
        low, high = (np.array(state[key], dtype=float).reshape(6) for key in ("low", "high"))
        if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high)) and np.all(low <= high)):
            raise ValueError(f"region low={low.tolist()}, high={high.tolist()} but expected finite values with low <= high")
        self._low, self._high = low, high
        self._force_max, self._moment_max = float(state["force_max"]), float(state["moment_max"])
        self._coupling_max = float(state.get("coupling_max", 0.0))  # older checkpoints: the samples after them only
        self.samples = int(state["samples"])


def _axes_text(values: np.ndarray) -> str:
    """'0.5 N (forces), 0.05 N·m (moments)' when equal per group, else the six values with units."""
    forces, moments = values[:3], values[3:]
    if np.all(forces == forces[0]) and np.all(moments == moments[0]):
        return f"{forces[0]:.3g} N, {moments[0]:.3g} N·m"
    return ", ".join(f"{v:.3g} {'N' if j < 3 else 'N·m'}" for j, v in enumerate(values))

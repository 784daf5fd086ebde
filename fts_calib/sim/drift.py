r"""Simulated offsets that move: a drift per minute, a warm-up, a temperature channel, tool-change jumps.

Real offsets are not constant (paper eq 3 assumes they are): they drift while the sensor
warms up and jump when the calibration tool is remounted. The simulated change of the
wrench offsets from the start of the run, at time ``t`` [s] after it and after ``j`` tool
changes, is

.. math::

    \delta D(t, j) = r\,t / 60 + a\,(1 - e^{-t/\tau}) + k\,(T(t) - T(0)) + j\,J, \qquad
    T(t) = T_0 + \Delta T\,(1 - e^{-t/\tau})

with ``r`` the rate [N/min, N m/min] (6,), ``a`` the warm-up amplitude [N, N m] (6,),
``tau`` its time constant [s], ``k`` the offset per degree [N/°C, N m/°C] (6,), ``T`` the
sensor temperature [°C] that a temperature channel reports, and ``J`` the jump at each
tool change [N, N m] (6,). The sensor reads ``W - delta D`` (its offsets are ``D + delta D``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core import arrays as validation
from ..core.arrays import as_matrix, frozen


def _zeros() -> np.ndarray:
    return np.zeros(6)


@dataclass(frozen=True)
class OffsetDrift:
    """How the simulated sensor's offsets move (see the module docstring).

    Attributes:
        rate_per_min: Linear drift, [N/min, N/min, N/min, N m/min, N m/min, N m/min]. Shape (6,).
        warmup: Amplitude of the warm-up exponential, [N, N, N, N m, N m, N m]. Shape (6,).
        per_degree: Offset change per degree of sensor temperature, [N/°C, N m/°C]. Shape (6,).
        jump: Offset change at each tool change, [N, N, N, N m, N m, N m]. Shape (6,).
        time_constant_s: Time constant of the warm-up (offset and temperature), in [s].
        temperature_start_C: Sensor temperature at the start, in [°C].
        temperature_rise_C: Temperature rise of the full warm-up, in [°C].
    """

    rate_per_min: np.ndarray = field(default_factory=_zeros)
    warmup: np.ndarray = field(default_factory=_zeros)
    per_degree: np.ndarray = field(default_factory=_zeros)
    jump: np.ndarray = field(default_factory=_zeros)
    time_constant_s: float = 120.0
    temperature_start_C: float = 25.0
    temperature_rise_C: float = 8.0

    def __post_init__(self):
        for name in ("rate_per_min", "warmup", "per_degree", "jump"):
            object.__setattr__(self, name, frozen(validation.finite_array(name, as_matrix(getattr(self, name), (6,), name))))
        object.__setattr__(self, "time_constant_s", validation.positive("time_constant_s", self.time_constant_s, "s"))
        for name in ("temperature_start_C", "temperature_rise_C"):
            object.__setattr__(self, name, validation.number(name, getattr(self, name), "°C"))

    @classmethod
    def typical(cls, force_per_min: float = 1.0, jump: float = 1.0) -> OffsetDrift:
        """A drift of the size of a strain-gauge sensor warming up, every term present.

        Forces drift up to ``force_per_min`` [N/min] at the start (moments a 20th of it, in
        N m/min), a part of it through the temperature; tool changes jump up to ``jump`` [N]
        (moments a 20th, in N m).
        """
        signs = np.array([1.0, -0.8, 0.6, 1.0, -0.7, 0.5])
        scale = np.array([1.0, 1.0, 1.0, 0.05, 0.05, 0.05])
        return cls(
            rate_per_min=0.45 * force_per_min * signs * scale,
            warmup=0.3 * force_per_min * signs[::-1] * scale,
            per_degree=0.1 * force_per_min * signs * scale,
            jump=jump * signs[[2, 0, 1, 5, 3, 4]] * scale,
        )

    def temperature(self, time) -> np.ndarray:
        """Sensor temperature [°C] at times [s] after the start, shape (N,)."""
        t = np.asarray(time, dtype=float)
        return self.temperature_start_C + self.temperature_rise_C * (1.0 - np.exp(-t / self.time_constant_s))

    def offsets(self, time, tool_changes) -> np.ndarray:
        """The change of the offsets since the start, ``delta D``, shape (N, 6).

        Args:
            time: Times after the start of the run [s], shape (N,).
            tool_changes: Tool changes before each sample, shape (N,) or one number.
        """
        t = np.asarray(time, dtype=float).reshape(-1, 1)
        warm = 1.0 - np.exp(-t / self.time_constant_s)
        heat = self.temperature_rise_C * warm
        changes = np.broadcast_to(np.asarray(tool_changes, dtype=float), (len(t),)).reshape(-1, 1)
        return self.rate_per_min * t / 60.0 + self.warmup * warm + self.per_degree * heat + changes * self.jump

r"""A simulated strain-gauge sensor: strains from wrenches (paper eqs 21-22), with noise.

The inverse of the sensor model. The projected strains follow eq 22,
``Delta_bar = C_bar^-1 (W - D)``; the eight bridge strains are ``pinv(P) Delta_bar`` plus
content in the two patterns P does not see (a load-dependent and a constant part, as a
real sensor has), then optional white noise per channel, a slow offset drift, and the
quantization of the paper's acquisition chain (x128 gain, 24-bit ADC, saturation).

Units: wrenches in [N, N, N, N m, N m, N m]; strains in the sensor's raw unit (mV/V for
the shipped simulated sensor).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.arrays import as_matrix, as_samples, frozen
from ..model.sensor import P_NULL, P_PINV, c_from_c_bar


@dataclass(frozen=True)
class SimulatedSensor:
    """Strain generator for a sensor with known C_bar and D.

    Attributes:
        C_bar: True modified calibration matrix. Shape (6, 6).
        D: True wrench offsets, [N, N, N, N m, N m, N m]. Shape (6,).
        noise_std: White noise standard deviation per bridge, raw units. Shape (8,).
        null_coupling: Strain in the two null patterns of P per unit wrench. Shape (2, 6).
        null_offset: Constant strain in the two null patterns. Shape (2,).
        drift_rate: Offset drift of each bridge, raw units per second. Shape (8,).
        adc_bits: ADC resolution; 0 disables quantization.
        adc_full_scale: Largest strain the ADC reads (reference / gain), raw units; beyond
            it readings saturate.
    """

    C_bar: np.ndarray
    D: np.ndarray = field(default_factory=lambda: np.zeros(6))
    noise_std: np.ndarray = field(default_factory=lambda: np.zeros(8))
    null_coupling: np.ndarray = field(default_factory=lambda: np.zeros((2, 6)))
    null_offset: np.ndarray = field(default_factory=lambda: np.zeros(2))
    drift_rate: np.ndarray = field(default_factory=lambda: np.zeros(8))
    adc_bits: int = 0
    adc_full_scale: float = 1000.0 / 128.0

    def __post_init__(self):
        object.__setattr__(self, "C_bar", frozen(as_matrix(self.C_bar, (6, 6), "C_bar")))
        object.__setattr__(self, "D", frozen(as_matrix(self.D, (6,), "D")))
        object.__setattr__(self, "noise_std", frozen(np.broadcast_to(np.asarray(self.noise_std, float), (8,))))
        object.__setattr__(self, "null_coupling", frozen(as_matrix(self.null_coupling, (2, 6), "null_coupling")))
        object.__setattr__(self, "null_offset", frozen(as_matrix(self.null_offset, (2,), "null_offset")))
        object.__setattr__(self, "drift_rate", frozen(np.broadcast_to(np.asarray(self.drift_rate, float), (8,))))
        if np.any(self.noise_std < 0):
            raise ValueError(f"noise_std={self.noise_std} but expected values >= 0")
        if not (self.adc_bits == 0 or 8 <= self.adc_bits <= 32):
            raise ValueError(f"adc_bits={self.adc_bits} but expected 0 (off) or 8 to 32")
        if not self.adc_full_scale > 0:
            raise ValueError(f"adc_full_scale={self.adc_full_scale} but expected > 0")

    @property
    def C(self) -> np.ndarray:
        """True calibration matrix ``C_bar @ P``, shape (6, 8)."""
        return c_from_c_bar(self.C_bar)

    @property
    def lsb(self) -> float:
        """Quantization step of the ADC in raw strain units (0 when quantization is off)."""
        return 2.0 * self.adc_full_scale / 2**self.adc_bits if self.adc_bits else 0.0

    def strains(self, w_sensor, time=None, rng: np.random.Generator | None = None) -> np.ndarray:
        """Raw strains that the sensor reads under the given wrenches.

        Args:
            w_sensor: Wrench on the sensor, [N, N, N, N m, N m, N m]. Shape (6,) or (N, 6).
            time: Sample times in [s] for the drift, shape (N,); no drift when None.
            rng: Random generator for the noise; noiseless when None.

        Returns:
            Strains, shape (8,) or (N, 8).
        """
        W, single = as_samples(w_sensor, 6, "w_sensor")
        bar = np.linalg.solve(self.C_bar, (W - self.D).T).T  # eq 22
        strain = bar @ P_PINV.T + (W @ self.null_coupling.T + self.null_offset) @ P_NULL
        if time is not None:
            strain = strain + np.asarray(time, dtype=float).reshape(-1, 1) * self.drift_rate
        if rng is not None and np.any(self.noise_std > 0):
            strain = strain + rng.standard_normal(strain.shape) * self.noise_std
        if self.adc_bits:
            lsb = self.lsb
            strain = np.clip(np.round(strain / lsb) * lsb, -self.adc_full_scale, self.adc_full_scale - lsb)
        return strain[0] if single else strain

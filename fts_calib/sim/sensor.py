"""A simulated sensor of any channel layout: channels from wrenches (paper eqs 21-22), with noise.

The inverse of the sensor model. The projected channels follow eq 22,
``Delta_bar = C_bar^-1 (W - D)``; the n raw channels are ``pinv(P) Delta_bar`` plus
content in the n - 6 patterns P does not see (a load-dependent and a constant part, as a
real sensor has; none for ``wrench-6``), then optional white noise per channel, a slow
offset drift, and the quantization of the acquisition chain (the paper's: x128 gain,
24-bit ADC, saturation; a low-cost sensor's: 10-bit integer counts with a reading at zero
load near mid-range, railed where the load drives a channel past the converter's range).

A smooth nonlinearity bends the wrench the channels see before eq 22: axis ``i`` reads
``W_i + FS_i (quadratic u_i^2 + cubic u_i^3 + odd |u_i| u_i)`` with ``u_i = W_i / FS_i``
(``FS``: the sensor file's full scale), so that ``quadratic: 0.03`` is 3 % of full scale at full
load on that axis; a polynomial of the same degree in the channels undoes the first two, none
the odd bend.

A factory-calibrated sensor (layout ``wrench-6``, ``configs/factory_sensor.yaml``) is the
same model with P = I: its channels are the wrench its factory calibration reports, and
``C_bar`` maps them to the true wrench (the correction an in-situ calibration finds).

Units: wrenches in [N, N, N, N m, N m, N m]; channels in the sensor's raw unit (mV/V for
the shipped strain-gauge sensor, N and N m for a factory wrench).
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from ..core.arrays import as_samples
from ..core.deprecation import renamed_method
from ..core.exceptions import FileFormatError
from ..model.sensor_config import SensorSpec, SimulationSpec, load_sensor_config


@dataclass(frozen=True)
class SimulatedSensor(SimulationSpec):
    """Strain generator for a sensor with known C_bar and D (attributes: :class:`SimulationSpec`)."""

    @classmethod
    def from_spec(cls, spec: SimulationSpec) -> SimulatedSensor:
        """The simulated sensor of a sensor file's ``simulation`` section."""
        return spec if isinstance(spec, cls) else cls(**{f.name: getattr(spec, f.name) for f in fields(spec)})

    def channels(self, w_sensor, time=None, rng: np.random.Generator | None = None) -> np.ndarray:
        """Raw channels that the sensor reads under the given wrenches.

        Args:
            w_sensor: Wrench on the sensor, [N, N, N, N m, N m, N m]. Shape (6,) or (N, 6).
            time: Sample times in [s] for the drift, shape (N,); no drift when None.
            rng: Random generator for the noise; noiseless when None.

        Returns:
            Raw channels, shape (n,) or (N, n), n = ``layout.n_channels``.
        """
        W, single = as_samples(w_sensor, 6, "w_sensor")
        bar = np.linalg.solve(self.C_bar, (self.bent(W) - self.D).T).T  # eq 22
        strain = bar @ self.layout.pinv.T + (W @ self.null_coupling.T + self.null_offset) @ self.layout.null_basis
        strain = strain + self.channel_offset
        if time is not None:
            strain = strain + np.asarray(time, dtype=float).reshape(-1, 1) * self.drift_rate
        if rng is not None and np.any(self.noise_std > 0):
            strain = strain + rng.standard_normal(strain.shape) * self.noise_std
        if self.adc_bits:
            low, high = self.adc_codes
            origin = low if self.adc_range is not None else 0.0  # the codes are origin + k lsb
            strain = np.clip(origin + np.round((strain - origin) / self.lsb) * self.lsb, low, high)
        return strain[0] if single else strain

    strains = renamed_method("strains", channels)

    def bent(self, w_sensor) -> np.ndarray:
        """The wrench the channels respond to: ``w_sensor`` through the nonlinearity (see the module docstring).

        Args:
            w_sensor: Wrench on the sensor, [N, N, N, N m, N m, N m]. Shape (N, 6).

        Returns:
            Shape (N, 6), same units (``w_sensor`` itself when the sensor is linear).
        """
        W = np.asarray(w_sensor, dtype=float)
        if not (self.quadratic or self.cubic or self.odd):
            return W
        u = W / self.full_scale
        return W + self.full_scale * (self.quadratic * u**2 + self.cubic * u**3 + self.odd * np.abs(u) * u)


def load_simulated_sensor(path: str | Path) -> SimulatedSensor:
    """The simulated sensor of a sensor configuration file (its ``simulation`` section).

    Args:
        path: The YAML file, or a shipped name (``"sensor"``: the paper's, true C = Table 1).

    Raises:
        FileFormatError: The file is malformed or has no ``simulation`` section.
    """
    return simulated_sensor(load_sensor_config(path), path)


def simulated_sensor(spec: SensorSpec, path: str | Path) -> SimulatedSensor:
    """The simulated sensor of an already loaded sensor file ``path``.

    Raises:
        FileFormatError: The file has no ``simulation`` section.
    """
    if spec.simulated is None:
        raise FileFormatError(path, "simulation", "missing: this sensor file defines no simulated sensor")
    return SimulatedSensor.from_spec(spec.simulated)

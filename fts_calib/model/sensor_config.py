"""The sensor configuration file (``configs/sensor.yaml``): specification and simulated truth.

Fields: ``name``; ``strain_unit`` (text); ``full_scale`` ``{force [N], moment [N m]}``
(the paper's sensor: 50 N and 5 N m), used to express errors in % of full scale;
``rate_hz`` (strain sample rate); optional ``simulation``, the true model of the
simulated sensor: ``C`` (6x8, must be of the form C_bar P) or ``C_bar`` (6x6), ``D`` (6),
``noise_std`` (one number or 8, raw units), ``null_coupling`` (2x6), ``null_offset`` (2),
``drift_rate`` (one number or 8, raw units per s) and ``adc`` ``{bits, gain, reference}``
(full scale of the ADC = reference / gain, in raw units).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.arrays import frozen
from ..core.exceptions import FileFormatError, StructureError
from ..core.fileio import load_yaml, read_array, read_positive, require
from ..sim.sensor import SimulatedSensor
from .sensor import c_bar_from_c


@dataclass(frozen=True)
class SensorSpec:
    """What the software needs to know of the sensor.

    Attributes:
        name: Sensor name.
        strain_unit: Unit of the raw strains (text, e.g. 'mV/V').
        full_scale: Full scale per wrench axis, [N, N, N, N m, N m, N m]. Shape (6,).
        rate_hz: Strain sample rate in [Hz].
        simulated: The simulated sensor of this configuration, or None.
    """

    name: str
    strain_unit: str
    full_scale: np.ndarray
    rate_hz: float
    simulated: SimulatedSensor | None = None

    def __post_init__(self):
        object.__setattr__(self, "full_scale", frozen(self.full_scale))


def _per_bridge(value, path: Path, field: str) -> np.ndarray:
    array = np.asarray(value, dtype=float) if not isinstance(value, list) else read_array(value, (8,), path, field)
    if array.ndim == 0:
        array = np.full(8, float(array))
    if array.shape != (8,) or not np.all(np.isfinite(array)):
        raise FileFormatError(path, field, f"expected one number or 8, got {value!r}")
    return array


def _read_simulation(raw, path: Path) -> SimulatedSensor:
    if not isinstance(raw, dict):
        raise FileFormatError(path, "simulation", "expected a mapping")
    if "C_bar" in raw:
        C_bar = read_array(raw["C_bar"], (6, 6), path, "simulation.C_bar")
    else:
        C = read_array(require(raw, "C", path, "simulation."), (6, 8), path, "simulation.C")
        try:
            C_bar = c_bar_from_c(C)
        except StructureError as exc:
            raise FileFormatError(path, "simulation.C", str(exc)) from None
    adc = raw.get("adc") or {}
    bits = int(adc.get("bits", 0))
    full_scale = read_positive(adc.get("reference", 1000.0), path, "simulation.adc.reference") / read_positive(
        adc.get("gain", 128.0), path, "simulation.adc.gain"
    )
    try:
        return SimulatedSensor(
            C_bar=C_bar,
            D=read_array(raw.get("D", [0.0] * 6), (6,), path, "simulation.D"),
            noise_std=_per_bridge(raw.get("noise_std", 0.0), path, "simulation.noise_std"),
            null_coupling=read_array(raw.get("null_coupling", [[0.0] * 6] * 2), (2, 6), path, "simulation.null_coupling"),
            null_offset=read_array(raw.get("null_offset", [0.0, 0.0]), (2,), path, "simulation.null_offset"),
            drift_rate=_per_bridge(raw.get("drift_rate", 0.0), path, "simulation.drift_rate"),
            adc_bits=bits,
            adc_full_scale=full_scale,
        )
    except ValueError as exc:
        raise FileFormatError(path, "simulation", str(exc)) from None


def load_sensor_config(path: str | Path) -> SensorSpec:
    """Read a sensor configuration file (see the module docstring).

    Raises:
        FileFormatError: A missing or malformed field; the message names file and field.
    """
    path = Path(path)
    data = load_yaml(path)
    full = data.get("full_scale") or {}
    if not isinstance(full, dict):
        raise FileFormatError(path, "full_scale", "expected {force: N, moment: N·m}")
    force = read_positive(full.get("force", 50.0), path, "full_scale.force")
    moment = read_positive(full.get("moment", 5.0), path, "full_scale.moment")
    simulated = _read_simulation(data["simulation"], path) if data.get("simulation") is not None else None
    return SensorSpec(
        name=str(require(data, "name", path)),
        strain_unit=str(data.get("strain_unit", "raw")),
        full_scale=np.array([force] * 3 + [moment] * 3),
        rate_hz=read_positive(data.get("rate_hz", 1000.0), path, "rate_hz"),
        simulated=simulated,
    )

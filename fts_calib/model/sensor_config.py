"""The sensor configuration file (``configs/sensor.yaml``): specification and simulated truth.

Fields: ``name``; ``strain_unit`` (text); ``full_scale`` ``{force [N], moment [N m]}``
(the paper's sensor: 50 N and 5 N m), used to express errors in % of full scale;
``rate_hz`` (strain sample rate); optional ``simulation``, the true model of the
simulated sensor: ``C`` (6x8, must be of the form C_bar P) or ``C_bar`` (6x6), ``D`` (6),
``noise_std`` (one number or 8, raw units), ``null_coupling`` (2x6), ``null_offset`` (2),
``drift_rate`` (one number or 8, raw units per s) and ``adc`` ``{bits, gain, reference}``
(full scale of the ADC = reference / gain, in raw units). An unknown key (a typo) is
refused with the known keys listed.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core import validation
from ..core.arrays import as_matrix, frozen
from ..core.exceptions import ConfigError, FileFormatError, ShapeError, StructureError
from ..core.fileio import check_keys, fields_of, load_yaml, read_array, read_number, read_positive, require
from .sensor import c_bar_from_c, c_from_c_bar

#: The keys of a sensor file and of its sections (any other is refused).
SENSOR_FILE_KEYS = ("name", "strain_unit", "full_scale", "rate_hz", "simulation")
FULL_SCALE_KEYS = ("force", "moment")
SIMULATION_KEYS = ("C", "C_bar", "D", "noise_std", "null_coupling", "null_offset", "drift_rate", "adc")
ADC_KEYS = ("bits", "gain", "reference")


@dataclass(frozen=True)
class SimulationSpec:
    """The true model of a simulated sensor (the ``simulation`` section of a sensor file).

    :class:`fts_calib.sim.sensor.SimulatedSensor` turns it into strains; planning uses its
    C_bar, D and noise as the nominal sensor of the excitation report.

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
        for name, shape in (("C_bar", (6, 6)), ("D", (6,)), ("null_coupling", (2, 6)), ("null_offset", (2,))):
            object.__setattr__(self, name, frozen(validation.finite_array(name, as_matrix(getattr(self, name), shape, name))))
        for name in ("noise_std", "drift_rate"):  # one number for every bridge, or one per bridge
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape not in ((), (8,)):
                raise ShapeError(f"{name}.shape={value.shape} but expected () or (8,)")
            object.__setattr__(self, name, frozen(validation.finite_array(name, np.broadcast_to(value, (8,)))))
        if np.any(self.noise_std < 0):
            raise ConfigError("noise_std", self.noise_std.tolist(), "values >= 0")
        bits = validation.number("adc_bits", self.adc_bits)
        if not (bits.is_integer() and (bits == 0 or 8 <= bits <= 32)):
            raise ConfigError("adc_bits", self.adc_bits, "0 (off) or an integer from 8 to 32")
        object.__setattr__(self, "adc_bits", int(bits))
        object.__setattr__(self, "adc_full_scale", validation.positive("adc_full_scale", self.adc_full_scale))

    @property
    def C(self) -> np.ndarray:
        """True calibration matrix ``C_bar @ P``, shape (6, 8)."""
        return c_from_c_bar(self.C_bar)

    @property
    def lsb(self) -> float:
        """Quantization step of the ADC in raw strain units (0 when quantization is off)."""
        return 2.0 * self.adc_full_scale / 2**self.adc_bits if self.adc_bits else 0.0


@dataclass(frozen=True)
class SensorSpec:
    """What the software needs to know of the sensor.

    Attributes:
        name: Sensor name.
        strain_unit: Unit of the raw strains (text, e.g. 'mV/V').
        full_scale: Full scale per wrench axis, [N, N, N, N m, N m, N m]. Shape (6,).
        rate_hz: Strain sample rate in [Hz].
        simulated: The true model of the simulated sensor, or None.
    """

    name: str
    strain_unit: str
    full_scale: np.ndarray
    rate_hz: float
    simulated: SimulationSpec | None = None

    def __post_init__(self):
        full_scale = as_matrix(self.full_scale, (6,), "full_scale")
        if not np.all(np.isfinite(full_scale) & (full_scale > 0)):
            raise ConfigError("full_scale", full_scale.tolist(), "finite values > 0", owner=f"sensor '{self.name}'")
        object.__setattr__(self, "full_scale", frozen(full_scale))
        object.__setattr__(self, "rate_hz", validation.positive("rate_hz", self.rate_hz, "Hz", f"sensor '{self.name}'"))


def _per_bridge(value, path: Path, field: str) -> np.ndarray:
    """One number for every bridge, or a list of 8; SimulationSpec checks the values."""
    if isinstance(value, list):
        if len(value) != 8:
            raise FileFormatError(path, field, f"expected one number or 8, got {value!r}")
        return read_array(value, (8,), path, field)
    return np.array(read_number(value, path, field))


def _read_simulation(raw, path: Path) -> SimulationSpec:
    if not isinstance(raw, dict):
        raise FileFormatError(path, "simulation", "expected a mapping")
    check_keys(raw, SIMULATION_KEYS, path, "simulation")
    if "C_bar" in raw:
        C_bar = read_array(raw["C_bar"], (6, 6), path, "simulation.C_bar")
    else:
        C = read_array(require(raw, "C", path, "simulation."), (6, 8), path, "simulation.C")
        try:
            C_bar = c_bar_from_c(C)
        except StructureError as exc:
            raise FileFormatError(path, "simulation.C", str(exc)) from None
    adc = raw.get("adc") or {}
    if not isinstance(adc, dict):
        raise FileFormatError(path, "simulation.adc", "expected {bits, gain, reference}")
    check_keys(adc, ADC_KEYS, path, "simulation.adc")
    bits = read_number(adc.get("bits", 0), path, "simulation.adc.bits")
    if not bits.is_integer():  # the type of the field; its range is SimulationSpec's to check
        raise FileFormatError(path, "simulation.adc.bits", f"is {bits} but expected an integer number of bits")
    # reference and gain are no fields of SimulationSpec (it holds their ratio): checked here
    full_scale = read_positive(adc.get("reference", 1000.0), path, "simulation.adc.reference") / read_positive(
        adc.get("gain", 128.0), path, "simulation.adc.gain"
    )
    with fields_of(path, "simulation.", {"adc_bits": "adc.bits", "adc_full_scale": "adc"}):
        return SimulationSpec(
            C_bar=C_bar,
            D=read_array(raw.get("D", [0.0] * 6), (6,), path, "simulation.D"),
            noise_std=_per_bridge(raw.get("noise_std", 0.0), path, "simulation.noise_std"),
            null_coupling=read_array(raw.get("null_coupling", [[0.0] * 6] * 2), (2, 6), path, "simulation.null_coupling"),
            null_offset=read_array(raw.get("null_offset", [0.0, 0.0]), (2,), path, "simulation.null_offset"),
            drift_rate=_per_bridge(raw.get("drift_rate", 0.0), path, "simulation.drift_rate"),
            adc_bits=int(bits),
            adc_full_scale=full_scale,
        )


def load_sensor_config(path: str | Path) -> SensorSpec:
    """Read a sensor configuration file (see the module docstring).

    Raises:
        FileFormatError: A missing, unknown or malformed field; the message names file and field.
    """
    path = Path(path)
    data = load_yaml(path)
    check_keys(data, SENSOR_FILE_KEYS, path)
    full = data.get("full_scale") or {}
    if not isinstance(full, dict):
        raise FileFormatError(path, "full_scale", "expected {force: N, moment: N·m}")
    check_keys(full, FULL_SCALE_KEYS, path, "full_scale")
    # force and moment fill the six entries of SensorSpec.full_scale: checked here, by their names
    force = read_positive(full.get("force", 50.0), path, "full_scale.force")
    moment = read_positive(full.get("moment", 5.0), path, "full_scale.moment")
    simulated = _read_simulation(data["simulation"], path) if data.get("simulation") is not None else None
    name = str(require(data, "name", path))
    rate_hz = read_number(data.get("rate_hz", 1000.0), path, "rate_hz", "Hz")
    with fields_of(path):
        return SensorSpec(
            name=name,
            strain_unit=str(data.get("strain_unit", "raw")),
            full_scale=np.array([force] * 3 + [moment] * 3),
            rate_hz=rate_hz,
            simulated=simulated,
        )

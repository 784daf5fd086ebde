"""The sensor configuration file (``configs/sensor.yaml``): specification and simulated truth.

Fields: ``name``; ``strain_unit`` (text); optional ``channels``, the channel layout
(:mod:`fts_calib.model.channels`: ``maltese-cross-8``, the default, the paper's 8 bridges;
``wrench-6``, a factory-calibrated sensor whose channels are a wrench; or
``{projection: 6 x n rows}``); ``full_scale`` ``{force [N], moment [N m]}`` (the paper's
sensor: 50 N and 5 N m), used to express errors in % of full scale; ``rate_hz`` (strain
sample rate); optional ``simulation``, the true model of the simulated sensor: ``C``
(6 x n, must be of the form C_bar P) or ``C_bar`` (6x6), ``D`` (6), ``noise_std`` (one
number or n, raw units), ``null_coupling`` ((n - 6) x 6), ``null_offset`` (n - 6),
``drift_rate`` (one number or n, raw units per s) and ``adc`` ``{bits, gain, reference}``
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
from ..core.resources import locate
from .channels import MALTESE_CROSS_8, ChannelLayout, channel_layout

#: The keys of a sensor file and of its sections (any other is refused).
#: Full scale per wrench axis when a sensor file gives none, [N, N, N, N m, N m, N m] (the paper's nominal range).
DEFAULT_FULL_SCALE = (50.0, 50.0, 50.0, 5.0, 5.0, 5.0)

SENSOR_FILE_KEYS = ("name", "strain_unit", "channels", "full_scale", "rate_hz", "simulation")
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
        noise_std: White noise standard deviation per channel, raw units. Shape (n,) (one
            number is every channel's).
        null_coupling: Strain in the n - 6 null patterns of P (``layout.null_basis``) per
            unit wrench. Shape (n - 6, 6); an empty array for none.
        null_offset: Constant strain in the null patterns. Shape (n - 6,); empty for none.
        drift_rate: Offset drift of each channel, raw units per second. Shape (n,) (one
            number is every channel's).
        adc_bits: ADC resolution; 0 disables quantization.
        adc_full_scale: Largest strain the ADC reads (reference / gain), raw units; beyond
            it readings saturate.
        layout: The sensor's channel layout (n channels); the paper's 8 bridges by default.
    """

    C_bar: np.ndarray
    D: np.ndarray = field(default_factory=lambda: np.zeros(6))
    noise_std: np.ndarray = field(default_factory=lambda: np.zeros(()))
    null_coupling: np.ndarray = field(default_factory=lambda: np.zeros(0))
    null_offset: np.ndarray = field(default_factory=lambda: np.zeros(0))
    drift_rate: np.ndarray = field(default_factory=lambda: np.zeros(()))
    adc_bits: int = 0
    adc_full_scale: float = 1000.0 / 128.0
    layout: ChannelLayout = MALTESE_CROSS_8

    def __post_init__(self):
        layout = channel_layout(self.layout)
        object.__setattr__(self, "layout", layout)
        n, n_null = layout.n_channels, layout.n_channels - 6
        for name, shape in (("C_bar", (6, 6)), ("D", (6,)), ("null_coupling", (n_null, 6)), ("null_offset", (n_null,))):
            value = getattr(self, name)
            if name.startswith("null_") and np.size(value) == 0:  # empty: no content in the null patterns
                value = np.zeros(shape)
            object.__setattr__(self, name, frozen(validation.finite_array(name, as_matrix(value, shape, name))))
        for name in ("noise_std", "drift_rate"):  # one number for every channel, or one per channel
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape not in ((), (n,)):
                raise ShapeError(f"{name}.shape={value.shape} but expected () or ({n},), one per channel of the {layout.name} layout")
            object.__setattr__(self, name, frozen(validation.finite_array(name, np.broadcast_to(value, (n,)))))
        if np.any(self.noise_std < 0):
            raise ConfigError("noise_std", self.noise_std.tolist(), "values >= 0")
        bits = validation.number("adc_bits", self.adc_bits)
        if not (bits.is_integer() and (bits == 0 or 8 <= bits <= 32)):
            raise ConfigError("adc_bits", self.adc_bits, "0 (off) or an integer from 8 to 32")
        object.__setattr__(self, "adc_bits", int(bits))
        object.__setattr__(self, "adc_full_scale", validation.positive("adc_full_scale", self.adc_full_scale))

    @property
    def C(self) -> np.ndarray:
        """True calibration matrix ``C_bar @ P``, shape (6, n)."""
        return self.layout.c_from_c_bar(self.C_bar)

    @property
    def lsb(self) -> float:
        """Quantization step of the ADC in raw strain units (0 when quantization is off)."""
        return 2.0 * self.adc_full_scale / 2**self.adc_bits if self.adc_bits else 0.0


@dataclass(frozen=True)
class SensorSpec:
    """What the software needs to know of the sensor.

    Attributes:
        name: Sensor name.
        strain_unit: Unit of the raw strains (text, e.g. 'mV/V'; 'N, N·m' for a wrench).
        full_scale: Full scale per wrench axis, [N, N, N, N m, N m, N m]. Shape (6,).
        rate_hz: Strain sample rate in [Hz].
        simulated: The true model of the simulated sensor, or None; of the same layout.
        layout: The channel layout; the paper's 8 bridges by default.
    """

    name: str
    strain_unit: str
    full_scale: np.ndarray
    rate_hz: float
    simulated: SimulationSpec | None = None
    layout: ChannelLayout = MALTESE_CROSS_8

    def __post_init__(self):
        object.__setattr__(self, "layout", channel_layout(self.layout))
        if self.simulated is not None and self.simulated.layout != self.layout:
            raise ConfigError(
                "channels",
                self.layout.name,
                f"the layout of the simulation section ({self.simulated.layout.name})",
                owner=f"sensor '{self.name}'",
            )
        full_scale = as_matrix(self.full_scale, (6,), "full_scale")
        if not np.all(np.isfinite(full_scale) & (full_scale > 0)):
            raise ConfigError("full_scale", full_scale.tolist(), "finite values > 0", owner=f"sensor '{self.name}'")
        object.__setattr__(self, "full_scale", frozen(full_scale))
        object.__setattr__(self, "rate_hz", validation.positive("rate_hz", self.rate_hz, "Hz", f"sensor '{self.name}'"))


def _per_channel(value, path: Path, field: str, n: int) -> np.ndarray:
    """One number for every channel, or a list of n; SimulationSpec checks the values."""
    if isinstance(value, list):
        if len(value) != n:
            raise FileFormatError(path, field, f"expected one number or {n} (one per channel), got {value!r}")
        return read_array(value, (n,), path, field)
    return np.array(read_number(value, path, field))


def _read_simulation(raw, path: Path, layout: ChannelLayout) -> SimulationSpec:
    if not isinstance(raw, dict):
        raise FileFormatError(path, "simulation", "expected a mapping")
    check_keys(raw, SIMULATION_KEYS, path, "simulation")
    if "C_bar" in raw:
        C_bar = read_array(raw["C_bar"], (6, 6), path, "simulation.C_bar")
    else:
        C = read_array(require(raw, "C", path, "simulation."), (6, layout.n_channels), path, "simulation.C")
        try:
            C_bar = layout.c_bar_from_c(C)
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
    n, n_null = layout.n_channels, layout.n_channels - 6
    with fields_of(path, "simulation.", {"adc_bits": "adc.bits", "adc_full_scale": "adc"}):
        return SimulationSpec(
            C_bar=C_bar,
            D=read_array(raw.get("D", [0.0] * 6), (6,), path, "simulation.D"),
            noise_std=_per_channel(raw.get("noise_std", 0.0), path, "simulation.noise_std", n),
            null_coupling=read_array(raw.get("null_coupling", np.zeros((n_null, 6))), (n_null, 6), path, "simulation.null_coupling"),
            null_offset=read_array(raw.get("null_offset", [0.0] * n_null), (n_null,), path, "simulation.null_offset"),
            drift_rate=_per_channel(raw.get("drift_rate", 0.0), path, "simulation.drift_rate", n),
            adc_bits=int(bits),
            adc_full_scale=full_scale,
            layout=layout,
        )


def load_sensor_config(path: str | Path) -> SensorSpec:
    """Read a sensor configuration file (see the module docstring).

    Args:
        path: The YAML file, or the name of a shipped one (``"sensor"``: the paper's sensor,
            ``"factory_sensor"``: a 6-axis wrench), as ``--sensor`` on the command line.

    Raises:
        ResourceNotFound: A bare name that is neither a file nor shipped (lists them).
        FileFormatError: A missing, unknown or malformed field; the message names file and field.
    """
    path = locate(path, "configs", "sensor")
    data = load_yaml(path)
    check_keys(data, SENSOR_FILE_KEYS, path)
    full = data.get("full_scale") or {}
    if not isinstance(full, dict):
        raise FileFormatError(path, "full_scale", "expected {force: N, moment: N·m}")
    check_keys(full, FULL_SCALE_KEYS, path, "full_scale")
    # force and moment fill the six entries of SensorSpec.full_scale: checked here, by their names
    force = read_positive(full.get("force", DEFAULT_FULL_SCALE[0]), path, "full_scale.force")
    moment = read_positive(full.get("moment", DEFAULT_FULL_SCALE[3]), path, "full_scale.moment")
    with fields_of(path, names={"projection": "channels.projection"}):
        layout = channel_layout(data.get("channels"))
    simulated = _read_simulation(data["simulation"], path, layout) if data.get("simulation") is not None else None
    name = str(require(data, "name", path))
    rate_hz = read_number(data.get("rate_hz", 1000.0), path, "rate_hz", "Hz")
    with fields_of(path):
        return SensorSpec(
            name=name,
            strain_unit=str(data.get("strain_unit", "raw")),
            full_scale=np.array([force] * 3 + [moment] * 3),
            rate_hz=rate_hz,
            simulated=simulated,
            layout=layout,
        )

"""The sensor configuration file (``configs/sensor.yaml``): specification and simulated truth.

Fields: ``name``; ``strain_unit`` (text); optional ``channels``, the channel layout
(:mod:`fts_calib.model.channels`: ``maltese-cross-8``, the default, the paper's 8 bridges;
``wrench-6``, a factory-calibrated sensor whose channels are a wrench;
``{projection: 6 x n rows}``; or ``full``: the paper's 8 channels without a projection, a
free 6 x 8 C); optional ``model``, the sensor model (``auto``, the default: chosen by
held-out error; ``linear``, ``quadratic`` or ``cubic``: :mod:`fts_calib.model.features`);
``full_scale`` ``{force [N], moment [N m]}`` (the paper's sensor: 50 N and 5 N m), used to
express errors in % of full scale; ``rate_hz`` (strain sample rate); optional ``simulation``, the true model of the simulated sensor: ``C``
(6 x n, must be of the form C_bar P) or ``C_bar`` (6x6), ``D`` (6), ``noise_std`` (one
number or n, raw units), ``null_coupling`` ((n - 6) x 6), ``null_offset`` (n - 6),
``drift_rate`` (one number or n, raw units per s), ``adc`` ``{bits, gain, reference}``
(full scale of the ADC = reference / gain, in raw units: codes from -full scale in steps of
2 full scale / 2^bits) or ``{bits, range: [low, high]}`` (codes from low to high in steps
of (high - low) / (2^bits - 1): ``{bits: 10, range: [0, 1023]}`` reads integer counts),
``channel_offset`` (one number or n, raw units: the reading at zero load, e.g. mid-range
of an unsigned ADC) and ``nonlinearity`` ``{quadratic, cubic, odd}`` (each a fraction of full
scale at full load, see :class:`SimulationSpec`). An unknown key (a typo) is refused with
the known keys listed.

What the channels can read (:mod:`fts_calib.model.channel_limits`), all optional:
``resolution`` (one number or n, raw units: the step of an ADC's counts), ``range``
(``[low, high]`` for every channel, or n of them: the lowest and highest reading, its
rails) and ``adc_bits`` (with ``range``: the resolution is (high - low) / (2^bits - 1)).
What is not declared is detected from the data.

How well the sensor repeats, optional: ``repeatability`` ``{force [N], moment [N m]}``, the
standard deviation of the scatter of its reading of one load from one still pose to another
(hysteresis, creep), beyond the noise within a pose; the fit check expects it in the residual
and the accuracy budget holds it (:attr:`SensorSpec.repeatability`). Absent: 0 (the sensor
repeats to within its noise).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core import arrays as validation
from ..core.arrays import as_matrix, frozen
from ..core.exceptions import ConfigError, FileFormatError, ShapeError, StructureError
from ..core.files import check_keys, fields_of, load_yaml, read_array, read_number, read_positive, require
from ..core.resources import locate
from .channel_limits import ChannelLimits
from .channels import MALTESE_CROSS_8, ChannelLayout, channel_layout
from .features import AUTO_MODEL, model_setting

#: The keys of a sensor file and of its sections (any other is refused).
SENSOR_FILE_KEYS = (
    "name",
    "strain_unit",
    "channels",
    "model",
    "full_scale",
    "rate_hz",
    "resolution",
    "range",
    "adc_bits",
    "repeatability",
    "simulation",
)
FULL_SCALE_KEYS = ("force", "moment")
REPEATABILITY_KEYS = ("force", "moment")
SIMULATION_KEYS = (
    "C",
    "C_bar",
    "D",
    "noise_std",
    "null_coupling",
    "null_offset",
    "drift_rate",
    "adc",
    "channel_offset",
    "nonlinearity",
)
ADC_KEYS = ("bits", "gain", "reference", "range")
NONLINEARITY_KEYS = ("quadratic", "cubic", "odd")
#: The paper's full scale, [N, N, N, N m, N m, N m]: the default of a sensor file's.
DEFAULT_FULL_SCALE = (50.0, 50.0, 50.0, 5.0, 5.0, 5.0)


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
        adc_range: ``(low, high)``, the lowest and highest code of the ADC in raw units
            (codes ``low + k (high - low) / (2^bits - 1)``), or None for the symmetric range
            of ``adc_full_scale``.
        channel_offset: Reading of each channel at zero load, raw units. Shape (n,) (one
            number is every channel's).
        quadratic: Quadratic nonlinearity, a fraction of full scale at full load: each axis
            reads ``W_i + quadratic FS_i (W_i / FS_i)^2`` (0.03: 3 % of full scale at full load).
        cubic: Cubic nonlinearity, the same with ``(W_i / FS_i)^3``.
        odd: A bend odd in the load, the same with ``|W_i / FS_i| (W_i / FS_i)``: no polynomial of
            the channels represents it (a sensor whose two load directions bend alike, outwards).
        full_scale: Full scale per axis the nonlinearity is relative to, [N, N, N, N m, N m,
            N m]. Shape (6,) (the sensor file's ``full_scale``).
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
    adc_range: tuple[float, float] | None = None
    channel_offset: np.ndarray = field(default_factory=lambda: np.zeros(()))
    quadratic: float = 0.0
    cubic: float = 0.0
    odd: float = 0.0
    full_scale: np.ndarray = field(default_factory=lambda: np.array(DEFAULT_FULL_SCALE))
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
        for name in ("noise_std", "drift_rate", "channel_offset"):  # one number for every channel, or one per channel
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
        if self.adc_range is not None:
            low, high = (validation.number(f"adc_range[{k}]", v) for k, v in enumerate(as_matrix(self.adc_range, (2,), "adc_range")))
            if not (math.isfinite(low) and math.isfinite(high) and low < high):
                raise ConfigError("adc_range", [low, high], "[low, high] with low < high, finite")
            object.__setattr__(self, "adc_range", (low, high))
        for name in NONLINEARITY_KEYS:
            object.__setattr__(self, name, validation.number(name, getattr(self, name)))  # either sign: the direction of the bend
        full_scale = as_matrix(self.full_scale, (6,), "full_scale")
        if not np.all(np.isfinite(full_scale) & (full_scale > 0)):
            raise ConfigError("full_scale", full_scale.tolist(), "finite values > 0")
        object.__setattr__(self, "full_scale", frozen(full_scale))

    @property
    def C(self) -> np.ndarray:
        """True calibration matrix ``C_bar @ P``, shape (6, n)."""
        return self.layout.c_from_c_bar(self.C_bar)

    @property
    def D_readings(self) -> np.ndarray:
        """The offsets of the readings, ``D - C channel_offset`` (what a calibration of them finds), shape (6,)."""
        return self.D - self.C @ self.channel_offset

    @property
    def lsb(self) -> float:
        """Quantization step of the ADC in raw strain units (0 when quantization is off)."""
        if not self.adc_bits:
            return 0.0
        if self.adc_range is not None:
            return (self.adc_range[1] - self.adc_range[0]) / (2**self.adc_bits - 1)
        return 2.0 * self.adc_full_scale / 2**self.adc_bits

    @property
    def adc_codes(self) -> tuple[float, float]:
        """The lowest and highest code of the ADC in raw units (its rails); ``(-inf, inf)`` without one."""
        if not self.adc_bits:
            return (-math.inf, math.inf)
        if self.adc_range is not None:
            return self.adc_range
        return (-self.adc_full_scale, self.adc_full_scale - self.lsb)

    @property
    def limits(self) -> ChannelLimits:
        """What the simulated channels can read: the ADC's step and its rails."""
        low, high = self.adc_codes
        n = self.layout.n_channels
        return ChannelLimits(np.full(n, self.lsb), np.full(n, low), np.full(n, high))


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
        limits: The declared resolution and range of the channels
            (:mod:`fts_calib.model.channel_limits`), or None when nothing is declared (then
            detected from the data).
        model: The sensor model setting: 'auto' (chosen by held-out error), 'linear',
            'quadratic' or 'cubic' (:mod:`fts_calib.model.features`).
        full_channels: The model reads the raw channels (a free 6 x n C) instead of ``P Delta``.
        repeatability: Standard deviation of the scatter of the reading of one load from one still
            pose to another, beyond the noise within a pose (hysteresis, creep), per axis,
            [N, N, N, N m, N m, N m], shape (6,); None when not declared (the sensor repeats).
    """

    name: str
    strain_unit: str
    full_scale: np.ndarray
    rate_hz: float
    simulated: SimulationSpec | None = None
    layout: ChannelLayout = MALTESE_CROSS_8
    limits: ChannelLimits | None = None
    model: str = AUTO_MODEL
    full_channels: bool = False
    repeatability: np.ndarray | None = None

    def __post_init__(self):
        object.__setattr__(self, "layout", channel_layout(self.layout))
        if self.repeatability is not None:
            repeatability = as_matrix(self.repeatability, (6,), "repeatability")
            if not np.all(np.isfinite(repeatability) & (repeatability >= 0)):
                raise ConfigError("repeatability", repeatability.tolist(), "finite values >= 0", owner=f"sensor '{self.name}'")
            object.__setattr__(self, "repeatability", frozen(repeatability))
        object.__setattr__(self, "model", model_setting(self.model))
        object.__setattr__(self, "full_channels", bool(self.full_channels))
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
        if self.limits is not None and self.limits.n_channels != self.layout.n_channels:
            raise ShapeError(f"limits of {self.limits.n_channels} channels but the {self.layout.name} layout has {self.layout.n_channels}")

    @property
    def channel_limits(self) -> ChannelLimits:
        """The declared limits, or limits with nothing known (no resolution, no rails)."""
        return self.limits if self.limits is not None else ChannelLimits.none(self.layout.n_channels)


def _per_channel(value, path: Path, field: str, n: int) -> np.ndarray:
    """One number for every channel, or a list of n; SimulationSpec checks the values."""
    if isinstance(value, list):
        if len(value) != n:
            raise FileFormatError(path, field, f"expected one number or {n} (one per channel), got {value!r}")
        return read_array(value, (n,), path, field)
    return np.array(read_number(value, path, field))


def _read_limits(data: dict, path: Path, n: int) -> ChannelLimits | None:
    """The declared ``resolution``, ``range`` and ``adc_bits`` of a sensor file, or None when none is."""
    if not any(key in data for key in ("resolution", "range", "adc_bits")):
        return None
    low, high = np.full(n, -np.inf), np.full(n, np.inf)
    given = data.get("range")
    if given is not None:
        pairs = np.asarray(given, dtype=object)
        if pairs.shape == (2,):
            low[:], high[:] = read_array(given, (2,), path, "range")
        else:
            both = read_array(given, (n, 2), path, "range")
            low, high = both[:, 0].copy(), both[:, 1].copy()
        bad = [k for k in range(n) if not low[k] < high[k]]
        if bad:
            k = bad[0]
            raise FileFormatError(path, "range", f"channel {k + 1}: [{low[k]:g}, {high[k]:g}] but expected [low, high] with low < high")
    resolution = np.zeros(n)
    if "resolution" in data and "adc_bits" in data:
        raise FileFormatError(path, "adc_bits", "give either resolution or adc_bits with range, not both")
    if "resolution" in data:
        resolution = np.broadcast_to(_per_channel(data["resolution"], path, "resolution", n), (n,)).copy()
        if np.any(~np.isfinite(resolution) | (resolution < 0)):
            raise FileFormatError(path, "resolution", f"is {resolution.tolist()} but expected values >= 0 (raw units; 0: not quantized)")
    if "adc_bits" in data:
        bits = read_number(data["adc_bits"], path, "adc_bits")
        if not (bits.is_integer() and 1 <= bits <= 32):
            raise FileFormatError(path, "adc_bits", f"is {bits:g} but expected an integer number of bits from 1 to 32")
        if given is None:
            raise FileFormatError(path, "range", "missing: adc_bits needs the range of the codes, e.g. range: [0, 1023] for 10-bit counts")
        resolution = (high - low) / (2 ** int(bits) - 1)
    return ChannelLimits(resolution, low, high)


def _read_simulation(raw, path: Path, layout: ChannelLayout, sensor_full_scale: np.ndarray) -> SimulationSpec:
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
        raise FileFormatError(path, "simulation.adc", "expected {bits, gain, reference} or {bits, range: [low, high]}")
    check_keys(adc, ADC_KEYS, path, "simulation.adc")
    bits = read_number(adc.get("bits", 0), path, "simulation.adc.bits")
    if not bits.is_integer():  # the type of the field; its range is SimulationSpec's to check
        raise FileFormatError(path, "simulation.adc.bits", f"is {bits} but expected an integer number of bits")
    if "range" in adc and ("gain" in adc or "reference" in adc):
        raise FileFormatError(path, "simulation.adc", "give either range or gain and reference, not both")
    adc_range = tuple(read_array(adc["range"], (2,), path, "simulation.adc.range")) if "range" in adc else None
    # reference and gain are no fields of SimulationSpec (it holds their ratio): checked here
    full_scale = read_positive(adc.get("reference", 1000.0), path, "simulation.adc.reference") / read_positive(
        adc.get("gain", 128.0), path, "simulation.adc.gain"
    )
    nonlinearity = raw.get("nonlinearity") or {}
    if not isinstance(nonlinearity, dict):
        expected = "expected {quadratic: fraction, cubic: fraction, odd: fraction} of full scale at full load"
        raise FileFormatError(path, "simulation.nonlinearity", expected)
    check_keys(nonlinearity, NONLINEARITY_KEYS, path, "simulation.nonlinearity")
    n, n_null = layout.n_channels, layout.n_channels - 6
    names = {"adc_bits": "adc.bits", "adc_full_scale": "adc", "adc_range": "adc.range"}
    with fields_of(path, "simulation.", {**names, **{k: f"nonlinearity.{k}" for k in NONLINEARITY_KEYS}}):
        return SimulationSpec(
            C_bar=C_bar,
            D=read_array(raw.get("D", [0.0] * 6), (6,), path, "simulation.D"),
            noise_std=_per_channel(raw.get("noise_std", 0.0), path, "simulation.noise_std", n),
            null_coupling=read_array(raw.get("null_coupling", np.zeros((n_null, 6))), (n_null, 6), path, "simulation.null_coupling"),
            null_offset=read_array(raw.get("null_offset", [0.0] * n_null), (n_null,), path, "simulation.null_offset"),
            drift_rate=_per_channel(raw.get("drift_rate", 0.0), path, "simulation.drift_rate", n),
            adc_bits=int(bits),
            adc_full_scale=full_scale,
            adc_range=adc_range,
            channel_offset=_per_channel(raw.get("channel_offset", 0.0), path, "simulation.channel_offset", n),
            quadratic=read_number(nonlinearity.get("quadratic", 0.0), path, "simulation.nonlinearity.quadratic"),
            cubic=read_number(nonlinearity.get("cubic", 0.0), path, "simulation.nonlinearity.cubic"),
            odd=read_number(nonlinearity.get("odd", 0.0), path, "simulation.nonlinearity.odd"),
            full_scale=sensor_full_scale,
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
    full_channels = data.get("channels") == "full"
    with fields_of(path, names={"projection": "channels.projection"}):
        layout = channel_layout(None if full_channels else data.get("channels"), also=("full",))
    full_scale = np.array([force] * 3 + [moment] * 3)
    simulated = _read_simulation(data["simulation"], path, layout, full_scale) if data.get("simulation") is not None else None
    limits = _read_limits(data, path, layout.n_channels)
    repeatability = None
    if data.get("repeatability") is not None:
        raw = data["repeatability"]
        if not isinstance(raw, dict):
            raise FileFormatError(path, "repeatability", "expected {force: N, moment: N·m}")
        check_keys(raw, REPEATABILITY_KEYS, path, "repeatability")
        parts = [read_number(raw.get(k, 0.0), path, f"repeatability.{k}", u) for k, u in (("force", "N"), ("moment", "N·m"))]
        for k, v in zip(REPEATABILITY_KEYS, parts, strict=True):
            if not v >= 0:
                raise FileFormatError(path, f"repeatability.{k}", f"is {v:g} but expected a value >= 0")
        repeatability = np.array([parts[0]] * 3 + [parts[1]] * 3)
    name = str(require(data, "name", path))
    rate_hz = read_number(data.get("rate_hz", 1000.0), path, "rate_hz", "Hz")
    with fields_of(path):
        return SensorSpec(
            name=name,
            strain_unit=str(data.get("strain_unit", "raw")),
            full_scale=full_scale,
            rate_hz=rate_hz,
            simulated=simulated,
            layout=layout,
            limits=limits,
            model=str(data.get("model", AUTO_MODEL)),
            full_channels=full_channels,
            repeatability=repeatability,
        )

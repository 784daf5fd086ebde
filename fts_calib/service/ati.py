"""ATI calibration files (``FTxxxxx.cal``, XML): the factory calibration in, ours out in the same structure.

The structure (as ATI ships it, and as public parsers read it): a root ``<FTSensor Serial
BodyStyle Family NumGages CalFileVersion>`` holding one ``<Calibration PartNumber CalDate
ForceUnits TorqueUnits DistUnits ...>``, which holds six ``<Axis>`` elements (a scaled
matrix for ATI's internal use), a ``<BasicTransform Dx Dy Dz Rx Ry Rz/>`` and six
``<UserAxis Name="Fx|Fy|Fz|Tx|Ty|Tz" values="NumGages numbers" max="..."/>``. The file's own
comment says to build the calibration matrix from the ``UserAxis`` rows: each row maps the
gauge voltages to one axis, in ``ForceUnits`` (N, kN, lbf, klbf, kgf) or ``TorqueUnits``
(N-m, N-mm, N-cm, kN-m, lbf-in, lbf-ft, kgf-cm, kgf-m) per volt; the tool transform is
already in them. Read with the standard library's expat parser (which gives line numbers).

The import is a calibration of layout ``projection`` whose P is the factory matrix in SI
(6 x NumGages: [N, N, N, N m, N m, N m] per V), with ``C_bar = I`` and ``D = 0``: ``C = P``.
A recording of the raw gauge voltages (``strain_1..strain_n``) calibrated with
``--sensor FT.cal`` then finds C_bar, the correction of the factory matrix, and the
factory file itself is the reference that ``validate`` compares against and the prior that
``--prior`` shrinks toward (C_bar = I). The export writes any calibration's C as
``UserAxis`` rows in N and N-m, with ``max`` the sensor's full scale; the offsets D have no
place in ATI's format (a DAQ tares them) and are written in a comment.
"""

from __future__ import annotations

import xml.parsers.expat
from dataclasses import dataclass
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from .._version import __version__
from ..core.arrays import frozen
from ..core.bounded import MAX_CHANNELS, read_bounded
from ..core.exceptions import ConfigError, FileFormatError
from ..model.calibration import Calibration, load_calibration
from ..model.channels import WRENCH_AXES, ChannelLayout
from ..model.sensor_config import SensorSpec

#: The suffix of an ATI calibration file.
SUFFIX = ".cal"
#: The UserAxis names, in wrench order.
AXIS_NAMES = ("Fx", "Fy", "Fz", "Tx", "Ty", "Tz")
#: Force units of ATI files, in [N].
FORCE_UNITS = {"n": 1.0, "kn": 1e3, "lbf": 4.4482216152605, "klbf": 4448.2216152605, "kgf": 9.80665}
#: Torque units of ATI files, in [N m].
TORQUE_UNITS = {
    "n-m": 1.0,
    "n-mm": 1e-3,
    "n-cm": 1e-2,
    "kn-m": 1e3,
    "lbf-in": 4.4482216152605 * 0.0254,
    "lbf-ft": 4.4482216152605 * 0.3048,
    "kgf-cm": 9.80665e-2,
    "kgf-m": 9.80665,
}


@dataclass(frozen=True)
class AtiCalibration:
    """An ATI calibration file, in SI.

    Attributes:
        path: The file.
        serial: The sensor's serial number (``FTSensor Serial``).
        body_style: Its model (``BodyStyle``, e.g. 'Mini45').
        matrix: The UserAxis matrix, [N or N m per V]. Shape (6, n), n gauges.
        max: Rated range per axis, [N, N, N, N m, N m, N m]. Shape (6,).
        force_units: The file's ForceUnits.
        torque_units: The file's TorqueUnits.
    """

    path: Path
    serial: str
    body_style: str
    matrix: np.ndarray
    max: np.ndarray
    force_units: str
    torque_units: str

    def __post_init__(self):
        object.__setattr__(self, "matrix", frozen(self.matrix))
        object.__setattr__(self, "max", frozen(self.max))

    @property
    def layout(self) -> ChannelLayout:
        """The layout ``projection`` with P = the factory matrix (6 x n gauges)."""
        return ChannelLayout("projection", self.matrix)

    def calibration(self) -> Calibration:
        """The factory calibration: layout P = the factory matrix, C_bar = I, D = 0 (so C = P)."""
        provenance = {
            "method": "ATI factory calibration (UserAxis matrix)",
            "source": str(self.path),
            "sensor": {"serial": self.serial, "body_style": self.body_style},
            "units_in_file": {"force": self.force_units, "torque": self.torque_units},
        }
        return Calibration(C_bar=np.eye(6), D=np.zeros(6), provenance=provenance, layout=self.layout)

    def sensor_spec(self, rate_hz: float = 1000.0) -> SensorSpec:
        """The sensor configuration it describes: its layout, full scale ``max``, gauges in V."""
        return SensorSpec(f"ATI {self.body_style} {self.serial}".strip(), "V", self.max, rate_hz, layout=self.layout)


def _elements(path: Path) -> list[tuple[str, dict[str, str], int]]:
    """(tag, attributes, line) of every element, in document order."""
    found: list[tuple[str, dict[str, str], int]] = []
    parser = xml.parsers.expat.ParserCreate()
    parser.StartElementHandler = lambda tag, attrs: found.append((tag, dict(attrs), parser.CurrentLineNumber))
    data = read_bounded(path, "ATI calibration (XML)")
    try:
        parser.Parse(data, True)
    except xml.parsers.expat.ExpatError as exc:
        message = f"line {exc.lineno}, column {exc.offset + 1}: not valid XML ({xml.parsers.expat.ErrorString(exc.code)})"
        raise FileFormatError(path, None, message + ": expected an ATI calibration file (<FTSensor><Calibration>...)") from None
    return found


def _unit(table: dict[str, float], value: str | None, path: Path, field: str) -> float:
    if value is None or value.strip().lower() not in table:
        raise FileFormatError(path, field, f"is {value!r} but expected one of {', '.join(table)} (case does not matter)")
    return table[value.strip().lower()]


def load_ati_calibration(path: str | Path) -> AtiCalibration:
    """Read an ATI calibration file (see the module docstring).

    Raises:
        FileFormatError: Not XML, no FTSensor/Calibration, a UserAxis missing, repeated or
            with another number of values than NumGages, an unknown unit; the message
            names the file, the element and its line.
    """
    path = Path(path)
    elements = _elements(path)
    if not elements or elements[0][0] != "FTSensor":
        root = elements[0][0] if elements else "nothing"
        raise FileFormatError(path, None, f"the root element is <{root}> but expected <FTSensor>: not an ATI calibration file")
    sensor = elements[0][1]
    calibrations = [e for e in elements if e[0] == "Calibration"]
    if len(calibrations) != 1:
        raise FileFormatError(path, "Calibration", f"{len(calibrations)} <Calibration> elements but expected one")
    cal, cal_line = calibrations[0][1], calibrations[0][2]
    force = _unit(FORCE_UNITS, cal.get("ForceUnits"), path, "Calibration.ForceUnits")
    torque = _unit(TORQUE_UNITS, cal.get("TorqueUnits"), path, "Calibration.TorqueUnits")
    axes: dict[str, tuple[list[float], float, int]] = {}
    for tag, attrs, line in elements:
        if tag != "UserAxis":
            continue
        name = attrs.get("Name")
        if name not in AXIS_NAMES:
            raise FileFormatError(path, "UserAxis.Name", f"line {line}: is {name!r} but expected one of {', '.join(AXIS_NAMES)}")
        if name in axes:
            raise FileFormatError(path, f"UserAxis[{name}]", f"line {line}: repeated (first on line {axes[name][2]})")
        try:
            values = [float(v) for v in (attrs.get("values") or "").split()]
            rated = float(attrs.get("max", "nan"))
        except ValueError:
            raise FileFormatError(path, f"UserAxis[{name}]", f"line {line}: values and max must be numbers") from None
        axes[name] = (values, rated, line)
    missing = [a for a in AXIS_NAMES if a not in axes]
    if missing:
        hint = " (the file has only <Axis> rows, ATI's internal scaled matrix: ask ATI for a file with UserAxis)" if not axes else ""
        raise FileFormatError(
            path, f"UserAxis[{missing[0]}]", f"missing: expected UserAxis {', '.join(missing)} in <Calibration> (line {cal_line}){hint}"
        )
    n = len(axes["Fx"][0])
    gauges = sensor.get("NumGages")
    if gauges is not None and gauges.strip().isdigit():
        n = int(gauges) if len(gauges.strip()) <= 9 else MAX_CHANNELS + 1  # int() of 5,000 digits raises
    width = max(n, *(len(axes[a][0]) for a in AXIS_NAMES))
    if width > MAX_CHANNELS:  # before any matrix work (an SVD grows with the cube of n)
        raise FileFormatError(
            path, "UserAxis.values", f"{width:,} gauges but fts-calib reads at most {MAX_CHANNELS}: not a sensor's calibration"
        )
    for name in AXIS_NAMES:
        values, _, line = axes[name]
        if len(values) != n:
            raise FileFormatError(path, f"UserAxis[{name}].values", f"line {line}: {len(values)} numbers but NumGages is {n}")
    scale = np.array([force] * 3 + [torque] * 3)
    matrix = np.array([axes[a][0] for a in AXIS_NAMES]) * scale[:, None]
    rated = np.array([axes[a][1] for a in AXIS_NAMES]) * scale
    if not np.all(np.isfinite(matrix)):
        k = int(np.argmin(np.all(np.isfinite(matrix), axis=1)))
        raise FileFormatError(path, f"UserAxis[{AXIS_NAMES[k]}].values", f"line {axes[AXIS_NAMES[k]][2]}: a value is not finite")
    try:
        ChannelLayout("projection", matrix)  # the factory matrix becomes P: of full row rank
    except ConfigError as exc:
        raise FileFormatError(path, "UserAxis", f"the matrix {exc.reason}") from None
    if not np.all(np.isfinite(rated) & (rated > 0)):
        k = int(np.argmin(np.where(np.isfinite(rated), rated, -np.inf)))
        raise FileFormatError(path, f"UserAxis[{AXIS_NAMES[k]}].max", f"line {axes[AXIS_NAMES[k]][2]}: expected a rated range > 0")
    return AtiCalibration(
        path=path,
        serial=sensor.get("Serial", ""),
        body_style=sensor.get("BodyStyle", ""),
        matrix=matrix,
        max=rated,
        force_units=cal["ForceUnits"],
        torque_units=cal["TorqueUnits"],
    )


def read_calibration(path: str | Path) -> Calibration:
    """A calibration from an fts-calib YAML file or an ATI ``.cal`` file (by its suffix).

    Raises:
        FileFormatError: The file is malformed (see :func:`load_ati_calibration` and
            :func:`fts_calib.model.calibration.load_calibration`).
    """
    path = Path(path)
    if path.suffix.lower() == SUFFIX:
        return load_ati_calibration(path).calibration()
    return load_calibration(path)


def ati_text(calibration: Calibration, full_scale, serial: str = "", body_style: str = "") -> str:
    """A calibration in the structure of an ATI calibration file (see the module docstring).

    Args:
        calibration: Any calibration: its C (6 x n) becomes the UserAxis rows, in N and N-m
            per raw channel unit.
        full_scale: The sensor's range per axis, [N, N, N, N m, N m, N m] (``max``). Shape (6,).
        serial: ``FTSensor Serial``.
        body_style: ``FTSensor BodyStyle``.
    """
    calibration.require_linear("the ATI export (its UserAxis rows)")
    full_scale = np.asarray(full_scale, dtype=float).reshape(6)
    n = calibration.layout.n_channels
    offsets = ", ".join(f"{a} {float(d)!r}" for a, d in zip(WRENCH_AXES, calibration.D, strict=True))
    prov = calibration.provenance
    lines = [
        '<?xml version="1.0" encoding="utf-8"?>',
        f"<!-- Written by fts-calib {__version__}: an in-situ calibration ({prov.get('method', 'unknown method')},",
        f"     {prov.get('time', 'time unknown')}) in the structure of an ATI calibration file. The UserAxis rows are",
        f"     C, forces in N and torques in N-m per raw channel unit ({n} channels, {calibration.layout.name} layout).",
        f"     Offsets D, not part of this format (tare them): {offsets} (N, N-m). -->",
        f'<FTSensor Serial={quoteattr(serial)} BodyStyle={quoteattr(body_style)} NumGages="{n}" CalFileVersion="1.1">',
        '  <Calibration ForceUnits="N" TorqueUnits="N-m" DistUnits="m">',
        '    <BasicTransform Dx="0" Dy="0" Dz="0" Rx="0" Ry="0" Rz="0"/>',
    ]
    for name, row, rated in zip(AXIS_NAMES, calibration.C, full_scale, strict=True):
        values = " ".join(repr(float(v)) for v in row)
        lines.append(f'    <UserAxis Name="{name}" values="{values}" max="{float(rated)!r}"/>')
    lines += ["  </Calibration>", "</FTSensor>", ""]
    return "\n".join(lines)

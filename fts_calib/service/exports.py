"""Export a calibration for firmware and other software: a C header, JSON, ROS 2 parameters.

- ``c-header``: C (6 x n, n channels of the calibration's layout) and D (6) as arrays, and an inline function computing
  ``wrench = C strain + D``, as the paper's STM32 does. A nonlinear model (quadratic, cubic, or
  a free C over the raw channels) gets its polynomial instead: ``u = P strain`` (or the
  channels), the features ``phi`` built as Python builds them (each a product of a lower one and
  one entry of u, :mod:`fts_calib.model.features`), and ``wrench = Theta phi + D``. ``float`` by default (a Cortex-M4
  has a single-precision FPU); define ``FTS_CALIB_DOUBLE`` before including it for double.
  With a ``health`` section, a separate section adds the parity check (:func:`parity_section`).
  Values are printed as Python repr (shortest, round-trips a double; in float mode
  the compiler rounds them).
- ``json``: C, C_bar, D, units, quality and provenance.
- ``ros2``: the parameters of ros2_controllers' ``force_torque_sensor_broadcaster`` (its
  ``offset`` and ``multiplier``) with control_toolbox's gravity compensation filter for
  the payload the sensor carries (:mod:`fts_calib.service.ros2`).
- ``ati``: C as the UserAxis rows of an ATI calibration file (:mod:`fts_calib.service.ati`).

Angles and units as everywhere in fts-calib: N, N m, m; strains raw.
"""

from __future__ import annotations

import json
import re

from ..core.exceptions import ConfigError
from ..core.files import to_plain
from ..model.calibration import FORMAT, Calibration
from ..model.features import SensorModel, monomials
from ..model.parity import ParityModel
from ..robot.tool import STANDARD_GRAVITY, ToolConfiguration
from .ati import ati_text
from .ros2 import ros2_parameters

#: The formats :func:`export` writes.
FORMATS = ("c-header", "json", "ros2", "ati")


def _identifier(name: str) -> str:
    text = re.sub(r"[^0-9A-Za-z_]", "_", name).upper().strip("_") or "FTS_CALIB"
    return "_" + text if text[0].isdigit() else text


def c_header(calibration: Calibration, name: str = "fts_calib") -> str:
    """A C header with the calibration (see the module docstring).

    Args:
        calibration: The calibration.
        name: Prefix of the identifiers and of the include guard (letters, digits, '_').
    """
    prefix = _identifier(name)
    lower = prefix.lower()
    if calibration.model is not None:
        return _polynomial_header(calibration, calibration.model, prefix)
    C_rows = _rows(calibration.C, prefix)
    D_values = ", ".join(f"{prefix}_R({float(v)!r})" for v in calibration.D)
    prov = calibration.provenance
    n = calibration.layout.n_channels
    lines = [
        f"/* {lower}.h: force/torque sensor calibration written by fts-calib {prov.get('software_version', '')}".rstrip() + ".",
        " * wrench = C * strain + D, wrench = [Fx Fy Fz] in N and [Mx My Mz] in N*m, in the sensor frame;",
        f" * strain = the {n} raw channels ({calibration.layout.name} layout), in the unit used during calibration.",
        f" * method: {prov.get('method', 'unknown')}; time: {prov.get('time', 'unknown')}. */",
        *_guard_and_real(prefix),
        f"/* C: rows Fx Fy Fz (N per strain unit), Mx My Mz (N*m per strain unit); columns strain 1..{n} */",
        f"static const {lower}_real {prefix}_C[6][{n}] = {{",
        C_rows,
        "};",
        "",
        "/* D: offsets [Fx Fy Fz Mx My Mz] in N and N*m */",
        f"static const {lower}_real {prefix}_D[6] = {{{D_values}}};",
        "",
        f"/* wrench[6] = C * strain[{n}] + D */",
        f"static inline void {lower}_wrench(const {lower}_real strain[{n}], {lower}_real wrench[6])",
        "{",
        "    for (int i = 0; i < 6; ++i) {",
        f"        {lower}_real sum = {prefix}_D[i];",
        f"        for (int k = 0; k < {n}; ++k) sum += {prefix}_C[i][k] * strain[k];",
        "        wrench[i] = sum;",
        "    }",
        "}",
        "",
        *parity_section(calibration, prefix),
        f"#endif /* {prefix}_H */",
        "",
    ]
    return "\n".join(lines)


def _guard_and_real(prefix: str) -> list[str]:
    """The header's include guard and its real type: float, or double with ``FTS_CALIB_DOUBLE``."""
    lower = prefix.lower()
    return [
        f"#ifndef {prefix}_H",
        f"#define {prefix}_H",
        "",
        "#ifdef FTS_CALIB_DOUBLE",
        f"typedef double {lower}_real;",
        f"#define {prefix}_R(x) x",
        "#else",
        f"typedef float {lower}_real;",
        f"#define {prefix}_R(x) x##f",
        "#endif",
        "",
    ]


def _rows(matrix, prefix: str) -> str:
    """A C initializer of a matrix's rows, each value as ``PREFIX_R(repr)``."""
    return ",\n".join("    {" + ", ".join(f"{prefix}_R({float(v)!r})" for v in row) + "}" for row in matrix)


def _polynomial_header(calibration: Calibration, model: SensorModel, prefix: str) -> str:
    """The C header of a nonlinear model: its inputs, features and coefficients, and the evaluator."""
    lower = prefix.lower()
    n, d, p = model.n_channels, model.inputs, len(model.names)
    first, last = _factors(d, model.degree)
    prov = calibration.provenance
    inputs = f"u = P * strain, the {calibration.layout.name} layout's 6 combinations" if not model.full else "u = strain (no projection)"
    lines = [
        f"/* {lower}.h: force/torque sensor calibration written by fts-calib {prov.get('software_version', '')}".rstrip() + ".",
        f" * A {model.family} model: wrench = THETA * phi(u) + D, {inputs};",
        f" * phi = the {p} monomials of u up to degree {model.degree} ({', '.join(model.names[: min(p, d + 2)])}, ...), each",
        " * the product of an earlier feature and one entry of u. wrench = [Fx Fy Fz] in N and [Mx My Mz] in N*m,",
        f" * in the sensor frame; strain = the {n} raw channels, in the unit used during calibration.",
        f" * method: {prov.get('method', 'unknown')}; time: {prov.get('time', 'unknown')}. */",
        *_guard_and_real(prefix),
    ]
    if not model.full:
        lines += ["/* P: the layout's projection, u = P * strain */", f"static const {lower}_real {prefix}_P[6][{n}] = {{"]
        lines += [_rows(model.projection, prefix), "};", ""]
    lines += [
        f"/* feature f >= {d} is phi[{prefix}_FIRST[f - {d}]] * u[{prefix}_LAST[f - {d}]] */",
        f"static const unsigned short {prefix}_FIRST[{p - d}] = {{{', '.join(map(str, first))}}};",
        f"static const unsigned char {prefix}_LAST[{p - d}] = {{{', '.join(map(str, last))}}};",
        "",
        f"/* THETA: rows Fx Fy Fz (N per feature unit), Mx My Mz (N*m per feature unit); columns the {p} features */",
        f"static const {lower}_real {prefix}_THETA[6][{p}] = {{",
        _rows(model.coefficients, prefix),
        "};",
        "",
        "/* D: offsets [Fx Fy Fz Mx My Mz] in N and N*m */",
        f"static const {lower}_real {prefix}_D[6] = {{{', '.join(f'{prefix}_R({float(v)!r})' for v in calibration.D)}}};",
        "",
        f"/* wrench[6] = THETA * phi(u(strain[{n}])) + D */",
        f"static inline void {lower}_wrench(const {lower}_real strain[{n}], {lower}_real wrench[6])",
        "{",
        f"    {lower}_real phi[{p}];",
        f"    for (int i = 0; i < {d}; ++i) {{",
    ]
    if model.full:
        lines.append("        phi[i] = strain[i];")
    else:
        lines += [
            f"        {lower}_real sum = {prefix}_R(0.0);",
            f"        for (int k = 0; k < {n}; ++k) sum += {prefix}_P[i][k] * strain[k];",
            "        phi[i] = sum;",
        ]
    lines += [
        "    }",
        f"    for (int f = {d}; f < {p}; ++f) phi[f] = phi[{prefix}_FIRST[f - {d}]] * phi[{prefix}_LAST[f - {d}]];",
        "    for (int i = 0; i < 6; ++i) {",
        f"        {lower}_real sum = {prefix}_D[i];",
        f"        for (int f = 0; f < {p}; ++f) sum += {prefix}_THETA[i][f] * phi[f];",
        "        wrench[i] = sum;",
        "    }",
        "}",
        "",
        *parity_section(calibration, prefix),
        f"#endif /* {prefix}_H */",
        "",
    ]
    return "\n".join(lines)


def _factors(d: int, degree: int) -> tuple[list[int], list[int]]:
    """For each feature above degree 1: the index of the lower feature and of the entry of u it is multiplied by."""
    terms = monomials(d, degree)
    where = {m: i for i, m in enumerate(terms)}
    higher = [m for m in terms if len(m) > 1]
    return [where[m[:-1]] for m in higher], [m[-1] for m in higher]


def parity_section(calibration: Calibration, prefix: str) -> list[str]:
    """The parity check of the C header (:meth:`fts_calib.model.parity.ParityModel.check`); none without a health section.

    ``PREFIX_parity(strain, baseline, residual)`` writes the whitened parity residual
    ``e = L (N strain - c) - baseline`` (m values of unit variance per healthy sample) and
    returns 1 when ``e . e`` exceeds ``PREFIX_PARITY_THRESHOLD`` (the chi-square(m) point of
    probability 1e-9 per sample). Allocation-free; ``baseline`` may be NULL (zeros).

    Args:
        calibration: The calibration (its ``health`` section).
        prefix: The identifiers' prefix (upper case).
    """
    if calibration.health is None:
        return []
    parity = ParityModel.from_dict(calibration.health)
    lower, m, n = prefix.lower(), parity.n_parity, parity.n_channels
    L = parity.whitening
    rows = ",\n".join("    {" + ", ".join(f"{prefix}_R({float(v)!r})" for v in row) + "}" for row in L @ parity.N)
    offset = ", ".join(f"{prefix}_R({float(v)!r})" for v in L @ parity.c)
    return [
        "/* health: the parity check (docs/health.md). e = L (N strain - c) - baseline has unit variance per",
        " * healthy sample; its offset moves like the wrench offsets (track it as baseline, slowly, while no fault). */",
        f"#define {prefix}_N_PARITY {m}",
        f"#define {prefix}_PARITY_THRESHOLD {prefix}_R({parity.sample_threshold!r})",
        f"static const {lower}_real {prefix}_PARITY_N[{m}][{n}] = {{",
        rows,
        "};",
        f"static const {lower}_real {prefix}_PARITY_C[{m}] = {{{offset}}};",
        "",
        f"/* residual[{m}] = L (N strain[{n}] - c) - baseline[{m}] (baseline may be NULL); returns 1 on a fault */",
        f"static inline int {lower}_parity(const {lower}_real strain[{n}], const {lower}_real *baseline, {lower}_real residual[{m}])",
        "{",
        f"    {lower}_real sum2 = 0;",
        f"    for (int i = 0; i < {m}; ++i) {{",
        f"        {lower}_real e = -{prefix}_PARITY_C[i];",
        f"        for (int k = 0; k < {n}; ++k) e += {prefix}_PARITY_N[i][k] * strain[k];",
        "        if (baseline) e -= baseline[i];",
        "        residual[i] = e;",
        "        sum2 += e * e;",
        "    }",
        f"    return sum2 > {prefix}_PARITY_THRESHOLD;",
        "}",
        "",
    ]


def json_text(calibration: Calibration) -> str:
    """The calibration as JSON (format, units, C, C_bar, D, quality, provenance)."""
    q = calibration.quality
    data = {
        "format": FORMAT,
        "units": {"wrench": ["N", "N", "N", "N·m", "N·m", "N·m"], "strain": "raw channel reading"},
        "channels": calibration.layout.to_config(),
        "C": calibration.C,
        "C_bar": calibration.C_bar,
        "D": calibration.D,
        "model": "linear" if calibration.model is None else calibration.model.to_config(),
        **({"model_selection": dict(calibration.model_selection)} if calibration.model_selection is not None else {}),
        "quality": None
        if q is None
        else {
            "rank": q.rank,
            "condition_number": q.condition_number,
            "samples_used": q.samples_used,
            "residual_rms": q.residual_rms,
            "stderr_C": q.stderr_C,
            "stderr_D": q.stderr_D,
        },
        "provenance": dict(calibration.provenance),
        "offset_history": list(calibration.offset_history),
    }
    return json.dumps(to_plain(data), indent=2, ensure_ascii=False) + "\n"


def export(
    calibration: Calibration,
    fmt: str,
    payload: ToolConfiguration | None = None,
    gravity: float = STANDARD_GRAVITY,
    name: str = "fts_calib",
    sensor_frame: str = "ft_sensor",
    world_frame: str = "world",
    full_scale=None,
) -> str:
    """The text of an export in one of :data:`FORMATS`.

    Args:
        calibration: The calibration.
        fmt: One of :data:`FORMATS`.
        payload: The payload to compensate (ros2).
        gravity: Magnitude of gravity [m/s^2] (ros2).
        name: Prefix of the C identifiers (c-header).
        sensor_frame: TF frame of the sensor (ros2).
        world_frame: TF frame whose z axis points up (ros2).
        full_scale: The sensor's range per axis, [N, N, N, N m, N m, N m], shape (6,) (ati).

    Raises:
        ConfigError: Unknown format, ``ros2`` without a payload or ``ati`` without a full scale.
    """
    if fmt == "c-header":
        return c_header(calibration, name)
    if fmt == "json":
        return json_text(calibration)
    if fmt == "ros2":
        if payload is None:
            message = "the ros2 export describes the payload to compensate: give its tool file (--payload)"
            raise ConfigError("payload", None, "the payload's tool configuration", message=message)
        return ros2_parameters(calibration, payload, gravity, sensor_frame, world_frame)
    if fmt == "ati":
        if full_scale is None:
            raise ConfigError("full_scale", None, "the sensor's range per axis (the UserAxis max): give its --sensor")
        return ati_text(calibration, full_scale)
    raise ConfigError("format", fmt, f"one of {', '.join(FORMATS)}")

"""The ``export`` command: a calibration as a C header, JSON or ros2_control parameters (broadcaster and gravity compensation)."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

from ..core.exceptions import ConfigError
from ..core.files import STDOUT, atomic_write_text, check_outputs
from ..core.resources import resolve
from ..robot.tool import STANDARD_GRAVITY, load_tool
from ..service.ati import read_calibration
from ..service.exports import export
from .exit_codes import ExitCode, writing
from .options import EXPORT_FORMATS
from .setup import Setup


@dataclass(frozen=True)
class ExportNames:
    """The names an export gives: the C identifiers' prefix, the ROS 2 TF frames.

    Attributes:
        name: Prefix of the C identifiers (c-header).
        sensor_frame: TF frame of the sensor (ros2).
        world_frame: TF frame whose z axis points up (ros2).
    """

    name: str = "fts_calib"
    sensor_frame: str = "ft_sensor"
    world_frame: str = "world"


def export_format(output: str | Path, fmt: str | None) -> tuple[str, str]:
    """The export format: ``fmt`` when given, else the one the suffix of ``output`` names; with how it was chosen.

    Returns:
        The format, and '' when given or the words of the choice (e.g. 'from the suffix .h').

    Raises:
        ConfigError: No format given and a suffix that names none (standard output, ``.txt``):
            the message lists the suffixes and formats.
    """
    if fmt is not None:
        if fmt not in EXPORT_FORMATS:
            raise ConfigError("format", fmt, " or ".join(EXPORT_FORMATS))
        return fmt, ""
    suffix = Path(str(output)).suffix.lower() if str(output) != STDOUT else ""
    found = [name for name, suffixes in EXPORT_FORMATS.items() if suffix in suffixes]
    if not found:
        named = ", ".join(f"{' or '.join(suffixes)} for {name}" for name, suffixes in EXPORT_FORMATS.items())
        what = f"the suffix of -o {output}, '{suffix}'," if suffix else f"-o {output}"
        message = f"{what} names no export format: give --format ({', '.join(EXPORT_FORMATS)}) or a file name ending in {named}"
        raise ConfigError("format", None, "a format, or -o with its suffix", message=message)
    return found[0], f"from the suffix {suffix}"


def run(
    setup: Setup,
    names: ExportNames | None = None,
    *,
    calibration: str | Path,
    output: str | Path,
    fmt: str | None = None,
    payload: str | Path | None = None,
) -> int:
    """Write an export of a calibration (``fts-calib export``).

    Args:
        setup: The sensor file or ATI ``.cal`` (its full scale: ati's ``max``), and the
            configuration of ``payload`` (its first when None).
        names: The C identifiers' prefix and the ROS 2 frames.
        calibration: Calibration file (fts-calib YAML or an ATI ``.cal``).
        output: File to write; ``-`` for standard output (a device or FIFO is written in place).
        fmt: 'c-header' (C and D as arrays and an inline wrench function), 'json' (C, C_bar,
            D, quality, provenance), 'ros2' (force_torque_sensor_broadcaster's offset and
            multiplier, and control_toolbox's GravityCompensationWrench parameters for
            ``payload``: :mod:`fts_calib.service.ros2`) or 'ati'; None: the one the suffix of
            ``output`` names (.h, .json, .yaml or .yml, .cal), said when written.
        payload: Tool file of the payload (ros2): a shipped name or a YAML path; its gravity
            is the one exported.

    Returns:
        0.

    Raises:
        ConfigError: An unknown format, no format and a suffix that names none, ros2 without
            a payload, ati with a sensor of another number of channels than the calibration's,
            or ``output`` one of the inputs.
        OSError: ``output`` cannot be written (a folder); checked before anything is read.
    """
    names = names or ExportNames()
    fmt, chosen = export_format(output, fmt)
    sensor, configuration = setup.sensor_file, setup.configuration
    check_outputs({"-o": output}, {"the calibration": calibration, "the payload file": payload, "the sensor file": sensor})
    loaded = read_calibration(calibration)
    configuration_of_payload, gravity = None, STANDARD_GRAVITY
    if payload is not None:
        tool = load_tool(resolve(payload, "configs"))
        configuration_of_payload = tool.configuration(configuration) if configuration else tool.configurations[0]
        gravity = tool.gravity
    full_scale = None
    if fmt == "ati":
        spec = setup.sensor
        n, m = loaded.layout.n_channels, spec.layout.n_channels
        if n != m:  # the ati file's max would be another sensor's full scale
            message = (
                f"--calibration {calibration} has {n} channels ({loaded.layout.name}) but --sensor {sensor} has {m} "
                f"({spec.layout.name}): give the sensor of this calibration (its file or its ATI .cal; factory_sensor: a 6-axis wrench)"
            )
            raise ConfigError("sensor", str(sensor), f"a sensor of {n} channels", message=message)
        full_scale = spec.full_scale
    text = export(loaded, fmt, configuration_of_payload, gravity, names.name, names.sensor_frame, names.world_frame, full_scale)
    with writing(output):
        path = atomic_write_text(output, text)
    # on standard output the export is the output: the note goes to standard error
    how = f"{fmt}, {chosen}" if chosen else fmt
    print(f"wrote {'standard output' if str(output) == STDOUT else path} ({how})", file=sys.stderr if str(output) == STDOUT else sys.stdout)
    return ExitCode.OK

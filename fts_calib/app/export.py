"""The ``export`` command: a calibration as a C header, JSON or ros2_control parameters (broadcaster and gravity compensation)."""

from __future__ import annotations

import sys
from pathlib import Path

from ..core.exceptions import ConfigError
from ..core.files import STDOUT, atomic_write_text, check_outputs
from ..core.resources import resolve
from ..robot.tool import STANDARD_GRAVITY, load_tool
from ..service.ati import read_calibration
from ..service.exports import export
from .exit_codes import ExitCode, writing
from .setup import load_sensor


def run(
    *,
    fmt: str,
    calibration: str | Path,
    output: str | Path,
    name: str = "fts_calib",
    payload: str | Path | None = None,
    configuration: str | None = None,
    sensor_frame: str = "ft_sensor",
    world_frame: str = "world",
    sensor: str | Path = "sensor",
) -> int:
    """Write an export of a calibration (``fts-calib export``).

    Args:
        fmt: 'c-header' (C and D as arrays and an inline wrench function), 'json' (C, C_bar,
            D, quality, provenance) or 'ros2' (force_torque_sensor_broadcaster's offset and
            multiplier, and control_toolbox's GravityCompensationWrench parameters for
            ``payload``: :mod:`fts_calib.service.ros2`).
        calibration: Calibration file (fts-calib YAML or an ATI ``.cal``).
        output: File to write; ``-`` for standard output (a device or FIFO is written in place).
        name: Prefix of the C identifiers.
        payload: Tool file of the payload (ros2): a shipped name or a YAML path; its gravity
            is the one exported.
        configuration: Configuration of the payload's tool file; the first when None.
        sensor_frame: TF frame of the sensor (ros2).
        world_frame: TF frame whose z axis points up (ros2).
        sensor: Sensor configuration or ATI ``.cal`` file: its full scale (ati's ``max``).

    Returns:
        0.

    Raises:
        ConfigError: An unknown format, ros2 without a payload, ati with a sensor of
            another number of channels than the calibration's, or ``output`` one of the inputs.
        OSError: ``output`` cannot be written (a folder); checked before anything is read.
    """
    check_outputs({"-o": output}, {"the calibration": calibration, "the payload file": payload, "the sensor file": sensor})
    loaded = read_calibration(calibration)
    configuration_of_payload, gravity = None, STANDARD_GRAVITY
    if payload is not None:
        tool = load_tool(resolve(payload, "configs"))
        configuration_of_payload = tool.configuration(configuration) if configuration else tool.configurations[0]
        gravity = tool.gravity
    full_scale = None
    if fmt == "ati":
        spec = load_sensor(sensor)
        n, m = loaded.layout.n_channels, spec.layout.n_channels
        if n != m:  # the ati file's max would be another sensor's full scale
            message = (
                f"--calibration {calibration} has {n} channels ({loaded.layout.name}) but --sensor {sensor} has {m} "
                f"({spec.layout.name}): give the sensor of this calibration (its file or its ATI .cal; factory_sensor: a 6-axis wrench)"
            )
            raise ConfigError("sensor", str(sensor), f"a sensor of {n} channels", message=message)
        full_scale = spec.full_scale
    text = export(loaded, fmt, configuration_of_payload, gravity, name, sensor_frame, world_frame, full_scale)
    with writing(output):
        path = atomic_write_text(output, text)
    # on standard output the export is the output: the note goes to standard error
    print(f"wrote {'standard output' if str(output) == STDOUT else path} ({fmt})", file=sys.stderr if str(output) == STDOUT else sys.stdout)
    return ExitCode.OK

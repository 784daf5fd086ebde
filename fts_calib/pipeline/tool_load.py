"""A calibration tool whose weight the sensor cannot carry: a mass in grams, or another sensor's full scale.

A mass written in g instead of kg scales every known wrench by 1000, and with it C and D:
the data still fit the model exactly, so no fit check can see it. What can: the tool hangs
on the sensor during the calibration, so its weight lies within the sensor's range. Far
beyond it (:data:`MAX_LOAD_RATIO` times the full scale) the tool file or the sensor file is
wrong, and the calibration is refused before any sample is read.
"""

from __future__ import annotations

import numpy as np

from ..core.exceptions import ConfigError
from ..robot.tool import STANDARD_GRAVITY, Tool

#: How far beyond the sensor's force full scale a tool's weight may be before it is refused: a
#: calibration load stays within the range (a 2.5 kg tool is 0.5 of a 50 N sensor's); ten times
#: it is no tool that sensor carries, while grams for kilograms make it a thousand times.
MAX_LOAD_RATIO = 10.0


def check_tool_load(tool: Tool, full_scale: np.ndarray) -> None:
    """Refuse a tool configuration whose weight is far beyond the sensor's force full scale.

    Args:
        tool: The calibration tool.
        full_scale: The sensor's full scale per wrench axis [N, N, N, N m, N m, N m]. Shape (6,).

    Raises:
        ConfigError: A configuration weighs more than :data:`MAX_LOAD_RATIO` times the largest
            force full scale; the message names it, its weight and what to check.
    """
    force = float(np.max(full_scale[:3]))
    for k, configuration in enumerate(tool.configurations):
        # [N] on Earth: the mass alone is judged here (a gravity in cm/s² is the fit check's to name)
        weight = configuration.mass * STANDARD_GRAVITY
        if weight > MAX_LOAD_RATIO * force:
            message = (
                f"tool '{tool.name}', configuration {configuration.name}: mass {configuration.mass:g} kg weighs about {weight:,.0f} N, "
                f"{weight / force:,.0f} times the sensor's full scale of {force:g} N: a calibration tool hangs on the sensor, "
                "so the mass is in another unit than kg (grams?) or the sensor is not the one given (--sensor, its full_scale)"
            )
            raise ConfigError(f"configurations[{k}].mass", configuration.mass, "a weight within the sensor's range", message=message)

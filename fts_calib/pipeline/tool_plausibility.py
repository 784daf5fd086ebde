"""The values of a tool file that no residual shows: the magnitude of gravity and the size of the centres of mass.

Two mistakes of a tool file scale C without leaving a residual (a wrong gravity scales every
wrench; a uniform scale of every centre of mass scales the moment rows), so the fit check
(:mod:`fts_calib.pipeline.fit`) judges their values instead: a centre of mass beyond
:data:`MAX_COM_M` (mm or cm written for m) and a gravity outside :data:`GRAVITY_RANGE`.
"""

from __future__ import annotations

import math

import numpy as np

from ..robot.tool import Tool

#: Largest plausible distance of a calibration tool's centre of mass from the sensor, in [m].
MAX_COM_M = 1.0
#: Smallest distance a unit correction may bring it to, in [m] (below, the unit is not guessed).
MIN_COM_M = 0.005
#: A typical calibration tool's centre of mass distance, in [m]: picks mm or cm when both are plausible.
TYPICAL_COM_M = 0.1
#: The range accepted for the magnitude of gravity, in [m/s^2] (9.78 to 9.83 on Earth's surface).
GRAVITY_RANGE = (9.7, 9.9)


def implausible_gravity(tool: Tool) -> str:
    """Why the tool file's gravity cannot be the Earth's, or ''.

    A wrong magnitude of gravity scales every wrench, so C absorbs it and the residuals do not
    show it; only its value does. On Earth it is 9.78 to 9.83 m/s^2.

    Args:
        tool: The tool file (its ``gravity`` in [m/s^2]).

    Returns:
        The reason in words, naming a likely unit (cm/s^2, g), or '' when plausible.
    """
    low, high = GRAVITY_RANGE
    if low <= tool.gravity <= high:
        return ""
    unit = (
        " (it looks like cm/s^2)" if low <= tool.gravity / 100 <= high else " (it looks like g, not m/s^2)" if tool.gravity == 1.0 else ""
    )
    return f"the tool file's gravity is {tool.gravity:g} m/s^2, expected {low:g} to {high:g} m/s^2 on Earth{unit}"


def implausible_geometry(tool: Tool) -> str:
    """Why the tool file's centres of mass cannot be a calibration tool's, or ''.

    Scaling every centre of mass by the same factor scales the moment rows of C and fits the
    data as well: the mistake shows only in the size. A centre of mass beyond
    :data:`MAX_COM_M` is taken for mm or cm when that unit brings it to a plausible size.

    Args:
        tool: The tool file (its configurations' centres of mass in S, in [m], shape (3,) each).

    Returns:
        The reason in words, naming the likely unit and its factor, or '' when plausible.
    """
    largest = max(float(np.linalg.norm(c.p_sensor_com)) for c in tool.configurations)
    if largest <= MAX_COM_M:
        return ""
    plausible = [(unit, f) for unit, f in (("mm", 1e-3), ("cm", 1e-2)) if MIN_COM_M <= largest * f <= MAX_COM_M]
    if plausible:  # the unit that brings it nearest a typical tool's 0.1 m (log scale)
        unit, factor = min(plausible, key=lambda u: abs(math.log(largest * u[1] / TYPICAL_COM_M)))
        return (
            f"the centres of mass of the tool file are in {unit}, not m: the largest is {largest:g} m from the sensor "
            f"(divide them by {1 / factor:g})"
        )
    return f"the tool file's largest centre of mass is {largest:g} m from the sensor: expected at most {MAX_COM_M:g} m"


def implausible_tool(tool: Tool) -> str:
    """Why the tool file's gravity or centres of mass cannot be right, or '' (gravity first).

    Args:
        tool: The tool file (gravity in [m/s^2], centres of mass in [m]).

    Returns:
        :func:`implausible_gravity`, else :func:`implausible_geometry`.
    """
    return implausible_gravity(tool) or implausible_geometry(tool)

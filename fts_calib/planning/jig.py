"""Which tool configurations determine a sensor model: the check of a tool file, and a jig that would.

A quadratic or cubic sensor model is determined beyond the loads of a calibration only when the
loads come from enough masses at enough centres of mass (:mod:`fts_calib.model.determination`: a
quadratic model two masses, each at five centres of mass not in one plane; the paper's jig, one
mass at three, determines the linear model only). :func:`check_jig` judges a tool file's
configurations over gravity from every direction (what a plan of ``fts-calib trajectory`` gives);
:func:`suggest_jig` extends them to a jig that determines the family, sized to the sensor's full
scale: the centres of mass the tool has, mirrored and turned about the tool axis, and a second
weight whose loads reach about 85 % of the full scale.

Units: masses in [kg], centres of mass in [m] in the sensor frame, full scale in [N, N m].
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..model.determination import Determination, determine, jig_sums
from ..model.features import degree_of
from ..robot.tool import Tool, ToolConfiguration

#: Gravity directions (unit vectors) of the check: a Fibonacci sphere, what a plan's sweeps cover.
CHECK_DIRECTIONS = 60
#: The heavier weight's loads reach this fraction of the full scale (force or moment, whichever first).
FULL_SCALE_FRACTION = 0.85
#: Centres of mass a suggestion tries at most.
MAX_CENTRES = 12


def sphere_directions(n: int = CHECK_DIRECTIONS) -> np.ndarray:
    """``n`` unit vectors spread evenly over the sphere (Fibonacci lattice), shape (n, 3)."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    phi = np.pi * (1.0 + 5**0.5) * k
    r = np.sqrt(1.0 - z**2)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def check_jig(tool: Tool, family: str, per_configuration: bool = False, directions: np.ndarray | None = None) -> Determination:
    """What the tool's configurations determine of ``family``.

    Args:
        tool: The tool file.
        family: 'linear', 'quadratic' or 'cubic'.
        per_configuration: One offset per configuration (else one for all).
        directions: Gravity in the sensor frame where each configuration is seen still (a plan's
            stops; any length), shape (n, 3); every direction (:func:`sphere_directions`) when None.
    """
    seen = sphere_directions() if directions is None else np.asarray(directions, dtype=float).reshape(-1, 3)
    seen = seen / np.maximum(np.linalg.norm(seen, axis=1, keepdims=True), 1e-300)
    degree = degree_of(family)
    loads = {k: jig_sums([c.mass], np.array([c.p_sensor_com]), seen, degree, tool.gravity)[0] for k, c in enumerate(tool.configurations)}
    return determine(loads, family, per_configuration)


def _centre_candidates(coms: list[np.ndarray]) -> list[np.ndarray]:
    """Centres of mass to add, in order: each off-axis one mirrored and turned by 90° about the tool axis (x of S), then nearer."""
    out = []
    for c in coms:
        x, y, z = c
        if abs(y) + abs(z) > 0:
            out += [np.array([x, -y, -z]), np.array([x, -z, y]), np.array([x, z, -y])]
    for c in coms:
        out.append(np.array([0.7 * c[0], 0.7 * c[1] + 0.5 * c[2], 0.7 * c[2] - 0.5 * c[1]]))
    return out


def _second_mass(mass: float, coms: np.ndarray, gravity: float, full_scale: np.ndarray) -> float:
    """A second weight [kg]: its loads at :data:`FULL_SCALE_FRACTION` of the full scale, or half the first when that is not heavier."""
    lever = max(float(np.max(np.linalg.norm(coms, axis=1))), 1e-3)
    cap = FULL_SCALE_FRACTION * min(float(np.min(full_scale[:3])) / gravity, float(np.min(full_scale[3:])) / (gravity * lever))
    heavier = round(cap, 1)
    return heavier if heavier >= 1.3 * mass else round(0.5 * mass, 2)


def suggest_jig(tool: Tool, family: str, full_scale) -> Tool:
    """A jig that determines ``family``: the tool's configurations, more centres of mass, and a second weight if it has one mass.

    Args:
        tool: The tool file (its configurations, gravity, shape and tolerance are kept).
        family: 'quadratic' or 'cubic'.
        full_scale: The sensor's full scale per axis [N, N m], shape (6,).

    Returns:
        The tool with the configurations to mount, named A, B, ... (the tool's own first, by
        their names); unchanged when it determines the family already.
    """
    if check_jig(tool, family).determined:
        return tool
    full_scale = np.asarray(full_scale, dtype=float)
    coms = [np.asarray(c.p_sensor_com, dtype=float) for c in tool.configurations]
    unique: list[np.ndarray] = []
    for c in coms:
        if all(np.abs(c - u).max() > 1e-6 for u in unique):
            unique.append(c)
    masses = sorted({round(c.mass, 9) for c in tool.configurations})
    if len(masses) < 2:
        masses.append(_second_mass(masses[0], np.array(unique), tool.gravity, full_scale))
    candidates = _centre_candidates(unique)
    while True:
        configurations = _grid(tool, masses, unique)
        found = check_jig(dataclasses.replace(tool, configurations=tuple(configurations)), family)
        if found.determined or not candidates or len(unique) >= MAX_CENTRES:
            return dataclasses.replace(tool, name=f"{tool.name}: a jig for a {family} model", configurations=tuple(configurations))
        unique.append(candidates.pop(0))


def _grid(tool: Tool, masses: list[float], coms: list[np.ndarray]) -> list[ToolConfiguration]:
    """The tool's own configurations, then every other mass x centre of mass, named on from the tool's names."""
    out = list(tool.configurations)
    names = set(tool.names)
    letters = (chr(ord("A") + k) for k in range(26 * 4))
    for mass in masses:
        for com in coms:
            if any(abs(c.mass - mass) < 1e-9 and np.abs(c.p_sensor_com - com).max() < 1e-6 for c in out):
                continue
            name = next(n for n in letters if n not in names)
            names.add(name)
            nearest = min(tool.configurations, key=lambda c: float(np.linalg.norm(c.p_sensor_com - com)))
            inertia = None if nearest.inertia_com is None else nearest.inertia_com * (mass / nearest.mass)
            out.append(ToolConfiguration(name, float(mass), np.array(com, dtype=float), inertia))
    return out

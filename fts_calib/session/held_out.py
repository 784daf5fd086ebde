"""Held-out units of the kept samples: a tool load and an orientation cell.

The choice of the sensor model by held-out error (:mod:`fts_calib.model.model_choice`) leaves
one *unit* out at a time. A unit is held out only when no other unit holds the same load:
samples that share a tool configuration and see gravity from nearly the same direction in the
sensor frame carry the same known wrench, the same filter residue and the same systematic error
of that pose, so they form **one unit wherever they are in the run or the files**. A sweep
recorded twice, two files of one run, or a pose revisited an hour later add samples to the units
they already have, never new units: the held-out error of a model does not fall with repeats.

The orientation cell of gravity ``g`` (in the sensor frame) is a cell of the equal-angle cube
sphere: the face of the cube of ``g``'s largest component, and the angles
``atan(g_j / |g_i|)`` of its two others, each in [-45°, 45°], cut in :data:`CELLS_PER_EDGE` bins:
6 x 9 x 9 = 486 cells, none wider than :data:`CELL_DEG`. The cell is a fixed function of the
direction alone, so the same orientation falls into the same cell whatever came before, in any
batching. (A pose held on the edge of two cells would be split by its noise; with joint noise of
1e-5 rad that is one pose in 10,000.) The unit's index is ``configuration * N_CELLS + cell``.

Units: gravity in [m/s^2] (only its direction matters).
"""

from __future__ import annotations

import math

import numpy as np

#: A gap between kept samples longer than this separates two still stretches (the arm moved), [s].
UNIT_GAP_S = 0.5
#: Bins per edge of a cube face: cells of 90 / 9 = 10 degrees.
CELLS_PER_EDGE = 9
#: The widest angle a cell spans along a face's edge, [deg].
CELL_DEG = 90.0 / CELLS_PER_EDGE
#: Cells on the sphere (6 faces).
N_CELLS = 6 * CELLS_PER_EDGE * CELLS_PER_EDGE


def orientation_cells(g_sensor: np.ndarray) -> np.ndarray:
    """The cube-sphere cell of each gravity direction (see the module docstring).

    Args:
        g_sensor: Gravity in the sensor frame, [m/s^2] (any length but 0). Shape (N, 3).

    Returns:
        Cell indices in [0, :data:`N_CELLS`), shape (N,).
    """
    g = np.asarray(g_sensor, dtype=float).reshape(-1, 3)
    axis = np.argmax(np.abs(g), axis=1)
    rows = np.arange(len(g))
    major = np.abs(g[rows, axis])
    face = 2 * axis + (g[rows, axis] < 0)
    others = np.stack([g[rows, (axis + 1) % 3], g[rows, (axis + 2) % 3]], axis=1)
    angle = np.arctan2(others, np.maximum(major, 1e-300)[:, None])  # in [-pi/4, pi/4]
    bins = np.clip(np.floor((angle / (math.pi / 2) + 0.5) * CELLS_PER_EDGE), 0, CELLS_PER_EDGE - 1).astype(np.int64)
    return (face * CELLS_PER_EDGE + bins[:, 0]) * CELLS_PER_EDGE + bins[:, 1]


def held_out_units(configuration: np.ndarray, g_sensor: np.ndarray) -> np.ndarray:
    """The held-out unit of each sample: its tool configuration and orientation cell.

    Args:
        configuration: Tool configuration index per sample (>= 0), shape (N,).
        g_sensor: Gravity in the sensor frame [m/s^2], shape (N, 3).

    Returns:
        Shape (N,), integers ``configuration * N_CELLS + cell`` (:func:`orientation_cells`).
    """
    codes = np.asarray(configuration, dtype=np.int64).reshape(-1)
    return codes * N_CELLS + orientation_cells(g_sensor)

"""The one estimate of an identified payload, and its tool file.

Still poses (:mod:`fts_calib.payload.still`) and a continuous motion
(:mod:`fts_calib.payload.moving`) give the same record, :class:`PayloadEstimate`: the mass
[kg], the centre of mass in the sensor frame S [m] and the wrench offsets
[N, N, N, N m, N m, N m], each with its standard error. What only one of them gives is an
optional field: the orientations, their spread and a small mount rotation of the still poses;
the inertia about the centre of mass [kg m^2], the offsets' drift and the joint stream's
latency [s] of a motion. The identification (:func:`fts_calib.payload.identify.identify_payload`)
adds where the samples came from and, when it decided between still and moving, what it
decided and why.

:func:`save_payload` writes it as a tool file (:func:`fts_calib.robot.tool.save_tool`) with
the standard errors in its header: the one place a payload's tool file is written.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.arrays import frozen
from ..robot.tool import STANDARD_GRAVITY, Tool, ToolConfiguration, save_tool

#: The payload's parameters in the order of :attr:`PayloadEstimate.stderr`: mass, centre of mass, inertia about it.
NAMES = ("mass", "com x", "com y", "com z", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")
#: The (row, column) of each inertia element of :data:`NAMES`.
PAIRS = ((0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2))
#: The identification's kinds: still poses, or a continuous motion.
STILL, MOVING = "still", "moving"


@dataclass(frozen=True)
class PayloadEstimate:
    """An identified payload (see the module docstring).

    Attributes:
        mass: [kg].
        stderr_mass: [kg].
        com: Centre of mass in the sensor frame [m]. Shape (3,).
        stderr_com: [m]. Shape (3,).
        offsets: Wrench offsets [N, N, N, N m, N m, N m] (a motion's: at its middle when they
            drift). Shape (6,).
        stderr_offsets: Same units. Shape (6,).
        residual_rms: Per axis [N, N m]. Shape (6,).
        samples: Samples used.
        motion: ``still`` (still poses) or ``moving`` (a continuous motion).
        mount_rotation: Still poses: the small rotation of the sensor mount [rad], shape (3,), or None.
        stderr_mount_rotation: [rad], shape (3,), or None.
        poses: Still poses: the gravity direction of each orientation found (unit), shape (K, 3).
        spread_deg: Still poses: the RMS spread of the gravity directions along the two principal
            axes [deg], largest first, shape (2,) (:func:`fts_calib.payload.still.orientation_spread`).
        condition: Still poses: the condition number of the scaled normal matrix of the fit.
        inertia_com: A motion: the inertia about the centre of mass, axes of S [kg m^2], shape
            (3, 3); None for still poses.
        stderr_inertia: [kg m^2], shape (3, 3), or None.
        offset_rate: A motion: how fast the offsets drift [N/s, N m/s], shape (6,) (zeros when not estimated).
        parameters: A motion: the ten inertial parameters (:mod:`fts_calib.robot.inertial`), shape (10,), or None.
        unconstrained: A motion: the unconstrained least-squares parameters, shape (10,), or None.
        constrained: A motion: whether the consistency constraint moved the estimate.
        latency_s: A motion: the latency of the joint stream applied [s] (0 for arrays); None for still poses.
        stderr_latency_s: Its standard error [s] (inf when not estimated).
        gravity: The magnitude of gravity the estimate used [m/s^2] (the robot model's).
        source: What the samples came from (a path, ``udp://HOST:PORT``); '' for arrays.
        rows: Samples read from the source (before the checks and the filter).
        duration_s: Time spanned by the samples used [s] (0 when unknown).
        rails: One line per channel whose samples were refused at its rail
            (:meth:`fts_calib.filters.sample_checks.RailTally.lines`).
        decided: How ``motion`` was decided from the data, in words ('' when it was given).
        left_out: A motion: the samples left out near gaps in the samples (rows refused,
            datagrams lost), how many gaps and where, in words ('' when none).
    """

    mass: float
    stderr_mass: float
    com: np.ndarray
    stderr_com: np.ndarray
    offsets: np.ndarray
    stderr_offsets: np.ndarray
    residual_rms: np.ndarray
    samples: int
    motion: str = STILL
    mount_rotation: np.ndarray | None = None
    stderr_mount_rotation: np.ndarray | None = None
    poses: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 3)))
    spread_deg: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(2))
    condition: float = 0.0
    inertia_com: np.ndarray | None = None
    stderr_inertia: np.ndarray | None = None
    offset_rate: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(6))
    parameters: np.ndarray | None = None
    unconstrained: np.ndarray | None = None
    constrained: bool = False
    latency_s: float | None = None
    stderr_latency_s: float = math.inf
    gravity: float = STANDARD_GRAVITY
    source: str = ""
    rows: int = 0
    duration_s: float = 0.0
    rails: tuple[str, ...] = ()
    decided: str = ""
    left_out: str = ""

    def __post_init__(self):
        arrays = ("com", "stderr_com", "offsets", "stderr_offsets", "residual_rms", "poses", "spread_deg", "offset_rate")
        optional = ("mount_rotation", "stderr_mount_rotation", "inertia_com", "stderr_inertia", "parameters", "unconstrained")
        for name in arrays + tuple(n for n in optional if getattr(self, n) is not None):
            object.__setattr__(self, name, frozen(getattr(self, name)))
        object.__setattr__(self, "rails", tuple(self.rails))

    @property
    def stderr(self) -> np.ndarray:
        """The standard errors of :data:`NAMES` (mass [kg], com [m], inertia elements [kg m^2]); shape (10,), (4,) without inertia."""
        head = np.concatenate([[self.stderr_mass], self.stderr_com])
        if self.stderr_inertia is None:
            return head
        return np.concatenate([head, [self.stderr_inertia[i, j] for i, j in PAIRS]])

    def tool(self, name: str = "payload", gravity: float | None = None) -> Tool:
        """The payload as a tool with one configuration, with its inertia when known (for :func:`save_payload`).

        A body on the consistency boundary (a principal moment of zero, or one equal to the sum
        of the other two) can miss it by rounding; its principal moments are put back on it.

        Args:
            name: The tool's and its configuration's name.
            gravity: The magnitude of gravity [m/s^2]; the estimate's (:attr:`gravity`) when None.
        """
        inertia = None
        if self.inertia_com is not None:
            values, vectors = np.linalg.eigh((self.inertia_com + self.inertia_com.T) / 2)
            values = np.maximum(values, 1e-9 * max(float(values[2]), 0.0))  # a moment of zero would come back as -1e-20
            values[2] = min(values[2], values[0] + values[1])
            inertia = (vectors * values) @ vectors.T
        configuration = ToolConfiguration(name, self.mass, self.com, inertia)
        return Tool(name=name, gravity=self.gravity if gravity is None else gravity, configurations=(configuration,))


def payload_header(estimate: PayloadEstimate) -> str:
    """The tool file's header of an identified payload: where it came from and the standard errors."""
    source = estimate.source or "arrays"
    errors = ", ".join(f"{e:.2g}" for e in estimate.stderr_com)
    if estimate.motion == MOVING:
        return (
            f"payload identified by fts-calib from {source} ({estimate.samples} samples of motion, {estimate.duration_s:.1f} s)\n"
            f"mass {estimate.mass:.6g} ± {estimate.stderr_mass:.2g} kg; com ± {errors} m; "
            f"inertia ± {', '.join(f'{e:.2g}' for e in estimate.stderr[4:])} kg·m² ({', '.join(NAMES[4:])})"
        )
    return (
        f"payload identified by fts-calib from {source} ({estimate.samples} samples, {len(estimate.poses)} orientations)\n"
        f"mass {estimate.mass:.6g} ± {estimate.stderr_mass:.2g} kg; com ± {errors} m"
    )


def save_payload(estimate: PayloadEstimate, path: str | Path, name: str = "payload") -> Path:
    """Write an identified payload as a tool file, atomically (see the module docstring).

    Args:
        estimate: The payload.
        path: Destination (YAML).
        name: The name of the tool and of its one configuration.

    Returns:
        The path written.
    """
    return save_tool(estimate.tool(name), path, payload_header(estimate))

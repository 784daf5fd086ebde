"""Pipeline settings (``configs/pipeline.yaml``): the quasi-static filter and the live path.

``filter``: a sample is kept when the joint speeds stay below ``max_joint_speed`` [rad/s]
and the joint accelerations below ``max_joint_acceleration`` [rad/s^2] (estimated by a least-squares quadratic over
``derivative_window_s`` [s]: the feeds carry no velocities), when the strains are
stationary over ``strain_window_s`` [s] (standard deviation of every bridge at most
``max_strain_std`` raw units, or ``auto``: ``strain_std_factor`` times the noise floor
measured on still samples), and when the dynamic part of the tool's wrench is at most
``max_dynamic_fraction`` of its weight (force) and of weight times lever (moment).

``live``: ``max_gap_s`` [s], the longest gap of the joint stream the synchronizer
interpolates across; ``latency_s`` [s], added to joint times to align them with strain
times; ``checkpoint_interval_s`` [s], how often the session's accumulators are saved.

``design``: ``noise_std``, the strain noise per bridge [raw units] assumed by the
excitation report of planned trajectories (default: the sensor file's).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from ..core.exceptions import FileFormatError
from ..core.fileio import load_yaml, read_positive


@dataclass(frozen=True)
class FilterConfig:
    """Quasi-static sample filter thresholds (see the module docstring)."""

    max_joint_speed: float = 0.01  # [rad/s]
    max_joint_acceleration: float = 0.1  # [rad/s^2]
    derivative_window_s: float = 0.05  # [s]
    strain_window_s: float = 0.1  # [s]
    max_strain_std: float | None = None  # [raw units]; None = auto
    strain_std_factor: float = 4.0
    max_dynamic_fraction: float = 1e-3

    def __post_init__(self):
        for name in (
            "max_joint_speed",
            "max_joint_acceleration",
            "derivative_window_s",
            "strain_window_s",
            "strain_std_factor",
            "max_dynamic_fraction",
        ):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"filter.{name}={value} but expected a finite value > 0")
        if self.max_strain_std is not None and not (math.isfinite(self.max_strain_std) and self.max_strain_std > 0):
            raise ValueError(f"filter.max_strain_std={self.max_strain_std} but expected a value > 0 or 'auto'")


@dataclass(frozen=True)
class LiveConfig:
    """Live-feed settings (see the module docstring)."""

    max_gap_s: float = 0.05
    latency_s: float = 0.0
    checkpoint_interval_s: float = 5.0


@dataclass(frozen=True)
class PipelineConfig:
    """All pipeline settings.

    Attributes:
        filter: Quasi-static filter.
        live: Live feeds.
        noise_std: Strain noise per bridge for experiment design [raw units], or None for
            the sensor file's.
    """

    filter: FilterConfig = field(default_factory=FilterConfig)
    live: LiveConfig = field(default_factory=LiveConfig)
    noise_std: float | None = None


def load_pipeline_config(path: str | Path) -> PipelineConfig:
    """Read a pipeline configuration file; absent keys take the defaults.

    Raises:
        FileFormatError: An unknown key or a bad value; the message names the field.
    """
    path = Path(path)
    data = load_yaml(path)
    unknown = sorted(set(data) - {"filter", "live", "design"})
    if unknown:
        raise FileFormatError(path, None, f"unknown sections {unknown}; expected filter, live, design")

    def section(name: str, cls):
        raw = data.get(name) or {}
        if not isinstance(raw, dict):
            raise FileFormatError(path, name, "expected a mapping")
        known = set(cls.__dataclass_fields__)
        bad = sorted(set(raw) - known)
        if bad:
            raise FileFormatError(path, name, f"unknown keys {bad}; expected {sorted(known)}")
        values: dict[str, float | None] = {}
        for key, value in raw.items():
            if key == "max_strain_std" and value == "auto":
                values[key] = None
            elif key == "latency_s":
                try:
                    values[key] = float(value)
                except (TypeError, ValueError):
                    raise FileFormatError(path, f"{name}.{key}", f"expected a number in s, got {value!r}") from None
            else:
                values[key] = read_positive(value, path, f"{name}.{key}")
        try:
            return cls(**values)
        except ValueError as exc:
            raise FileFormatError(path, name, str(exc)) from None

    design = data.get("design") or {}
    noise = design.get("noise_std") if isinstance(design, dict) else None
    return PipelineConfig(
        filter=section("filter", FilterConfig),
        live=section("live", LiveConfig),
        noise_std=None if noise is None else read_positive(noise, path, "design.noise_std"),
    )

"""The demo: the paper's simulation validation (eqs 21-22, Fig. 7) on the shipped sensor and tool.

Gravity is drawn from uniformly random directions in the sensor frame, one tool
configuration after the other; strains come from the simulated sensor (true C = Table 1
of the paper, with noise and 24-bit quantization); the online estimator runs on them.
Printed: the rank and the relative error of C_bar_11 after each configuration (the
paper's Fig. 7 story), then the recovered C beside the true one.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .calibration import Calibration, save_calibration
from .estimator import OnlineEstimator
from .resources import resolve
from .sensor import WRENCH_AXES
from .sensor_config import load_sensor_config
from .tool import load_tool


@dataclass(frozen=True)
class PaperSimulationResult:
    """Outcome of :func:`run_paper_simulation`.

    Attributes:
        calibration: The estimate after all configurations.
        true_C: The simulated sensor's C. Shape (6, 8).
        true_D: Its offsets, [N, N, N, N m, N m, N m]. Shape (6,).
        ranks: Rank of S_XX after each configuration.
        c11_errors: Relative error of C_bar_11 after each configuration (min-norm solution
            while rank deficient).
    """

    calibration: Calibration
    true_C: np.ndarray
    true_D: np.ndarray
    ranks: list[int]
    c11_errors: list[float]


def random_gravity(n: int, gravity: float, rng: np.random.Generator) -> np.ndarray:
    """Gravity vectors of magnitude ``gravity`` [m/s^2] in uniformly random directions, (n, 3)."""
    v = rng.standard_normal((n, 3))
    return gravity * v / np.linalg.norm(v, axis=1, keepdims=True)


def run_paper_simulation(sensor_path: str | Path, tool_path: str | Path, samples: int, seed: int) -> PaperSimulationResult:
    """Simulate the paper's validation and calibrate; see the module docstring.

    Args:
        sensor_path: Sensor configuration with a ``simulation`` section.
        tool_path: Tool file with at least three non-collinear configurations.
        samples: Samples per tool configuration.
        seed: Seed of the random orientations and noise.
    """
    spec = load_sensor_config(sensor_path)
    if spec.simulated is None:
        raise ValueError(f"{sensor_path}: no 'simulation' section to simulate a sensor from")
    sensor = spec.simulated
    tool = load_tool(tool_path)
    rng = np.random.default_rng(seed)
    est = OnlineEstimator()
    ranks, errors = [], []
    for config in tool.configurations:
        W = config.static_wrench(random_gravity(samples, tool.gravity, rng))
        est.update_batch(W, sensor.strains(W, rng=rng))
        ranks.append(est.rank()[0])
        estimate = est.solve(min_norm=True)
        errors.append(abs(estimate.C_bar[0, 0] / sensor.C_bar[0, 0] - 1.0))
    calibration = est.solve()
    return PaperSimulationResult(calibration, sensor.C, sensor.D, ranks, errors)


def main(out: Path, samples: int = 2000, seed: int = 0) -> int:
    """Run the demo, print the results with units, write ``out/calibration.yaml``."""
    sensor_path, tool_path = resolve("sensor", "configs"), resolve("paper_tool", "configs")
    print("fts-calib demo: the paper's simulation validation (eqs 21-22)")
    print(f"  sensor: {sensor_path} (true C = Table 1 of the paper)\n  tool:   {tool_path}")
    print(f"  {samples} samples per tool configuration, gravity from uniformly random directions, seed {seed}\n")
    result = run_paper_simulation(sensor_path, tool_path, samples, seed)
    for k, (rank, err) in enumerate(zip(result.ranks, result.c11_errors, strict=True)):
        print(f"  after configuration {k + 1}: rank of S_XX = {rank}, relative error of C_bar_11 = {err:.2e}")
    cal = result.calibration
    scale = np.max(np.abs(result.true_C), axis=1, keepdims=True)
    rel = np.abs(cal.C - result.true_C) / scale
    header = "".join(f"{f'Δ{k + 1}':>10}" for k in range(8))
    for title, matrix in (("estimated C", cal.C), ("true C (Table 1 of the paper)", result.true_C)):
        print(f"\n  {title}, per mV/V (rows Fx Fy Fz in N, Mx My Mz in N·m):\n      {header}")
        for i, axis in enumerate(WRENCH_AXES):
            print(f"    {axis}" + "".join(f"{v:10.4f}" for v in matrix[i]))
    print(f"\n  largest coefficient error: {100 * rel.max():.4f} % of its row's largest coefficient")
    units = ["N", "N", "N", "N·m", "N·m", "N·m"]
    offsets = ", ".join(f"{axis} {d - t:+.2e} {u}" for axis, d, t, u in zip(WRENCH_AXES, cal.D, result.true_D, units, strict=True))
    print(f"  offset error: {offsets}")
    path = save_calibration(cal, out / "calibration.yaml")
    print(f"\n  wrote {path}")
    return 0

"""Benchmark: plans sized to the default accuracy target, and their budgets against simulation truth.

For UR5 and Kinova: plan + check with the default target (time), the motion per
configuration; a simulated 1 kHz recording with the joints read 8 ms late, calibrated as
``fts-calib calibrate`` does; the calibration's own error against the true sensor (RMS over
loads uniform in the full-scale box, % FS), the latency estimated from the moving samples,
and a Monte Carlo over tools drawn within their tolerance: how often the measured budget's
total covers the observed error. Prints figures; asserts nothing.
Run: .venv/bin/python bench/bench_budget.py [--runs N]
"""

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from fts_calib.budget.propagation import DEFAULT_TARGET_PERCENT, range_moments
from fts_calib.core.resources import resolve
from fts_calib.filters.settings import load_pipeline_config
from fts_calib.model.sensor_config import load_sensor_config
from fts_calib.planning.sweeps import SweepPattern
from fts_calib.planning.trajectory_run import plan_trajectories
from fts_calib.robot.definition import load_robot
from fts_calib.robot.kinematics import Kinematics
from fts_calib.robot.tool import ToolConfiguration, load_tool
from fts_calib.session.calibration_run import calibrate_recording
from fts_calib.sim.runs import simulate_recording
from fts_calib.sim.sensor import load_simulated_sensor

LAG_S = 0.008  # [s] the joint readings of the simulated recordings are this late


def lag_joints(path: Path, joint_names, lag_s: float) -> None:
    """Rewrite a recording with every joint column read lag_s late (interpolated within each configuration)."""
    frame = pd.read_csv(path)
    for _, rows in frame.groupby("tool", sort=False):
        t = rows["time"].to_numpy()
        for name in joint_names:
            frame.loc[rows.index, name] = np.interp(t - lag_s, t, rows[name].to_numpy())
    frame.to_csv(path, index=False, float_format="%.10g")


def own_error(calibration, sim, full_scale) -> np.ndarray:
    """The calibration's error against the true sensor, RMS over the full-scale box, % FS per axis."""
    error = np.hstack([calibration.C_bar - sim.C_bar, (calibration.D - sim.D)[:, None]])
    M = range_moments(sim.C_bar, sim.D, full_scale)
    return 100 * np.sqrt(np.einsum("jk,kl,jl->j", error, M, error)) / full_scale


def calibrate(path, kin, tool_file, pipeline, full_scale):
    # the session measures the budget and the latency itself, as for every route to a calibration
    return calibrate_recording(path, kin, tool_file, pipeline, full_scale=full_scale)


def drawn_tool(tool, rng):
    """The tool as it really is: one mass error and one centre-of-mass error, within tolerance, common to every configuration."""
    dm = rng.uniform(-tool.tolerance.mass, tool.tolerance.mass)
    dc = rng.uniform(-tool.tolerance.com, tool.tolerance.com, 3)
    configs = tuple(ToolConfiguration(c.name, c.mass + dm, c.p_sensor_com + dc, c.inertia_com) for c in tool.configurations)
    return dataclasses.replace(tool, configurations=configs)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=30, help="Monte Carlo runs per robot (default: 30)")
    runs = parser.parse_args().runs
    tool = load_tool(resolve("paper_tool", "configs"))
    spec = load_sensor_config(resolve("sensor", "configs"))
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    pipeline = load_pipeline_config(resolve("pipeline", "configs"))
    for robot, today in (("ur5", 53.4), ("kinova", 94.7)):
        kin = Kinematics(load_robot(resolve(robot, "robots")))
        t0 = time.perf_counter()
        run = plan_trajectories(
            resolve(robot, "robots"), tool, spec, pipeline.filter, 1e-5, SweepPattern(), 100.0, target_percent=DEFAULT_TARGET_PERCENT
        )
        planned = time.perf_counter() - t0
        plan = run.result.plan
        print(
            f"{robot}: plan + check {planned:.2f} s; {plan.duration:.1f} s of motion per configuration (the 4 x 6 x 0.5 s plan: "
            f"{today} s); {run.sized.summary() if run.sized else ''}"
        )
        fine = plan_trajectories(
            resolve(robot, "robots"), tool, spec, pipeline.filter, 1e-5, plan.pattern, spec.rate_hz, target_percent=None
        )
        trajectories = [fine.result.plan.trajectory(name) for name in tool.names]
        covered, errors, latencies = [], [], []
        with tempfile.TemporaryDirectory() as folder:
            for k in range(runs + 1):
                rng = np.random.default_rng(k)
                true_tool = tool if k == 0 else drawn_tool(tool, rng)
                path = simulate_recording(Path(folder) / f"run{k}.csv", kin, true_tool, trajectories, sensor, rng)
                lag_joints(path, kin.joint_names, LAG_S)
                result = calibrate(path, kin, tool, pipeline, spec.full_scale)
                error = own_error(result.calibration, spec.simulated, spec.full_scale)
                if k == 0:
                    print(
                        f"  exact tool, joints {1e3 * LAG_S:g} ms late, {spec.rate_hz:g} Hz: the calibration's own error "
                        f"(RMS over the full-scale box) {', '.join(f'{v:.4f}' for v in error)} % FS (largest {error.max():.4f} %); "
                        f"{result.latency.summary() if result.latency else 'no latency estimate'}"
                    )
                    continue
                budget = result.budget
                without_mount = budget.without(["sensor mount"])  # the simulation has no mount error
                covered.append(error <= without_mount.total_percent)
                errors.append(error.max())
                latencies.append(result.latency.latency_s if result.latency else np.nan)
        if runs:
            covered = np.array(covered)
            print(
                f"  {runs} runs with the tool drawn within tolerance (±{1e3 * tool.tolerance.mass:g} g, ±{1e3 * tool.tolerance.com:g} mm): "
                "measured budget total (less the mount term) covers the observed error on every axis in "
                f"{100 * np.mean(covered.all(axis=1)):.0f} % "
                f"of runs (per axis {', '.join(f'{100 * v:.0f}' for v in covered.mean(axis=0))} %); observed largest error "
                f"median {np.median(errors):.4f} %, max {np.max(errors):.4f} % FS; latency {1e3 * np.nanmean(latencies):.3f} "
                f"± {1e3 * np.nanstd(latencies):.3f} ms over the runs"
            )


if __name__ == "__main__":
    main()

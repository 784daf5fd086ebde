"""Benchmark: continuous plans (no dwell) and fewer tool configurations, predicted by the budget and measured in simulation.

For each number of tool configurations (1, 2, 3) and continuous motions of increasing length
(UR5, the shipped paper tool, sensor at 1 kHz): the predicted budget of the plan's samples in
the dynamic filter mode (:func:`fts_calib.budget.predicted.dynamic_plan_budget`, the
terms a plan can shrink: the simulation knows the tool's mass, centre of mass and the mount
exactly), and the error measured in simulation: the tool's wrench by Pinocchio's RNEA
(:mod:`fts_calib.sim.rnea`, a dynamics model independent of the calibration's) with each
configuration's inertia drawn within the tolerance (uniform, each element within
+-tolerance x its largest principal moment), the joints read 8 ms late with 1e-5 rad of white
noise, calibrated with ``filter.mode: dynamic``; the error is the calibration's against the
true sensor, RMS over loads uniform in the full-scale box, largest axis, % FS (the budget's
figure before the coverage factor: compare with the predicted sigma, k = 1, and total, k = 2).
With ``--smooth`` the motions are the smooth excitation of :mod:`fts_calib.planning.smooth`
(``trajectory --motion smooth``) of :data:`SMOOTH_S` seconds instead of the rasters.
Prints the tables of docs/accuracy.md; asserts nothing.
Run: .venv/bin/python bench/bench_continuous.py [--seeds N] [--quick] [--smooth] [--configurations 1,2,3]
"""

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path

import numpy as np

from fts_calib.budget.predicted import SYSTEMATIC, dynamic_plan_budget
from fts_calib.budget.propagation import range_moments
from fts_calib.core.exceptions import FtsCalibError
from fts_calib.core.resources import resolve
from fts_calib.filters.settings import load_pipeline_config
from fts_calib.model.sensor_config import load_sensor_config
from fts_calib.planning.motion import plan_sweeps
from fts_calib.planning.planner import plan_base
from fts_calib.planning.sizing import with_configurations
from fts_calib.planning.smooth import smooth_plan
from fts_calib.planning.sweeps import SweepPattern, spanned
from fts_calib.planning.trajectory_run import motion_uncertainty
from fts_calib.robot.collision import CollisionChecker
from fts_calib.robot.definition import load_robot
from fts_calib.robot.kinematics import Kinematics
from fts_calib.robot.tool import ToolConfiguration, load_tool
from fts_calib.session.calibration_run import calibrate_recording
from fts_calib.sim.rnea import rnea_tool_wrench
from fts_calib.sim.sensor import load_simulated_sensor
from fts_calib.sources.recording import RecordingWriter

LAG_S = 0.008  # [s] the joint readings are this late
JOINT_NOISE = 1e-5  # [rad] white noise of each joint reading
LATENCY_STD_S = 1e-4  # [s] uncertainty of the latency once fitted (filter.latency_uncertainty_s)
#: Continuous rasters (levels, stops, span), shortest first.
PATTERNS = ((2, 1, 0.2), (3, 1, 0.2), (3, 2, 0.35), (4, 3, 0.75))
#: Smooth excitations (fts_calib/planning/smooth.py): motion per configuration [s].
SMOOTH_S = (4.0, 5.0, 6.0, 8.0)


def drawn_inertia(tool, tolerance, rng):
    """The tool as it really is: each configuration's inertia elements off by up to tolerance x its largest principal moment."""
    configs = []
    for c in tool.configurations:
        bound = tolerance * np.linalg.eigvalsh(c.inertia_com).max()
        for _ in range(100):  # a draw that is physical
            d = rng.uniform(-bound, bound, 6)
            delta = np.array([[d[0], d[3], d[4]], [d[3], d[1], d[5]], [d[4], d[5], d[2]]])
            try:
                configs.append(ToolConfiguration(c.name, c.mass, c.p_sensor_com, c.inertia_com + delta))
                break
            except FtsCalibError:
                continue
    return dataclasses.replace(tool, configurations=tuple(configs))


def record(path, kin, true_tool, plan, sensor, rng):
    """A 1 kHz recording of the plan for each configuration: RNEA wrench, joints late and noisy."""
    with RecordingWriter(path, kin.joint_names, sensor.layout.n_channels) as writer:
        offset = 0.0
        for name in true_tool.names:
            W = rnea_tool_wrench(kin, true_tool, name, plan.q, plan.qd, plan.qdd)
            t = plan.time + offset
            late = np.column_stack([np.interp(plan.time - LAG_S, plan.time, plan.q[:, k]) for k in range(kin.n_joints)])
            joints = late + rng.normal(0.0, JOINT_NOISE, late.shape)
            writer.write(t, joints, sensor.channels(W, time=t, rng=rng), name)
            offset = t[-1] + 2.0
    return Path(path)


def own_error(calibration, sim, full_scale) -> np.ndarray:
    """The calibration's error against the true sensor, RMS over the full-scale box, % FS per axis."""
    error = np.hstack([calibration.C_bar - sim.C_bar, (calibration.D - sim.D)[:, None]])
    M = range_moments(sim.C_bar, sim.D, full_scale)
    return 100 * np.sqrt(np.einsum("jk,kl,jl->j", error, M, error)) / full_scale


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=2, help="simulated runs per cell (default: 2)")
    parser.add_argument("--quick", action="store_true", help="the two shortest motions only")
    parser.add_argument("--smooth", action="store_true", help="the smooth excitation (planning/smooth.py) instead of the rasters")
    parser.add_argument("--configurations", default="1,2,3", help="numbers of configurations, comma separated (default: 1,2,3)")
    args = parser.parse_args()
    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    tool = load_tool(resolve("paper_tool", "configs"))
    spec = load_sensor_config(resolve("sensor", "configs"))
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    pipeline = load_pipeline_config(resolve("pipeline", "configs")).with_filter_mode("dynamic")
    # the joint noise known, the latency fitted with the calibration to +-0.1 ms (1 sigma): the plan assumes the same
    known = dataclasses.replace(pipeline.filter, joint_noise=JOINT_NOISE, latency_uncertainty_s=LATENCY_STD_S)
    pipeline = dataclasses.replace(pipeline, filter=known, nominal_c=tuple(map(tuple, spec.simulated.C)))
    uncertainty = motion_uncertainty(pipeline.filter, spec.rate_hz)
    sim = spec.simulated
    from fts_calib.budget.propagation import wrench_noise

    nominal = (sim.C_bar, sim.D, wrench_noise(sim.C, sim.noise_std), spec.full_scale)
    checker = CollisionChecker(kin, tool.shape, kin.sweep_joints[0])
    home, ranges = plan_base(kin, checker, SweepPattern(2, 2, 0.0, 0.02, continuous=True))
    print(
        f"UR5, paper tool, {spec.rate_hz:g} Hz, joints {1e3 * LAG_S:g} ms late with {JOINT_NOISE:g} rad noise; inertia drawn within "
        f"{100 * uncertainty.inertia:g} %; dynamic filter (window {uncertainty.window_s:g} s, degree {uncertainty.order}); "
        f"{args.seeds} runs per cell"
    )
    print("| configurations | motion per configuration [s] | predicted σ / total (k=2), % FS | measured, % FS (largest axis) | kept |")
    print("|---|---|---|---|---|")
    motions = list(SMOOTH_S if args.smooth else PATTERNS)
    motions = motions[:2] if args.quick else motions
    for count in map(int, args.configurations.split(",")):
        part = with_configurations(tool, count)
        for motion in motions:
            if args.smooth:
                plan = smooth_plan(kin, home.home, ranges.ranges, motion, spec.rate_hz)
                coarse = smooth_plan(kin, home.home, ranges.ranges, motion, 50.0)
                label = "smooth"
            else:
                levels, stops, span = motion
                pattern = SweepPattern(levels, stops, 0.0, 0.02, span, continuous=True)
                plan = plan_sweeps(kin, home.home, spanned(ranges.ranges, span), pattern, spec.rate_hz)
                coarse = plan_sweeps(kin, home.home, spanned(ranges.ranges, span), pattern, 50.0)
                label = f"{levels}×{stops}, span {span:g}"
            budget = dynamic_plan_budget(kin, part, coarse, *nominal, sample_rate_hz=spec.rate_hz, uncertainty=uncertainty)
            shrinkable = budget.without(list(SYSTEMATIC))
            sigma = float(np.max(100 * shrinkable.sigma / spec.full_scale))
            measured, kept = [], []
            t0 = time.perf_counter()
            with tempfile.TemporaryDirectory() as folder:
                for seed in range(args.seeds):
                    rng = np.random.default_rng(seed)
                    true_tool = drawn_inertia(part, uncertainty.inertia, rng)
                    path = record(Path(folder) / "run.csv", kin, true_tool, plan, sensor, rng)
                    try:
                        result = calibrate_recording(path, kin, part, pipeline, full_scale=spec.full_scale, accept_poor_fit=True)
                    except FtsCalibError as exc:
                        measured.append(float("nan"))
                        print(f"  ({count} configurations, {plan.duration:.1f} s: {str(exc)[:120]})")
                        continue
                    kept.append(sum(result.session.progress().kept_by_configuration.values()))
                    if result.calibration is None:
                        measured.append(float("nan"))
                        print(f"  ({count} configurations, {plan.duration:.1f} s: no calibration: {str(result.error)[:160]})")
                        continue
                    measured.append(float(own_error(result.calibration, sim, spec.full_scale).max()))
            total = shrinkable.largest_percent
            predicted = f"{sigma:.3g} / {total:.3g}" if np.isfinite(total) else "rank < 7"
            shown = ", ".join("not solved" if np.isnan(m) else f"{m:.3g}" for m in measured)
            print(
                f"| {count} | {plan.duration:.1f} ({label}) | {predicted} | {shown} | "
                f"{int(np.mean(kept)) if kept else 0} of {count * len(plan.time)} | ({time.perf_counter() - t0:.0f} s)"
            )


if __name__ == "__main__":
    main()

"""Benchmark: payload from a continuous motion on the simulated UR5, over seeds.

The shipped 1.4 kg validation payload moved by the wrist motion of
:func:`fts_calib.payload.inertia_motion.payload_excitation` (jerk-limited, no dwell),
joints 8 ms late with 1e-5 rad of noise on a 20-bit encoder, the simulated sensor's noise
and 24-bit ADC, offsets drifting as a sensor warming up (:meth:`OffsetDrift.typical`);
identified by :func:`fts_calib.payload.identify.identify_payload` as a motion (latency estimated).
Prints, per motion length: the largest error over the seeds of mass [%], centre of mass [mm],
inertia [% of its largest principal moment: the error's largest singular value], the
scatter of the seeds over the reported standard errors (per parameter: min-max), and the
identification time. Asserts nothing. Run: .venv/bin/python bench/bench_payload_motion.py [SEEDS]
"""

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from fts_calib.core.exceptions import PayloadError
from fts_calib.core.resources import resolve
from fts_calib.model.calibration import Calibration
from fts_calib.payload.estimate import NAMES
from fts_calib.payload.identify import identify_payload
from fts_calib.payload.inertia_motion import payload_excitation
from fts_calib.robot.definition import load_robot
from fts_calib.robot.kinematics import Kinematics
from fts_calib.robot.tool import load_tool
from fts_calib.sim.drift import OffsetDrift
from fts_calib.sim.payload_run import simulate_payload_motion
from fts_calib.sim.sensor import load_simulated_sensor

HOME = np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0])  # [rad]
PAIRS = ((0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2))


def main(seeds: int) -> None:
    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    calibration = Calibration(sensor.C_bar, sensor.D)
    payload = load_tool(resolve("validation_tool", "configs")).configurations[0]
    drift = OffsetDrift.typical()  # a sensor warming up: forces 1 N/min at the start, moments a 20th
    truth = np.concatenate([[payload.mass], payload.p_sensor_com, [payload.inertia_com[i, j] for i, j in PAIRS]])
    with tempfile.TemporaryDirectory() as folder:
        for seconds in (5.0, 7.0, 10.0):
            motion = payload_excitation(kin, HOME, seconds=seconds, amplitude=1.0)
            errors, stderrs, inertia, latency, took, refused = [], [], [], [], [], []
            for seed in range(seeds):
                rng = np.random.default_rng(seed)
                path = simulate_payload_motion(Path(folder) / "run.csv", kin, payload, sensor, motion, rng, 0.008, 1e-5, drift=drift)
                t0 = time.perf_counter()
                try:
                    est = identify_payload(path, kin, calibration, "moving")
                except PayloadError as error:
                    refused.append(str(error).split(": ", 1)[1][:120])
                    continue
                took.append(time.perf_counter() - t0)
                derived = np.concatenate([[est.mass], est.com, [est.inertia_com[i, j] for i, j in PAIRS]])
                errors.append(derived - truth)
                stderrs.append(est.stderr)
                inertia.append(np.linalg.norm(est.inertia_com - payload.inertia_com, 2) / np.linalg.norm(payload.inertia_com, 2))
                latency.append(est.latency_s - 0.008)
            if refused:
                print(f"{motion[0][-1]:.1f} s of motion: refused in {len(refused)} of {seeds} seeds, e.g. {refused[0]}...")
            if len(errors) < 2:
                continue
            errors, stderrs = np.array(errors), np.array(stderrs)
            scatter = errors.std(axis=0, ddof=1) / stderrs.mean(axis=0)
            worst_z = np.max(np.abs(errors) / stderrs)
            print(
                f"{motion[0][-1]:.1f} s of motion, {len(errors)} seeds identified: "
                f"mass {100 * np.max(np.abs(errors[:, 0])) / payload.mass:.4f} %, "
                f"centre of mass {1e3 * np.max(np.abs(errors[:, 1:4])):.4f} mm, inertia {100 * max(inertia):.2f} %, "
                f"latency {1e6 * np.max(np.abs(latency)):.1f} us (largest errors); scatter / standard error "
                f"{scatter.min():.2f}-{scatter.max():.2f}, largest |error| / standard error {worst_z:.1f} "
                f"({NAMES[int(np.argmax(np.max(np.abs(errors) / stderrs, axis=0)))]}); "
                f"identification {np.median(took):.2f} s median"
            )


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 20)

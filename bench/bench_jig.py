"""A jig that determines a quadratic model, end to end: suggested, planned, simulated, calibrated, validated on another tool.

1. ``fts-calib trajectory --model quadratic`` on the paper's tool refuses (its three centres of mass at one
   mass cannot determine a quadratic model) and writes the jig that would (``suggested_tool.yaml``).
2. ``fts-calib trajectory --tool suggested_tool.yaml --model quadratic`` plans its sweeps (UR5, 100 Hz).
3. ``fts-calib simulate`` plays them on a bent sensor: the shipped low-cost sensor (10-bit counts, rails,
   3 % of full scale of quadratic bend), and the paper's sensor bent by 1 % (quadratic, every axis).
4. ``fts-calib calibrate`` with the default ``--model auto``.
5. Another tool (the shipped validation payload, 1.4 kg) is simulated over the first configuration's motion,
   and the calibration's error on it compared with the noise: the channels' noise and rounding through C.

Run: .venv/bin/python bench/bench_jig.py [SEED]   (prints the figures; about a minute on two cores)
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from fts_calib.app.cli import main
from fts_calib.model.calibration import load_calibration
from fts_calib.robot.tool import load_tool
from fts_calib.service.validation import validate_recording

BENT = Path(__file__).resolve().parents[1] / "configs" / "sensor.yaml"


def bent_sensor(folder: Path) -> Path:
    """The paper's sensor file with a quadratic bend of 1 % of full scale on every axis."""
    text = BENT.read_text(encoding="utf-8").rstrip() + "\n  nonlinearity: {quadratic: 0.01}\n"  # the simulation section is last
    path = folder / "bent_sensor.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def run(seed: int) -> None:
    """Print the steps' outcomes and the validation table of each sensor."""
    from fts_calib.core.resources import resolve
    from fts_calib.model.sensor_config import load_sensor_config
    from fts_calib.robot.definition import load_robot
    from fts_calib.robot.kinematics import Kinematics

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        start = time.perf_counter()
        status = main(["trajectory", "--robot", "ur5", "--tool", "paper_tool", "-o", str(out / "suggest"), "--model", "quadratic"])
        print(f"== trajectory --model quadratic on the paper's tool: exit {status}")
        jig = out / "suggest" / "suggested_tool.yaml"
        common = ["--robot", "ur5", "--tool", str(jig)]
        status = main(["trajectory", *common, "-o", str(out / "plan"), "--model", "quadratic", "--rate", "100", "--no-plot"])
        print(f"== trajectory with the suggested jig: exit {status} ({time.perf_counter() - start:.0f} s)")
        other = out / "other_plan"  # another tool over the first configuration's motion
        other.mkdir()
        pd.read_csv(out / "plan" / "A.csv").assign(tool="V").to_csv(other / "V.csv", index=False)
        kin = Kinematics(load_robot("ur5"))
        for sensor in ("lowcost_sensor", str(bent_sensor(out))):
            spec = load_sensor_config(resolve(sensor, "configs", "sensor"))
            recording, calibration, validation = out / "recording.csv", out / "calibration.yaml", out / "validation.csv"
            main(["simulate", *common, "--trajectory", str(out / "plan"), "--sensor", sensor, "-o", str(recording), "--seed", str(seed)])
            status = main(["calibrate", *common, str(recording), "--sensor", sensor, "-o", str(calibration), "--quiet"])
            cal = load_calibration(calibration)
            argv = ["simulate", "--robot", "ur5", "--tool", "validation_tool", "--trajectory", str(other), "--sensor", sensor]
            main([*argv, "-o", str(validation), "--seed", str(seed + 1)])
            result = validate_recording(validation, kin, load_tool("validation_tool"), [cal], spec.full_scale, limits=spec.limits)
            error = result.measured[0] - result.expected
            rms = np.sqrt(np.mean(error**2, axis=0))
            truth = spec.simulated
            variance = truth.noise_std**2 + truth.lsb**2 / 12.0  # white noise and rounding, per channel
            noise = np.sqrt((cal.C**2 * variance).sum(axis=1))
            print(f"== {spec.name}: calibrate exit {status}, {cal.model_selection['chosen']}; ({time.perf_counter() - start:.0f} s in all)")
            print(f"   another tool (1.4 kg), its own motion and noise, {len(error):,} samples; RMS error against the noise, per axis:")
            units = ["N"] * 3 + ["N·m"] * 3
            for axis, r, n, unit, fs in zip(("Fx", "Fy", "Fz", "Mx", "My", "Mz"), rms, noise, units, spec.full_scale, strict=True):
                print(f"   {axis}: {r:.3g} {unit} RMS, noise {n:.3g} {unit}: {r / n:.2f}x ({100 * r / fs:.4f} % FS)")


if __name__ == "__main__":
    run(int(sys.argv[1]) if len(sys.argv) > 1 else 0)

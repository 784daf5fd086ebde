"""validate uses the calibration's offset model on its own recording (issue 23, item 5)."""

import numpy as np
import pytest

from fts_calib import Calibration
from fts_calib.core.resources import resolve
from fts_calib.model.offset_models import Candidate, OffsetBasis, describe
from fts_calib.model.sensor_config import load_sensor_config
from fts_calib.planning.motion import sample_motion
from fts_calib.planning.trajectory_files import TrajectoryFile
from fts_calib.service.validation import validate_recording
from fts_calib.sim.drift import OffsetDrift
from fts_calib.sim.runs import simulate_recording
from fts_calib.sim.sensor import SimulatedSensor

HOME = np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0])
JOINTS = ("wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
JUMP = np.array([1.0, -0.8, 0.6, 0.03, -0.02, 0.01])  # offset change at each tool change [N, N m]
RATE = np.array([0.6, 0.4, -0.5, 0.02, 0.01, -0.015])  # linear drift [N/min, N m/min]
ORDER = ["C", "A", "B"]  # the calibration tool's order: offsets are matched by name, not index


def _calibration(sensor, model: str, scale_s: float, end_s: float) -> Calibration:
    """The true C with the true offset model of the simulation, in the calibration tool's order."""
    K = len(ORDER)
    basis = OffsetBasis(n_configurations=K, drift_degree=1 if model == "drift" else 0, time_scale_s=scale_s, temperature=False)
    changes = {"A": 0, "B": 1, "C": 2}  # tool changes before each configuration of the recording
    theta = np.array([sensor.D + changes[name] * JUMP for name in ORDER]).T  # (6, K): D moves by -delta D (sim/recording)
    if model == "drift":
        theta = np.column_stack([theta, RATE / 60.0 * scale_s])  # per unit of tau = t / scale
    columns = tuple(range(basis.size))
    trace = [(0.0, ORDER.index("A"), 25.0), (end_s, ORDER.index("C"), 25.0)]  # the run's first and last samples
    description = describe(model, Candidate(model, columns, np.eye(basis.size)), basis, theta, (0.0, 25.0), [], trace, ORDER)
    provenance = {"tools": {"configurations": [{"name": n} for n in ORDER]}}
    return Calibration(sensor.C_bar, description["trajectory"][-1]["D"], provenance=provenance, offset_model=description)


@pytest.mark.parametrize("model", ["per-configuration", "drift"])
def test_a_calibration_validated_on_its_own_recording_uses_its_offset_model(tmp_path, ur5, paper_tool, seed, model):
    """Offsets jump by up to 1 N at each tool change (and drift up to 0.6 N/min): with the
    model's offsets, only the strain noise is left, the RMS error per axis is
    sigma_W = sqrt((C diag(s^2) C^T)_jj) to 10 % (an RMS over ~6,000 samples: 1 % sampling
    error, plus quantization); with D alone two configurations are off by one or two jumps."""
    spec = load_sensor_config(resolve("sensor", "configs"))
    sensor = SimulatedSensor.from_spec(spec.simulated)
    rng = np.random.default_rng([seed, 0])
    trajectories = []
    for name in ("A", "B", "C"):
        stops = HOME[[3, 4, 5]] + rng.uniform(-1.0, 1.0, (3, 3))
        t, q, qd, qdd = sample_motion(ur5, HOME, JOINTS, stops, 0.0, 250.0)
        trajectories.append(TrajectoryFile(ur5.joint_names, t, q, qd, qdd, name))
    drift = OffsetDrift(jump=JUMP, rate_per_min=RATE if model == "drift" else np.zeros(6))
    path = simulate_recording(tmp_path / "run.csv", ur5, paper_tool, trajectories, sensor, rng, dynamic=False, drift=drift)
    end_s = sum(traj.time[-1] - traj.time[0] for traj in trajectories) + 2 * 2.0  # 2 s tool changes
    calibration = _calibration(spec.simulated, model, 600.0, end_s)
    result = validate_recording(
        path, ur5, paper_tool, [calibration, Calibration(sensor.C_bar, calibration.D)], spec.full_scale, dynamic=False
    )
    sigma_W = np.sqrt(np.diag(sensor.C @ np.diag(sensor.noise_std**2) @ sensor.C.T))
    np.testing.assert_allclose(result.errors[0].rms, sigma_W, rtol=0.1)
    assert result.offsets[0].startswith(f"{model} model") and f"{result.samples:,} of {result.samples:,} samples" in result.offsets[0]
    assert "A, B, C" in result.offsets[0]
    assert result.offsets[1].startswith("constant D")
    assert np.all(result.errors[1].rms[:3] > 0.4)  # D alone: errors of the jumps (>= sqrt(1/3) x 0.6 N)
    later = validate_recording(
        path, ur5, paper_tool, [_calibration(spec.simulated, model, 600.0, end_s / 2)], spec.full_scale, dynamic=False
    )
    if model == "drift":  # samples after the calibration run's end take D (another recording would)
        assert later.offsets[0].startswith("drift model") and f" of {result.samples:,} samples" in later.offsets[0]
        assert f"{result.samples:,} of" not in later.offsets[0]

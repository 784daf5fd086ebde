"""One motion recorded at 1 kHz, 100 Hz and 10 Hz: payload, calibrate and tare agree within the noise.

The runs are simulated once at 1 kHz with the shipped sensor (noise 1e-5 mV/V per bridge, 24-bit
ADC, null-pattern content) and joint readings 8 ms late with 1e-5 rad of noise rounded to a
20-bit encoder (:func:`fts_calib.sim.runs.joint_readings`); the 100 Hz and 10 Hz recordings are
the same files with every 10th and 100th row (:func:`fts_calib.sim.runs.decimate_recording`), as
a slower logger records the same motion. Every command runs with its defaults. Each estimate is
judged against the simulation's truth by its own standard error, times ``Z``: the two-sided
normal quantile of 1e-6 (about 150 comparisons in this file: a false failure once in ~7,000
runs), so the tolerance follows the noise at each rate (the 10 Hz run keeps ~1 % of the 1 kHz
run's samples, and its standard errors are ~10x wider).

Before the windows held a minimum of samples, the 10 Hz payload run ended in "0 usable
samples" (with ``--motion still``: numpy's "Mean of empty slice" and ``LinAlgError``), the 10 Hz
calibration was refused as a clock in ms, and tare refused both lower rates as not still.
"""

import warnings
from statistics import NormalDist

import numpy as np
import pytest

from fts_calib.app.cli import main
from fts_calib.core.exceptions import PayloadError, ResultRefused
from fts_calib.core.resources import resolve
from fts_calib.filters.settings import FilterConfig
from fts_calib.model.calibration import Calibration, load_calibration
from fts_calib.payload.identify import identify_payload
from fts_calib.planning.motion import plan_sweeps
from fts_calib.planning.sweeps import SweepPattern, sweep_ranges, wrist_ranges
from fts_calib.planning.trajectory_files import TrajectoryFile
from fts_calib.robot.collision import CollisionChecker
from fts_calib.robot.definition import load_robot
from fts_calib.robot.kinematics import Kinematics
from fts_calib.robot.tool import load_tool
from fts_calib.service.retare_job import tare_recording
from fts_calib.sim.payload_run import simulate_payload_motion
from fts_calib.sim.runs import decimate_recording, simulate_recording
from fts_calib.sim.sensor import load_simulated_sensor
from fts_calib.sources.recording import RecordingReader

#: An estimate is within Z of its standard errors of the truth (two-sided normal quantile of 1e-6).
Z = NormalDist().inv_cdf(1 - 1e-6 / 2)
#: Decimation factors from the 1 kHz run: 1 kHz, 100 Hz, 10 Hz.
FACTORS = {"1 kHz": 1, "100 Hz": 10, "10 Hz": 100}
LATENCY_S, JOINT_NOISE = 0.008, 1e-5  # [s], [rad]
HOME = np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0])  # [rad]
POSES = [(0.0, 0.0), (1.2, 0.0), (-1.2, 0.5), (0.6, 2.0), (-0.5, -2.2), (2.2, 1.0)]  # [rad] wrist 2 and 3


def still_poses(poses, hold_s: float, move_s: float, rate_hz: float = 1000.0):
    """Each pose held ``hold_s``, a quintic move of ``move_s`` to the next: ``(time, q, qd, qdd)`` [s, rad, rad/s, rad/s^2]."""
    targets = []
    for a, b in poses:
        q = HOME.copy()
        q[4], q[5] = a, b
        targets.append(q)
    dt, n_hold, n_move = 1.0 / rate_hz, int(round(hold_s * rate_hz)), int(round(move_s * rate_hz))
    s = np.arange(n_move) / n_move
    shape = (10 * s**3 - 15 * s**4 + 6 * s**5, (30 * s**2 - 60 * s**3 + 30 * s**4) / move_s, (60 * s - 180 * s**2 + 120 * s**3) / move_s**2)
    q, qd, qdd = [], [], []
    for k, target in enumerate(targets):
        q.append(np.tile(target, (n_hold, 1)))
        qd.append(np.zeros((n_hold, 6)))
        qdd.append(np.zeros((n_hold, 6)))
        if k + 1 < len(targets):
            step = targets[k + 1] - target
            q.append(target + np.outer(shape[0], step))
            qd.append(np.outer(shape[1], step))
            qdd.append(np.outer(shape[2], step))
    q_all = np.concatenate(q)
    return np.arange(len(q_all)) * dt, q_all, np.concatenate(qd), np.concatenate(qdd)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The calibration, payload and tare runs at each rate: ``{rate: {"cal": path, "payload": path, "tare": path}}``."""
    ur5 = Kinematics(load_robot(resolve("ur5", "robots")))
    folder = tmp_path_factory.mktemp("rates")
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    tool = load_tool(resolve("paper_tool", "configs"))
    pattern = SweepPattern(levels=2, stops=3, dwell=1.5, span=0.5)  # stops of 1.5 s: 1.0 s is the still span at 10 Hz
    checker = CollisionChecker(ur5, tool.shape, ur5.sweep_joints[0])
    ranges = wrist_ranges(ur5, checker, HOME, sweep_ranges(ur5, HOME, pattern.margin), 0.02).ranges
    plan = plan_sweeps(ur5, HOME, ranges, pattern, 1000.0)
    trajectories = [TrajectoryFile(plan.joint_names, plan.time, plan.q, plan.qd, plan.qdd, c.name) for c in tool.configurations]
    joints = {"latency_s": LATENCY_S, "joint_noise": JOINT_NOISE}
    simulate_recording(folder / "cal.csv", ur5, tool, trajectories, sensor, np.random.default_rng(3), **joints)
    payload = load_tool(resolve("validation_tool", "configs")).configurations[0]
    motion = still_poses(POSES, 1.5, 1.0)
    simulate_payload_motion(folder / "payload.csv", ur5, payload, sensor, motion, np.random.default_rng(1), LATENCY_S, JOINT_NOISE)
    held = still_poses(POSES[1:2], 3.0, 1.0)  # the arm at rest 3 s with configuration A
    tare = tool.configuration("A")
    simulate_payload_motion(folder / "tare.csv", ur5, tare, sensor, held, np.random.default_rng(2), LATENCY_S, JOINT_NOISE)
    out = {}
    for rate, factor in FACTORS.items():
        out[rate] = {name: folder / f"{name}.csv" for name in ("cal", "payload", "tare")}
        if factor > 1:
            out[rate] = {name: decimate_recording(path, folder / f"{name}_{factor}.csv", factor) for name, path in out[rate].items()}
    return out


def test_decimating_keeps_every_kth_row_as_written(runs, ur5):
    with RecordingReader(runs["1 kHz"]["tare"], ur5.joint_names, None) as full:
        every = next(iter(full))
    with RecordingReader(runs["10 Hz"]["tare"], ur5.joint_names, None) as low:
        kept = next(iter(low))
    np.testing.assert_array_equal(kept.time, every.time[::100])
    np.testing.assert_array_equal(kept.channels, every.channels[::100])
    assert np.median(np.diff(kept.time)) == pytest.approx(0.1)


def test_the_windows_hold_their_duration_or_their_minimum_of_samples():
    """At 1 kHz the durations (0.05 s, 0.1 s); at 100 Hz the derivative window 7 samples; at 10 Hz both minima."""
    f = FilterConfig()
    for dt, derivative, strain in ((1e-3, 0.05, 0.1), (1e-2, 0.06, 0.1), (0.1, 0.6, 0.4)):
        windows = f.windows(dt)
        assert windows.derivative_s == pytest.approx(derivative, rel=1e-5) and windows.strain_s == pytest.approx(strain, rel=1e-5)
    assert f.windows(0.1).text().startswith("at 10 Hz (0.1 s between samples) the filter's windows are derivative 0.6 s, 7 samples")


@pytest.fixture(scope="module")
def truth():
    sim = load_simulated_sensor(resolve("sensor", "configs"))
    return sim, load_tool(resolve("validation_tool", "configs")).configurations[0]


@pytest.mark.parametrize("rate", FACTORS)
def test_payload_mass_and_centre_of_mass_agree_at_every_rate(runs, ur5, truth, rate):
    sim, payload = truth
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "Mean of empty slice" on the way
        estimate = identify_payload(runs[rate]["payload"], ur5, Calibration(sim.C_bar, sim.D))
    assert estimate.samples >= 3 * len(POSES), estimate.samples  # at 10 Hz too: 1.5 s held, 1.0 s the still span
    assert abs(estimate.mass - payload.mass) <= Z * estimate.stderr_mass, (rate, estimate.mass, estimate.stderr_mass)
    assert np.all(np.abs(estimate.com - payload.p_sensor_com) <= Z * estimate.stderr_com), (rate, estimate.com, estimate.stderr_com)


@pytest.mark.parametrize("rate", FACTORS)
def test_calibrate_c_and_d_agree_at_every_rate(runs, truth, tmp_path, rate, capsys):
    sim, _ = truth
    out = tmp_path / "cal.yaml"
    assert main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(runs[rate]["cal"]), "-o", str(out)]) == 0
    assert "filter: quasi-static" in capsys.readouterr().out  # the still samples at every rate
    cal = load_calibration(out)
    z_c = (cal.C_bar - sim.C_bar) / np.asarray(cal.quality.stderr_C_bar)
    z_d = (cal.D - sim.D) / np.asarray(cal.quality.stderr_D)
    assert np.abs(z_c).max() <= Z and np.abs(z_d).max() <= Z, (rate, np.abs(z_c).max(), z_d)


@pytest.mark.parametrize("rate", FACTORS)
def test_tare_d_agrees_at_every_rate(runs, ur5, truth, rate):
    sim, _ = truth
    tool = load_tool(resolve("paper_tool", "configs"))
    result = tare_recording(Calibration(sim.C_bar, np.zeros(6)), runs[rate]["tare"], ur5, tool, "A")
    error = result.calibration.D - sim.D
    assert np.all(np.abs(error) <= Z * result.estimate.stderr_D), (rate, error, result.estimate.stderr_D)


def test_poses_held_shorter_than_the_still_span_are_refused_naming_the_rate_and_the_windows(tmp_path, ur5, truth):
    """Poses held 0.5 s at 10 Hz: too short for the windows there (1 s); before: LinAlgError with --motion still."""
    sim, payload = truth
    motion = still_poses(POSES, 0.5, 1.0)
    full = simulate_payload_motion(tmp_path / "short.csv", ur5, payload, sim, motion, np.random.default_rng(5), LATENCY_S, JOINT_NOISE)
    path = decimate_recording(full, tmp_path / "short_10.csv", 100)
    calibration = Calibration(sim.C_bar, sim.D)
    expected = "at 10 Hz (0.1 s between samples) the filter's windows are derivative 0.6 s, 7 samples, strain 0.4 s, 5 samples"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for motion_kind in ("auto", "still"):
            with pytest.raises(PayloadError, match="too few for a still fit") as caught:
                identify_payload(path, ur5, calibration, motion_kind)
            assert expected in str(caught.value) and "held still for 1 s or more" in str(caught.value)
        tool = load_tool(resolve("paper_tool", "configs"))
        rng = np.random.default_rng(6)
        held = simulate_payload_motion(tmp_path / "tare.csv", ur5, tool.configuration("A"), sim, motion, rng, LATENCY_S)
        with pytest.raises(ResultRefused, match="the window is not still") as refused:
            tare_recording(calibration, decimate_recording(held, tmp_path / "tare_10.csv", 100), ur5, tool, "A")
        assert expected in str(refused.value)

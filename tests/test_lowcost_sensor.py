"""A low-cost sensor: 10-bit counts with sub-count noise, a channel at its rail, a quadratic nonlinearity.

The simulated sensor is checked against its own declared properties, then the pipeline
against it: still samples of a quantized channel are kept, a quantized sensor calibrates as
well as the same sensor unquantized within the quantization noise, and railed samples are
refused, counted and named.
"""

import dataclasses
import math

import numpy as np
import pytest

from fts_calib import load_calibration
from fts_calib.core.exceptions import InsufficientExcitation
from fts_calib.core.resources import resolve
from fts_calib.filters.sample_checks import RAILED
from fts_calib.filters.settings import PipelineConfig
from fts_calib.model.channel_limits import ChannelLimits
from fts_calib.model.sensor_config import load_sensor_config
from fts_calib.robot.tool import tool_load
from fts_calib.session.session import CalibrationSession
from fts_calib.sim.sensor import SimulatedSensor
from fts_calib.sources.batch import SampleBatch

HOME = np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0])  # [rad] the UR5's calibration home
POSES = 12
RATE_HZ = 250.0
POSE_S = 1.0  # [s] still at each pose
GAP_S = 1.5  # [s] unrecorded move to the next pose
CONSTANT = PipelineConfig().with_offsets("constant")


@pytest.fixture(scope="module")
def lowcost():
    spec = load_sensor_config(resolve("lowcost_sensor", "configs"))
    return spec, SimulatedSensor.from_spec(spec.simulated)


def pose_joints(rng: np.random.Generator) -> np.ndarray:
    """Twelve static poses of the UR5: home with its three wrist joints anywhere [rad], (12, 6)."""
    joints = np.tile(HOME, (POSES, 1))
    joints[:, 3:] = rng.uniform(-np.pi, np.pi, (POSES, 3))
    return joints


def static_poses(kin, tool, joints: np.ndarray) -> tuple[SampleBatch, np.ndarray]:
    """The same poses with every configuration of the tool, still for POSE_S each: (samples, the tool's wrench (N, 6))."""
    n = int(POSE_S * RATE_HZ)
    parts, t0 = [], 0.0
    for c in range(len(tool.configurations)):
        for pose in joints:
            parts.append((t0 + np.arange(n) / RATE_HZ, np.tile(pose, (n, 1)), np.full(n, c)))
            t0 += POSE_S + GAP_S
    time, q, codes = (np.concatenate(column) for column in zip(*parts, strict=True))
    W = tool_load(kin, tool, q, codes).static
    return SampleBatch(time, q, np.zeros((len(time), 8)), codes.astype(np.int64)), W


def run_session(kin, tool, batch: SampleBatch, channels: np.ndarray, limits=None, settings=CONSTANT) -> CalibrationSession:
    session = CalibrationSession(kin, tool, settings.with_limits(limits))  # the 8 channels of the Maltese cross
    session.add_samples(dataclasses.replace(batch, channels=channels))
    session.flush()
    return session


def quiet(sensor: SimulatedSensor, noise) -> SimulatedSensor:
    """The sensor without rails in reach (every channel mid-range), linear, with the given noise [counts]."""
    return dataclasses.replace(sensor, channel_offset=np.full(8, 512.0), quadratic=0.0, noise_std=np.broadcast_to(noise, (8,)))


# -- the simulator against its own declared properties -------------------------------------------


def test_simulated_counts_lie_on_the_grid_and_stop_at_the_rails(lowcost, rng):
    _, sensor = lowcost
    W = rng.uniform(-1, 1, (5000, 6)) * np.array([60, 60, 60, 6, 6, 6])  # beyond full scale: some channels rail
    seed = int(rng.integers(2**32))
    counts = sensor.channels(W, rng=np.random.default_rng(seed))
    assert np.array_equal(counts, np.round(counts)), "10-bit counts are integers"
    assert counts.min() >= 0.0 and counts.max() <= 1023.0
    # the same readings before the converter (the same noise draws)
    analog = dataclasses.replace(sensor, adc_bits=0).channels(W, rng=np.random.default_rng(seed))
    # where they are beyond a rail, the count is that rail exactly
    assert np.all(counts[analog >= 1023.5] == 1023.0) and np.all(counts[analog <= -0.5] == 0.0)
    assert (analog > 1023.5).any() and (analog < -0.5).any()
    # within the range, rounding: at most half a count from them (and float noise)
    inside = (analog > -0.5) & (analog < 1023.5)
    assert np.max(np.abs(counts - analog)[inside]) <= 0.5 + 1e-9


@pytest.mark.parametrize(("quadratic", "cubic"), [(0.03, 0.0), (0.0, 0.02), (0.01, -0.005)])
def test_the_nonlinearity_is_its_stated_fraction_of_full_scale_at_full_load(lowcost, quadratic, cubic):
    spec, sensor = lowcost
    bent = dataclasses.replace(sensor, adc_bits=0, noise_std=np.zeros(8), quadratic=quadratic, cubic=cubic)
    linear = dataclasses.replace(bent, quadratic=0.0, cubic=0.0)
    FS = spec.full_scale
    for axis in range(6):
        for u in (1.0, -1.0, 0.5):
            W = np.zeros((1, 6))
            W[0, axis] = u * FS[axis]
            # the true linear model read back: C s + D of the readings gives the bent wrench
            read = bent.channels(W) @ bent.C.T + bent.D_readings
            expected = W[0].copy()
            expected[axis] += FS[axis] * (quadratic * u**2 + cubic * u**3)
            np.testing.assert_allclose(read[0], expected, rtol=0, atol=1e-9 * FS.max())
            # the linear sensor reads the load itself: the offsets of the readings account for channel_offset
            np.testing.assert_allclose(linear.channels(W) @ linear.C.T + linear.D_readings, W, rtol=0, atol=1e-9 * FS.max())


# -- quantized channels ---------------------------------------------------------------------------


def test_still_samples_of_subcount_channels_are_kept(lowcost, ur5, paper_tool, rng):
    """10-bit counts with 0.3 counts of noise (0.05 on three channels): still means still.

    Before the floor, the three sub-count channels read one code for seconds, their measured
    noise floor was 0, and every one-count step was "motion": 60 % of such samples were kept.
    """
    _, sensor = lowcost
    noise = np.array([0.05, 0.3, 0.05, 0.3, 0.05, 0.3, 0.3, 0.3])  # [counts]
    batch, W = static_poses(ur5, paper_tool, pose_joints(rng))
    counts = quiet(sensor, noise).channels(W, rng=rng)
    for limits in (None, ChannelLimits(np.ones(8), 0.0, 1023.0)):  # learnt from the data, or declared
        session = run_session(ur5, paper_tool, batch, counts, limits)
        kept = session.progress().kept / len(batch)
        assert kept >= 0.90, f"kept {100 * kept:.1f} % of still samples ({session.all_skipped()})"
        floor = session.filter.noise_floor
        assert np.all(floor >= 1 / math.sqrt(12) - 1e-12), f"noise floor {floor} below one count / sqrt(12)"


def test_a_quantized_sensor_calibrates_as_well_as_unquantized_within_the_quantization_noise(lowcost, ur5, paper_tool, rng):
    _, sensor = lowcost
    noise = np.array([0.05, 0.3, 0.05, 0.3, 0.05, 0.3, 0.3, 0.3])  # [counts]
    batch, W = static_poses(ur5, paper_tool, pose_joints(rng))
    seed = int(rng.integers(2**32))  # the same noise draws for both
    quantized = quiet(sensor, noise)
    analog = dataclasses.replace(quantized, adc_bits=0)
    results = {}
    for name, simulated in (("quantized", quantized), ("unquantized", analog)):
        session = run_session(ur5, paper_tool, batch, simulated.channels(W, rng=np.random.default_rng(seed)))
        results[name] = session.solve()
    # judged on loads of the same tool at new orientations, read without noise or rounding
    joints = np.tile(HOME, (300, 1))
    joints[:, 3:] = rng.uniform(-np.pi, np.pi, (300, 3))
    W_check = tool_load(ur5, paper_tool, joints, rng.integers(0, 3, 300)).static
    truth = analog.channels(W_check)
    error = {name: np.sqrt(np.mean((cal.wrench(truth) - W_check) ** 2, axis=0)) for name, cal in results.items()}
    # Tolerance. Rounding to a count adds to each channel an error of standard deviation at most
    # q = 1/sqrt(12) count; with sub-count noise it is a constant of each still pose, so it
    # averages over the P = 36 poses, not over the samples. Through C it is sigma_i = q |C_i| on
    # axis i (|C_i|: the norm of row i of C), and a least squares of p = 7 parameters per axis
    # (6 of C_bar, 1 of D) from P poses leaves an error of RMS sigma_i sqrt(p / P) at loads
    # like those of the fit. Three times that bounds it (a chi-square of 7 degrees of freedom
    # beyond 9 times its mean has a probability below 1e-9).
    q = 1 / math.sqrt(12)
    sigma = q * np.linalg.norm(quantized.C, axis=1)
    bound = error["unquantized"] + 3 * sigma * math.sqrt(7 / (3 * POSES))

    assert np.all(error["quantized"] <= bound), f"quantized {error['quantized']} unquantized {error['unquantized']} bound {bound}"
    # and the fit check judges the rounding as noise, not as a poor fit
    assert results["quantized"].quality.fit["verdict"] == "consistent", results["quantized"].quality.fit


# -- rails ------------------------------------------------------------------------------------------


def test_railed_samples_are_refused_counted_and_named(lowcost, ur5, paper_tool, rng):
    spec, sensor = lowcost
    linear = dataclasses.replace(sensor, quadratic=0.0)
    batch, W = static_poses(ur5, paper_tool, pose_joints(rng))
    counts = linear.channels(W, rng=rng)
    at_rail = (counts <= 0) | (counts >= 1023)
    assert at_rail.any(axis=1).any(), "the shipped sensor's strain_7 rails in some poses"
    session = run_session(ur5, paper_tool, batch, counts, spec.limits)
    assert session.skipped[RAILED] == int(at_rail.any(axis=1).sum())
    lines = session.checks.rails.lines(paper_tool.names)
    railed_channels = np.nonzero(at_rail.any(axis=0))[0]
    assert len(lines) == len(railed_channels)
    for line, k in zip(lines, railed_channels, strict=True):
        assert line.startswith(f"strain_{k + 1} at its rail ")
        assert line.endswith(f": {int(at_rail[:, k].sum()):,} samples")
    # the calibration without them reads the wrench; one that keeps them does not
    joints = np.tile(HOME, (300, 1))
    joints[:, 3:] = rng.uniform(-np.pi, np.pi, (300, 3))
    W_check = tool_load(ur5, paper_tool, joints, rng.integers(0, 3, 300)).static
    truth = dataclasses.replace(linear, adc_bits=0).channels(W_check)  # no noise, no rounding, no rail
    refused = session.solve()
    kept = run_session(ur5, paper_tool, batch, counts, None).solve(accept_poor_fit=True)

    def rms(cal):
        return np.sqrt(np.mean((cal.wrench(truth) - W_check) ** 2, axis=0))

    # within ten times the quantization noise through C of the fit (sqrt(7/36) of q |C_i|, see above),
    # where the railed samples leave errors of a sizeable fraction of the load
    sigma = (1 / math.sqrt(12)) * np.linalg.norm(linear.C, axis=1) * math.sqrt(7 / 36)
    assert np.all(rms(refused) <= 10 * sigma + 3 * np.linalg.norm(linear.C, axis=1) * linear.noise_std.max() / math.sqrt(36))

    assert rms(kept).max() > 10 * rms(refused).max()


# -- the command line on a static-pose recording of the shipped low-cost sensor ----------------------


@pytest.fixture(scope="module")
def lowcost_recording(tmp_path_factory, seed):
    """``fts-calib simulate --poses-only`` of the shipped UR5 trajectories through the low-cost sensor."""
    from fts_calib.app.cli import main
    from fts_calib.core.resources import data_dir

    folder = tmp_path_factory.mktemp("lowcost")
    recording = folder / "poses.csv"
    sensor = resolve("lowcost_sensor", "configs")
    args = [
        "simulate",
        "--robot",
        "ur5",
        "--tool",
        "paper_tool",
        "--trajectory",
        str(data_dir("trajectories") / "ur5"),
        "--sensor",
        str(sensor),
    ]
    assert main([*args, "--poses-only", "--seed", str(seed), "-o", str(recording)]) == 0
    # the same sensor with nothing declared of its channels: resolution and rails are detected
    undeclared = folder / "undeclared.yaml"
    undeclared.write_text("\n".join(line for line in sensor.read_text().splitlines() if not line.startswith(("adc_bits", "range"))))
    return recording, sensor, undeclared


def _recording_table(path):
    import pandas as pd

    return pd.read_csv(path)


def test_simulate_poses_only_records_the_stops_alone(lowcost_recording, ur5):
    recording, _, _ = lowcost_recording
    table = _recording_table(recording)
    joints = table[list(ur5.joint_names)].to_numpy()
    # poses: rows of one joint reading, separated by gaps in time (the unrecorded moves)
    moves = np.nonzero(np.any(np.diff(joints, axis=0) != 0, axis=1))[0]
    assert len(moves) >= 10
    assert np.all(np.diff(table["time"].to_numpy())[moves] > 0.01), "a pose changes only across a gap"
    assert np.array_equal(table.filter(like="strain_").to_numpy(), np.round(table.filter(like="strain_").to_numpy()))


def test_calibrate_detects_an_undeclared_rail_refuses_its_samples_and_names_it(lowcost_recording, tmp_path, capsys):
    from fts_calib.app.cli import main

    recording, _, undeclared = lowcost_recording
    out = tmp_path / "cal.yaml"
    code = main(
        [
            "calibrate",
            "--robot",
            "ur5",
            "--tool",
            "paper_tool",
            str(recording),
            "--sensor",
            str(undeclared),
            "-o",
            str(out),
            "--accept-poor-fit",
        ]
    )
    text = capsys.readouterr().out
    assert code == 0, text
    strain_7 = _recording_table(recording)["strain_7"].to_numpy()
    railed = int(np.sum(strain_7 == 1023))
    assert railed > 0, "the shipped sensor's strain_7 rails in some poses"
    assert "detected in the data, not declared in the sensor file: high rail of strain_7 at 1023" in text
    counted = next(line for line in text.splitlines() if line.strip().startswith(RAILED))
    assert counted.split()[-1] == f"{railed:,}", counted
    named = next(line for line in text.splitlines() if "strain_7 at its rail 1023 in" in line)
    assert named.endswith(f": {railed:,} samples"), named
    assert load_calibration(out).quality.skipped[RAILED] == railed
    dwell = load_calibration(out).health["dwell"]  # the channels' stays in one code at the still poses, learnt
    rate = 1.0 / float(np.median(np.diff(_recording_table(recording)["time"].to_numpy())))
    assert dwell["segments"] >= 10 and dwell["rate_hz"] == pytest.approx(rate, rel=1e-3), dwell


def test_validate_json_holds_the_errors_an_independent_computation_finds(lowcost_recording, ur5, paper_tool, tmp_path):
    import json

    from fts_calib.app.cli import main
    from fts_calib.model.calibration import Calibration, save_calibration

    recording, sensor_file, _ = lowcost_recording
    sensor = SimulatedSensor.from_spec(load_sensor_config(sensor_file).simulated)
    calibration = save_calibration(Calibration(sensor.C_bar, sensor.D_readings), tmp_path / "true.yaml")
    report = tmp_path / "report.json"
    args = [
        "validate",
        str(recording),
        "--calibration",
        str(calibration),
        "--robot",
        "ur5",
        "--tool",
        "paper_tool",
        "--sensor",
        str(sensor_file),
    ]
    assert main([*args, "--static", "--json", str(report)]) == 0
    written = json.loads(report.read_text())
    assert set(written) == {"axes", "samples"} and list(written["axes"]) == ["Fx", "Fy", "Fz", "Mx", "My", "Mz"]
    # independently: every row with no channel at 0 or 1023 counts, its error is C s + D - the tool's weight
    table = _recording_table(recording)
    channels = table.filter(like="strain_").to_numpy()
    rows = ~np.any((channels <= 0) | (channels >= 1023), axis=1)
    codes = np.array([paper_tool.names.index(name) for name in table["tool"]])
    W = tool_load(ur5, paper_tool, table[list(ur5.joint_names)].to_numpy()[rows], codes[rows]).static
    error = channels[rows] @ sensor.C.T + sensor.D_readings - W
    assert written["samples"] == int(rows.sum()) < len(table)
    for i, axis in enumerate(written["axes"]):
        scale = np.abs(W[:, i]).max()  # BLAS may sum in another order: 1e-9 of the axis's load
        assert written["axes"][axis]["rms"] == pytest.approx(np.sqrt(np.mean(error[:, i] ** 2)), abs=1e-9 * scale)
        assert written["axes"][axis]["max"] == pytest.approx(np.abs(error[:, i]).max(), abs=1e-9 * scale)


def test_tare_refuses_the_samples_of_a_channel_stuck_at_its_rail(lowcost, ur5, tmp_path, rng):
    from fts_calib.model.calibration import Calibration
    from fts_calib.service.retare_job import tare_recording
    from fts_calib.sources.recording import RecordingWriter

    _, sensor = lowcost
    counts = quiet(sensor, 0.3).channels(np.zeros((500, 6)), rng=rng)  # nothing mounted
    counts[:200, 6] = 1023.0  # strain_7 stuck at the top of the converter for the first 200
    path = tmp_path / "tare.csv"
    with RecordingWriter(path, ur5.joint_names, 8) as writer:
        writer.write(np.arange(500) / RATE_HZ, np.tile(HOME, (500, 1)), counts, "nothing")
    linear = quiet(sensor, 0.3)
    result = tare_recording(Calibration(linear.C_bar, np.zeros(6)), path)
    assert result.rails == ("strain_7 at its rail 1023 in 1 pose (nothing 1): 200 samples",)
    assert result.estimate.samples_used == 300
    # the offsets from the 300 others: the true ones of the readings, within 5 sigma of their mean plus the
    # rounding's bias (one load: a constant; with 0.3 counts of noise at most 0.05 count a channel, so
    # at most 0.05 sqrt(8) |C_i| < |C_i| / sqrt(12) on axis i)
    sigma = 0.3 * np.linalg.norm(linear.C, axis=1) / math.sqrt(300)
    assert np.all(np.abs(result.estimate.D - linear.D_readings) <= 5 * sigma + np.linalg.norm(linear.C, axis=1) / math.sqrt(12))
    # stuck all along: no sample is left, and the error says why
    counts[:, 6] = 1023.0
    with RecordingWriter(path, ur5.joint_names, 8) as writer:
        writer.write(np.arange(500) / RATE_HZ, np.tile(HOME, (500, 1)), counts, "nothing")
    with pytest.raises(InsufficientExcitation, match=r"a channel is at its rail \(strain_7 at its rail 1023 in 1 pose"):
        tare_recording(Calibration(linear.C_bar, np.zeros(6)), path)


def test_validate_json_never_overwrites_an_input(lowcost_recording, tmp_path, capsys):
    from fts_calib.app.cli import main
    from fts_calib.app.exit_codes import exit_code
    from fts_calib.core.exceptions import ConfigError
    from fts_calib.model.calibration import Calibration, save_calibration

    recording, sensor_file, _ = lowcost_recording
    sensor = SimulatedSensor.from_spec(load_sensor_config(sensor_file).simulated)
    calibration = save_calibration(Calibration(sensor.C_bar, sensor.D_readings), tmp_path / "true.yaml")
    before = calibration.read_bytes()
    code = main(["validate", str(recording), "--calibration", str(calibration), "--robot", "ur5", "--json", str(calibration)])
    err = capsys.readouterr().err
    assert code == exit_code(ConfigError("json", None, "")), err
    assert "--json" in err and "calibration 1" in err, err
    assert calibration.read_bytes() == before


def test_a_resumed_session_keeps_its_railed_counts(lowcost, ur5, paper_tool, tmp_path, rng):
    spec, sensor = lowcost
    batch, W = static_poses(ur5, paper_tool, pose_joints(rng))
    counts = dataclasses.replace(sensor, quadratic=0.0).channels(W, rng=rng)
    settings = CONSTANT.with_limits(spec.limits)
    whole = run_session(ur5, paper_tool, batch, counts, spec.limits)
    half = len(batch) // 2
    first = CalibrationSession(ur5, paper_tool, settings, checkpoint=tmp_path / "run.checkpoint.json")
    first.add_samples(dataclasses.replace(batch.rows(0, half), channels=counts[:half]))
    first.checkpoint()
    resumed = CalibrationSession.resume(tmp_path / "run.checkpoint.json", ur5, paper_tool, settings)
    resumed.add_samples(dataclasses.replace(batch.rows(half, len(batch)), channels=counts[half:]))
    resumed.flush()
    assert resumed.skipped[RAILED] == whole.skipped[RAILED] > 0
    assert resumed.checks.rails.lines(paper_tool.names) == whole.checks.rails.lines(paper_tool.names)


def test_payload_refuses_railed_samples_and_finds_the_mass(lowcost, ur5, paper_tool, tmp_path, rng):
    from fts_calib.model.calibration import Calibration
    from fts_calib.payload.identify import identify_payload
    from fts_calib.sources.recording import RecordingWriter

    _, sensor = lowcost
    linear = dataclasses.replace(sensor, quadratic=0.0)
    n = int(POSE_S * RATE_HZ)
    joints = np.repeat(pose_joints(rng), n, axis=0)
    time = np.repeat(np.arange(POSES) * (POSE_S + GAP_S), n) + np.tile(np.arange(n) / RATE_HZ, POSES)
    W = tool_load(ur5, paper_tool, joints, 0).static  # configuration A: strain_7 within its range
    W[: 2 * n] += np.array([0.0, 0.0, 60.0, 0.0, 0.0, 0.0])  # the first two poses pressed: strain_7 at its rail there
    counts = linear.channels(W, rng=rng)
    assert np.all(counts[: 2 * n, 6] == 1023.0), "the pressed poses rail"
    path = tmp_path / "payload.csv"
    with RecordingWriter(path, ur5.joint_names, 8) as writer:
        writer.write(time, joints, counts, "A")
    railed = int(np.sum(np.any((counts <= 0) | (counts >= 1023), axis=1)))
    # random poses: some closer than the 15° a payload wizard asks for; they determine it all the same
    found = identify_payload(path, ur5, Calibration(linear.C_bar, linear.D_readings), "still")
    assert len(found.rails) == 1 and found.rails[0].startswith("strain_7 at its rail 1023 in ")
    assert found.rails[0].endswith(f": {railed:,} samples")
    # the pressed poses would pull the mass by about 60 N / 9.81 m/s^2 over a sixth of the samples
    # (1 kg); without them: the noise of 1 count through C (about 0.4 N on a force axis) over
    # the samples left, and the rounding bias of each pose (|C_i| / sqrt(12), over >= 2 poses)
    mass = paper_tool.configurations[0].mass
    assert abs(found.mass - mass) < 0.05 * mass, found

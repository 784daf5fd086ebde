"""The dynamic filter (filter.mode: dynamic): moving samples calibrate, against an independent dynamics model.

The recordings are continuous motions of the UR5 with no still sample (tests/dynamic_motion.py),
the tool's wrench from Pinocchio's RNEA on an attached body (fts_calib.sim.rnea), while the
calibration predicts it with its own Newton-Euler (fts_calib.robot.tool) on its own
kinematics. True C: the paper's Table 1 (the simulated sensor of configs/sensor.yaml).
"""

import dataclasses

import numpy as np
import pytest

from fts_calib.core.exceptions import FileFormatError, InsufficientExcitation, PoorFit
from fts_calib.core.resources import resolve
from fts_calib.filters.dynamic import DynamicFilter, nominal_c, third_difference_noise, trust_weights
from fts_calib.filters.joint_rates import joint_rates, kernel_gains
from fts_calib.filters.settings import FilterConfig, PipelineConfig, load_pipeline_config
from fts_calib.model.sensor_config import load_sensor_config
from fts_calib.session.calibration_run import calibrate_recording
from fts_calib.session.session import CalibrationSession
from fts_calib.sim.sensor import SimulatedSensor
from fts_calib.sources.writer import RecordingWriter
from tests.dynamic_motion import error_percent_fs, motion, noiseless, recording

SPEC = load_sensor_config(resolve("sensor", "configs"))
SENSOR = SimulatedSensor.from_spec(SPEC.simulated)
DYNAMIC = PipelineConfig(filter=FilterConfig(mode="dynamic")).with_nominal_c(nominal_c(SPEC)).with_offsets("constant")
# every error source of the trust rule zero: a perfectly known tool, exact rates, no latency uncertainty
EXACT = dataclasses.replace(
    DYNAMIC, filter=FilterConfig(mode="dynamic", latency_s=0.0, latency_uncertainty_s=0.0, inertia_tolerance=0.0, max_error_ratio=1e300)
)


def session_of(kin, tool, settings, batches, rates=True, chunk=None, model="linear"):
    session = CalibrationSession(kin, tool, settings, full_scale=SPEC.full_scale, model=model)
    for batch, exact in batches:
        if chunk is None:
            session.add_samples(batch, exact if rates else None)
            continue
        for start in range(0, len(batch), chunk):
            part = slice(start, start + chunk)
            session.add_samples(batch.rows(start, start + chunk), (exact[0][part], exact[1][part]) if rates else None)
    session.flush()
    return session


def test_noiseless_moving_samples_recover_c_exactly(ur5, paper_tool):
    """Exact joint rates (a controller's), a noiseless sensor: C and D to 1e-9, from moving samples only."""
    tool = dataclasses.replace(paper_tool, tolerance=None)
    batches = recording(ur5, tool, noiseless(SENSOR))
    for _, (velocity, _) in batches:  # no still sample: every one beyond the quasi-static speed limit
        assert np.min(np.max(np.abs(velocity), axis=1)) > FilterConfig().max_joint_speed
    session = session_of(ur5, tool, EXACT, batches)
    calibration = session.solve()
    assert session.progress().kept == sum(len(b) for b, _ in batches)  # every sample kept, weight 1
    assert np.max(np.abs(calibration.C_bar - SPEC.simulated.C_bar)) <= 1e-9 * np.max(np.abs(SPEC.simulated.C_bar))
    assert np.max(np.abs(calibration.D - SPEC.simulated.D) / SPEC.full_scale) <= 1e-9
    quasi_static = CalibrationSession(ur5, tool, PipelineConfig(), full_scale=SPEC.full_scale)
    for batch, _ in batches:
        quasi_static.add_samples(batch)
    quasi_static.flush()
    assert quasi_static.progress().kept == 0  # the default filter keeps none of them
    with pytest.raises(InsufficientExcitation):
        quasi_static.solve()


def test_noiseless_joint_readings_through_the_derivative_filter(ur5, paper_tool):
    """The rates estimated from exact readings (local quintic, 0.3 s): C within 1e-6 of its largest coefficient."""
    tool = dataclasses.replace(paper_tool, tolerance=None)
    batches = recording(ur5, tool, noiseless(SENSOR))
    settings = dataclasses.replace(EXACT, filter=dataclasses.replace(EXACT.filter, joint_noise=0.0))
    session = session_of(ur5, tool, settings, batches, rates=False)
    calibration = session.solve()
    kept = session.progress().kept
    assert kept >= 0.85 * sum(len(b) for b, _ in batches)  # the first and last 0.3 s of each motion: a cut window
    assert np.max(np.abs(calibration.C_bar - SPEC.simulated.C_bar)) <= 1e-6 * np.max(np.abs(SPEC.simulated.C_bar))
    assert np.max(error_percent_fs(calibration, SPEC.simulated, SPEC.full_scale)) <= 1e-5


def test_chunks_do_not_change_the_result(ur5, paper_tool):
    tool = dataclasses.replace(paper_tool, tolerance=None)
    batches = recording(ur5, tool, noiseless(SENSOR), seconds=3.0)
    whole = session_of(ur5, tool, EXACT, batches, rates=False).solve()
    chunked = session_of(ur5, tool, EXACT, batches, rates=False, chunk=777).solve()
    np.testing.assert_allclose(chunked.C_bar, whole.C_bar, rtol=0, atol=1e-9 * np.max(np.abs(whole.C_bar)))


@pytest.mark.parametrize("offset", [0, 1, 2])
def test_late_noisy_joints_calibrate_within_the_budget(ur5, paper_tool, seed, offset, tmp_path):
    """Joints 8 ms late with 1e-5 rad of noise, a noisy 24-bit sensor, 5 s of motion per configuration.

    ``calibrate`` with ``latency_s: auto`` fits the latency on a first read and applies it on the
    second; the error over the full-scale box stays within the issue's 0.01 % FS (seen over seeds
    0-4: at most 0.0037 % FS, the latency within 4 us of 8 ms, 10,700 to 11,000 of 15,000 samples kept).
    """
    rng = np.random.default_rng(seed + 100 * offset)
    path = tmp_path / "moving.csv"
    with RecordingWriter(path, ur5.joint_names) as writer:
        for batch, _ in recording(ur5, paper_tool, SENSOR, lag_s=0.008, joint_noise=1e-5, rng=rng):
            writer.write(batch.time, batch.joints, batch.channels, paper_tool.names[int(batch.configuration[0])])
    result = calibrate_recording(path, ur5, paper_tool, DYNAMIC, layout=SPEC.layout, full_scale=SPEC.full_scale, model="linear")
    assert result.calibration is not None, result.error
    applied = result.session.filter.latency_s
    assert abs(applied - 0.008) <= 5e-5, applied
    error = error_percent_fs(result.calibration, SPEC.simulated, SPEC.full_scale)
    assert np.all(error <= 0.01), error
    assert result.session.progress().kept >= 0.5 * 15_000
    assert result.calibration.quality.fit["verdict"] == "consistent"  # the moving samples' residual at the noise


def test_a_wrong_inertia_fails_the_fit_check(ur5, paper_tool, seed):
    """The fit check of the dynamic mode judges the moving samples' residual: a tool file with three times the inertia is refused."""
    rng = np.random.default_rng(seed)
    batches = recording(ur5, paper_tool, SENSOR, joint_noise=1e-5, rng=rng, seconds=4.0)
    settings = dataclasses.replace(DYNAMIC, filter=dataclasses.replace(DYNAMIC.filter, latency_s=0.0, latency_uncertainty_s=2e-5))
    wrong = dataclasses.replace(
        paper_tool, configurations=tuple(dataclasses.replace(c, inertia_com=3.0 * c.inertia_com) for c in paper_tool.configurations)
    )
    assert session_of(ur5, paper_tool, settings, batches, rates=False).fit_check().verdict == "consistent"  # seen: ratio 0.5
    with pytest.raises(PoorFit):
        session_of(ur5, wrong, settings, batches, rates=False).solve()  # seen: ratio 12


def test_realistic_sensor_calibrates(ur5, paper_tool, seed):
    """Quantized (24-bit ADC), a little nonlinearity (0.02 % FS at full load), late noisy joints: the linear C to its floor.

    The error is that of the calibration's wrench from the bent sensor's channels, over the
    full-scale box; the linear model leaves the nonlinearity (seen over seeds 0-2: at most
    0.0112 % FS, against the 0.02 % the quadratic term reaches at full load).
    """
    rng = np.random.default_rng(seed)
    sensor = dataclasses.replace(SENSOR, quadratic=2e-4)
    batches = recording(ur5, paper_tool, sensor, lag_s=0.008, joint_noise=1e-5, rng=rng)
    settings = dataclasses.replace(DYNAMIC, filter=dataclasses.replace(DYNAMIC.filter, latency_s=0.008, latency_uncertainty_s=2e-5))
    session = session_of(ur5, paper_tool, settings, batches, rates=False)
    calibration = session.solve()
    W = np.random.default_rng(1).uniform(-1.0, 1.0, (4000, 6)) * SPEC.full_scale
    error = 100.0 * np.sqrt(np.mean((calibration.wrench(sensor.channels(W)) - W) ** 2, axis=0)) / SPEC.full_scale
    assert np.all(error <= 0.02), error


def test_the_derivative_filter_is_exact_on_a_quintic_and_shifts_by_the_latency():
    t = np.arange(0.0, 2.0, 0.001)
    coefficients = np.array([0.3, -0.2, 0.5, 0.1, -0.05, 0.02])
    q = np.polynomial.polynomial.polyval(t, coefficients)[:, None]
    out = joint_rates(t, q, 0.3, 0.001, None, shift_s=0.008, order=5)
    later = t + 0.008
    inner = out.full
    d1, d2 = np.polynomial.polynomial.polyder(coefficients), np.polynomial.polynomial.polyder(coefficients, 2)
    assert inner.sum() == len(t) - 300
    np.testing.assert_allclose(out.joints[inner, 0], np.polynomial.polynomial.polyval(later[inner], coefficients), atol=1e-10)
    np.testing.assert_allclose(out.velocity[inner, 0], np.polynomial.polynomial.polyval(later[inner], d1), atol=1e-9)
    np.testing.assert_allclose(out.acceleration[inner, 0], np.polynomial.polynomial.polyval(later[inner], d2), atol=1e-8)
    # without the cut-window fit (the dynamic filter drops those samples): the same whole windows, the readings and no rates elsewhere
    bare = joint_rates(t, q, 0.3, 0.001, None, shift_s=0.008, order=5, cut=False)
    for name in ("joints", "velocity", "acceleration"):
        np.testing.assert_array_equal(getattr(bare, name)[inner], getattr(out, name)[inner])
    np.testing.assert_array_equal(bare.joints[~inner], q[~inner])
    assert not bare.velocity[~inner].any() and not bare.acceleration[~inner].any() and out.acceleration[~inner].all()


def test_noise_gains_are_those_of_the_kernels(rng):
    """White joint noise reaches velocity and acceleration with the gains the trust rule uses (Monte Carlo, 5 %)."""
    t = np.arange(0.0, 20.0, 0.001)
    noise = 1e-5 * rng.standard_normal((len(t), 4))
    out = joint_rates(t, noise, 0.3, 0.001, None, order=5)
    gain_v, gain_a, _, _ = kernel_gains(0.3, 0.001, 5)
    assert np.std(out.velocity[out.full]) == pytest.approx(gain_v * 1e-5, rel=0.05)
    assert np.std(out.acceleration[out.full]) == pytest.approx(gain_a * 1e-5, rel=0.05)
    assert third_difference_noise(noise + np.sin(t)[:, None]) == pytest.approx(np.full(4, 1e-5), rel=0.05)


def test_trust_weights_and_drops():
    sigma = np.ones(6)
    random = np.zeros((3, 6))
    systematic = np.zeros((3, 6))
    random[1, 2] = 2.0  # random error twice the noise: weight 1/5, kept
    systematic[2, 4] = 3.5  # a bias beyond 3 noises: dropped
    weight, trusted = trust_weights(random, systematic, sigma, 3.0)
    np.testing.assert_allclose(weight, [1.0, 0.2, 1.0 / (1.0 + 3.5**2)])
    assert trusted.tolist() == [True, True, False]


def test_an_inertia_known_only_roughly_drops_the_fast_turns(ur5, paper_tool):
    batches = recording(ur5, paper_tool, noiseless(SENSOR), seconds=3.0)
    counts = []
    for tolerance in (0.0, 1.0):
        settings = dataclasses.replace(EXACT, filter=dataclasses.replace(EXACT.filter, inertia_tolerance=tolerance, max_error_ratio=3.0))
        session = session_of(ur5, paper_tool, settings, batches)
        assert isinstance(session.filter, DynamicFilter)
        counts.append(session.filter.rejected["expected wrench not trusted"])
    assert counts[0] == 0 and counts[1] > 0


def test_the_settings_file_takes_the_mode(tmp_path):
    path = tmp_path / "pipeline.yaml"
    path.write_text("filter:\n  mode: dynamic\n  latency_s: auto\n  joint_noise: 1.0e-5\n  dynamic_window_s: 0.2\n")
    settings = load_pipeline_config(path)
    assert settings.filter.mode == "dynamic" and settings.filter.latency_s is None and settings.filter.joint_noise == 1e-5
    path.write_text("filter:\n  mode: moving\n")
    with pytest.raises(FileFormatError, match="quasi-static or dynamic"):
        load_pipeline_config(path)
    assert motion(np.zeros(1), 0)[0].shape == (1, 6)


def test_live_feeds_calibrate_in_dynamic_mode(ur5, paper_tool, seed, tmp_path):
    """`live --filter dynamic`: the recording replayed as datagrams gives the calibration of `calibrate` on it (within 20 % of its
    standard errors: the synchronizer interpolates the joints at the strain times, and keeps ~0.2 % other samples; the standard
    errors count each weighted sample as one observation, the weights being inverse variances)."""
    import threading

    from fts_calib.session.calibration_run import LiveRunner
    from fts_calib.sources.live_feed import LiveFeed, StreamEnd
    from fts_calib.sources.sender import ReplayOptions, replay
    from fts_calib.sources.synchronizer import Synchronizer
    from fts_calib.sources.udp import UdpReceiver

    rng = np.random.default_rng(seed)
    path = tmp_path / "moving.csv"
    with RecordingWriter(path, ur5.joint_names) as writer:
        for batch, _ in recording(ur5, paper_tool, SENSOR, seconds=3.0, joint_noise=1e-5, rng=rng):
            writer.write(
                batch.time - batch.time[0] + 4.0 * batch.configuration[0],
                batch.joints,
                batch.channels,
                paper_tool.names[batch.configuration[0]],
            )
    settings = dataclasses.replace(DYNAMIC, filter=dataclasses.replace(DYNAMIC.filter, latency_s=0.0, latency_uncertainty_s=2e-5))
    reference = calibrate_recording(path, ur5, paper_tool, settings, layout=SPEC.layout, full_scale=SPEC.full_scale, model="linear")
    session = CalibrationSession(ur5, paper_tool, settings, full_scale=SPEC.full_scale, model="linear")
    receiver = UdpReceiver("127.0.0.1", 0)
    sync = Synchronizer(ur5.joint_names, ur5.continuous, 0.05, 0.0, configurations=paper_tool.names)
    runner = LiveRunner(session, LiveFeed(receiver, sync, end=StreamEnd(idle_timeout_s=10.0)))
    result = {}
    thread = threading.Thread(target=lambda: result.update(stats=runner.run()))
    thread.start()
    try:
        replay(path, *receiver.address, ReplayOptions(speed=4.0))  # the session keeps up: at 20x a loaded machine drops datagrams
        thread.join(timeout=60)
    finally:
        receiver.close()
    assert not thread.is_alive() and result["stats"].ended
    got = session.solve()
    assert isinstance(session.filter, DynamicFilter) and session.progress().kept >= 0.9 * reference.session.progress().kept
    assert np.all(np.abs(got.C - reference.calibration.C) <= 0.2 * reference.calibration.quality.stderr_C + 1e-12)

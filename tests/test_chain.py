"""The filter chain: built in one place, one pass equal to its parts by hand, the same for every job that selects samples."""

import dataclasses

import numpy as np
import pytest

from fts_calib.core.exceptions import ConfigError, ShapeError
from fts_calib.filters.chain import NO_FILTER, filter_chain
from fts_calib.filters.dynamic import DynamicFilter
from fts_calib.filters.quasi_static import QuasiStaticFilter, held_still, quasi_static, window_moves
from fts_calib.filters.sample_checks import NON_FINITE, SampleChecks
from fts_calib.filters.settings import DYNAMIC, QUASI_STATIC, FilterConfig, PipelineConfig
from fts_calib.robot.tool import tool_load
from fts_calib.sources.batch import SampleBatch
from fts_calib.sources.recording import RecordingReader

HOME = np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0])  # [rad] a UR5 pose clear of its limits


def _stream(path, kin, tool):
    with RecordingReader(path, kin.joint_names, tool.names) as reader:
        return SampleBatch.concatenate(list(reader))


def test_the_chain_is_the_checks_then_the_filter_by_hand(ur5, paper_tool, ur5_recording):
    """One pass through the chain keeps what SampleChecks then quasi_static keep, with the same load, to the bit."""
    stream = _stream(ur5_recording, ur5, paper_tool)
    stream = dataclasses.replace(stream, channels=stream.channels.copy())
    stream.channels[::997, 3] = np.nan  # a few bad samples for the checks
    chain = filter_chain(PipelineConfig(), ur5)
    step = chain.samples(stream, paper_tool, final=True)
    checks = SampleChecks(ur5)
    ok = checks.accept(stream)
    by_hand = quasi_static(QuasiStaticFilter(FilterConfig(), ur5.continuous), ur5, paper_tool, stream.select(ok), final=True)
    assert chain.mode == QUASI_STATIC and chain.checks.skipped[NON_FINITE] == int((~ok).sum()) > 0
    assert np.array_equal(step.checked.time, stream.time[ok])
    assert np.array_equal(step.still.keep, by_hand.keep) and step.still.keep.sum() > 1000
    assert np.array_equal(step.still.w_sensor, by_hand.w_sensor) and np.array_equal(step.still.g_sensor, by_hand.g_sensor)
    assert np.array_equal(step.still.still, by_hand.still)  # rules 1-3, before the dynamic rule
    assert chain.skipped()[NON_FINITE] == checks.skipped[NON_FINITE] and "filter: joint speed" in chain.skipped()


def test_the_modes_and_their_refusals(ur5, paper_tool, ur5_recording):
    stream = _stream(ur5_recording, ur5, paper_tool).rows(0, 500)
    none = filter_chain(PipelineConfig(), ur5, NO_FILTER)
    step = none.samples(stream, paper_tool)
    assert none.filter is None and step.still.keep.all() and len(step.kept) == 500
    np.testing.assert_array_equal(step.still.w_sensor, tool_load(ur5, paper_tool, stream.joints, stream.configuration).static)
    unknown = filter_chain(PipelineConfig(), ur5, NO_FILTER).samples(stream, None)  # an unknown payload: gravity alone
    assert unknown.still.w_sensor is None and unknown.still.g_sensor.shape == (500, 3)
    assert isinstance(filter_chain(PipelineConfig().with_filter_mode(DYNAMIC), ur5).filter, DynamicFilter)
    assert filter_chain(PipelineConfig().with_filter_mode(DYNAMIC), ur5, QUASI_STATIC).mode == QUASI_STATIC  # a job's own mode
    with pytest.raises(ConfigError, match="'slow'"):
        filter_chain(PipelineConfig(), ur5, "slow")
    with pytest.raises(ShapeError, match="exact joint rates are for filter.mode 'dynamic'"):
        filter_chain(PipelineConfig(), ur5).samples(stream, paper_tool, rates=(stream.joints, stream.joints))
    with pytest.raises(ConfigError, match="kinematics"):
        filter_chain(PipelineConfig(), None, DYNAMIC)


def test_without_kinematics_the_strains_alone_decide(rng):
    """No robot: no joint limits checked, no load known; still strains pass, then a strain ramp does not (the strain rule)."""
    t = np.arange(4000) / 1000.0  # [s]
    channels = 1e-4 * rng.standard_normal((4000, 8))  # [raw] noise only for 2 s (the noise floor is measured there)
    channels[2000:] += np.linspace(0.0, 1.0, 2000)[:, None]  # then a load changing all along
    batch = SampleBatch(t, np.zeros((4000, 0)), channels, np.zeros(4000, dtype=np.int64))
    step = filter_chain(PipelineConfig(), None).samples(batch, None, final=True)
    first, second = step.still.keep[:1900].mean(), step.still.keep[2100:].mean()
    assert first > 0.9 and second < 0.01, (first, second)
    assert np.all(np.isnan(step.still.g_sensor))
    with_joints = dataclasses.replace(batch, joints=np.outer(t, [0.0, 0.5]))  # a joint column moving at 0.5 rad/s, no kinematics
    assert not filter_chain(PipelineConfig(), None, n_joints=2).samples(with_joints, None, final=True).still.keep.any()


def test_held_still_is_the_filters_joint_rules_by_brute_force(short_plan):
    """Every sample within half a strain window (by time) slow and steady: at 100 Hz, and at 25 Hz where the window
    holds its minimum of samples (5: 0.16 s, not 0.1 s)."""
    settings = FilterConfig()
    for stride in (1, 4):  # 100 Hz, and 25 Hz: windows of other sample counts
        time, qd, qdd = short_plan.time[::stride], short_plan.qd[::stride], short_plan.qdd[::stride]
        speed_ok, accel_ok, _, _ = held_still(time, qd, qdd, settings)
        ok = (np.max(np.abs(qd), axis=1) <= settings.max_joint_speed) & (np.max(np.abs(qdd), axis=1) <= settings.max_joint_acceleration)
        dt = float(np.median(np.diff(time)))
        half = max(settings.strain_window_s, (settings.strain_min_samples - 1) * dt * (1 + 1e-6)) / 2  # [s] t - half .. t + half
        assert stride == 1 or half == pytest.approx(0.08)
        near = (time[None, :] >= time[:, None] - half) & (time[None, :] <= time[:, None] + half)
        brute = np.array([ok[row].all() for row in near])
        assert np.array_equal(speed_ok & accel_ok, brute) and 0 < brute.sum() < len(brute)


def test_a_window_moves_beyond_the_joint_speed_rule():
    """100 samples at 1 kHz: 0.1 s, so 1 mrad of travel at the default 0.01 rad/s; 10 % either side decides."""
    time = np.arange(100) / 1000.0  # [s]
    settings = FilterConfig()
    for speed, moves in ((0.9 * settings.max_joint_speed, False), (1.1 * settings.max_joint_speed, True)):
        joints = np.outer(time, [0.0, speed, 0.0])
        assert window_moves(time, joints, settings) is moves
    assert window_moves(time, np.outer(time, [0.0, 0.02, 0.0]), dataclasses.replace(settings, max_joint_speed=0.03)) is False
    assert window_moves(time, np.zeros((100, 0)), settings) is False  # no joints: nothing moves


def test_validate_takes_its_joint_rate_window_from_the_settings(ur5, paper_tool, ur5_recording):
    """The moving tool's expected wrench from the chain's derivative window: another window, other rates, other errors."""
    from fts_calib.core.resources import resolve
    from fts_calib.model.calibration import Calibration
    from fts_calib.service.validation import validate_recording
    from fts_calib.sim.sensor import load_simulated_sensor

    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    true = Calibration(sensor.C_bar, sensor.D)
    full_scale = np.array([50.0, 50.0, 50.0, 5.0, 5.0, 5.0])
    default = validate_recording(ur5_recording, ur5, paper_tool, [true], full_scale)
    same = validate_recording(ur5_recording, ur5, paper_tool, [true], full_scale, settings=PipelineConfig())
    wide = PipelineConfig(filter=FilterConfig(derivative_window_s=0.4))
    other = validate_recording(ur5_recording, ur5, paper_tool, [true], full_scale, settings=wide)
    assert np.array_equal(default.errors[0].rms, same.errors[0].rms)
    assert not np.array_equal(default.errors[0].rms, other.errors[0].rms)

"""The quasi-static filter: rules, chunk independence, the windowed deviation."""

import numpy as np
import pytest

from fts_calib.filters.quasi_static import QuasiStaticFilter, quasi_static, window_bounds, windowed_std
from fts_calib.filters.settings import FilterConfig
from fts_calib.sources.batch import SampleBatch
from fts_calib.sources.recording import RecordingReader


def test_windowed_std_equals_the_direct_computation(rng):
    t = np.cumsum(rng.uniform(0.0008, 0.0012, 3000))
    x = np.column_stack([0.1 + 1e-5 * rng.standard_normal(3000), np.sin(3 * t), np.full(3000, 0.123)])
    index = np.arange(3000)
    left, right = window_bounds(t, index, 0.05)
    direct = np.array([x[a : b + 1].std(axis=0) for a, b in zip(left, right, strict=True)])
    got = windowed_std(x, left, right)
    # running sums lose digits to the mean of each column, so their round-off follows the column's
    # scale (spreads of 1e-5 and up to 0.09), not each entry (the sine's spread varies 25-fold)
    for k, column in enumerate(("noise", "sine")):
        np.testing.assert_allclose(got[:, k], direct[:, k], rtol=0, atol=1e-7 * np.abs(direct[:, k]).max(), err_msg=column)
    assert np.all(got[:, 2] == 0.0)  # a constant has no spread, exactly


def _stream(path, kin, tool):
    with RecordingReader(path, kin.joint_names, tool.names) as reader:
        return SampleBatch.concatenate(list(reader))


def _decide(settings, kin, tool, t, q, s, k):
    """The filter's whole decision (its four rules) over one batch: the kept mask, shape (N,)."""
    filt = QuasiStaticFilter(settings, kin.continuous)
    return filt, quasi_static(filt, kin, tool, SampleBatch(t, q, s, k), final=True).keep


def test_decisions_do_not_depend_on_where_chunks_end(ur5, paper_tool, ur5_recording, rng):
    stream = _stream(ur5_recording, ur5, paper_tool)
    n = len(stream)
    whole = quasi_static(QuasiStaticFilter(FilterConfig(), ur5.continuous), ur5, paper_tool, stream, final=True)
    filt = QuasiStaticFilter(FilterConfig(), ur5.continuous)
    cuts = np.sort(rng.choice(n, 25, replace=False))
    parts = [quasi_static(filt, ur5, paper_tool, stream.rows(i, j)) for i, j in zip([0, *cuts], [*cuts, n], strict=True)]
    parts.append(quasi_static(filt, ur5, paper_tool, stream.rows(0, 0), final=True))
    keep = np.concatenate([p.keep for p in parts])
    assert np.array_equal(np.concatenate([p.decided.time for p in parts]), stream.time)
    # the noise floor is learnt chunk by chunk: decisions agree but for a handful of borderline samples
    assert np.sum(keep != whole.keep) <= 0.002 * n
    assert whole.keep.sum() > 1000
    # the load comes with the kept samples, one row each
    assert len(whole.g_sensor) == len(whole.w_sensor) == whole.keep.sum()


def test_each_rule_rejects_what_it_should(ur5, paper_tool, rng):
    """Three seconds still, then a slow turn of the last joint, then still with a strain ramp."""
    rate = 500.0
    t = np.arange(int(9 * rate)) / rate
    q = np.tile(np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0]), (len(t), 1))
    moving = (t >= 3) & (t < 6)
    q[:, 5] = np.where(moving, 0.3 * (t - 3), np.where(t >= 6, 0.9, 0.0))
    s = 0.1 + 1e-5 * rng.standard_normal((len(t), 8))
    ramp = t >= 7.5
    s[ramp] += 5e-3 * (t[ramp, None] - 7.5)  # the strains creep while the joints are still
    f, keep = _decide(FilterConfig(), ur5, paper_tool, t, q, s, np.zeros(len(t), dtype=np.int64))
    assert keep[(t > 0.2) & (t < 2.8)].all()
    assert not keep[moving].any()
    assert not keep[t > 7.6].any()
    assert keep[(t > 6.2) & (t < 7.4)].mean() > 0.9
    assert f.rejected["joint speed"] > 0.9 * moving.sum() and f.rejected["strain not stationary"] > 0


def test_the_dynamic_rule_catches_what_loose_joint_thresholds_let_through(ur5, paper_tool):
    rate = 500.0
    t = np.arange(int(4 * rate)) / rate
    q = np.tile(np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0]), (len(t), 1))
    q[:, 4] = 0.1 * t**2  # wrist_2 accelerates at 0.2 rad/s² from rest: about 3e-3 g at the tool
    loose = FilterConfig(max_joint_speed=1.0, max_joint_acceleration=1.0, max_strain_std=1.0)
    s, k = np.full((len(t), 8), 0.1), np.zeros(len(t), dtype=np.int64)
    f, keep = _decide(loose, ur5, paper_tool, t, q, s, k)
    assert f.rejected["dynamic wrench"] > 0.5 * len(t) and keep.mean() < 0.5
    strict = FilterConfig(max_joint_speed=1.0, max_joint_acceleration=1.0, max_strain_std=1.0, max_dynamic_fraction=1.0)
    assert _decide(strict, ur5, paper_tool, t, q, s, k)[1].all()


def test_the_filter_alone_decides_from_rates_and_stationarity_and_returns_the_rates(ur5, paper_tool):
    """Rules 1-3 without kinematics: the joint rates it returns are those of the motion."""
    rate = 500.0
    t = np.arange(int(4 * rate)) / rate
    q = np.tile(np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0]), (len(t), 1))
    q[:, 4] = 0.1 * t**2  # velocity 0.2 t rad/s, acceleration 0.2 rad/s²
    loose = FilterConfig(max_joint_speed=1.0, max_joint_acceleration=1.0, max_strain_std=1.0)
    decided = QuasiStaticFilter(loose, ur5.continuous).process(
        SampleBatch(t, q, np.full((len(t), 8), 0.1), np.zeros(len(t), dtype=np.int64)), final=True
    )
    assert decided.still.all() and len(decided.samples) == len(t)
    inner = slice(50, -50)  # the Savitzky-Golay window is exact on a quadratic away from the edges
    np.testing.assert_allclose(decided.joint_velocity[inner, 4], 0.2 * t[inner], atol=1e-9)
    np.testing.assert_allclose(decided.joint_acceleration[inner, 4], 0.2, atol=1e-7)


def test_bad_thresholds_are_refused():
    with pytest.raises(ValueError, match="filter.max_joint_speed=0.0 but expected a finite value > 0"):
        FilterConfig(max_joint_speed=0.0)


@pytest.mark.parametrize("rate", [100.0, 1000.0])
def test_a_stream_that_ends_while_speeding_up_keeps_nothing_of_the_motion(ur5, paper_tool, rng, rate):
    """Still 3 s, then the last joint speeds up below the acceleration limit until the stream ends at 1.08 times the speed limit.

    A difference over the cut window at the stream's end is the velocity of its middle, short of
    the sample's: samples up to 10 % over the speed limit passed (fed whole or in chunks).
    """
    settings = FilterConfig()
    accel = 0.9 * settings.max_joint_acceleration  # only the speed rule can reject
    end = 3.0 + 1.08 * settings.max_joint_speed / accel  # 3.12 s: on the sample grid of either rate
    t = np.arange(int(round(end * rate)) + 1) / rate
    q = np.tile(np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0]), (len(t), 1))
    tau = np.maximum(t - 3.0, 0.0)
    q[:, 5] = 0.5 * accel * tau**2
    speed = accel * tau  # the truth
    s, k = 0.1 + 1e-5 * rng.standard_normal((len(t), 8)), np.zeros(len(t), dtype=np.int64)
    assert speed[-1] > 1.05 * settings.max_joint_speed  # the truth: the last 0.01 s over the limit
    _, keep = _decide(settings, ur5, paper_tool, t, q, s, k)
    assert not keep[speed > settings.max_joint_speed].any()
    assert keep[(t > 0.2) & (t < 2.8)].all()
    filt, cuts = QuasiStaticFilter(settings, ur5.continuous), np.sort(rng.choice(len(t), 5, replace=False))
    batch = SampleBatch(t, q, s, k)
    parts = [quasi_static(filt, ur5, paper_tool, batch.rows(i, j)).keep for i, j in zip([0, *cuts], [*cuts, len(t)], strict=True)]
    chunked = np.concatenate([*parts, quasi_static(filt, ur5, paper_tool, batch.rows(0, 0), final=True).keep])
    assert not chunked[speed > settings.max_joint_speed].any()


def test_a_lone_sample_after_a_gap_at_the_end_shows_nothing_and_is_not_kept(ur5, paper_tool, rng):
    """Still 3 s at 100 Hz, a 2 s gap (a tool change), one sample of another load, the end.

    Its strain window and joint rates held itself alone: deviation and rates zero, so it was kept.
    """
    t = np.concatenate([np.arange(300) / 100.0, [5.0]])
    q = np.tile(np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0]), (len(t), 1))
    s = 0.1 + 1e-5 * rng.standard_normal((len(t), 8))
    s[-1] += 0.05  # another tool
    filt, keep = _decide(FilterConfig(), ur5, paper_tool, t, q, s, np.zeros(len(t), dtype=np.int64))
    assert not keep[-1]
    assert keep[200:300].all()  # the still samples before the gap, their window on one side only, are kept
    assert filt.rejected["strain not stationary"] == 1


def test_a_quantized_still_pose_read_from_a_file_of_ten_digits_is_kept(ur5, paper_tool, rng):
    """Ten still poses at 100 Hz on a 16-bit grid (noise 1/10 of a step: a channel mostly holds one
    code and now and then flips one), values written with 10 digits as the recording writer does.

    The noise floor measured over the first still windows is 0 for such a channel; the floor
    must be the step's own step / sqrt(12), from the grid detected despite the file's rounding
    (before: the grid went unseen and one flip failed the sample's whole window).
    """
    lsb = 2.0**-22 * 1000  # the simulated sensor's step at 16 bits [mV/V]
    t = np.arange(2000) / 100.0
    q = np.tile(np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0]), (len(t), 1))
    q[:, 5] = np.repeat(0.3 * np.arange(10), 200)  # ten poses (the jumps between them: not still)
    level = np.repeat(rng.uniform(-0.4, 0.4, (10, 8)), 200, axis=0)
    s = np.round((level + lsb / 10 * rng.standard_normal((len(t), 8))) / lsb) * lsb
    s = np.array([[float(f"{v:.9e}") for v in row] for row in s])
    filt, keep = _decide(FilterConfig(), ur5, paper_tool, t, q, s, np.zeros(len(t), dtype=np.int64))
    np.testing.assert_allclose(filt.grid.resolution, lsb, rtol=1e-6)
    pose = np.arange(len(t)) % 200
    inner = (pose > 30) & (pose < 170)  # away from the pose changes (joint and strain windows)
    assert keep[inner].all(), f"{np.sum(~keep[inner])} of {inner.sum()} still samples dropped"

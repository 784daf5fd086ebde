"""Channel limits: the resolution and rails of a channel, declared in the sensor file or detected."""

import math

import numpy as np
import pytest

from fts_calib.core.exceptions import ConfigError, FileFormatError
from fts_calib.core.resources import resolve
from fts_calib.filters.sample_checks import RailTally, refuse_railed
from fts_calib.model.channel_limits import (
    RAIL_MIN_SAMPLES,
    ChannelLimits,
    GridWatch,
    RailWatch,
    detect_limits,
    detect_resolution,
    on_adc_boundary,
    quantization_noise,
    railed,
)
from fts_calib.model.sensor_config import load_sensor_config

ATOL_STEP = 1e-9  # relative: a detected step against the true one (float noise of the values only)


def test_the_resolution_is_the_common_step_of_the_values_despite_float_noise(rng):
    counts = np.round(512 + 3.0 * rng.standard_normal((2000, 1)))
    scaled = counts * 0.00122  # counts through a float factor: the differences carry rounding noise
    decimal = 0.3 + np.round(40 * rng.random((2000, 1))) * 0.1  # 0.1 is no binary fraction either
    free = rng.standard_normal((2000, 1))  # not on a grid
    constant = np.full((2000, 1), 7.0)  # one value shows no step
    step = detect_resolution(np.hstack([counts, scaled, decimal, free, constant]))
    np.testing.assert_allclose(step[:3], [1.0, 0.00122, 0.1], rtol=ATOL_STEP)
    assert step[3] == 0.0 and step[4] == 0.0
    # codes that skip some steps (sparse data) still show the step of the grid they lie on
    assert detect_resolution(np.array([0.0, 2.0, 3.0, 7.0])) == 1.0


def test_a_grid_learnt_chunk_by_chunk_is_the_grid_of_the_whole(rng):
    values = np.round(100 + 0.3 * rng.standard_normal((600, 2))) * np.array([1.0, 0.5])
    values[:300, 0] = 100.0  # a sub-count channel: nothing to see in the first chunks
    watch = GridWatch([0.0, 0.25])  # the second is declared: kept whatever the values say
    for part in np.array_split(values, 7):
        watch.update(part)
    np.testing.assert_allclose(watch.resolution, [detect_resolution(values[:, 0]), 0.25])
    assert watch.resolution[0] == 1.0


def test_the_rule_refuses_a_channel_at_or_beyond_its_rail_and_counts_it_per_channel_and_configuration():
    limits = ChannelLimits(np.ones(3), [0.0, -np.inf, 0.0], [1023.0, np.inf, 1023.0])
    channels = np.array([[10, 5e9, 1023], [0, 1, 1], [1024, 2, 3], [5, 6, np.nan], [1, 2, 3]], dtype=float)
    at = railed(channels, limits)
    assert at.tolist() == [
        [False, False, True],
        [True, False, False],
        [True, False, False],
        [False, False, False],  # NaN is a non-finite value, counted as such elsewhere
        [False, False, False],
    ]
    tally = RailTally(3)
    keep = refuse_railed(channels, np.array([0, 1, 1, 0, 0]), np.array([0.0, 5.0, 5.1, 6.0, 7.0]), limits, tally)
    assert keep.tolist() == [False, False, False, True, True]
    # strain_1 railed at t 5.0 and 5.1 (configuration B): one pose, two samples, readings 0 and 1024
    assert tally.lines(["A", "B"]) == [
        "strain_1 at its rail 0-1024 in 1 pose (B 1): 2 samples",
        "strain_3 at its rail 1023 in 1 pose (A 1): 1 sample",
    ]
    # no rail known: every sample passes
    assert refuse_railed(channels, np.zeros(5), np.arange(5.0), ChannelLimits.none(3), tally).all()


def test_a_rail_is_detected_at_an_adc_end_and_not_at_a_subcount_channels_largest_pose(rng):
    """Channel 1 rails at 1023 in two poses; channel 2 (sub-count noise) holds its largest code 700 in
    two poses (the same orientation with two tool configurations): that is no rail."""
    poses = [(1023.0, 700.0), (500.0, 600.0), (1023.0, 700.0), (400.0, 650.0)]
    rows = [np.tile(p, (50, 1)) for p in poses]
    rows[1] = rows[1] + np.round(0.3 * rng.standard_normal((50, 2)))
    channels = np.vstack(rows)
    whole = RailWatch(2)
    whole.update(channels)
    low, high = whole.rails([1.0, 1.0])
    assert high.tolist() == [1023.0, math.inf] and np.all(np.isinf(low))
    # chunks that cut stretches anywhere give the same answer
    chunked = RailWatch(2)
    for part in np.array_split(channels, 13):
        chunked.update(part)
    assert [r.tolist() for r in chunked.rails([1.0, 1.0])] == [low.tolist(), high.tolist()]
    # off a grid, a value held exactly for a window in two stretches is a clipped channel
    clipped = np.concatenate([np.full(RAIL_MIN_SAMPLES, 7.8), rng.standard_normal(30), np.full(RAIL_MIN_SAMPLES, 7.8)])
    watch = RailWatch(1)
    watch.update(clipped[:, None])
    assert watch.rails([0.0])[1].tolist() == [7.8]
    assert on_adc_boundary(4095.0, 1.0) and on_adc_boundary(-128 * 0.5, 0.5, high=False) and not on_adc_boundary(700.0, 1.0)
    assert on_adc_boundary(0.0, 1.0, high=False) and not on_adc_boundary(0.0, 1.0) and not on_adc_boundary(1023.0, 1.0, high=False)


def test_detect_limits_completes_what_is_declared(rng):
    loads = rng.uniform(-1, 1, 20)
    loads[::5] = 1.0  # four poses beyond the rail, whatever the seed
    counts = np.clip(np.round(1000 + 40 * np.repeat(loads, 30)[:, None] + 0.2 * rng.standard_normal((600, 1))), 0, 1023)
    declared = ChannelLimits([0.0], [-np.inf], [2000.0])  # an upper rail declared: kept, not the detected one
    found = detect_limits(counts, declared)
    assert found.resolution.tolist() == [1.0] and found.high.tolist() == [2000.0]
    assert found.detected == ("resolution of strain_1 (1)",)
    alone = detect_limits(counts)
    assert alone.high.tolist() == [1023.0] and "high rail of strain_1 at 1023" in alone.detected
    assert quantization_noise(found.resolution)[0] == pytest.approx(1 / math.sqrt(12))


def test_the_lowcost_sensor_file_declares_10_bit_counts():
    spec = load_sensor_config(resolve("lowcost_sensor", "configs"))
    assert spec.limits is not None
    assert spec.limits.resolution.tolist() == [1.0] * 8
    assert spec.limits.low.tolist() == [0.0] * 8 and spec.limits.high.tolist() == [1023.0] * 8
    sim = spec.simulated
    assert sim is not None and sim.lsb == 1.0 and sim.adc_codes == (0.0, 1023.0) and sim.quadratic == 0.03
    assert load_sensor_config(resolve("sensor", "configs")).limits is None  # nothing declared: detected


@pytest.mark.parametrize(
    ("extra", "match"),
    [
        ("adc_bits: 10\n", r"range.*missing: adc_bits needs the range of the codes"),
        ("adc_bits: 10.5\nrange: [0, 1023]\n", r"adc_bits.*expected an integer number of bits"),
        ("resolution: -1\n", r"resolution.*expected values >= 0"),
        ("range: [5, 5]\n", r"range.*channel 1: \[5, 5\] but expected \[low, high\] with low < high"),
        ("range: [[0, 1], [0, 1]]\n", r"range"),
        ("resolution: 1\nadc_bits: 10\nrange: [0, 1023]\n", r"either resolution or adc_bits"),
    ],
)
def test_bad_limits_in_a_sensor_file_are_refused_with_the_field(tmp_path, extra, match):
    path = tmp_path / "sensor.yaml"
    path.write_text("name: test\nstrain_unit: counts\n" + extra)
    with pytest.raises(FileFormatError, match=match):
        load_sensor_config(path)


def test_limits_refuse_bad_values():
    with pytest.raises(ConfigError, match="resolution"):
        ChannelLimits([-1.0], [0.0], [1.0])
    with pytest.raises(ConfigError, match="low < high"):
        ChannelLimits([1.0], [2.0], [1.0])


IDENTITY = "[[1,0,0,0,0,0],[0,1,0,0,0,0],[0,0,1,0,0,0],[0,0,0,1,0,0],[0,0,0,0,1,0],[0,0,0,0,0,1]]"


@pytest.mark.parametrize(
    ("extra", "match"),
    [
        ("adc: {bits: 10, range: [0, 1023], gain: 128}", r"simulation.adc.*either range or gain and reference"),
        ("adc: {bits: 10, range: [5, 1]}", r"simulation.adc.range.*\[5.0, 1.0\] but expected \[low, high\] with low < high"),
        ("nonlinearity: 0.03", r"simulation.nonlinearity.*expected \{quadratic: fraction, cubic: fraction, odd: fraction\}"),
        ("nonlinearity: {quadratic: 0.03, cubc: 0.01}", r"simulation.nonlinearity.*did you mean 'cubic'"),
        ("nonlinearity: {quadratic: .nan}", r"simulation.nonlinearity.quadratic.*finite"),
        ("channel_offset: [1, 2]", r"simulation.channel_offset.*one number or 8"),
    ],
)
def test_bad_simulation_of_a_lowcost_sensor_is_refused_with_the_field(tmp_path, extra, match):
    path = tmp_path / "sensor.yaml"
    path.write_text(f"name: test\nstrain_unit: counts\nsimulation:\n  C_bar: {IDENTITY}\n  {extra}\n")
    with pytest.raises(FileFormatError, match=match):
        load_sensor_config(path)


def test_a_pipeline_file_cannot_declare_channel_limits(tmp_path):
    from fts_calib.filters.settings import load_pipeline_config

    path = tmp_path / "pipeline.yaml"
    path.write_text("checks:\n  limits: 5\n")
    with pytest.raises(FileFormatError, match=r"checks.limits.*the sensor file's"):
        load_pipeline_config(path)


def test_a_grid_read_from_a_file_of_ten_digits_is_seen_and_one_its_digits_do_not_resolve_is_not(rng):
    """The recording writer's ``%.9e``: a gap between two readings is off its multiple of the step by
    up to 1e-9 of the readings (1.7e-6 of a 16-bit step at 0.4 mV/V, beyond GRID_TOLERANCE alone)."""
    lsb = 2.0**-22 * 1000  # 16 bits [mV/V]
    written = np.vectorize(lambda v: float(f"{v:.9e}"))
    codes = np.round(rng.uniform(-0.45, 0.45, (300, 1)) / lsb) * lsb  # codes hundreds of steps apart
    free = rng.uniform(-0.45, 0.45, (300, 1))  # off any grid
    step = detect_resolution(written(np.hstack([codes, free])))
    np.testing.assert_allclose(step[0], lsb, rtol=1e-6)
    assert step[1] == 0.0
    fine = np.round(rng.uniform(-0.45, 0.45, 300) / (lsb / 256)) * (lsb / 256)  # 24 bits: codes within the digits' rounding
    assert detect_resolution(written(fine)) == 0.0

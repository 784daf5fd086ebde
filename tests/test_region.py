"""The load region a calibration was fitted on: its rule, its accumulation, its file section and the warning of a nonlinear model."""

import warnings

import numpy as np
import pytest
import yaml

from fts_calib import Calibration, FileFormatError, FtsCalibWarning, ShapeError, WrenchReader, load_calibration
from fts_calib.core.exceptions import ConfigError
from fts_calib.model.features import SensorModel
from fts_calib.model.region import MARGIN_SHARE, LoadRegion, RegionBuilder, region_from_dict

from .helpers import C_BAR_TRUE, D_TRUE, P_PAPER, paper_simulation

FULL_SCALE = np.array([50.0, 50.0, 50.0, 5.0, 5.0, 5.0])  # [N, N m]
MARGIN = MARGIN_SHARE * FULL_SCALE  # [N, N m]: 0.5 N, 0.05 N m


def _region(W) -> LoadRegion:
    builder = RegionBuilder(FULL_SCALE)
    builder.add(W)
    return builder.region()


def test_the_region_is_the_box_and_the_magnitudes_of_the_known_wrenches(rng):
    W, _, _ = paper_simulation(50, rng)  # 2 kg at three centres of mass, random orientations
    region = _region(W)
    np.testing.assert_array_equal(region.low, W.min(axis=0))
    np.testing.assert_array_equal(region.high, W.max(axis=0))
    assert region.force_max == np.linalg.norm(W[:, :3], axis=1).max() and region.samples == 150
    assert region.moment_max == np.linalg.norm(W[:, 3:], axis=1).max()
    np.testing.assert_array_equal(region.margin, [0.5, 0.5, 0.5, 0.05, 0.05, 0.05])
    assert region.contains(W).all()
    assert region.contains(np.zeros(6)).tolist() == [True]  # between the gravity spheres: inside the box, said so in the docs


def test_the_rule_axis_by_axis_and_by_magnitude():
    """A region of two wrenches; each probe leaves it by one rule only (the margins: 0.5 N, 0.05 N m)."""
    region = _region(np.array([[10.0, 0.0, 0.0, 0.0, 1.0, 0.0], [-10.0, 0.0, 0.0, 0.0, -1.0, 0.0]]))
    probes = {
        "inside, within the margin of Fx": ([10.4, 0.0, 0.0, 0.0, 0.0, 0.0], True),
        "beyond the margin of Fx": ([10.6, 0.0, 0.0, 0.0, 0.0, 0.0], False),
        "Fy outside its range [0, 0] + margin": ([0.0, 0.6, 0.0, 0.0, 0.0, 0.0], False),
        "beyond the margin of My": ([0.0, 0.0, 0.0, 0.0, -1.06, 0.0], False),
        "not a number": ([np.nan, 0.0, 0.0, 0.0, 0.0, 0.0], False),
    }
    for name, (w, inside) in probes.items():
        assert region.contains(w).tolist() == [inside], name
    # the magnitude caps: a corner of the box lies beyond |F| <= force_max + |margin of F| = 10 + 0.866 N
    box_only = _region(np.array([[10.0, 0.0, 0.0, 0, 0, 0], [0.0, 10.0, 0.0, 0, 0, 0], [0.0, 0.0, 0.0, 0, 0, 0]]))
    corner = np.array([10.0, 10.0, 0.0, 0.0, 0.0, 0.0])  # inside the box, |F| = 14.1 N > 10.87 N
    assert box_only.force_limit == pytest.approx(10.0 + np.sqrt(3 * 0.25), rel=1e-12)
    assert box_only.contains(corner).tolist() == [False]
    assert box_only.contains(corner / np.linalg.norm(corner) * 10.0).tolist() == [True]
    torque = _region(np.array([[0, 0, 0, 1.0, 0.0, 0], [0, 0, 0, 0.0, 1.0, 0], [0, 0, 0, 0.0, 0.0, 0]]))
    assert torque.contains([0, 0, 0, 1.0, 1.0, 0]).tolist() == [False]  # |M| = 1.41 > 1 + 0.087 N m


def test_a_push_along_the_moment_is_outside_every_weight_s_region(rng):
    """Every weight has F . M = 0 (paper eq 20): a load with F . M beyond the margins' share is none a weight gives."""
    W, _, _ = paper_simulation(50, rng)
    region = _region(W)
    assert region.coupling_max <= 1e-12 * region.force_max * region.moment_max
    limit = np.linalg.norm(MARGIN[:3]) * region.moment_max + np.linalg.norm(MARGIN[3:]) * region.force_max  # 2.4 N^2 m
    assert region.coupling_limit == pytest.approx(region.coupling_max + limit, rel=1e-12)
    push = np.r_[10.0, 0.0, 0.0, 0.5, 0.0, 0.0]  # 10 N along x with 0.5 N m about x: F . M = 5 N^2 m, every axis in range
    assert np.all((push >= region.lower) & (push <= region.upper)) and region.contains(push).tolist() == [False]
    assert region.contains(np.r_[10.0, 0.0, 0.0, 0.1, 0.0, 0.0]).tolist() == [True]  # F . M = 1 N^2 m: within the margins
    legacy = region_from_dict({k: v for k, v in region.as_dict().items() if k != "coupling_max"}, "old.yaml")
    assert legacy.coupling_max is None and legacy.contains(push).tolist() == [True]  # a file written before: not checked


def test_one_pass_equals_batches_in_any_order_and_merged_builders(rng):
    W, _, _ = paper_simulation(40, rng)
    whole = _region(W)
    shuffled = RegionBuilder(FULL_SCALE)
    for part in np.array_split(W[rng.permutation(len(W))], 7):
        shuffled.add(part)
    first, second = RegionBuilder(FULL_SCALE), RegionBuilder(FULL_SCALE)
    first.add(W[:50])
    second.add(W[50:])
    first.merge(second)
    for other in (shuffled.region(), first.region()):  # minima and maxima: exact whatever the order
        np.testing.assert_array_equal(other.low, whole.low)
        np.testing.assert_array_equal(other.high, whole.high)
        assert (other.force_max, other.moment_max, other.samples) == (whole.force_max, whole.moment_max, whole.samples)


def test_the_builder_state_round_trips_and_an_empty_builder_has_no_region(rng):
    empty = RegionBuilder(FULL_SCALE)
    assert empty.region() is None and empty.state() == {"samples": 0}
    empty.add(np.zeros((0, 6)))
    assert empty.region() is None
    W, _, _ = paper_simulation(20, rng)
    builder = RegionBuilder(FULL_SCALE)
    builder.add(W)
    restored = RegionBuilder(FULL_SCALE)
    restored.restore(builder.state())
    np.testing.assert_array_equal(restored.region().low, builder.region().low)
    assert restored.region().samples == 60 and restored.region().force_max == builder.region().force_max
    with pytest.raises(ValueError, match="low <= high"):
        RegionBuilder(FULL_SCALE).restore({**builder.state(), "low": builder.state()["high"], "high": builder.state()["low"]})
    with pytest.raises(ShapeError, match=r"w_sensor.shape=\(4, 5\)"):
        builder.add(np.zeros((4, 5)))


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"low": [0.0] * 5}, r"field 'region.low': shape \(5,\) but expected \(6,\)"),
        ({"high": [1.0, 1.0, float("nan"), 1.0, 1.0, 1.0]}, r"field 'region.high': contains NaN"),
        ({"low": [2.0] * 6}, r"field 'region.low': .*low <= high on every axis"),
        ({"margin": [-0.5] + [0.5] * 5}, r"field 'region.margin': .*values >= 0"),
        ({"force_max": "heavy"}, r"field 'region.force_max': expected a number"),
        ({"moment_max": -1.0}, r"field 'region.moment_max': is -1.0 N·m but expected a finite value >= 0"),
        ({"samples": 0}, r"field 'region.samples': .*a whole number >= 1"),
        ({"samples": None}, r"field 'region.samples': missing|field 'region.samples': expected a number"),
    ],
)
def test_a_malformed_region_section_names_its_field(tmp_path, change, match):
    good = LoadRegion(np.full(6, -1.0), np.ones(6), 1.5, 1.5, np.full(6, 0.5), 10).as_dict()
    path = tmp_path / "cal.yaml"
    Calibration(C_bar=C_BAR_TRUE, D=D_TRUE).save(path)
    data = yaml.safe_load(path.read_text())
    data["region"] = {key: value for key, value in (good | change).items() if value is not None}
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(FileFormatError, match=match):
        load_calibration(path)
    with pytest.raises(FileFormatError, match=r"field 'region': expected a mapping"):
        region_from_dict([1, 2], path)


def test_the_dataclass_refuses_what_the_file_refuses():
    with pytest.raises(ConfigError, match=r"low=.* but expected low <= high on every axis \(not on axes \[3\]"):
        LoadRegion([0, 0, 0, 2, 0, 0], np.ones(6), 1.0, 1.0, np.zeros(6), 1)
    with pytest.raises(ShapeError, match=r"margin.shape=\(3,\) but expected \(6,\)"):
        LoadRegion(np.zeros(6), np.ones(6), 1.0, 1.0, np.zeros(3), 1)
    with pytest.raises(ConfigError, match=r"force_max=inf N but expected a finite value >= 0"):
        LoadRegion(np.zeros(6), np.ones(6), np.inf, 1.0, np.zeros(6), 1)
    with pytest.raises(ConfigError, match=r"region='dict' but expected a LoadRegion"):
        Calibration(C_bar=C_BAR_TRUE, D=D_TRUE, region={"low": [0] * 6})


def test_the_region_travels_with_the_file_and_a_tare(tmp_path, rng):
    W, S, _ = paper_simulation(30, rng)
    region = _region(W)
    calibration = Calibration(C_bar=C_BAR_TRUE, D=D_TRUE, region=region)
    path = calibration.save(tmp_path / "cal.yaml")
    section = yaml.safe_load(path.read_text())["region"]
    assert section["units"] == {"wrench": "N, N, N, N·m, N·m, N·m", "force_max": "N", "moment_max": "N·m", "coupling_max": "N²·m"}
    loaded = load_calibration(path)
    np.testing.assert_array_equal(loaded.region.low, region.low)  # YAML writes floats with repr: exact
    np.testing.assert_array_equal(loaded.region.margin, region.margin)
    assert (loaded.region.force_max, loaded.region.samples) == (region.force_max, region.samples)
    tared = load_calibration(loaded.with_offsets(np.zeros(6), "re-tare").save(tmp_path / "tared.yaml"))
    np.testing.assert_array_equal(tared.region.high, region.high)
    older = yaml.safe_load(path.read_text())
    del older["region"]
    (tmp_path / "older.yaml").write_text(yaml.safe_dump(older))
    assert load_calibration(tmp_path / "older.yaml").region is None


def _quadratic(region: LoadRegion | None) -> Calibration:
    """A quadratic model whose second-order terms are small: C_bar u plus 1e-3 of u1^2 on Fx."""
    theta = np.zeros((6, 27))
    theta[:, :6] = C_BAR_TRUE
    theta[0, 6] = 1e-3  # [N per (mV/V)^2] of u1^2
    model = SensorModel("quadratic", theta, P_PAPER, 8)
    return Calibration(C_bar=C_BAR_TRUE, D=D_TRUE, model=model, region=region)


def test_a_nonlinear_model_warns_outside_its_region_and_a_linear_one_never(rng):
    W, S, _ = paper_simulation(30, rng)  # channels of the paper's 2 kg tool through the true linear model
    region = _region(W)
    heavy, S_heavy, _ = paper_simulation(10, rng)  # the same loads
    S_heavy = S_heavy + 2.0 * (S_heavy - S_heavy.mean(axis=0))  # three times as far from their mean: about 3 times the load
    quadratic = _quadratic(region)
    outside = int(np.count_nonzero(~region.contains(quadratic.wrench(S_heavy, region_check=False))))
    assert outside > 0
    with pytest.warns(FtsCalibWarning, match=rf"{outside} of 30 wrenches lie outside the load region the quadratic model was fitted on"):
        quadratic.wrench(S_heavy)
    with warnings.catch_warnings():
        warnings.simplefilter("error", FtsCalibWarning)
        quadratic.wrench(S[np.flatnonzero(region.contains(quadratic.wrench(S, region_check=False)))])  # inside: silent
        quadratic.wrench(S_heavy, region_check=False)  # the caller reports the region itself
        Calibration(C_bar=C_BAR_TRUE, D=D_TRUE, region=region).wrench(S_heavy)  # linear: determined everywhere
        _quadratic(None).wrench(S_heavy)  # no region recorded: nothing to check


def test_the_reader_checks_the_region_only_when_asked(rng):
    W, S, _ = paper_simulation(30, rng)
    region = _region(W)
    reader = WrenchReader(_quadratic(region))
    probes = np.vstack([W, 3.0 * W, np.zeros((1, 6)), np.full((1, 6), np.nan)])
    expected = ~region.contains(probes)
    assert expected.any() and not expected.all()
    assert [reader.outside_region(w) for w in probes] == expected.tolist()
    assert reader.outside_region(list(3.0 * W[0])) is True
    with warnings.catch_warnings():
        warnings.simplefilter("error", FtsCalibWarning)
        reader.wrench(S[0] * 3.0)  # the hot path never checks
    assert WrenchReader(Calibration(C_bar=C_BAR_TRUE, D=D_TRUE)).outside_region(3.0 * W[0]) is False
    with pytest.raises(ShapeError, match=r"w_sensor.shape=\(5,\)"):
        reader.outside_region(np.zeros(5))

"""The calibration file (format fts-calib/1): round trip, atomic writes, clear errors."""

import dataclasses
import os

import numpy as np
import pytest
import yaml

from fts_calib import Calibration, ConfigError, FileFormatError, OnlineEstimator, ShapeError, load_calibration
from fts_calib.model.calibration import save_calibration

from .helpers import C_BAR_TRUE, D_TRUE, paper_simulation


@pytest.fixture
def calibration(rng):
    W, S, _ = paper_simulation(80, rng, noise_std=1e-4)
    est = OnlineEstimator()
    est.update_batch(W, S)
    return est.solve()


def test_round_trip_is_exact(tmp_path, calibration):
    path = save_calibration(calibration, tmp_path / "cal.yaml")
    loaded = load_calibration(path)
    np.testing.assert_array_equal(loaded.C_bar, calibration.C_bar)
    np.testing.assert_array_equal(loaded.C, calibration.C)
    np.testing.assert_array_equal(loaded.D, calibration.D)
    q, lq = calibration.quality, loaded.quality
    for name in ("residual_rms", "stderr_C_bar", "stderr_D", "stderr_C"):
        np.testing.assert_array_equal(getattr(lq, name), getattr(q, name))
    assert (lq.rank, lq.samples_used, lq.samples_seen, lq.condition_number) == (q.rank, q.samples_used, q.samples_seen, q.condition_number)
    assert loaded.provenance == calibration.provenance


def test_file_has_the_contract_fields(tmp_path, calibration):
    data = yaml.safe_load(save_calibration(calibration, tmp_path / "cal.yaml").read_text())
    assert data["format"] == "fts-calib/1"
    assert np.array(data["C"]).shape == (6, 8) and np.array(data["C_bar"]).shape == (6, 6) and len(data["D"]) == 6
    assert set(data["quality"]) >= {"samples_used", "samples_seen", "rank", "condition_number", "residual_rms", "stderr_C_bar", "stderr_D"}
    assert set(data["provenance"]) >= {"time", "software_version", "method"}
    assert "units" in data


def test_arrays_are_read_only(calibration):
    with pytest.raises(ValueError):
        calibration.C[0, 0] = 1.0
    with pytest.raises(ValueError):
        calibration.quality.stderr_D[0] = 1.0


def test_a_crash_during_write_keeps_the_old_file_and_leaves_no_temporary(tmp_path, calibration, monkeypatch):
    path = save_calibration(calibration, tmp_path / "cal.yaml")
    before = path.read_bytes()

    def boom(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", boom)
    with pytest.raises(OSError, match="disk full"):
        save_calibration(Calibration(C_bar=C_BAR_TRUE, D=D_TRUE), path)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cal.yaml"]


def test_with_offsets_keeps_the_history(calibration, tmp_path):
    new = calibration.with_offsets(np.ones(6), reason="re-tare", time="2026-11-22T10:00:00Z")
    assert new.offset_history[-1] == {"D": calibration.D.tolist(), "replaced": "2026-11-22T10:00:00Z", "reason": "re-tare"}
    loaded = load_calibration(save_calibration(new, tmp_path / "c.yaml"))
    assert loaded.offset_history == new.offset_history
    np.testing.assert_array_equal(loaded.D, np.ones(6))


def _write(tmp_path, data):
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _good(calibration):
    return {"format": "fts-calib/1", "C": calibration.C.tolist(), "C_bar": calibration.C_bar.tolist(), "D": calibration.D.tolist()}


def test_another_format_is_refused(tmp_path, calibration):
    data = _good(calibration) | {"format": "ati-cal/2"}
    with pytest.raises(FileFormatError, match=r"field 'format': is 'ati-cal/2' but expected 'fts-calib/1'"):
        load_calibration(_write(tmp_path, data))


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("C_bar", np.zeros((6, 5)).tolist(), r"field 'C_bar': shape \(6, 5\) but expected \(6, 6\)"),
        ("D", [0.0] * 5, r"field 'D': shape \(5,\) but expected \(6,\)"),
        ("C", np.zeros((8, 6)).tolist(), r"field 'C': shape \(8, 6\) but expected \(6, 8\)"),
        ("D", [0.0, 0.0, "x", 0.0, 0.0, 0.0], r"field 'D': expected numbers"),
        ("D", [0.0, 0.0, float("nan"), 0.0, 0.0, 0.0], r"field 'D': contains NaN"),
    ],
)
def test_wrong_shapes_and_values_name_the_field(tmp_path, calibration, field, value, match):
    data = _good(calibration) | {field: value}
    with pytest.raises(FileFormatError, match=match):
        load_calibration(_write(tmp_path, data))


def test_missing_field_and_inconsistent_c(tmp_path, calibration):
    data = _good(calibration)
    del data["D"]
    with pytest.raises(FileFormatError, match=r"field 'D': missing"):
        load_calibration(_write(tmp_path, data))
    data = _good(calibration)
    data["C"][2][3] += 0.5
    with pytest.raises(FileFormatError, match=r"field 'C': does not equal C_bar @ P"):
        load_calibration(_write(tmp_path, data))


def test_not_yaml_and_missing_file(tmp_path):
    path = tmp_path / "broken.yaml"
    path.write_text("format: fts-calib/1\nC: [1, 2\n")
    with pytest.raises(FileFormatError, match=r"broken.yaml: not valid YAML at line \d+, column \d+"):
        load_calibration(path)
    with pytest.raises(FileFormatError, match="file not found"):
        load_calibration(tmp_path / "none.yaml")


def test_constructor_checks_shapes():
    with pytest.raises(ShapeError, match=r"C_bar.shape=\(6, 8\) but expected \(6, 6\)"):
        Calibration(C_bar=np.zeros((6, 8)), D=np.zeros(6))


def test_constructor_refuses_what_the_file_refuses_non_finite_coefficients():
    with pytest.raises(ConfigError, match=r"D=\[0.0, nan, 0.0, 0.0, 0.0, 0.0\] but expected finite values"):
        Calibration(C_bar=C_BAR_TRUE, D=[0.0, float("nan"), 0.0, 0.0, 0.0, 0.0])
    C_bar = C_BAR_TRUE.copy()
    C_bar[2, 3] = np.inf
    with pytest.raises(ConfigError, match=r"C_bar=\[\[.*inf.*\]\] but expected finite values"):
        Calibration(C_bar=C_bar, D=D_TRUE)


def test_save_refuses_exactly_what_load_refuses(tmp_path, calibration, monkeypatch, rng):
    """Property over random corruptions of the quality (NaN, inf, -inf at random places, or none):
    save_calibration refuses a calibration iff the file it would write, written unchecked, fails
    load_calibration; a refusal is an internal error naming the field, with no file left."""
    import fts_calib.model.calibration as module
    from fts_calib.core.exceptions import FtsCalibError

    fields = ("residual_rms", "stderr_C_bar", "stderr_D", "stderr_C")
    check = module.check_loadable
    refused = 0
    for trial in range(40):
        changes = {}
        for name in fields:
            value = np.array(getattr(calibration.quality, name), dtype=float)
            if rng.random() < 0.16:  # none of the four corrupted in half the trials
                value.flat[rng.integers(value.size)] = rng.choice([np.nan, np.inf, -np.inf])
            changes[name] = value
        corrupt = dataclasses.replace(calibration, quality=dataclasses.replace(calibration.quality, **changes))
        bad = [name for name in fields if not np.all(np.isfinite(changes[name]))]
        unchecked = tmp_path / f"unchecked{trial}.yaml"
        monkeypatch.setattr(module, "check_loadable", lambda text, path: None)
        save_calibration(corrupt, unchecked)
        monkeypatch.setattr(module, "check_loadable", check)
        try:
            load_calibration(unchecked)
            loads = True
        except FileFormatError:
            loads = False
        assert loads == (not bad)
        target = tmp_path / f"checked{trial}.yaml"
        if loads:
            load_calibration(save_calibration(corrupt, target))
            continue
        refused += 1
        with pytest.raises(FtsCalibError, match=rf"internal error: .*quality\.{bad[0]}'?: contains NaN or inf.*nothing written"):
            save_calibration(corrupt, target)
        expected = {f"{kind}{t}.yaml" for t in range(trial + 1) for kind in ("unchecked", "checked")} - {target.name}
        assert {p.name for p in tmp_path.iterdir()} <= expected  # no file, no temporary left behind
    assert 5 <= refused <= 35  # both sides of the property were exercised

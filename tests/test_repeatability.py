"""A sensor that does not repeat from pose to pose: named with its two figures, then calibrated with it declared.

The truth: the simulated offsets drawn per stop (:mod:`tests.repeatability_case`) and the true
load at stops the calibration never saw.
"""

import dataclasses
import re

import numpy as np
import pytest

from fts_calib.core.exceptions import FileFormatError, PoorFit
from fts_calib.filters.settings import PipelineConfig
from fts_calib.model.sensor_config import load_sensor_config
from fts_calib.session.calibration_run import calibrate_recording

from . import repeatability_case as case

FIGURE = (
    r"within a still pose its noise is ([0-9.e-]+) N and [0-9.e-]+ N·m, "
    r"between poses its readings scatter by ([0-9.e-]+) N and ([0-9.e-]+) N·m"
)


def test_the_sensor_file_declares_its_repeatability(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text("name: s\nstrain_unit: counts\nrepeatability: {force: 1.5, moment: 0.1}\n")
    np.testing.assert_allclose(load_sensor_config(path).repeatability, [1.5, 1.5, 1.5, 0.1, 0.1, 0.1])
    path.write_text("name: s\nstrain_unit: counts\n")
    assert load_sensor_config(path).repeatability is None
    path.write_text("name: s\nrepeatability: {force: -1}\n")
    with pytest.raises(FileFormatError, match=r"field 'repeatability.force': is -1 but expected a value >= 0"):
        load_sensor_config(path)
    path.write_text("name: s\nrepeatability: {forces: 1}\n")
    with pytest.raises(FileFormatError, match=r"field 'repeatability': unknown keys \['forces'\]"):
        load_sensor_config(path)


def test_a_sensor_that_does_not_repeat_is_named_then_calibrates_within_its_budget_on_unseen_stops(tmp_path, seed):
    kin, tool, _ = case.setup()
    _, full_scale = case.sensor()
    recording, held = case.record(tmp_path, seed)
    before = calibrate_recording(recording, kin, tool, PipelineConfig(), full_scale=full_scale)
    assert isinstance(before.error, PoorFit), before.error
    text = before.error.check.diagnosis
    # seen: 'within a still pose its noise is 0.033 N and 0.00056 N·m, between poses ... 1.4 N and 0.089 N·m'
    found = re.search(FIGURE, text)
    assert found is not None and "repeatability: {force:" in text, text
    within, force, moment = (float(v) for v in found.groups())
    assert 0.01 < within < 0.06  # the channel noise through C: 0.02-0.03 N on the forces
    assert 0.6 * case.SCATTER[0] < force < 1.6 * case.SCATTER[0]  # the largest of three axes' scatter over 60 stops
    assert 0.6 * case.SCATTER[3] < moment < 1.6 * case.SCATTER[3]

    after = calibrate_recording(recording, kin, tool, PipelineConfig().with_repeatability(case.SCATTER), full_scale=full_scale)
    assert after.calibration is not None, after.error
    check = after.session.fit_check()
    assert check.verdict == "consistent", check.summary()
    assert np.all(check.tolerance >= case.SCATTER)  # the declared scatter is in the expected residual
    budget = after.session.budget
    assert "sensor repeatability" in budget.terms
    assert after.calibration.offset_model["model"] != "drift"  # the offsets' BIC counts poses, not samples that share an offset
    error = case.unseen_error(after.calibration, held)  # (stops, 6), on 30 stops the calibration never saw
    assert np.all(np.sqrt(np.mean(error**2, axis=0)) <= budget.total)
    assert np.all(np.mean(np.abs(error) <= budget.total, axis=0) >= 0.9)


def test_a_wrong_tool_file_on_a_sensor_that_repeats_is_not_called_a_sensor_that_does_not(ur5_recording, ur5, paper_tool):
    """B's centre of mass 5 mm off in the file: the residual is a function of gravity, not a scatter from pose to pose."""
    moved = tuple(
        dataclasses.replace(c, p_sensor_com=c.p_sensor_com + [0.0, 0.0, 5e-3 if c.name == "B" else 0.0]) for c in paper_tool.configurations
    )
    result = calibrate_recording(ur5_recording, ur5, dataclasses.replace(paper_tool, configurations=moved))
    assert isinstance(result.error, PoorFit), result.error
    assert "does not repeat" not in result.error.check.diagnosis, result.error.check.diagnosis


def _visited_twice(rng, reading):
    """Still poses of 3 configurations, 20 orientations each visited twice, 5 samples a pose: (time, W, channels, codes)."""
    coms = np.array([[0.08, 0.0, 0.0], [0.05, 0.06, 0.0], [0.05, 0.0, 0.06]])
    time, W, codes = [], [], []
    for c, com in enumerate(coms):
        g = rng.normal(size=(20, 3))
        g = 9.81 * g / np.linalg.norm(g, axis=1, keepdims=True)
        for visit in range(2):
            for k, gk in enumerate(g):
                start = 100.0 * (2 * c + visit) + k
                time.append(start + 0.01 * np.arange(5))
                W.append(np.tile(np.concatenate([1.2 * gk, np.cross(com, 1.2 * gk)]), (5, 1)))
                codes.append(np.full(5, c))
    time, W, codes = np.concatenate(time), np.vstack(W), np.concatenate(codes)
    return time, W, reading(W, time) + rng.normal(size=W.shape) * [0.02, 0.02, 0.02, 0.001, 0.001, 0.001], codes


def test_an_orientation_visited_twice_tells_a_sensor_that_does_not_repeat_from_a_bend(rng):
    """A new offset at every visit reads a revisited orientation differently; a bend no quadratic follows reads it alike."""
    from fts_calib.model.channels import WRENCH_6
    from fts_calib.session.diagnosis import pose_scatter

    scatter = np.array([1.0, 1.0, 1.0, 0.05, 0.05, 0.05])
    offsets = rng.normal(size=(2000, 6)) * scatter

    def drawn(W, time):  # a new offset at every still pose: the time's whole second numbers the poses
        return W + offsets[np.floor(time).astype(int)]

    def bent(W, time):  # odd on every axis: 1 N at 10 N, 0.1 N m at 1 N m, about the drawn scatter
        scale = np.array([10.0, 10.0, 10.0, 1.0, 1.0, 1.0])
        return W + 0.1 * scale * np.abs(W / scale) * (W / scale)

    time, W, channels, codes = _visited_twice(rng, drawn)
    found = pose_scatter(time, W, channels, codes, WRENCH_6, False)
    assert found is not None and found.shown() and found.revisited is not None
    np.testing.assert_allclose(found.revisited, found.between, rtol=0.35)  # both the drawn scatter
    np.testing.assert_allclose(found.between, scatter, rtol=0.35)
    time, W, channels, codes = _visited_twice(rng, bent)
    found = pose_scatter(time, W, channels, codes, WRENCH_6, False)
    assert found is not None and not found.shown(), (found.between, found.revisited, found.random_share)
    # the same orientation, the same bend: only the noise differs (the noise of a mean of 5 samples)
    np.testing.assert_allclose(found.revisited, found.within / np.sqrt(5), rtol=0.35)
    assert np.all(found.between > 3 * found.revisited)

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
from fts_calib.robot.tool import load_tool
from fts_calib.service.retare_job import tare_recording
from fts_calib.sim.payload_run import simulate_payload_motion
from fts_calib.sim.runs import decimate_recording
from fts_calib.sim.sensor import load_simulated_sensor
from fts_calib.sources.recording import RecordingReader

from .rate_table import JOINT_NOISE, LATENCY_S, POSES, RATES, held, simulate_rate_runs

#: An estimate is within Z of its standard errors of the truth (two-sided normal quantile of 1e-6).
Z = NormalDist().inv_cdf(1 - 1e-6 / 2)
FACTORS = RATES  # decimation factors from the 1 kHz run: 1 kHz, 100 Hz, 10 Hz


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The calibration, payload and tare runs at each rate: ``{rate: {"cal": path, "payload": path, "tare": path}}``."""
    return simulate_rate_runs(tmp_path_factory.mktemp("rates"))


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


@pytest.fixture(scope="module")
def short_stops(tmp_path_factory):
    """The runs of a plan held 0.3 s at each stop (the shipped UR5 plan's dwell)."""
    return simulate_rate_runs(tmp_path_factory.mktemp("short"), 0.3)


@pytest.mark.parametrize("rate", ["100 Hz", "10 Hz"])
def test_dynamic_filter_on_short_stops_writes_standard_errors_that_hold(short_stops, truth, tmp_path, rate):
    """0.3 s stops decimated to 100 Hz, `--filter dynamic`: the kept samples' weights (1 / (1 + rho^2)) summed to 5.8 for
    1,567 samples; taken as the count, below the 7 coefficients, 'inf' standard errors were written and the file refused on
    reading ("quality.stderr_C_bar contains NaN or inf"); at 10 Hz they were ~2x too wide (RMS z 0.4-0.5). Each weighted
    sample is one observation: the file loads, every coefficient within Z standard errors of the truth, and the standard
    errors are not inflated (RMS of the 42 z-scores above 0.4; 0.8-1.1 measured)."""
    sim, _ = truth
    out = tmp_path / "cal.yaml"
    argv = ["calibrate", "--robot", "ur5", "--tool", "paper_tool", "--filter", "dynamic", str(short_stops[rate]["cal"]), "-o", str(out)]
    assert main(argv) == 0
    cal = load_calibration(out)
    z = np.concatenate([((cal.C_bar - sim.C_bar) / cal.quality.stderr_C_bar).ravel(), (cal.D - sim.D) / cal.quality.stderr_D])
    assert np.abs(z).max() <= Z and np.sqrt(np.mean(z**2)) >= 0.4, (rate, z)


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
    motion = held(POSES, 0.5)
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
        at_rest = simulate_payload_motion(tmp_path / "tare.csv", ur5, tool.configuration("A"), sim, motion, rng, LATENCY_S)
        with pytest.raises(ResultRefused, match="the window is not still") as refused:
            tare_recording(calibration, decimate_recording(at_rest, tmp_path / "tare_10.csv", 100), ur5, tool, "A")
        assert expected in str(refused.value)

"""Diagnoses that name the cause: each with a recording that triggers it, and sensors and tools that must not trigger one.

The recordings are simulated UR5 runs of the short plan (24-bit ADC, strain noise, the moving
tool's Newton-Euler wrench) with the paper's tool; the truth is what the simulation was told.
"""

import dataclasses

import numpy as np
import pytest

from fts_calib import InsufficientExcitation, PoorFit
from fts_calib.core.resources import resolve
from fts_calib.planning.trajectory_files import TrajectoryFile
from fts_calib.robot.tool import ToolTolerance
from fts_calib.session.calibration_run import calibrate_recording
from fts_calib.session.diagnosis import WEAK_CONDITION
from fts_calib.session.fit import MAX_RATIO
from fts_calib.sim.runs import simulate_recording
from fts_calib.sim.sensor import load_simulated_sensor

#: Words of the diagnoses that only a fitting alternative of the tool file, the joints or the mount may give.
GUESSES = ("not m", "the mass of configuration", "labels permuted", "degrees", "--joint-unit", "sensor.rpy", "--mount")


def _record(tmp_path, name, ur5, tool, trajectories, seed, **sensor_changes):
    sensor = dataclasses.replace(load_simulated_sensor(resolve("sensor", "configs")), **sensor_changes)
    return simulate_recording(tmp_path / f"{name}.csv", ur5, tool, trajectories, sensor, np.random.default_rng(seed))


def _first(trajectory: TrajectoryFile, seconds: float) -> TrajectoryFile:
    keep = trajectory.time - trajectory.time[0] <= seconds
    t = trajectory
    return TrajectoryFile(t.joint_names, t.time[keep], t.q[keep], t.qd[keep], t.qdd[keep], t.tool)


def _no_guess(diagnosis: str) -> None:
    assert not any(word in diagnosis for word in GUESSES), diagnosis


def test_one_configuration_names_the_centres_of_mass_to_mount_even_when_the_fit_is_poor(tmp_path, short_plan, ur5, paper_tool, seed):
    """Only configuration A recorded, on a sensor 2 % nonlinear (its strains carry what A's loads cannot): the rank first."""
    path = _record(tmp_path, "a", ur5, paper_tool, [short_plan.trajectory("A")], seed, quadratic=0.02)
    result = calibrate_recording(path, ur5, paper_tool, model="linear")
    assert isinstance(result.error, InsufficientExcitation), result.error
    assert result.error.rank == 4 and result.error.full == 7
    text = str(result.error)
    assert "rank 4 of 7" in text and "one centre of mass (configuration A); mount two more" in text and "(B and C of the tool file)" in text
    _no_guess(text)


def test_a_weakly_excited_recording_names_the_axis_and_the_motion(tmp_path, short_plan, ur5, paper_tool, seed):
    """The first level of each configuration's sweep only: gravity turns on a cone about the sensor's x axis, Fx is constant.

    With a little nonlinearity (0.5 % FS) the strains carry more than the loads; the cause is still the motion.
    """
    trajectories = [_first(short_plan.trajectory(name), 8.0) for name in paper_tool.names]
    path = _record(tmp_path, "weak", ur5, paper_tool, trajectories, seed, quadratic=0.005)
    result = calibrate_recording(path, ur5, paper_tool, model="linear")
    assert isinstance(result.error, InsufficientExcitation), result.error
    text = str(result.error)
    assert "weak excitation: Fx does not vary" in text and "rank 6 of 7" in text, text
    assert "tilt the sensor's x axis up and down (rotate it about its y axis or its z axis)" in text
    _no_guess(text)


def test_a_poor_fit_of_a_weakly_excited_recording_names_the_axis_not_a_guess(tmp_path, short_plan, ur5, paper_tool, seed):
    """A's first 12 s reach the second level of its sweep, B's and C's first 8 s do not: full rank, Fx barely varies.

    The drift offsets follow the motion in time (condition number about 2e4); a 3 % FS bend leaves a poor fit
    (1 % is within fit.floor and the tolerances), and the weak excitation is named before the bend
    (the coefficients along Fx are the data's noise).
    """
    cuts = {"A": 12.0, "B": 8.0, "C": 8.0}
    trajectories = [_first(short_plan.trajectory(name), cuts[name]) for name in paper_tool.names]
    path = _record(tmp_path, "weak", ur5, paper_tool, trajectories, seed, quadratic=0.03)
    result = calibrate_recording(path, ur5, paper_tool, model="linear")
    assert isinstance(result.error, PoorFit), result.error
    diagnosis = result.error.check.diagnosis
    assert diagnosis.startswith("weak excitation: Fx barely varies over the kept samples (condition number"), diagnosis
    assert "tilt the sensor's x axis up and down" in diagnosis
    _no_guess(diagnosis)


def test_a_nonlinear_sensor_under_the_linear_model_is_named_as_such(tmp_path, short_plan, ur5, paper_tool, seed):
    """2 % of full scale of quadratic bend on the paper's jig: refused, the nonlinearity and the jig that would determine it named.

    The paper's jig (one mass at three centres of mass) cannot determine a quadratic model beyond its own loads: no
    diagnosis suggests one, and auto refuses like --model linear.
    """
    trajectories = [short_plan.trajectory(name) for name in paper_tool.names]
    path = _record(tmp_path, "bent", ur5, paper_tool, trajectories, seed, quadratic=0.02)
    result = calibrate_recording(path, ur5, paper_tool, model="linear")
    assert isinstance(result.error, PoorFit), result.error
    check = result.error.check
    assert check.max_ratio > 5 * MAX_RATIO  # seen: 27 with the floor fit.floor and the tolerances, 66 without
    assert check.diagnosis.startswith("the sensor is nonlinear: a quadratic model fits these loads at the noise"), check.diagnosis
    assert "cannot determine it beyond themselves" in check.diagnosis and "a jig of 2 masses at 5 centres of mass" in check.diagnosis
    assert "--model quadratic or auto" not in check.diagnosis
    _no_guess(check.diagnosis)
    # auto keeps the linear model here (no quadratic candidate) and refuses it the same way
    chosen = calibrate_recording(path, ur5, paper_tool, model="auto")
    assert isinstance(chosen.error, PoorFit), chosen.error
    assert chosen.error.check.diagnosis.startswith("the sensor is nonlinear") and "2 masses at 5 centres" in chosen.error.check.diagnosis


@pytest.mark.parametrize("quadratic", [0.0, 0.02])
def test_a_tool_within_half_a_millimetre_gets_no_false_diagnosis(tmp_path, short_plan, ur5, paper_tool, seed, quadratic):
    """Centres of mass off by up to 0.5 mm, as the tool file declares (a sensor linear or 2 % bent): whatever the verdict, no guess.

    (Whether such a tool passes the fit check is the tolerance's matter; here only what a poor fit would be blamed on.)
    """
    rng = np.random.default_rng(seed)
    trajectories = [short_plan.trajectory(name) for name in paper_tool.names]
    path = _record(tmp_path, "tol", ur5, paper_tool, trajectories, seed + 1, quadratic=quadratic)
    declared = dataclasses.replace(
        paper_tool,
        configurations=tuple(
            dataclasses.replace(c, p_sensor_com=c.p_sensor_com + rng.uniform(-0.5e-3, 0.5e-3, 3)) for c in paper_tool.configurations
        ),
        tolerance=ToolTolerance(mass=paper_tool.tolerance.mass, com=0.5e-3),  # the errors are within what the file declares
    )
    result = calibrate_recording(path, ur5, declared, model="linear", accept_poor_fit=True)
    assert result.error is None, result.error
    _no_guess(result.calibration.quality.fit["diagnosis"])


def test_the_weak_excitation_threshold_is_above_what_a_plan_reads(ur5_recording, ur5, paper_tool):
    """A plan's recording is far from the weak-excitation threshold: its fit is judged, not its motion."""
    from fts_calib.model.least_squares import information_rank

    session = calibrate_recording(ur5_recording, ur5, paper_tool).session
    est = session.estimator
    sums = est.model_sums(est.model_in_use()[0])
    known = np.r_[0:6, 12 : len(sums)]
    rank, condition = information_rank(sums[np.ix_(known, known)])
    assert rank == len(known) and condition < WEAK_CONDITION / 10


def test_a_dynamic_run_is_never_told_to_hold_the_arm_still(ur5, paper_tool):
    """The quasi-static advice ('hold the arm still at the stops') is for the quasi-static filter; the dynamic one's names its own."""
    from fts_calib.filters.dynamic import nominal_c
    from fts_calib.filters.settings import PipelineConfig
    from fts_calib.model.sensor_config import load_sensor_config
    from fts_calib.session.diagnosis import missing_words
    from fts_calib.session.session import CalibrationSession

    spec = load_sensor_config(resolve("sensor", "configs"))
    missing = {}
    for mode in ("quasi-static", "dynamic"):
        settings = PipelineConfig().with_filter_mode(mode).with_nominal_c(nominal_c(spec))
        missing[mode] = CalibrationSession(ur5, paper_tool, settings, layout=spec.layout).progress().missing  # the status line's
    few = np.array([3, 0, 0])  # a few samples of A: below what counts
    missing["dynamic refusal"] = missing_words(paper_tool, few, np.zeros((3, 4, 4)), dynamic=True)
    missing["quasi-static refusal"] = missing_words(paper_tool, few, np.zeros((3, 4, 4)))
    for mode in ("quasi-static", "quasi-static refusal"):
        assert "hold the arm still at the stops" in missing[mode], missing
    for mode in ("dynamic", "dynamic refusal"):
        assert "hold the arm still" not in missing[mode] and "no moving sample the dynamic filter trusts yet" in missing[mode], missing

"""What a jig's loads determine of a sensor model (the rule of ``--model quadratic|cubic`` and of ``auto``)."""

from __future__ import annotations

import numpy as np
import pytest

from fts_calib.app.cli import main
from fts_calib.model.determination import LoadSums, achievable_rank, determine, jig_sums, minimal_jig
from fts_calib.model.features import features, monomials
from fts_calib.planning.jig import sphere_directions

#: The paper's three centres of mass [m] and its tool's 2 kg.
PAPER = np.array([[0.12, 0.0, 0.0], [0.08, 0.06, 0.0], [0.08, 0.0, 0.06]])
FULL_SCALE = np.array([50.0] * 3 + [5.0] * 3)


def test_no_weight_excites_f_dot_m_so_a_quadratic_model_reaches_26_of_its_27_features():
    """F . M = (c x F) . F = 0 for every weight (paper eq 20): the sums of any jig are singular along it."""
    rng = np.random.default_rng(3)
    directions = rng.normal(size=(50, 3))
    sums = jig_sums([1.0, 2.5], rng.normal(size=(7, 3)) * 0.1, directions / np.linalg.norm(directions, axis=1, keepdims=True), 2)
    f_dot_m = np.zeros(1 + len(monomials(6, 2)))  # the coefficients of F.M over [1; features]
    for i in range(3):
        f_dot_m[1 + list(monomials(6, 2)).index((i, i + 3))] = 1.0
    total = sum(sums.values())
    assert np.abs(total @ f_dot_m).max() <= 1e-12 * np.abs(total).max()
    assert achievable_rank("linear", False) == 6 and achievable_rank("quadratic", False) == 26 and achievable_rank("cubic", False) == 76
    # with one offset per configuration |F|^2 = (m g)^2 is constant in each and joins its offset
    assert achievable_rank("quadratic", True) == 25


def test_the_paper_jig_cannot_determine_a_nonlinear_model_and_two_masses_at_five_centres_can():
    directions = sphere_directions()
    paper = determine(jig_sums([2.0], PAPER, directions, 3), "quadratic", False)
    assert (paper.rank, paper.achievable, paper.masses, paper.centres) == (20, 26, 1, 3) and not paper.determined
    assert "2 masses, each at 5 centres of mass" in paper.lacks(["A", "B", "C"]) and "fix 20 of its 26" in paper.lacks()
    assert minimal_jig("quadratic", False) == (2, 5) and minimal_jig("cubic", False) == (2, 8)
    five = np.vstack([PAPER, [[0.08, -0.06, 0.0], [0.08, 0.0, -0.06]]])
    jig = determine(jig_sums([2.0, 3.5], five, directions, 2), "quadratic", False)
    assert jig.determined and jig.rank == 26 and set(jig.held_out.values()) == {26} and (jig.masses, jig.centres) == (2, 5)
    one_mass = determine(jig_sums([2.0], five, directions, 2), "quadratic", False)
    assert not one_mass.determined  # one force magnitude: a bend with |F| is the force's gain


def test_loads_beyond_any_jig_of_weights_determine_a_model_on_their_own():
    """A rig that pushes and twists (loads over the full-scale box, one group) excites F . M too: determined."""
    loads = LoadSums(3)
    loads.add(np.random.default_rng(0).uniform(-1, 1, (3000, 6)) * FULL_SCALE, np.zeros(3000, dtype=int))
    found = determine(loads.sums, "cubic", False)
    assert found.rank == len(monomials(6, 3)) > found.achievable and found.determined


def test_load_sums_are_the_features_of_the_loads_per_group():
    rng = np.random.default_rng(1)
    W, groups = rng.normal(size=(40, 6)), rng.integers(0, 3, 40)
    loads = LoadSums(2)
    loads.add(W[:25], groups[:25])
    loads.add(W[25:], groups[25:])
    for k in range(3):
        phi = np.hstack([np.ones((np.sum(groups == k), 1)), features(W[groups == k], 2)])
        np.testing.assert_allclose(loads.sums[k], phi.T @ phi, rtol=1e-12, atol=1e-12 * np.abs(phi.T @ phi).max())


@pytest.mark.parametrize("family", ["quadratic", "cubic"])
def test_the_calibration_refuses_a_model_its_loads_cannot_determine(tmp_path, ur5_recording, capsys, family):
    """``--model quadratic|cubic`` on the paper's jig: exit 8, nothing written, what the jig lacks named."""
    out = tmp_path / "cal.yaml"
    argv = ["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(ur5_recording), "-o", str(out), "--model", family]
    assert main(argv) == 8
    printed = capsys.readouterr()
    assert f"no {family} model: the loads of this calibration cannot determine it beyond themselves" in printed.out + printed.err
    assert not out.exists()


def test_a_sensor_file_asking_for_a_cubic_model_is_refused_on_the_paper_jig(tmp_path, ur5_recording, capsys):
    """``model: cubic`` in the sensor YAML is the option's setting: the same refusal, exit 8 (was rank 43 of 84, exit 0)."""
    from fts_calib.core.resources import resolve

    sensor = tmp_path / "cubic_sensor.yaml"
    sensor.write_text(resolve("sensor", "configs").read_text(encoding="utf-8") + "\nmodel: cubic\n", encoding="utf-8")
    out = tmp_path / "cal.yaml"
    argv = ["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(ur5_recording), "--sensor", str(sensor), "-o", str(out)]
    assert main(argv) == 8
    printed = capsys.readouterr()
    assert "no cubic model" in printed.out + printed.err and "2 masses, each at 8 centres of mass" in printed.out + printed.err
    assert not out.exists()

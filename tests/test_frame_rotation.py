"""The sensor frame's turn found on the fit sums: exact on noiseless data, with its twin; the residual's quadratic form; the angles."""

import math

import numpy as np
import pinocchio as pin
import pytest

from fts_calib.robot.tool import wrench_matrix
from fts_calib.session.fit import _embeddings, fit_rows, projected_rss
from fts_calib.session.frame_rotation import (
    axis_aligned,
    frame_rotations,
    half_turn,
    nearest_axis_aligned,
    residual_form,
    rotated_sums,
    rotation_angle,
)

from .helpers import C_BAR_TRUE, COMS, D_TRUE, TOOL_MASS, random_gravity, strains_eq22, tool_wrench

#: Round-off of a turn recovered from noiseless sums (Gauss-Newton to a zero residual) [rad].
ATOL_TURN = 1e-7
#: Sensor frame's sigma per axis [N, N, N, N m, N m, N m]: the weights of the residual.
SIGMA = np.array([2e-3] * 3 + [2e-4] * 3)


def _random_rotation(rng) -> np.ndarray:
    """A turn by up to a half turn about a uniformly random axis, (3, 3)."""
    axis = rng.standard_normal(3)
    return pin.exp3(rng.uniform(0.0, math.pi) * axis / np.linalg.norm(axis))


def _sums(rng, R_sensor_assumed, n=200, noise_std=0.0):
    """Per configuration the fit sums of samples whose gravity, as computed, is turned from the sensor's: (k, 10, 10)."""
    sums = []
    for com in COMS:
        g_assumed = random_gravity(n, rng)
        strains = strains_eq22(C_BAR_TRUE, D_TRUE, tool_wrench(TOOL_MASS, com, g_assumed @ R_sensor_assumed.T))
        rows = fit_rows(g_assumed, strains + noise_std * rng.standard_normal(strains.shape))
        sums.append(rows.T @ rows)
    return np.array(sums)


MATRICES = [wrench_matrix(TOOL_MASS, com) for com in COMS]


def test_the_24_axis_aligned_rotations_are_distinct_rotations_identity_first():
    rotations = axis_aligned()
    assert rotations.shape == (24, 3, 3) and np.array_equal(rotations[0], np.eye(3))
    np.testing.assert_allclose(np.einsum("kji,kjl->kil", rotations, rotations), np.broadcast_to(np.eye(3), (24, 3, 3)), atol=0)
    np.testing.assert_allclose(np.linalg.det(rotations), 1.0)
    assert len({r.tobytes() for r in rotations}) == 24


def test_rotated_sums_are_the_sums_of_the_turned_gravity(rng):
    R = _random_rotation(rng)
    g, strains = random_gravity(50, rng), rng.standard_normal((50, 8))
    rows, turned = fit_rows(g, strains), fit_rows(g @ R.T, strains)
    expected = turned.T @ turned
    np.testing.assert_allclose(rotated_sums((rows.T @ rows)[None], R)[0], expected, atol=1e-12 * np.abs(expected).max())


def test_the_residual_form_is_the_weighted_residual_of_any_matrix(rng):
    """vec(B)^T Q vec(B) equals the residual the fit leaves of M_c B, summed with the weights, for a rotation or any B."""
    sums = _sums(rng, _random_rotation(rng), noise_std=1e-5)
    Q = residual_form(MATRICES, sums, False, SIGMA)
    for B in (_random_rotation(rng), rng.standard_normal((3, 3))):
        changes = np.stack([M @ B for M in MATRICES])[None]
        rss = projected_rss(changes, sums, _embeddings(sums, False))[0]
        expected = float(np.sum(rss / sums[:, 9, 9][:, None] / SIGMA**2))
        assert B.reshape(9) @ Q @ B.reshape(9) == pytest.approx(expected, rel=1e-9)


def test_a_turn_is_found_exactly_on_noiseless_sums_with_its_twin(rng):
    """Noiseless data of a random turn: the turn and its twin (a half turn about the centres of mass' plane) both found."""
    R = _random_rotation(rng)
    normal = np.cross(COMS[1] - COMS[0], COMS[2] - COMS[0])
    half = pin.exp3(math.pi * normal / np.linalg.norm(normal))
    np.testing.assert_allclose(half_turn(COMS), half, atol=1e-12)
    found = frame_rotations(MATRICES, _sums(rng, R), False, SIGMA, half)
    closest = min(rotation_angle(R.T @ S) for candidate in found for S in (candidate, half @ candidate))
    assert closest < ATOL_TURN, f"the turn or its twin: {closest:.3g} rad from the nearest of {len(found)} candidates"
    # the twin fits the noiseless sums as well: its residual is zero too
    Q = residual_form(MATRICES, _sums(rng, R), False, SIGMA)
    scale = float(np.abs(Q).max())
    for S in (R, half @ R):
        assert S.reshape(9) @ Q @ S.reshape(9) < 1e-12 * scale


def test_an_axis_swap_is_its_own_nearest_axis_aligned_rotation(rng):
    A = axis_aligned()[rng.integers(24)]
    nearest, angle = nearest_axis_aligned(A @ pin.exp3(np.array([0.01, 0.0, 0.0])))
    assert np.array_equal(nearest, A) and angle == pytest.approx(0.01, rel=1e-9)

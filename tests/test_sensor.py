"""Sensor model: projection, W = C Delta + D, and the structure check of C."""

import numpy as np
import pytest

from fts_calib import Calibration, ShapeError
from fts_calib.core.exceptions import StructureError
from fts_calib.model.channels import P_NULL, c_bar_from_c, project, wrench_from_strain

from .helpers import C_BAR_TRUE, D_TRUE, strains_eq22
from .paper import TABLE_1

# A wrench is a sum of 8 products and an offset; another summation order (batch or single
# BLAS kernel, another CPU) changes it by a few eps of its largest term, so results are
# compared to a tolerance of the whole quantity's largest entry, never entry by entry
# (a component can be near zero). 9 eps = 2e-15; the margin covers the terms' spread.
TOL_ROUND_OFF = 1e-14  # of the largest entry
FULL_SCALE = np.array([50.0, 50.0, 50.0, 5.0, 5.0, 5.0])  # [N, N, N, N m, N m, N m], the paper's sensor


def _atol(expected, tol=TOL_ROUND_OFF):
    return tol * np.abs(expected).max()


def test_single_and_batch_agree(rng):
    strains = rng.standard_normal((5, 8))
    batch = wrench_from_strain(TABLE_1, strains, D_TRUE)
    assert batch.shape == (5, 6)
    for row, strain in zip(batch, strains, strict=True):
        np.testing.assert_allclose(wrench_from_strain(TABLE_1, strain, D_TRUE), row, rtol=0, atol=_atol(batch))
    assert project(strains[0]).shape == (6,) and project(strains).shape == (5, 6)


def test_wrench_is_c_delta_plus_d_written_out(rng):
    strain = rng.standard_normal(8)
    expected = [sum(TABLE_1[i, k] * strain[k] for k in range(8)) + D_TRUE[i] for i in range(6)]
    np.testing.assert_allclose(wrench_from_strain(TABLE_1, strain, D_TRUE), expected, rtol=0, atol=_atol(expected))


def test_projection_is_eq_5_written_out(rng):
    d = rng.standard_normal(8)
    d1, d2, d3, d4, d5, d6, d7, d8 = d
    expected = [-d2 - d4 - d6 - d8, d3 - d7, d1 - d5, d1 + d3 + d5 + d7, -d4 + d8, -d2 + d6]
    # sums of four +-1 terms: round-off of a few eps of the largest term
    np.testing.assert_allclose(project(d), expected, rtol=0, atol=_atol(d))


def test_strain_patterns_outside_the_model_give_no_wrench():
    C = C_BAR_TRUE @ np.array(project(np.eye(8)).T)
    np.testing.assert_allclose(wrench_from_strain(C, P_NULL), 0.0, atol=1e-12)


def test_structure_check_names_the_residual():
    C = TABLE_1.copy()
    C[0, 0] += 0.5  # breaks c1 - c3 + c5 - c7 = 0 on the Fx row
    with pytest.raises(StructureError, match=r"largest entry of C - \(C @ pinv\(P\)\) @ P is 0.125") as info:
        c_bar_from_c(C)
    assert info.value.residual == pytest.approx(0.125, abs=5e-5)  # 0.5 / 4, plus the table rounding


@pytest.mark.parametrize(
    ("value", "shape"), [(np.zeros(7), r"\(7,\)"), (np.zeros((3, 6)), r"\(3, 6\)"), (np.zeros((2, 2, 8)), r"\(2, 2, 8\)")]
)
def test_wrong_strain_shape_says_received_and_expected(value, shape):
    with pytest.raises(ShapeError, match=rf"channels.shape={shape} but expected \(8,\) or \(N, 8\)"):
        project(value)


def test_calibration_wrench_recovers_the_wrench_that_made_the_strains(rng):
    """Noiseless strains of known wrenches (eq 22 and the paper's P, typed in helpers.py) give
    those wrenches back; a strain pattern outside the model (P's null space) changes nothing."""
    cal = Calibration(C_bar=C_BAR_TRUE, D=D_TRUE)
    W = rng.uniform(-1.0, 1.0, (3, 6)) * FULL_SCALE
    strain = strains_eq22(C_BAR_TRUE, D_TRUE, W) + rng.standard_normal((3, 1)) * P_NULL[0]
    # eq 22 solves with C_bar (condition number about 100): 100 eps of the largest entry
    np.testing.assert_allclose(cal.wrench(strain), W, rtol=0, atol=_atol(W, 1e-12))
    np.testing.assert_allclose(cal.wrench(strain[0]), W[0], rtol=0, atol=_atol(W, 1e-12))
    np.testing.assert_allclose(cal.C, TABLE_1, atol=5e-5)

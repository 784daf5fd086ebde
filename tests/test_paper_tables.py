"""The typed-in tables equal the paper's text, and satisfy C = C_bar P to their rounding."""

import re
from pathlib import Path

import numpy as np
import pytest

from fts_calib.model.channels import P_NULL, P_PINV, P, c_bar_from_c, c_from_c_bar

from .paper import ROUNDING, TABLE_1, TABLE_2

PAPER = Path(__file__).resolve().parents[2] / "shared" / "paper.md"


def _table_from_paper(number: int) -> np.ndarray:
    text = PAPER.read_text(encoding="utf-8")
    start = re.search(rf"^Table {number}\.", text, flags=re.M).start()  # the caption, not the prose
    rows = []
    for line in text[start:].splitlines()[1:]:
        cells = line.split("\t")
        if len(cells) == 9 and "Delta" not in line:  # a data row: label and 8 numbers
            rows.append([float(c) for c in cells[1:]])
        if len(rows) == 6:
            break
    return np.array(rows)


@pytest.mark.skipif(not PAPER.exists(), reason="../shared/paper.md is not beside the checkout")
@pytest.mark.parametrize(("number", "table"), [(1, TABLE_1), (2, TABLE_2)])
def test_typed_tables_equal_the_paper(number, table):
    np.testing.assert_array_equal(_table_from_paper(number), table)


@pytest.mark.skipif(not PAPER.exists(), reason="../shared/paper.md is not beside the checkout")
def test_projection_equals_eq_6_of_the_paper():
    text = PAPER.read_text(encoding="utf-8")
    block = text[text.index("(6) \\quad P") :]
    block = block[: block.index("\\end{bmatrix}")]
    body = block.split("\\begin{bmatrix}")[1]
    rows = [[float(v.replace("+", "")) for v in re.split(r"\s*&\s*", row.strip())] for row in body.split("\\\\")]
    np.testing.assert_array_equal(np.array(rows), P)


@pytest.mark.parametrize("table", [TABLE_1, TABLE_2], ids=["table1", "table2"])
def test_table_equals_c_bar_times_p_to_its_rounding(table):
    C_bar = table @ np.linalg.pinv(P)
    assert np.max(np.abs(C_bar @ P - table)) <= ROUNDING
    np.testing.assert_allclose(c_bar_from_c(table), C_bar, rtol=0, atol=1e-12)
    np.testing.assert_allclose(c_from_c_bar(C_bar), C_bar @ P, rtol=0, atol=1e-12)


def test_ideal_c_bar_of_table_1_is_a_signed_permutation():
    C_bar = c_bar_from_c(TABLE_1)
    dominant = np.argmax(np.abs(C_bar), axis=1)
    # Fx pairs with Delta_bar_1, Fy with Delta_bar_3, Fz with Delta_bar_2, Mx with Delta_bar_4,
    # My with Delta_bar_6 and Mz with Delta_bar_5
    assert dominant.tolist() == [0, 2, 1, 3, 5, 4]
    off = np.abs(C_bar).copy()
    off[np.arange(6), dominant] = 0
    assert np.all(off.max(axis=1) < 0.05 * np.abs(C_bar).max(axis=1))


def test_projection_properties():
    np.testing.assert_allclose(P_PINV, np.linalg.pinv(P), atol=1e-15)
    np.testing.assert_array_equal(P @ P_NULL.T, 0.0)  # exact in any order: sums of halves of small integers
    np.testing.assert_allclose(P_NULL @ P_NULL.T, np.eye(2), atol=1e-15)
    assert np.linalg.matrix_rank(P) == 6

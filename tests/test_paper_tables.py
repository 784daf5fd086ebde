"""The paper's printed numbers (``tests/data/paper_tables.yaml``): as printed, C = C_bar P to their rounding, shipped as they are."""

import re

import numpy as np
import pytest
import yaml

from fts_calib.core.resources import resolve
from fts_calib.model.calibration import load_calibration
from fts_calib.model.channels import P_NULL, P_PINV, P, c_bar_from_c, c_from_c_bar

from .paper import DATA, DATA_FILE, FULL_SCALE, PROJECTION, ROUNDING, TABLE_1, TABLE_2, TABLES

#: A printed number of the tables: four decimals, trailing zeros kept.
PRINTED = re.compile(r"-?\d+\.\d{4}")
#: The row labels as each table prints them.
ROW_LABELS = {
    1: ["$F_x$", "$F_y$", "$F_z$", "$M_x$", "$M_y$", "$M_z$"],
    2: ["Fx", "Fy", "Fz", "Mx", "My", "Mz"],
}
COLUMN_LABELS = [f"$\\Delta^{k}$" for k in range(1, 9)]


def _printed_rows(number: int) -> list[list[str]]:
    """The rows of a table as the data file writes them, read from its text (not through YAML)."""
    text = DATA_FILE.read_text(encoding="utf-8")
    block = text[text.index(f"\ntable_{number}:") :]
    block = block[: block.index("\n\n")]
    return [[cell.strip() for cell in row.split(",")] for row in re.findall(r"^\s+- \[(.*)\]$", block, flags=re.M)]


@pytest.mark.parametrize(("number", "table"), [(1, TABLE_1), (2, TABLE_2)])
def test_the_data_file_holds_each_table_as_printed(number, table):
    """Six labelled rows of eight numbers, each with the four decimals it is printed with: no number reformatted."""
    rows = _printed_rows(number)
    assert [row[0].strip("'") for row in rows] == ROW_LABELS[number], f"Table {number}: the row labels as printed"
    assert DATA[f"table_{number}"]["columns"] == COLUMN_LABELS, f"Table {number}: the column labels as printed"
    reformatted = [cell for row in rows for cell in row[1:] if not PRINTED.fullmatch(cell)]
    assert not reformatted and all(len(row) == 9 for row in rows), f"Table {number}: not as printed: {reformatted}"
    np.testing.assert_array_equal(table, [[float(cell) for cell in row[1:]] for row in rows])
    assert ROUNDING == 0.5 * 10.0 ** -len(rows[0][1].partition(".")[2]), "half of the last printed digit"


def test_projection_equals_eq_6_of_the_paper():
    np.testing.assert_array_equal(PROJECTION, P)
    assert DATA["projection"]["equation"] == 6


@pytest.mark.parametrize("table", [TABLE_1, TABLE_2], ids=["table1", "table2"])
def test_table_equals_c_bar_times_p_to_its_rounding(table):
    C_bar = table @ np.linalg.pinv(P)
    assert np.max(np.abs(C_bar @ P - table)) <= ROUNDING
    np.testing.assert_allclose(c_bar_from_c(table), C_bar, rtol=0, atol=1e-12)
    np.testing.assert_allclose(c_from_c_bar(C_bar), C_bar @ P, rtol=0, atol=1e-12)


@pytest.mark.parametrize("number", [1, 2])
def test_the_shipped_calibration_file_is_the_table(number):
    """configs/paper_tableN_calibration.yaml is the table of the data file made exactly of the form C_bar P, D unknown."""
    path = resolve(f"paper_table{number}_calibration", "configs")
    calibration = load_calibration(path)
    expected = c_bar_from_c(TABLES[number])
    atol = 1e-12 * np.abs(expected).max()  # [N or N m per strain unit]: the file holds C_bar as computed, to its repr
    np.testing.assert_allclose(calibration.C_bar, expected, rtol=0, atol=atol, err_msg=f"{path.name}: C_bar is not Table {number}'s")
    np.testing.assert_allclose(calibration.C, c_from_c_bar(expected), rtol=0, atol=atol, err_msg=f"{path.name}: C")
    assert np.max(np.abs(calibration.C - TABLES[number])) <= ROUNDING, f"{path.name}: C is Table {number} to its printed rounding"
    np.testing.assert_array_equal(calibration.D, np.zeros(6))
    assert calibration.provenance["method"].startswith(f"Table {number} of the paper"), calibration.provenance


def test_the_simulated_sensor_is_table_1_at_the_papers_nominal_range():
    """configs/sensor.yaml: the simulated sensor's true C is Table 1 as printed; its full scale is the paper's range."""
    sensor = yaml.safe_load(resolve("sensor", "configs").read_text(encoding="utf-8"))
    np.testing.assert_array_equal(sensor["simulation"]["C"], TABLE_1)
    full_scale = sensor["full_scale"]
    np.testing.assert_array_equal([full_scale["force"]] * 3 + [full_scale["moment"]] * 3, FULL_SCALE)


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

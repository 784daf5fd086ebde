"""The paper's printed numbers as test vectors, read from ``tests/data/paper_tables.yaml``.

Tables 1 and 2 (the calibration matrices of the jig and of the in situ method), the projection
P of eq 6 and the sensor's nominal range; the data file says where each comes from, and
``test_paper_tables.py`` checks it against the package and the shipped files.
"""

from pathlib import Path

import numpy as np
import yaml

#: The data file: every number as the paper prints it.
DATA_FILE = Path(__file__).resolve().parent / "data" / "paper_tables.yaml"
DATA = yaml.safe_load(DATA_FILE.read_text(encoding="utf-8"))


def _frozen(rows) -> np.ndarray:
    array = np.array(rows, dtype=float)
    array.setflags(write=False)  # shared by every test: a test that changes it would change the others'
    return array


def _matrix(key: str) -> np.ndarray:
    """A table's numbers, shape (6, 8): its printed rows without their labels."""
    return _frozen([row[1:] for row in DATA[key]["rows"]])


#: Table 1: calibration matrix from offline jig measurements; rows Fx..Mz, columns Delta1..8.
TABLE_1 = _matrix("table_1")

#: Table 2: calibration matrix from the in situ online method.
TABLE_2 = _matrix("table_2")

#: The tables by their number in the paper.
TABLES = {1: TABLE_1, 2: TABLE_2}

#: The projection P of eq 6, shape (6, 8).
PROJECTION = _frozen(DATA["projection"]["rows"])

#: The sensor's nominal range (full scale) per wrench axis [N, N, N, N m, N m, N m].
FULL_SCALE = _frozen([DATA["nominal_range"]["force"]] * 3 + [DATA["nominal_range"]["moment"]] * 3)

#: Half of the last printed digit (four decimals): the rounding of both tables.
ROUNDING = 5e-5

"""How often ``--model auto`` with ``--offsets auto`` picks the true model, over many seeds (not collected by pytest).

Static poses of a known mass in five positions, 12 poses each, on an 8-channel sensor with
integer ADC counts and 0.5 counts of noise (:mod:`tests.nonlinear`), of five kinds: linear,
a quadratic nonlinearity of 2 % of full scale at full load, offsets drifting by 1 % of full
scale over the run, both, and a linear sensor whose tool file has a centre of mass 0.5 mm off.

Run: .venv/bin/python -m tests.model_choice_sweep [SEEDS]   (100 by default)
"""

from __future__ import annotations

import sys
import time
from collections import Counter

from fts_calib.model.estimator import OnlineEstimator
from fts_calib.model.offset_basis import OffsetBasis

from .nonlinear import TOOL, pose_data

#: Kind -> (arguments of pose_data, the true (family, offset model)).
KINDS = {
    "linear": ({}, ("linear", "constant")),
    "quadratic 2 % FS": ({"quadratic": 0.02}, ("quadratic", "constant")),
    "drifting offsets": ({"drift_fs_per_run": 0.01}, ("linear", "drift")),
    "both": ({"quadratic": 0.02, "drift_fs_per_run": 0.01}, ("quadratic", "drift")),
    "misfit: CoM 0.5 mm off": ({"com_error": 0.0005}, ("linear", "constant")),
}


def choose(seed: int, **kind) -> tuple[str, str]:
    """(family, offset model) that auto picks on one seed's data."""
    data = pose_data(seed, **kind)
    est = OnlineEstimator(offsets="auto", basis=OffsetBasis(len(TOOL), 2, 600.0, False), model="auto")
    est.update_batch(data.W, data.channels, time=data.time, configuration=data.configuration, unit=data.unit)
    selection = est.selection()
    assert selection is not None
    return selection.chosen.family, selection.chosen.offsets.model


def main(seeds: int = 100) -> None:
    for name, (kind, truth) in KINDS.items():
        start = time.perf_counter()
        counts = Counter(choose(10_000 + seed, **kind) for seed in range(seeds))
        found = ", ".join(f"{f} + {o}: {n}" for (f, o), n in counts.most_common())
        print(f"{name:24s} true {truth[0]} + {truth[1]} in {counts[truth]} of {seeds} ({found}; {time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 100)

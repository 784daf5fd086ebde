"""How often ``--model auto`` with ``--offsets auto`` picks the true model, and how the choice does on loads it never saw.

Static poses (12 per configuration) on an 8-channel sensor with integer ADC counts and 0.5 counts
of noise (:mod:`tests.nonlinear`), of several kinds: linear, a quadratic nonlinearity of 2 % of full
scale at full load, offsets drifting by 1 % of full scale over the run, both, a linear sensor whose
tool file has a centre of mass 0.5 mm off, all on the jig that determines a quadratic model (two
masses at five centres of mass); a quadratic sensor on the paper's jig (one mass, three centres of
mass), where auto must stay linear. Each choice is validated on another tool (another mass and
centre of mass, :data:`tests.nonlinear.OTHER_TOOL`, read without noise; after a tare when the
offsets chosen are not constant: they jump at a tool change, so the other tool's own offset is
unknown) and made again on the recording given 2 and 5 times: the same choice must come out.

Run: .venv/bin/python -m tests.model_choice_sweep [SEEDS]   (100 by default)
"""

from __future__ import annotations

import sys
import time
from collections import Counter

import numpy as np

from fts_calib.model.estimator import OnlineEstimator
from fts_calib.model.offset_models import OffsetBasis

from .nonlinear import OTHER_TOOL, PAPER_JIG, percent_error, pose_data, repeated

#: Kind -> (arguments of pose_data, the true (family, offset model)).
KINDS = {
    "linear": ({}, ("linear", "constant")),
    "quadratic 2 % FS": ({"quadratic": 0.02}, ("quadratic", "constant")),
    "drifting offsets": ({"drift_fs_per_run": 0.01}, ("linear", "drift")),
    "both": ({"quadratic": 0.02, "drift_fs_per_run": 0.01}, ("quadratic", "drift")),
    "misfit: CoM 0.5 mm off": ({"com_error": 0.0005}, ("linear", "constant")),
    "quadratic 2 % FS, paper's jig": ({"quadratic": 0.02, "tool": PAPER_JIG}, ("linear", "constant")),
}


def estimator(data, model: str = "auto") -> OnlineEstimator:
    """The estimator of the pipeline (units: configuration and orientation cell) over ``data``."""
    tool = len(np.unique(data.configuration))
    est = OnlineEstimator(offsets="auto", basis=OffsetBasis(tool, 2, 600.0, False), model=model)
    est.update_batch(data.W, data.channels, time=data.time, configuration=data.configuration, unit=data.units)
    return est


def judge(seed: int, repeats=(2, 5), **kind) -> tuple[tuple[str, str], float, bool]:
    """((family, offset model) auto picks on one seed's data, its largest error on another tool in % FS, the same choice on repeats)."""
    data = pose_data(seed, **kind)
    est = estimator(data)
    selection = est.selection()
    assert selection is not None
    chosen = (selection.chosen.family, selection.chosen.offsets.model)
    names = [str(k) for k in range(len(np.unique(data.configuration)))]
    calibration = est.solve(configurations=names)
    other = {k: v for k, v in kind.items() if k != "tool" and k != "com_error"}
    # noiseless: the error of the calibration, not the noise of one sample
    check = pose_data(
        seed + 50_000, tool=OTHER_TOOL, sensor_seed=seed, at_end=True, poses=24, samples=1, noise_counts=0.0, rounding=False, **other
    )
    error = percent_error(calibration, check, signed=True)
    if chosen[1] != "constant":  # offsets that jump at a tool change: the other tool's own offset is unknown until a tare
        error = error - error.mean(axis=0)
    worst = float(np.abs(error).max())
    same = True
    for k in repeats:
        again = estimator(repeated(data, k)).selection()
        same &= again is not None and (again.chosen.family, again.chosen.offsets.model) == chosen
    return chosen, worst, same


def main(seeds: int = 100) -> None:
    for name, (kind, truth) in KINDS.items():
        start = time.perf_counter()
        runs = [judge(10_000 + seed, **kind) for seed in range(seeds)]
        counts = Counter(chosen for chosen, _, _ in runs)
        found = ", ".join(f"{f} + {o}: {n}" for (f, o), n in counts.most_common())
        worst = np.array([w for _, w, _ in runs])
        same = sum(s for _, _, s in runs)
        print(
            f"{name:30s} true {truth[0]} + {truth[1]} in {counts[truth]} of {seeds} ({found}); another tool: largest error "
            f"{np.median(worst):.3g} % FS median, {worst.max():.3g} % worst; the same choice given 2 and 5 times: {same} of {seeds} "
            f"({time.perf_counter() - start:.0f} s)"
        )


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 100)

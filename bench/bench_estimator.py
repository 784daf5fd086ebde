"""Benchmark of the online estimator: per-sample and batch updates against numpy lstsq.

The targets hold for the linear model (the default); the quadratic model's figures (its per-unit
sums of the held-out choice, and the choice itself at the solve) are printed beside them.

Prints figures; asserts nothing. Run: .venv/bin/python bench/bench_estimator.py
"""

import time
import tracemalloc

import numpy as np

from fts_calib import OnlineEstimator, SimulatedSensor
from fts_calib.model.accumulator import UNIT_SAMPLES
from fts_calib.model.channels import P
from fts_calib.robot.tool import static_wrench


def _data(n: int, rng: np.random.Generator):
    C_bar = np.diag([-116.0, 190.0, 190.0, 2.8, -2.75, -2.78])[[0, 2, 1, 3, 5, 4]]
    sensor = SimulatedSensor(C_bar=C_bar, noise_std=np.full(8, 1e-5))
    g = rng.standard_normal((n, 3))
    g *= 9.81 / np.linalg.norm(g, axis=1, keepdims=True)
    coms = np.array([[0.12, 0.0, 0.0], [0.08, 0.06, 0.0], [0.08, 0.0, 0.06]])  # [m], three configurations
    W = np.vstack([static_wrench(2.0, com, part) for com, part in zip(coms, np.array_split(g, 3), strict=True)])
    return W, sensor.channels(W, rng=rng)


def per_sample(W, S, repeats: int = 200, calls: int = 500, model: str = "linear") -> float:
    est = OnlineEstimator(model=model)
    per_call = []
    for r in range(repeats):
        w_rows, s_rows = W[r * calls : (r + 1) * calls], S[r * calls : (r + 1) * calls]
        start = time.perf_counter()
        for w, s in zip(w_rows, s_rows, strict=True):
            est.update(w, s)
        per_call.append((time.perf_counter() - start) / calls)
    return float(np.median(per_call))


def batch_rate(W, S, repeats: int = 5, model: str = "linear") -> tuple[float, float]:
    """(samples/s of update_batch + solve, seconds of the solve alone), best of ``repeats``."""
    best, solve = np.inf, np.inf
    for _ in range(repeats):
        est = OnlineEstimator(model=model)
        start = time.perf_counter()
        est.update_batch(W, S)
        middle = time.perf_counter()
        est.solve()
        end = time.perf_counter()
        best, solve = min(best, end - start), min(solve, end - middle)
    return len(W) / best, solve


def lstsq_rate(W, S, repeats: int = 3) -> float:
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        X = np.hstack([S @ P.T, np.ones((len(S), 1))])
        np.linalg.lstsq(X, W, rcond=None)
        best = min(best, time.perf_counter() - start)
    return len(W) / best


def batch_peak_memory(W, S) -> float:
    est = OnlineEstimator()
    tracemalloc.start()
    est.update_batch(W, S)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak / 1e6


def main():
    rng = np.random.default_rng(0)
    W, S = _data(1_000_000, rng)
    median = per_sample(W, S)
    print(f"per-sample update: median {median * 1e6:.2f} µs/sample (target <= 5 µs)")
    rate, _ = batch_rate(W, S)
    base = lstsq_rate(W, S)
    print(f"batch update + solve, 1,000,000 samples: {rate / 1e6:.1f} million samples/s (target >= 20)")
    quadratic = per_sample(W, S, repeats=40, model="quadratic")
    q_rate, q_solve = batch_rate(W, S, repeats=2, model="quadratic")
    print(f"quadratic model: per-sample update {quadratic * 1e6:.2f} µs/sample; batch update + solve {q_rate / 1e6:.2f} million samples/s")
    print(f"  (its solve, the held-out choice over {len(W) // UNIT_SAMPLES:,} units of {UNIT_SAMPLES:,} samples: {q_solve:.2f} s)")
    print(f"numpy.linalg.lstsq on the stacked problem: {base / 1e6:.1f} million samples/s; ratio {rate / base:.1f}x")
    for n in (100_000, 1_000_000):
        print(f"peak memory allocated inside update_batch for N={n:>9,}: {batch_peak_memory(W[:n], S[:n]):.1f} MB")


if __name__ == "__main__":
    main()

"""Static-pose data of a nonlinear sensor with known truth, for the model tests (not collected by pytest).

The known wrench comes from the paper's tool (three centres of mass, 2 kg) at random
orientations; the channels are integer ADC counts from the inverse of a known polynomial
model, ``W = C_bar u + Theta_2 phi_2(u) + Theta_3 phi_3(u) + D(t)`` with ``u = P Delta``,
plus white noise, a constant content in the null patterns of P, and rounding.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fts_calib.model.features import features, monomials
from fts_calib.model.sensor import P_NULL, P, c_bar_from_c
from fts_calib.robot.wrench import wrench_matrix

#: Counts per mV/V of the simulated ADC: the paper's Table 1 then reads about 2,000 counts at 50 N.
COUNTS_PER_MVV = 5000.0
#: Full scale [N, N, N, N m, N m, N m] (the paper's sensor).
FULL_SCALE = np.array([50.0] * 3 + [5.0] * 3)
#: A known mass in five positions (the paper's tool's three and two more): mass [kg] and centre of mass [m].
TOOL = [(2.0, [0.12, 0.0, 0.0]), (2.0, [0.08, 0.06, 0.0]), (2.0, [0.08, 0.0, 0.06]), (2.0, [0.08, -0.06, 0.0]), (2.0, [0.08, 0.0, -0.06])]
#: Table 1 of the paper (rows Fx..Mz, per mV/V).
TABLE_1 = np.array(
    [
        [-0.0783, 115.9959, 0.9697, 116.2178, 1.3307, 115.8044, 0.2828, 115.5825],
        [-261.2932, 0.4277, -0.7689, -1.1942, 260.2123, -2.8367, -0.3119, -1.2148],
        [-1.8840, -1.9708, -268.3156, -0.5501, -2.5808, 2.0404, 263.8509, 0.6196],
        [2.8420, -0.0162, 2.8130, -0.0295, 2.7539, -0.0427, 2.7829, -0.0294],
        [0.1194, 2.7478, 0.0584, 0.0326, -0.1015, -2.7470, -0.0405, -0.0318],
        [-0.0495, -0.0221, 0.0971, 2.7913, 0.0981, 0.0448, -0.0485, -2.7686],
    ]
)


@dataclass
class PoseData:
    """Samples and truth: W (N, 6), channels (N, 8) counts, time (N,) s, configuration (N,), unit (N,) (the pose)."""

    W: np.ndarray
    channels: np.ndarray
    time: np.ndarray
    configuration: np.ndarray
    unit: np.ndarray
    C_bar: np.ndarray
    D: np.ndarray
    theta: np.ndarray  # (6, 83): the true coefficients over the cubic features of u (no offset)
    drift: np.ndarray  # (6,) offset drift [N or N m per s]


def nonlinearity(rng, C_bar: np.ndarray, degree: int, fraction: float) -> np.ndarray:
    """Random coefficients (6, q) of the degree-``degree`` monomials of u: at most ``fraction`` of full scale at full load."""
    d_inv = np.linalg.inv(C_bar)
    terms = [m for m in monomials(6, degree) if len(m) == degree]
    theta = rng.normal(size=(6, len(terms)))
    loads = rng.uniform(-1, 1, size=(2000, 6)) * FULL_SCALE
    u = loads @ d_inv.T
    value = features(u, degree)[:, -len(terms) :] @ theta.T
    return theta * (fraction * FULL_SCALE / np.abs(value).max(axis=0))[:, None]


def pose_data(
    seed: int,
    quadratic: float = 0.0,
    cubic: float = 0.0,
    drift_fs_per_run: float = 0.0,
    poses: int = 12,
    samples: int = 150,
    noise_counts: float = 0.5,
    com_error: float = 0.0,
    rounding: bool = True,
) -> PoseData:
    """Static poses of the paper's tool on a nonlinear sensor (see the module docstring).

    Args:
        seed: Random seed.
        quadratic: Largest quadratic term at full load, as a fraction of full scale.
        cubic: Largest cubic term at full load, as a fraction of full scale.
        drift_fs_per_run: Offset change over the run, as a fraction of full scale (linear in time).
        poses: Static poses per configuration.
        samples: Samples per pose (1 kHz).
        noise_counts: White channel noise, ADC counts.
        com_error: Error of the second configuration's centre of mass in the tool file [m] (a model misfit:
            the same error in every configuration only moves the sensor origin, which C absorbs).
        rounding: Round the channels to integer counts.
    """
    rng = np.random.default_rng(seed)
    C_bar = c_bar_from_c(TABLE_1, 1e-5) / COUNTS_PER_MVV  # [N or N m per count]
    D = np.array([1.5, -2.0, 0.7, 0.12, -0.08, 0.05])
    theta = np.zeros((6, len(monomials(6, 3))))
    theta[:, :6] = C_bar
    if quadratic:
        theta[:, 6:27] = nonlinearity(rng, C_bar, 2, quadratic)
    if cubic:
        theta[:, 27:] = nonlinearity(rng, C_bar, 3, cubic)
    run_s = len(TOOL) * poses * 3.0
    drift = drift_fs_per_run * FULL_SCALE / run_s * rng.choice([-1.0, 1.0], 6)
    W, true_W, times, codes, units = [], [], [], [], []
    t0 = 0.0
    for c, (mass, com) in enumerate(TOOL):
        for _ in range(poses):
            direction = rng.normal(size=3)
            g = 9.81 * direction / np.linalg.norm(direction)
            t = t0 + np.arange(samples) / 1000.0
            true_W.append(np.tile(wrench_matrix(mass, com) @ g, (samples, 1)))
            wrong = np.asarray(com) + (com_error * np.array([0.0, 1.0, 0.0]) if c == 1 else 0.0)  # one configuration's
            W.append(np.tile(wrench_matrix(mass, wrong) @ g, (samples, 1)))
            times.append(t)
            codes.append(np.full(samples, c))
            units.append(np.full(samples, len(units)))
            t0 = t[-1] + 3.0
    Wt, time = np.vstack(true_W), np.concatenate(times)
    offset = D + np.outer(time, drift)
    u = np.linalg.solve(C_bar, (Wt - offset).T).T
    degree = 3 if cubic else 2 if quadratic else 1
    for _ in range(40 if degree > 1 else 0):  # fixed point of the inverse model: the nonlinear part is a few % of the linear one
        u = np.linalg.solve(C_bar, (Wt - offset - features(u, degree)[:, 6:] @ theta[:, 6 : len(monomials(6, degree))].T).T).T
    channels = u @ np.linalg.pinv(P).T + np.array([150.0, -100.0]) @ P_NULL
    channels = channels + rng.normal(scale=noise_counts, size=channels.shape)
    channels = np.round(channels) if rounding else channels
    return PoseData(np.vstack(W), channels, time, np.concatenate(codes), np.concatenate(units), C_bar, D, theta, drift)


def noiseless(data: PoseData) -> np.ndarray:
    """The model's exact u = P Delta of the truth (no noise, no rounding), for recovery tests, shape (N, 6)."""
    offset = data.D + np.outer(data.time, data.drift)
    u = np.linalg.solve(data.C_bar, (data.W - offset).T).T
    for _ in range(80):
        u = np.linalg.solve(data.C_bar, (data.W - offset - features(u, 3)[:, 6:] @ data.theta[:, 6:].T).T).T
    return u

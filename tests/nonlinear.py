"""Static-pose data of a nonlinear sensor with known truth, for the model tests (not collected by pytest).

The known wrench comes from a jig of weights (:data:`JIG`: two masses, each at five centres of
mass, which determines a quadratic model, :mod:`fts_calib.model.determination`; or the paper's
three centres of mass, :data:`PAPER_JIG`) at random orientations; the channels are integer ADC
counts from the inverse of a known model, ``W = C_bar u + Theta_2 phi_2(u) + Theta_3 phi_3(u) + D(t)``
with ``u = P Delta``, or of a sensor that bends the wrench it sees oddly, axis ``i`` reading
``W_i + odd FS_i |W_i / FS_i| (W_i / FS_i)`` (no polynomial in u represents it), plus white noise, a
constant content in the null patterns of P, and rounding.

Every model is judged on data the fit never saw: :func:`pose_data` with another ``seed`` and
``tool`` (:data:`OTHER_TOOL`, a mass and centre of mass no jig has) and the same ``sensor_seed``
reads the same sensor under another load; :func:`repeated` gives the same recording several
times, as a user who records the sweep twice does.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from fts_calib.model.channels import P_NULL, P, c_bar_from_c
from fts_calib.model.features import features, monomials
from fts_calib.robot.tool import wrench_matrix
from fts_calib.session.held_out import held_out_units

from .paper import FULL_SCALE, TABLE_1

#: Counts per mV/V of the simulated ADC: the paper's Table 1 then reads about 2,000 counts at 50 N.
COUNTS_PER_MVV = 5000.0
#: Five centres of mass [m] of a movable weight: the paper's tool's three and two more, not all in one plane.
CENTRES = [[0.12, 0.0, 0.0], [0.08, 0.06, 0.0], [0.08, 0.0, 0.06], [0.08, -0.06, 0.0], [0.08, 0.0, -0.06]]
#: A jig that determines a quadratic model: two masses [kg] (to 82 % of the moment's full scale), each at the five centres.
JIG = [(mass, c) for mass in (2.0, 3.5) for c in CENTRES]
#: The paper's jig: one mass at three centres of mass (the linear model only).
PAPER_JIG = [(2.0, c) for c in CENTRES[:3]]
#: Another tool, for validation: the shipped validation payload's mass [kg] and centre of mass [m].
OTHER_TOOL = [(1.4, [0.07, 0.015, -0.025])]
#: The jig's first mass alone at the five centres (one mass: no quadratic model, its |F|^2 is constant).
TOOL = [(2.0, c) for c in CENTRES]


@dataclass
class PoseData:
    """Samples and truth.

    W (N, 6), channels (N, 8) counts, time (N,) s, configuration (N,), unit (N,) (the pose), g (N, 3) gravity
    in the sensor frame [m/s^2]; the truth: C_bar, D, theta (6, 83) over the cubic features of u (no offset),
    odd (the odd bend's fraction), drift (6,) [N or N m per s].
    """

    W: np.ndarray
    channels: np.ndarray
    time: np.ndarray
    configuration: np.ndarray
    unit: np.ndarray
    C_bar: np.ndarray
    D: np.ndarray
    theta: np.ndarray
    drift: np.ndarray
    g: np.ndarray
    odd: float = 0.0

    @property
    def units(self) -> np.ndarray:
        """The held-out units the pipeline gives these samples: configuration and orientation cell."""
        return held_out_units(self.configuration, self.g)


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
    tool=JIG,
    odd: float = 0.0,
    sensor_seed: int | None = None,
    at_end: bool = False,
) -> PoseData:
    """Static poses of a jig on a nonlinear sensor (see the module docstring).

    Args:
        seed: Random seed of the poses and the noise.
        quadratic: Largest quadratic term at full load, as a fraction of full scale.
        cubic: Largest cubic term at full load, as a fraction of full scale.
        drift_fs_per_run: Offset change over a run of the jig, as a fraction of full scale (linear in time).
        poses: Static poses per configuration.
        samples: Samples per pose (1 kHz).
        noise_counts: White channel noise, ADC counts.
        com_error: Error of the second configuration's centre of mass in the tool file [m] (a model misfit:
            the same error in every configuration only moves the sensor origin, which C absorbs).
        rounding: Round the channels to integer counts.
        tool: The loads: (mass [kg], centre of mass [m]) per configuration.
        odd: The odd bend (see the module docstring), a fraction of full scale at full load.
        sensor_seed: Seed of the sensor's truth (its nonlinearity and drift sign); ``seed`` when None.
            Two calls with one ``sensor_seed`` read the same sensor.
        at_end: The offsets held at their value at the end of a run of :data:`JIG` (a validation after the calibration).
    """
    truth = np.random.default_rng(seed if sensor_seed is None else sensor_seed)
    rng = np.random.default_rng(seed) if sensor_seed is not None and sensor_seed != seed else truth
    C_bar = c_bar_from_c(TABLE_1, 1e-5) / COUNTS_PER_MVV  # [N or N m per count]
    D = np.array([1.5, -2.0, 0.7, 0.12, -0.08, 0.05])
    theta = np.zeros((6, len(monomials(6, 3))))
    theta[:, :6] = C_bar
    if quadratic:
        theta[:, 6:27] = nonlinearity(truth, C_bar, 2, quadratic)
    if cubic:
        theta[:, 27:] = nonlinearity(truth, C_bar, 3, cubic)
    run_s = len(JIG) * poses * 3.0
    drift = drift_fs_per_run * FULL_SCALE / run_s * truth.choice([-1.0, 1.0], 6)
    W, true_W, times, codes, units, gs = [], [], [], [], [], []
    t0 = 0.0
    for c, (mass, com) in enumerate(tool):
        for _ in range(poses):
            direction = rng.normal(size=3)
            g = 9.81 * direction / np.linalg.norm(direction)
            t = t0 + np.arange(samples) / 1000.0
            true_W.append(np.tile(wrench_matrix(mass, com) @ g, (samples, 1)))
            wrong = np.asarray(com) + (com_error * np.array([0.0, 1.0, 0.0]) if c == 1 else 0.0)  # one configuration's
            W.append(np.tile(wrench_matrix(mass, wrong) @ g, (samples, 1)))
            gs.append(np.tile(g, (samples, 1)))
            times.append(t)
            codes.append(np.full(samples, c))
            units.append(np.full(samples, len(units)))
            t0 = t[-1] + 3.0
    Wt, time = np.vstack(true_W), np.concatenate(times)
    offset = D + (np.full((len(time), 6), run_s * drift) if at_end else np.outer(time, drift))
    seen = Wt + odd * FULL_SCALE * np.abs(Wt / FULL_SCALE) * (Wt / FULL_SCALE)  # the odd bend: what the channels respond to
    u = np.linalg.solve(C_bar, (seen - offset).T).T
    degree = 3 if cubic else 2 if quadratic else 1
    for _ in range(40 if degree > 1 else 0):  # fixed point of the inverse model: the nonlinear part is a few % of the linear one
        u = np.linalg.solve(C_bar, (seen - offset - features(u, degree)[:, 6:] @ theta[:, 6 : len(monomials(6, degree))].T).T).T
    channels = u @ np.linalg.pinv(P).T + np.array([150.0, -100.0]) @ P_NULL
    channels = channels + rng.normal(scale=noise_counts, size=channels.shape)
    channels = np.round(channels) if rounding else channels
    return PoseData(np.vstack(W), channels, time, np.concatenate(codes), np.concatenate(units), C_bar, D, theta, drift, np.vstack(gs), odd)


def repeated(data: PoseData, times: int) -> PoseData:
    """The same recording ``times`` times in a row, each copy's clock shifted past the end of the previous one."""
    span = float(data.time[-1] - data.time[0]) + 1.0
    time = np.concatenate([data.time + k * span for k in range(times)])

    def tile(a: np.ndarray) -> np.ndarray:
        return np.concatenate([a] * times)

    return replace(
        data,
        W=tile(data.W),
        channels=tile(data.channels),
        time=time,
        configuration=tile(data.configuration),
        unit=np.concatenate([data.unit + k * (data.unit.max() + 1) for k in range(times)]),
        g=tile(data.g),
    )


def noiseless(data: PoseData) -> np.ndarray:
    """The model's exact u = P Delta of the truth (no noise, no rounding), for recovery tests, shape (N, 6)."""
    offset = data.D + np.outer(data.time, data.drift)
    u = np.linalg.solve(data.C_bar, (data.W - offset).T).T
    for _ in range(80):
        u = np.linalg.solve(data.C_bar, (data.W - offset - features(u, 3)[:, 6:] @ data.theta[:, 6:].T).T).T
    return u


def percent_error(calibration, data: PoseData, signed: bool = False) -> np.ndarray:
    """|wrench of ``calibration`` on ``data``'s channels - its known wrench| in % of full scale, per sample and axis, shape (N, 6).

    ``signed``: the difference itself, not its magnitude.
    """
    error = 100.0 * (calibration.wrench(data.channels) - data.W) / FULL_SCALE
    return error if signed else np.abs(error)

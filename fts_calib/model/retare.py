"""Re-tare: the offsets D alone, with C_bar known, from a few samples of a known load.

``D = mean(W_known - C Delta)`` with ``C = C_bar P``: the frequent use the paper stresses
(offset removal just before use). Wrenches [N, N, N, N m, N m, N m] in the sensor frame,
sample axis first; strains raw, shape (N, 8).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.arrays import as_samples, frozen
from ..core.deprecation import renamed
from ..core.exceptions import InsufficientExcitation, ShapeError
from .channels import MALTESE_CROSS_8, ChannelLayout
from .features import SensorModel


@dataclass(frozen=True)
class OffsetEstimate:
    """Offsets estimated with C_bar known (re-tare).

    Attributes:
        D: Wrench offsets in [N, N, N, N m, N m, N m]. Shape (6,).
        stderr_D: Standard error of each offset, same units. Shape (6,).
        samples_used: Samples averaged.
        samples_skipped: Samples with non-finite values, skipped.
    """

    D: np.ndarray
    stderr_D: np.ndarray
    samples_used: int
    samples_skipped: int

    def __post_init__(self):
        object.__setattr__(self, "D", frozen(self.D))
        object.__setattr__(self, "stderr_D", frozen(self.stderr_D))


@renamed(strain="channels")
def estimate_offsets(
    C_bar, channels, w_sensor=None, layout: ChannelLayout = MALTESE_CROSS_8, model: SensorModel | None = None
) -> OffsetEstimate:
    """Re-tare: the offsets D alone, with C_bar known, from a few samples of a known load.

    ``D = mean(W_known - C Delta)``: the frequent use the paper stresses (offset removal
    just before use).

    Args:
        C_bar: Known modified calibration matrix. Shape (6, 6).
        channels: Raw channels under the known load. Shape (N, n) or (n,).
        w_sensor: The known load in [N, N, N, N m, N m, N m], shape (N, 6) or (6,);
            zero (nothing mounted) when None.
        layout: The sensor's channel layout (n channels); the paper's 8 bridges by default.
        model: A nonlinear sensor model (the calibration's ``model``): ``D = mean(W_known -
            Theta phi(u))``, C_bar unused; None for the linear ``C Delta``.

    Raises:
        InsufficientExcitation: No finite sample.
    """
    C = layout.c_from_c_bar(C_bar)
    S, _ = as_samples(channels, layout.n_channels, "channels")
    W = np.zeros((len(S), 6)) if w_sensor is None else as_samples(w_sensor, 6, "w_sensor")[0]
    if len(W) == 1 and len(S) > 1:
        W = np.repeat(W, len(S), axis=0)
    if len(W) != len(S):
        raise ShapeError(f"w_sensor has {len(W)} rows but channels has {len(S)}: expected the same N")
    residual = W - (S @ C.T if model is None else model.wrench(S))
    ok = np.all(np.isfinite(residual), axis=1)
    n = int(ok.sum())
    if n == 0:
        raise InsufficientExcitation(0, 1, "no finite sample to estimate the offsets from.")
    residual = residual[ok]
    D = residual.mean(axis=0)
    stderr = residual.std(axis=0, ddof=1) / math.sqrt(n) if n > 1 else np.full(6, math.inf)
    return OffsetEstimate(D=D, stderr_D=stderr, samples_used=n, samples_skipped=int(len(ok) - n))

r"""Offline calibration from a jig (paper eq 9 and its first validation stage).

Pure axial loads W ([N, N, N, N m, N m, N m], in the sensor frame) are applied step by
step and the strains Delta recorded with their offsets already removed; C_bar is the
least-squares solution through the pseudo-inverse (SVD) of the projected strains
``X = P Delta``. With the samples as columns, W (6, N) and X (6, N):

.. math::

    \bar C = W X^{\#}, \qquad C = \bar C P \quad \text{(eqs 7, 9)}, \qquad D = 0.
"""

from __future__ import annotations

import numpy as np

from .._version import __version__
from ..core.arrays import as_samples
from ..core.deprecation import renamed
from ..core.exceptions import InsufficientExcitation, ShapeError
from .calibration import Calibration, now_iso
from .channels import MALTESE_CROSS_8, ChannelLayout
from .least_squares import fit_quality, information_rank


@renamed(strain="channels")
def jig_calibration(w_sensor, channels, rcond: float = 1e-12, layout: ChannelLayout = MALTESE_CROSS_8) -> Calibration:
    """Offline calibration from a jig (paper eq 9 and its first validation stage).

    Pure axial loads are applied step by step and the strains recorded with their offsets
    already removed; C_bar is the least-squares solution through the pseudo-inverse of the
    projected strains (SVD), and ``C = C_bar P`` (eq 7). D is zero by construction.

    Args:
        w_sensor: Applied wrenches, in [N, N, N, N m, N m, N m]. Shape (N, 6).
        channels: Strains with offsets removed. Shape (N, n), n = ``layout.n_channels``.
        rcond: Singular values below ``rcond`` times the largest count as zero.
        layout: The sensor's channel layout; the paper's 8-bridge one by default.

    Raises:
        InsufficientExcitation: The projected strains do not span 6 directions.
    """
    W, _ = as_samples(w_sensor, 6, "w_sensor")
    S, _ = as_samples(channels, layout.n_channels, "channels")
    if W.shape[0] != S.shape[0]:
        raise ShapeError(f"w_sensor has {W.shape[0]} rows but channels has {S.shape[0]}: expected the same N")
    ok = np.all(np.isfinite(W), axis=1) & np.all(np.isfinite(S), axis=1)
    W, X = W[ok], S[ok] @ layout.projection.T
    U, s, Vt = np.linalg.svd(X, full_matrices=False)
    rank = int(np.sum(s > rcond * s[0])) if s.size and s[0] > 0 else 0
    if rank < 6:
        raise InsufficientExcitation(rank, 6 - rank, "the jig loads must include all six axes.", full=6)
    C_bar = ((Vt.T / s) @ (U.T @ W)).T  # eq 9: W X^#, with X^# the pseudo-inverse
    inv = (Vt.T / s**2) @ Vt
    skipped = {"non-finite wrench or strain": int((~ok).sum())} if (~ok).any() else {}
    _, condition = information_rank(X.T @ X)
    quality = fit_quality(
        W.T @ W, W.T @ X, X.T @ X, C_bar, inv, float(len(W)), len(W), len(ok), rank, condition, skipped, layout.projection
    )
    provenance = {
        "method": "offline jig, pseudo-inverse (paper eq 9); offsets removed beforehand, D = 0",
        "time": now_iso(),
        "software_version": __version__,
    }
    return Calibration(C_bar=C_bar, D=np.zeros(6), quality=quality, provenance=provenance, layout=layout)

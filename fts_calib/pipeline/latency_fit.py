r"""The joint stream's latency fitted with the calibration, from the dynamic filter's moving samples.

Joints read ``tau`` late shift the expected wrench by ``tau dW/dt`` to first order. Fitting
the calibration to ``W + tau dW/dt`` (axes scaled by their full scale ``FS``, regressors
``x = [P Delta; e_c]``, one offset per tool configuration) leaves a residual quadratic in
``tau``; with ``S`` the weighted sums of ``z z^T``, ``z = [x; W / FS; dW/dt / FS]``, and the
parts of ``W`` and ``dW/dt`` the regressors do not explain
(``A = S_WW - S_Wx S_xx^+ S_xW``, ``B = S_WV - S_Wx S_xx^+ S_xV``, ``E = S_VV - S_Vx S_xx^+ S_xV``):

.. math::

    \mathrm{RSS}(\tau) = \mathrm{tr} A + 2\tau\,\mathrm{tr} B + \tau^2\,\mathrm{tr} E, \qquad
    \hat\tau = -\mathrm{tr} B / \mathrm{tr} E, \qquad
    \sigma_\tau^2 = \frac{\mathrm{RSS}(\hat\tau)}{6 (n - p)\,\mathrm{tr} E}.

``tau`` is the latency *left* after the one the filter applied: ``calibrate`` with
``filter.latency_s: auto`` reads the recording again with it applied
(:func:`fts_calib.pipeline.calibrate.calibrate_recording`). The standard error takes the
samples as independent: optimistic where the errors correlate over the derivative window.
Only sums are kept: memory does not grow with the stream. Times [s].
"""

from __future__ import annotations

import math

import numpy as np

#: Fewest samples for a latency estimate.
MIN_SAMPLES = 200


class LatencyFit:
    """Sums for the latency fitted with the calibration (see the module docstring).

    Args:
        n_configurations: k, the tool's configurations (one offset column each).
        full_scale: Full scale per axis [N, N m], shape (6,).
    """

    def __init__(self, n_configurations: int, full_scale):
        self.k = int(n_configurations)
        self.full_scale = np.asarray(full_scale, dtype=float)
        width = 6 + self.k + 12
        self.sums = np.zeros((self.k, width, width))  # per configuration
        self.counts = np.zeros(self.k, dtype=np.int64)

    @property
    def count(self) -> int:
        """Samples added."""
        return int(self.counts.sum())

    def add(self, projected: np.ndarray, codes: np.ndarray, wrench: np.ndarray, rate: np.ndarray, weight: np.ndarray) -> None:
        """Add kept samples.

        Args:
            projected: ``P Delta`` of the samples, shape (N, 6).
            codes: Configuration index per sample, shape (N,).
            wrench: Expected wrench [N, N m], shape (N, 6).
            rate: Its rate of change [N/s, N m/s], shape (N, 6).
            weight: The samples' weights, shape (N,).
        """
        finite = np.all(np.isfinite(rate), axis=1)
        n = int(finite.sum())
        if not n:
            return
        z = np.zeros((n, self.sums.shape[1]))
        z[:, :6] = projected[finite]
        z[np.arange(n), 6 + codes[finite]] = 1.0
        z[:, 6 + self.k : 12 + self.k] = wrench[finite] / self.full_scale
        z[:, 12 + self.k :] = rate[finite] / self.full_scale
        codes, weight = codes[finite], weight[finite]
        single = bool(np.all(codes == codes[0]))
        for c in np.unique(codes):
            mine = slice(None) if single else codes == c  # one configuration (the usual chunk): no copies
            part = z[mine]
            self.sums[c] += (part * weight[mine, None]).T @ part
            self.counts[c] += len(part)

    def solve(self) -> tuple[float, float] | None:
        """``(tau [s], standard error [s])``, or None with too few samples or no change of the wrench."""
        if self.count < MIN_SAMPLES:
            return None
        p = 6 + self.k
        S = self.sums.sum(axis=0)
        x, w, v = slice(0, p), slice(p, p + 6), slice(p + 6, p + 12)
        inverse = np.linalg.pinv(S[x, x])

        def part(a: slice, b: slice) -> float:
            return float(np.trace(S[a, b] - S[a, x] @ inverse @ S[x, b]))

        A, B, E = part(w, w), part(w, v), part(v, v)
        if not E > 0:
            return None
        tau = -B / E
        rss = max(A + 2 * tau * B + tau * tau * E, 0.0)
        dof = max(self.count - p, 1)
        return tau, math.sqrt(rss / (6 * dof) / E)

    def residuals(self, tau: float) -> tuple[dict[int, np.ndarray], np.ndarray] | None:
        """The fit's residual per configuration at the latency ``tau`` [s] (the dynamic fit check), and its C_bar.

        Returns:
            ``({configuration index: weighted residual RMS per axis [N, N m], scaled by
            sqrt(sum of weights / samples) so that samples of weight 1 / (1 + rho^2) show the strain
            noise alone}, C_bar (6, 6))``, or None with too few samples.
        """
        if self.count < MIN_SAMPLES:
            return None
        p = 6 + self.k
        S = self.sums.sum(axis=0)
        x = slice(0, p)
        target = S[p : p + 6, x] + tau * S[p + 6 : p + 12, x]
        theta = target @ np.linalg.pinv(S[x, x])  # (6, p): scaled wrench from [P Delta; e_c]
        L = np.hstack([-theta, np.eye(6), tau * np.eye(6)])
        out = {}
        for c in range(self.k):
            weight = self.sums[c, 6 + c, 6 + c]  # the sum of the weights: the one-hot column's
            if self.counts[c] and weight > 0:
                rss = np.maximum(np.diag(L @ self.sums[c] @ L.T), 0.0)
                out[c] = self.full_scale * np.sqrt(rss / weight) * math.sqrt(weight / self.counts[c])
        return out, theta[:, :6] * self.full_scale[:, None]

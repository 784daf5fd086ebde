"""The sums of the online estimator: ``z z^T`` with ``z = [W; P Delta; b]``, weights and forgetting.

One symmetric (12 + k) x (12 + k) sum holds every normal matrix of the estimator
(:mod:`fts_calib.model.estimator`): W the known wrench (6,) in [N, N, N, N m, N m, N m],
``P Delta`` the projected strain (6,), ``b`` the offset basis (k,) of the sample's tool
configuration, time [s] and temperature [°C] (:mod:`fts_calib.model.offset_models`), so the
memory does not grow with the number of samples.

Weights are frequency weights: a sample of weight 2 counts exactly like the same sample
given twice; or, with ``precision=True`` (the dynamic filter's ``1 / (1 + rho^2)``), inverse
variances relative to the unit weight's: the sums are the same, but each row of positive
weight is one observation for the residual's degrees of freedom (a weight of 0.004 does not
make a sample 0.004 of one: it is one sample of a larger noise). The forgetting factor ``lam`` in (0, 1] multiplies the sums by ``lam``
before each accepted sample (1 keeps everything). A sample with a non-finite value is
skipped and counted.
"""

from __future__ import annotations

import math
from collections import Counter

import numpy as np

from ..core.arrays import as_samples
from ..core.deprecation import renamed
from ..core.exceptions import ConfigError, ShapeError
from .channels import MALTESE_CROSS_8, ChannelLayout, channel_layout
from .features import degree_of, model_setting
from .least_squares import gram
from .model_choice import UnitSums
from .offset_models import OffsetBasis, OffsetTrace

_CHUNK = 1 << 16  # rows per block in batch updates: bounds temporary memory to ~10 MB
_NON_FINITE = "non-finite wrench, strain or weight"
#: Samples per held-out unit when the caller gives no units: consecutive blocks of this many used samples.
UNIT_SAMPLES = 1000


class SampleSums:
    """The estimator's sums (see the module docstring).

    Single samples are staged in a small buffer and added to the sums in blocks by the
    same code as :meth:`update_batch` (one matrix product per block instead of one outer
    product per sample); every method that reads the sums adds the staged rows first, so
    the buffer is invisible to a caller.

    Args:
        forgetting: Exponential forgetting factor in (0, 1]; 1 weighs all samples equally.
        layout: The sensor's channel layout (or its sensor-YAML ``channels`` value).
        basis: The full offset basis; :class:`OffsetBasis` ``()`` when None.
        model: The sensor model setting ('linear', 'quadratic', 'cubic' or 'auto',
            :mod:`fts_calib.model.features`). Any but 'linear' also keeps the per-unit sums of
            :mod:`fts_calib.model.model_choice` (the largest family's features).
        full_channels: The model's inputs are the raw channels (a free 6 x n C) instead of ``P Delta``.
    """

    _STAGE = 64  # rows staged by update() before they are added to the sums

    def __init__(
        self,
        forgetting: float = 1.0,
        layout: ChannelLayout | str | None = MALTESE_CROSS_8,
        basis: OffsetBasis | None = None,
        model: str = "linear",
        full_channels: bool = False,
    ):
        if not (0.0 < forgetting <= 1.0):
            raise ConfigError("forgetting", forgetting, "a number in (0, 1]")
        self.model = model_setting(model)
        self.full_channels = bool(full_channels)
        if forgetting != 1.0 and (self.model != "linear" or self.full_channels):
            raise ConfigError("forgetting", forgetting, "1 with a model other than linear on P Delta (held-out sums cannot forget)")
        self.forgetting = float(forgetting)
        self.layout = channel_layout(layout)
        self.basis = basis if basis is not None else OffsetBasis()
        self._P = self.layout.projection
        self._strain_shape = (self.layout.n_channels,)
        width = 12 + self.basis.size
        self._sums = np.zeros((width, width))
        self._staged: list[tuple] = []  # samples of update() not yet in the sums
        self._weight_sum = 0.0
        #: Observations for the residual's degrees of freedom, after forgetting: the frequency weights' sum, and
        #: one per row of positive precision weight.
        self._count_sum = 0.0
        self.samples_used = 0
        self.samples_seen = 0
        self.skipped: Counter[str] = Counter()
        #: ``t_0`` [s] and ``T_0`` [°C] of the offset basis: those of the first sample that had them.
        self.time_origin: float | None = None
        self.temperature_origin: float | None = None
        self.trace = OffsetTrace()  # the offset trajectory's sample points
        self.units: UnitSums | None = None  # per-unit sums of the model choice: None for the linear model on P Delta
        self.unit_rows = 0  # rows added to the unit sums (for the default units)
        if self.model != "linear" or self.full_channels:
            projection = None if self.full_channels else self._P
            self.units = UnitSums(projection, self.layout.n_channels, degree_of(self.model), self.basis.size)

    @renamed(strain="channels")
    def update(self, w_sensor, channels, weight: float = 1.0, time=None, configuration: int = 0, temperature=None, unit: int = -1) -> bool:
        """Add one sample (eqs 15-16).

        Args:
            w_sensor: Known wrench on the sensor, in [N, N, N, N m, N m, N m]. Shape (6,).
            channels: Raw channel readings. Shape (n,), n = ``layout.n_channels``.
            weight: Frequency weight >= 0.
            time: Sample time [s], or None (at the time origin: no drift term).
            configuration: Index of the tool configuration mounted, in [0, K).
            temperature: Sensor temperature [°C], or None (none measured).
            unit: The held-out unit of the sample (a static pose, a block of still windows),
                an integer >= 0; -1: blocks of :data:`UNIT_SAMPLES` samples. Used by models
                other than linear only.

        Returns:
            True when the sample was used; False when it was skipped (a non-finite value)
            and counted in ``skipped``.
        """
        wrench = np.asarray(w_sensor, dtype=float)
        s = np.asarray(channels, dtype=float)
        if wrench.shape != (6,) or s.shape != self._strain_shape:
            raise ShapeError(f"w_sensor.shape={wrench.shape}, channels.shape={s.shape} but expected (6,) and {self._strain_shape}")
        if configuration and self.basis.n_configurations > 1:  # the checks of _codes, for one index
            self._codes(np.array([configuration]), 1)
        self.samples_seen += 1
        # sums of squares: inf or NaN when any value is (or would overflow the sums), and
        # never inf - inf, so the check itself raises no floating-point warning
        stamps_ok = (time is None or math.isfinite(time)) and (temperature is None or math.isfinite(temperature))
        if not (math.isfinite(s.dot(s) + wrench.dot(wrench)) and stamps_ok and math.isfinite(weight) and weight >= 0):
            self._skip(_NON_FINITE, 1)
            return False
        pattern = (time is None, temperature is None)
        if self._staged and self._staged[-1][-1] != pattern:
            self._flush()  # a block has times (and temperatures) for all its rows or for none
        self._staged.append((wrench, s, float(weight), time, int(configuration), temperature, unit, pattern))
        self.samples_used += 1
        if len(self._staged) == self._STAGE:
            self._flush()
        return True

    @renamed(strain="channels")
    def update_batch(
        self,
        w_sensor,
        channels,
        weight=None,
        time=None,
        configuration=None,
        temperature=None,
        unit=None,
        w_static=None,
        *,
        precision: bool = False,
    ) -> int:
        """Add many samples; the sums equal those of calling :meth:`update` on each in order.

        Args:
            w_sensor: Known wrenches, in [N, N, N, N m, N m, N m]. Shape (N, 6).
            channels: Raw channel readings. Shape (N, n), n = ``layout.n_channels``.
            weight: Frequency weights >= 0, shape (N,); all 1 when None.
            time: Sample times [s], shape (N,), or None (no drift term).
            configuration: Tool configuration index per sample in [0, K), shape (N,); all 0
                when None.
            temperature: Sensor temperatures [°C], shape (N,), or None.
            unit: The held-out unit of each sample (integers >= 0; the same integer is the same
                unit, in any call: :mod:`fts_calib.session.held_out`), shape (N,); None: blocks of
                :data:`UNIT_SAMPLES` samples. Used by models other than linear only.
            w_static: The weight-only part of each known wrench (paper eqs 17-18) [N, N m],
                shape (N, 6): what the loads determine of a nonlinear model is judged on it
                (:mod:`fts_calib.model.determination`); ``w_sensor`` when None.
            precision: The weights are inverse variances relative to the unit weight's, not
                frequencies: the same sums, each row of positive weight one observation for the
                residual's degrees of freedom (the standard errors).

        Returns:
            Number of samples used; rows with a non-finite value are skipped and counted.
        """
        W, _ = as_samples(w_sensor, 6, "w_sensor")
        S, _ = as_samples(channels, self.layout.n_channels, "channels")
        if W.shape[0] != S.shape[0]:
            raise ShapeError(f"w_sensor has {W.shape[0]} rows but channels has {S.shape[0]}: expected the same N")
        n = W.shape[0]
        weight, time, temperature = (
            self._column(v, n, name) for v, name in ((weight, "weight"), (time, "time"), (temperature, "temperature"))
        )
        codes = self._codes(configuration, n)
        units = self._units(unit, n)
        static = None if w_static is None or self.units is None else as_samples(w_static, 6, "w_static")[0]
        if static is not None and len(static) != n:
            raise ShapeError(f"w_static has {len(static)} rows but w_sensor has {n}: expected the same N")
        self._flush()
        used = 0
        for start in range(0, n, _CHUNK):
            part = slice(start, min(start + _CHUNK, n))
            columns = (weight, time, codes, temperature, units, static)
            used += self._add_block(W[part], S[part], *(None if v is None else v[part] for v in columns), precision=precision)
        self.samples_seen += n
        self.samples_used += used
        return used

    @staticmethod
    def _column(value, n: int, name: str) -> np.ndarray | None:
        if value is None:
            return None
        value = np.asarray(value, dtype=float).reshape(-1) if np.ndim(value) else np.full(n, float(value))
        if value.shape != (n,):
            raise ShapeError(f"{name}.shape={value.shape} but expected ({n},)")
        return value

    def _codes(self, configuration, n: int) -> np.ndarray | None:
        """Configuration indices (N,) checked against K; None when the basis has one column."""
        if configuration is None or self.basis.n_configurations == 1:
            return None  # one configuration column: every sample's offset is the same
        codes = np.asarray(configuration).reshape(-1)
        if codes.shape != (n,) or codes.dtype.kind not in "iu":
            raise ShapeError(f"configuration: {codes.shape} {codes.dtype} but expected ({n},) integers")
        K = self.basis.n_configurations
        if np.any((codes < 0) | (codes >= K)):
            bad = int(codes[(codes < 0) | (codes >= K)][0])
            raise ConfigError("configuration", bad, f"an index from 0 to {K - 1} (the estimator has {K} offset columns)")
        return codes.astype(np.int64)

    def _units(self, unit, n: int) -> np.ndarray | None:
        """Unit indices (N,) checked; None when no unit sums are kept or none were given."""
        if self.units is None or unit is None:
            return None
        units = np.asarray(unit).reshape(-1)
        if units.shape != (n,) or units.dtype.kind not in "iu":
            raise ShapeError(f"unit: {units.shape} {units.dtype} but expected ({n},) integers")
        return units.astype(np.int64)

    def _add_units(self, Z: np.ndarray, S: np.ndarray, unit: np.ndarray | None, weight: np.ndarray | None, static=None, codes=None) -> None:
        """Add finite rows to the per-unit sums (the model choice); nothing for the linear model."""
        if self.units is None:
            return
        if unit is None or np.any(unit < 0):  # blocks of UNIT_SAMPLES samples, by their index among those added
            blocks = (self.unit_rows + np.arange(len(Z))) // UNIT_SAMPLES
            unit = blocks if unit is None else np.where(unit < 0, blocks, unit)
        self.unit_rows += len(Z)
        self.units.add(Z[:, :6], S, Z[:, 12:], unit, weight, static, codes)

    def drift_rows(self, time, temperature) -> np.ndarray:
        """The drift columns of the offset basis (time powers, temperature) of samples already added.

        Args:
            time: Sample times [s], shape (N,), or None.
            temperature: Temperatures [°C], shape (N,), or None.

        Returns:
            Shape (N, basis.n_drift), with this estimator's origins.
        """
        rows = self.basis.rows(time, None, temperature, self.time_origin or 0.0, self.temperature_origin or 0.0)
        return rows[:, self.basis.n_configurations :]

    def _set_origins(self, time, temperature) -> None:
        if self.time_origin is None and time is not None and len(time):
            self.time_origin = float(time[0])
        if self.temperature_origin is None and temperature is not None and len(temperature):
            self.temperature_origin = float(temperature[0])

    def _add_block(self, W, S, weight, time, codes, temperature, unit=None, static=None, *, precision: bool = False) -> int:
        Z = np.empty((W.shape[0], self._sums.shape[0]))
        Z[:, :6] = W
        with np.errstate(over="ignore", invalid="ignore"):  # bad rows are found below
            np.matmul(S, self._P.T, out=Z[:, 6:12])
            if weight is None and self.forgetting == 1.0 and self._fast(Z, time, codes, temperature):
                self._add_units(Z, S, unit, None, static, codes)
                return len(Z)
            # the rule of update(): a row is bad when its sum of squares is not finite
            ok = np.isfinite(np.einsum("ij,ij->i", S, S) + np.einsum("ij,ij->i", W, W))
        for stamp in (time, temperature, weight):
            if stamp is not None:
                ok &= np.isfinite(stamp)
        if weight is not None:
            ok &= weight >= 0
        rejected = int(len(ok) - np.count_nonzero(ok))
        if rejected:
            self._skip(_NON_FINITE, rejected)
            Z, S = Z[ok], S[ok]
            weight, time, codes, temperature, unit, static = (
                None if v is None else v[ok] for v in (weight, time, codes, temperature, unit, static)
            )
        self._set_origins(time, temperature)
        self.basis._fill(Z[:, 12:], time, codes, temperature, self.time_origin or 0.0, self.temperature_origin or 0.0)
        self._add_units(Z, S, unit, weight, static, codes)
        self._accumulate(Z, weight, precision)
        self.trace.note(time, codes, temperature, self.temperature_origin or 0.0)
        return len(Z)

    def _fast(self, Z: np.ndarray, time, codes, temperature) -> bool:
        """Add an unweighted block in one product when every row is good; False (nothing changed) otherwise.

        One bad row makes the whole product non-finite, so the row checks run only then.
        """
        origins = (self.time_origin, self.temperature_origin)
        self._set_origins(time, temperature)
        self.basis._fill(Z[:, 12:], time, codes, temperature, self.time_origin or 0.0, self.temperature_origin or 0.0)
        block = gram(Z)
        if not np.all(np.isfinite(block)):
            self.time_origin, self.temperature_origin = origins  # the row checks set them from the first good row
            return False
        self._sums += block
        self._weight_sum += float(len(Z))
        self._count_sum += float(len(Z))
        self.trace.note(time, codes, temperature, self.temperature_origin or 0.0)
        return True

    def _accumulate(self, Z: np.ndarray, weight: np.ndarray | None, precision: bool = False) -> None:
        """Add finite rows ``z`` (in order) to the sums, with weights (frequencies, or precisions) and forgetting."""
        counted = np.ones(len(Z)) if weight is None else (weight > 0).astype(float) if precision else weight
        if self.forgetting != 1.0 and len(Z):
            # row i of m is multiplied by lam once per later row, the old sums m times
            decay = self.forgetting ** np.arange(len(Z) - 1, -1, -1, dtype=float)
            weight = decay if weight is None else weight * decay
            counted = counted * decay
            self._sums *= self.forgetting ** len(Z)
            self._weight_sum *= self.forgetting ** len(Z)
            self._count_sum *= self.forgetting ** len(Z)
        self._sums += gram(Z, weight)
        self._weight_sum += float(len(Z)) if weight is None else float(weight.sum())
        self._count_sum += float(counted.sum())

    def _flush(self) -> None:
        if self._staged:
            W, S, weight, time, codes, temperature, unit, pattern = zip(*self._staged, strict=True)
            self._staged = []
            weights = np.array(weight)
            self._add_block(
                np.array(W),
                np.array(S),
                None if np.all(weights == 1.0) else weights,
                None if pattern[0][0] else np.array(time, dtype=float),
                self._codes(np.array(codes), len(codes)),
                None if pattern[0][1] else np.array(temperature, dtype=float),
                None if self.units is None else np.array(unit, dtype=np.int64),
            )

    def _skip(self, reason: str, count: int) -> None:
        self.skipped[reason] += count

"""The offsets ``validate`` adds to each calibration's wrench: its own offset model where it applies.

A calibration's ``D`` is the offset at the end of its run. On the calibration's own
recording, a per-configuration or drift model knows better: each configuration's offset (by
name: the validation tool's configuration ``B`` takes the calibration's offset of ``B``) and
the drift at each sample's time and temperature
(:func:`fts_calib.model.offset_basis.evaluate_offsets`). The model applies only where it was
fitted: a configuration the calibration never saw, or a sample outside the time span of its
run (another recording, another day), takes ``D``. Constant models, and files written before
offset models existed, use ``D`` everywhere. :attr:`ValidationOffsets.words` says which.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ..model.calibration import Calibration
from ..model.offset_basis import evaluate_offsets

#: Slack on the calibration run's time span [s]: samples this far outside still use the
#: drift model (the trace's first and last points are samples, not the run's exact ends).
TIME_SLACK_S = 1.0


class ValidationOffsets:
    """The offsets of one calibration at the samples of a validation recording.

    Args:
        calibration: The calibration.
        tool_names: The validation tool's configuration names, its order (the recording's
            configuration indices).
    """

    def __init__(self, calibration: Calibration, tool_names: Sequence[str]):
        self.D = np.asarray(calibration.D, dtype=float)
        model: Mapping = calibration.offset_model or {}
        self.model = str(model.get("model", "constant")) if "basis" in model else "constant"
        self.description = model
        names = _configuration_names(calibration)
        fitted = _fitted_configurations(model, names)
        # validation tool index -> calibration index, -1 where the calibration has no offset of it
        self.codes = np.array([names.index(n) if n in fitted else -1 for n in tool_names], dtype=np.int64)
        self.matched = [n for n in tool_names if n in fitted]
        trajectory = model.get("trajectory") or []
        times = [float(p["time_s"]) for p in trajectory if "time_s" in p]
        start = float(model.get("time_origin_s", 0.0))
        # the run's span; unknown (every time) when the file traced none of its samples
        self.span = (min([start, *times]) - TIME_SLACK_S, max([start, *times]) + TIME_SLACK_S) if times else (-np.inf, np.inf)
        self.modelled = 0  # samples given the model's offset
        self.samples = 0

    def offsets(self, time: np.ndarray, configuration: np.ndarray, temperature: np.ndarray | None) -> np.ndarray:
        """The offset of each sample, [N, N, N, N m, N m, N m], shape (N, 6).

        Args:
            time: Sample times [s], shape (N,).
            configuration: The validation tool's configuration index per sample, shape (N,).
            temperature: Sensor temperatures [°C], shape (N,), or None.
        """
        n = len(time)
        out = np.broadcast_to(self.D, (n, 6)).copy()
        self.samples += n
        if self.model == "constant" or n == 0:
            return out
        configuration = np.asarray(configuration, dtype=np.int64)
        known = (configuration >= 0) & (configuration < len(self.codes))  # an unknown configuration takes D
        codes = np.where(known, self.codes[np.clip(configuration, 0, max(len(self.codes) - 1, 0))], -1)
        use = codes >= 0
        if self.model == "drift":
            use &= (time >= self.span[0]) & (time <= self.span[1])
        if use.any():
            heat = None if temperature is None else temperature[use]
            out[use] = evaluate_offsets(self.description, time[use], codes[use], heat)
            self.modelled += int(use.sum())
        return out

    @property
    def words(self) -> str:
        """Which offsets were used, for the printout."""
        if self.model == "constant":
            return "constant D (the calibration's offset model is constant)"
        share = f"{self.modelled:,} of {self.samples:,} samples"
        if self.model == "per-configuration":
            how = f"each configuration's offset by name ({', '.join(self.matched) or 'none matched'})"
        else:
            matched = ", ".join(self.matched) or "none"
            how = f"the drift at each sample's time and temperature (within the calibration run, configurations {matched})"
        return f"{self.model} model: {how} on {share}; D at the end of the run on the others"


def _configuration_names(calibration: Calibration) -> list[str]:
    """The calibration tool's configuration names, its order (the offset basis's columns)."""
    tools = (calibration.provenance or {}).get("tools") or {}
    names = [str(c.get("name")) for c in tools.get("configurations") or [] if isinstance(c, Mapping)]
    if names:
        return names
    size = int(((calibration.offset_model or {}).get("basis") or {}).get("n_configurations", 1))
    return [str(c) for c in range(size)]


def _fitted_configurations(model: Mapping, names: Sequence[str]) -> set[str]:
    """The configurations whose offset column the model fitted ('offset A' in its columns)."""
    columns = [str(c) for c in model.get("columns") or []]
    return {n for n in names if f"offset {n}" in columns}

"""The online estimator's sums carried between instances: its checkpoint state and the merge of two.

:func:`estimator_state` turns an :class:`~fts_calib.model.estimator.OnlineEstimator` into
plain data (its sums ``z z^T``, weights, counts, origins and offset trace) and
:func:`restore_estimator` builds one back; :func:`merge_estimators` adds the sums of two
estimators as one pass over both samples would. Units are the estimator's: W in
[N, N, N, N m, N m, N m], time in [s], temperature in [°C].
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np

from ..core.arrays import as_matrix
from ..core.exceptions import ConfigError
from .channels import channel_layout
from .offset_basis import CONSTANT_ONLY, OffsetBasis
from .offset_trace import OffsetTrace

if TYPE_CHECKING:
    from .estimator import OnlineEstimator


def merge_estimators(first: OnlineEstimator, other: OnlineEstimator) -> OnlineEstimator:
    """A new estimator holding the data of both (as one pass over both would).

    Both must have the same forgetting factor, channel layout, offset setting and basis;
    with forgetting < 1, ``other``'s data count as the more recent. ``other``'s sums are
    moved to ``first``'s time and temperature origins first.

    Args:
        first: The estimator of the earlier data.
        other: The estimator of the later data.

    Returns:
        A new estimator of ``first``'s class; its sums are (12 + k) x (12 + k), k the basis size.

    Raises:
        ConfigError: The two differ in a setting named above, or in the sensor model.
    """
    for name, mine, theirs in (
        ("forgetting", first.forgetting, other.forgetting),
        ("channels", first.layout, other.layout),
        ("offsets", first.offsets, other.offsets),
        ("offset basis", first.basis, other.basis),
        ("model", (first.model, first.full_channels), (other.model, other.full_channels)),
    ):
        if mine != theirs:
            label = f"channel layouts {first.layout.name} and {other.layout.name}" if name == "channels" else f"{name} {mine} and {theirs}"
            message = f"cannot merge estimators {'of' if name == 'channels' else 'with'} {label}"
            raise ConfigError(name, theirs, f"{mine}, the same as this estimator's", message=message)
    first._flush()
    other._flush()
    out = type(first)(first.forgetting, first.layout, first.offsets, first.basis, first.model, first.full_channels, first.full_scale)
    out.time_origin = first.time_origin if first.time_origin is not None else other.time_origin
    out.temperature_origin = first.temperature_origin if first.temperature_origin is not None else other.temperature_origin
    shift = [
        0.0 if b is None or a is None else b - a
        for a, b in ((out.time_origin, other.time_origin), (out.temperature_origin, other.temperature_origin))
    ]
    G = np.eye(len(first._sums))
    G[12:, 12:] = first.basis.shift(*shift)
    decay = first.forgetting**other.samples_used
    out._sums = first._sums * decay + G @ other._sums @ G.T
    out._weight_sum = first._weight_sum * decay + other._weight_sum
    out.samples_used = first.samples_used + other.samples_used
    out.samples_seen = first.samples_seen + other.samples_seen
    out.trace = first.trace.merged(other.trace)
    if first.units is not None and other.units is not None:
        out.units, out.unit_rows = first.units.merged(other.units, G[12:, 12:]), first.unit_rows + other.unit_rows
    for source in (first.skipped, other.skipped):
        for reason, count in source.items():
            out._skip(reason, count)
    return out


def estimator_state(est: OnlineEstimator) -> dict:
    """Everything needed to resume an estimator: plain types, safe to write as YAML or JSON.

    Args:
        est: The estimator; its staged samples are added to the sums first.

    Returns:
        A mapping of settings, the sums ``S`` ((12 + k) x (12 + k) nested lists), weights and counts.
    """
    return {
        "forgetting": est.forgetting,
        "channels": est.layout.to_config(),
        "offsets": est.offsets,
        "model": est.model,
        "full_channels": est.full_channels,
        **({"units": est.units.state(), "unit_rows": est.unit_rows} if est.units is not None else {}),
        "basis": est.basis.to_config(),
        "time_origin": est.time_origin,
        "temperature_origin": est.temperature_origin,
        "trace": est.trace.state(),
        "S": est._current().tolist(),
        "weight_sum": est._weight_sum,
        "samples_used": est.samples_used,
        "samples_seen": est.samples_seen,
        "skipped": dict(est.skipped),
    }


def restore_estimator(cls: type[OnlineEstimator], state: Mapping) -> OnlineEstimator:
    """Rebuild an estimator from :func:`estimator_state` (a state of an older version, without offset models, too).

    Args:
        cls: The estimator class to build.
        state: The mapping :func:`estimator_state` wrote.

    Returns:
        The estimator, its sums of shape (12 + k, 12 + k) as saved.

    Raises:
        ShapeError: The sums do not match the offset basis.
    """
    basis = OffsetBasis.from_config(state["basis"]) if "basis" in state else CONSTANT_ONLY
    offsets = str(state.get("offsets", "constant"))
    model, full = str(state.get("model", "linear")), bool(state.get("full_channels", False))
    out = cls(float(state["forgetting"]), channel_layout(state.get("channels")), offsets, basis, model, full)
    if out.units is not None and "units" in state:
        out.units.restore(state["units"])
        out.unit_rows = int(state.get("unit_rows", 0))
    width = 12 + basis.size
    out._sums = as_matrix(state["S"], (width, width), "state['S']").copy()
    out._weight_sum = float(state["weight_sum"])
    out.samples_used = int(state["samples_used"])
    out.samples_seen = int(state["samples_seen"])
    out.skipped = Counter({str(k): int(v) for k, v in state.get("skipped", {}).items()})
    for name in ("time_origin", "temperature_origin"):
        value = state.get(name)
        setattr(out, name, None if value is None else float(value))
    out.trace = OffsetTrace.from_state(state.get("trace"))
    return out

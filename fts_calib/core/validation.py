"""Value checks for the ``__post_init__`` of the configuration dataclasses.

Each check returns the value converted (a float, or a float array) and raises
:class:`~fts_calib.core.exceptions.ConfigError` with the field, the value and what was
expected. A dataclass that checks its fields in ``__post_init__`` refuses in Python what
its file loader refuses; the loader re-raises the error naming the file (see
:func:`fts_calib.core.fileio.fields_of`).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from .exceptions import ConfigError


def number(field: str, value: object, unit: str = "", owner: str = "") -> float:
    """``value`` as a finite float.

    Args:
        field: The field's name, for the message.
        value: The value to check.
        unit: Unit text for the message (e.g. 'kg'), or empty.
        owner: What the field belongs to, for the message (e.g. "configuration 'A'"), or empty.

    Raises:
        ConfigError: Not a number, or NaN or infinite.
    """
    out = _float(field, value, unit, owner)
    if not math.isfinite(out):
        raise ConfigError(field, out, "a finite value", unit, owner)
    return out


def positive(field: str, value: object, unit: str = "", owner: str = "") -> float:
    """``value`` as a finite float > 0; see :func:`number` for the arguments.

    Raises:
        ConfigError: Not a number, not finite, or <= 0.
    """
    out = _float(field, value, unit, owner)
    if not (math.isfinite(out) and out > 0):
        raise ConfigError(field, out, "a finite value > 0", unit, owner)
    return out


def non_negative(field: str, value: object, unit: str = "", owner: str = "") -> float:
    """``value`` as a finite float >= 0; see :func:`number` for the arguments.

    Raises:
        ConfigError: Not a number, not finite, or < 0.
    """
    out = _float(field, value, unit, owner)
    if not (math.isfinite(out) and out >= 0):
        raise ConfigError(field, out, "a finite value >= 0", unit, owner)
    return out


def finite_array(field: str, value: npt.ArrayLike, owner: str = "") -> np.ndarray:
    """``value`` as a float array without NaN or inf (its shape is the caller's to check).

    Raises:
        ConfigError: An entry is NaN or infinite.
    """
    array = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(array)):
        raise ConfigError(field, array.tolist(), "finite values (no NaN or inf)", owner=owner)
    return array


def _float(field: str, value: object, unit: str, owner: str) -> float:
    try:
        return float(value)  # type: ignore[arg-type]  # whatever float() takes; the rest is refused
    except (TypeError, ValueError):
        raise ConfigError(field, value, "a number" + (f" in {unit}" if unit else ""), owner=owner) from None

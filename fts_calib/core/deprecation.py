"""Old keyword names kept working for one release, with a :class:`DeprecationWarning`.

One implementation for every renamed argument (``strain`` -> ``channels``, ``readings`` ->
``joints``, ...): :func:`renamed` wraps a function so that a call with the old keyword
warns and passes the value on under the new name. A positional call costs one test of an
empty mapping, so the wrapper stays on a 1 kHz path.
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Callable
from typing import Any, TypeVar

F = TypeVar("F", bound=Callable[..., Any])

#: The release that removes the old names.
REMOVED_IN = "0.2"


def renamed(**old_to_new: str) -> Callable[[F], F]:
    """Decorator: accept each old keyword name, warn, and pass its value as the new one.

    Args:
        **old_to_new: Old keyword name -> new keyword name, e.g. ``strain="channels"``.

    Returns:
        The decorator; the wrapped function raises TypeError when a call gives both names.

    Example::

        @renamed(strain="channels")
        def wrench(self, channels): ...
    """

    def wrap(func: F) -> F:
        @functools.wraps(func)
        def inner(*args: Any, **kwargs: Any) -> Any:
            if kwargs:
                for old, new in old_to_new.items():
                    if old in kwargs:
                        if new in kwargs:
                            raise TypeError(f"{func.__qualname__}() got both '{old}' and '{new}': give '{new}' only")
                        warnings.warn(
                            f"{func.__qualname__}(): the argument '{old}' is now '{new}'; '{old}' goes in fts-calib {REMOVED_IN}",
                            DeprecationWarning,
                            stacklevel=2,
                        )
                        kwargs[new] = kwargs.pop(old)
            return func(*args, **kwargs)

        return inner  # type: ignore[return-value]

    return wrap


def renamed_method(old: str, new: Callable[..., Any]) -> Callable[..., Any]:
    """An alias of a renamed method that warns once per call and calls the new one.

    Args:
        old: The old method name (for the message).
        new: The new method (a function defined in the class body).

    Returns:
        A function to assign to the old name in the class body.
    """

    @functools.wraps(new)
    def alias(*args: Any, **kwargs: Any) -> Any:
        warnings.warn(
            f"{old}() is now {new.__name__}(); {old}() goes in fts-calib {REMOVED_IN}",
            DeprecationWarning,
            stacklevel=2,
        )
        return new(*args, **kwargs)

    alias.__doc__ = f"Deprecated alias of :meth:`{new.__name__}` (kept for one release)."
    return alias

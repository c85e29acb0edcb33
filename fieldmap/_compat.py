"""Deprecated spellings of the public API kept working for one release (fieldmap 0.2).

fieldmap 0.1 took the options of its point functions positionally, in orders that differed
between functions, and named the same thing differently (``unit=``/``units=``, ``kind=``,
``lat``/``lat_deg``). :func:`keyword_api` keeps such calls working, with a
``DeprecationWarning`` that names the spelling to use; they go in fieldmap 0.3.
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Callable
from typing import Any, TypeVar, cast

F = TypeVar("F", bound=Callable[..., Any])


def warn(message: str, stacklevel: int = 3) -> None:
    """Issue the ``DeprecationWarning`` of a 0.1 spelling (removed in fieldmap 0.3)."""
    warnings.warn(
        f"{message} (deprecated in fieldmap 0.2, removed in 0.3)",
        DeprecationWarning,
        stacklevel=stacklevel,
    )


def keyword_api(
    ncoords: int, old_order: tuple[str, ...] = (), renamed: dict[str, str] | None = None
) -> Callable[[F], F]:
    """Accept the 0.1 calls of a function whose options are now keyword-only.

    Parameters
    ----------
    ncoords : int
        Number of positional coordinates (3 for latitude, longitude, height).
    old_order : tuple of str
        The 0.1 names of the arguments that followed the coordinates, in their 0.1 order:
        extra positional arguments are bound to them.
    renamed : dict, optional
        0.1 keyword name -> current name (e.g. ``{"unit": "units"}``).
    """
    renamed = renamed or {}

    def decorate(func: F) -> F:
        name = func.__name__

        @functools.wraps(func)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            notes = []
            if len(args) > ncoords:
                extra = args[ncoords:]
                if len(extra) > len(old_order):
                    raise TypeError(
                        f"{name}() takes {ncoords} positional arguments but {len(args)} were given"
                    )
                names = old_order[: len(extra)]
                notes.append(f"pass {', '.join(names)} by keyword")
                for key, value in zip(names, extra):
                    if key in kwargs:
                        raise TypeError(f"{name}() got multiple values for argument {key!r}")
                    kwargs[key] = value
                args = args[:ncoords]
            for old, new in renamed.items():
                if old in kwargs:
                    if new in kwargs:
                        raise TypeError(f"{name}() got both {old!r} (0.1 name) and {new!r}")
                    notes.append(f"{old}= is now {new}=")
                    kwargs[new] = kwargs.pop(old)
            if notes:
                warn(f"{name}(): {'; '.join(notes)}", stacklevel=3)
            return func(*args, **kwargs)

        return cast(F, wrapper)

    return decorate

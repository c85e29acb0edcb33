"""Durations with units: the one parser of every duration fieldmap reads.

A duration is a number of seconds, or a number followed by a unit: ``s``, ``min`` or ``h``
(``300``, ``300s``, ``5min``, ``5 min``, ``1.5h``). ``fieldmap navsim --duration 5min``,
``--output-dt``, ``--gnss-outage 20min:5min``, ``fieldmap imu allan --duration 2h`` and the
Python keywords that take a duration (:class:`fieldmap.nav.study.FlightStudy`'s ``duration``
and ``output_dt``, :class:`fieldmap.nav.aiding.GnssSpec`'s ``outages``) read it here.

The value is returned as it is written (``nan``, ``-5min``, ``0``): whether it must be positive,
finite or within a flight is the caller's rule, checked where the duration is used.
"""

from __future__ import annotations

import argparse
import numbers

from fieldmap.errors import InputError

#: unit -> seconds; the longest spelling first (``min`` before ``s``... ``5min`` is not ``5mi s``)
UNITS = {"min": 60.0, "h": 3600.0, "s": 1.0}
#: how the accepted forms are named in messages
FORMS = "seconds, or a number with a unit s, min, h: 90, 90s, 5min, 1.5h"


def seconds(value: str | float, *, param: str | None = None, what: str = "duration") -> float:
    """Return the duration ``value`` in seconds.

    Parameters
    ----------
    value : str or float
        A number (seconds) or a string: a number and an optional unit ``s``, ``min``, ``h``,
        with or without a space between them. Units: s unless the string names one.
    param : str, optional
        The keyword the duration was given as, carried by the error (``param``).
    what : str
        The name of the duration in the message (``"duration"``, ``"start"``).

    Raises
    ------
    InputError
        ``value`` is no number, or a number with an unknown unit.

    Examples
    --------
    >>> seconds("5min"), seconds("1.5 h"), seconds(90), seconds("20s")
    (300.0, 5400.0, 90.0, 20.0)
    """
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        return float(value)
    text = str(value).strip()
    number, scale = text, 1.0
    for unit, size in UNITS.items():
        if text.lower().endswith(unit):
            number, scale = text[: -len(unit)].strip(), size
            break
    try:
        if isinstance(value, bool) or not number:
            raise ValueError
        return float(number) * scale
    except ValueError:
        raise InputError(f"{what} {text!r} is no time ({FORMS})", param=param) from None


def argument(text: str) -> float:
    """``type=`` of an argparse option that takes a duration (``--duration 5min``)."""
    try:
        return seconds(text)
    except InputError:
        raise argparse.ArgumentTypeError(f"{text.strip()!r} is no time ({FORMS})") from None

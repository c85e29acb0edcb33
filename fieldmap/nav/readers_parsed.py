"""What every flight-log format reader returns, and the helpers the readers share.

A reader of :mod:`fieldmap.nav.readers_tables` or :mod:`fieldmap.nav.readers_gnss` returns a
:class:`Parsed` (raw columns, file order, the line of each fix) that
:func:`fieldmap.nav.readers.read_track` turns into a :class:`~fieldmap.nav.readers.RawTrack`.
Times of day roll over at midnight (a step back by more than 12 h adds a day: ``_days``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime, timezone

import numpy as np

DAY = 86400.0
HINT = "--columns time=...,lat=...,lon=...,alt=..."
_EMPTY = frozenset({"", "nan", "na", "<na>", "n/a", "null", "none", "-"})


@dataclass
class Parsed:
    """Raw columns of one source: before units, checks and the height reference.

    ``alts`` maps a height reference (``ellipsoid``, ``msl``, ``pressure``) to the column name
    and values (NaN where empty) that hold heights in that reference; ``height_ref`` is the
    default key. ``where`` is the word for a position in the source (``line`` or ``record``);
    ``names`` the names of the time, latitude and longitude columns, for messages.
    """

    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    alts: dict[str, tuple[str, np.ndarray]]
    height_ref: str
    alt_units: str
    lines: np.ndarray
    source: str
    absolute: bool
    names: tuple[str, str, str] = ("time", "lat", "lon")
    where: str = "line"
    notes: list[str] = field(default_factory=list)
    #: a note on the default height reference, dropped when the caller gives one
    ref_note: str | None = None
    #: units fixed by the format's specification or the column name: no units checks
    units_fixed: bool = True
    #: how the times were read where their units were guessed (epoch ms), else None
    time_guess: str | None = None


def _line_of(text: str, pos: int) -> int:
    return text.count("\n", 0, pos) + 1


def _utc(d: datetime) -> float:
    return (d if d.tzinfo else d.replace(tzinfo=timezone.utc)).timestamp()


def _days(tods: list[float]) -> np.ndarray:
    """Day index of each time of day in order: a step back by more than 12 h is midnight."""
    day, out, prev = 0, np.zeros(len(tods)), None
    for i, x in enumerate(tods):
        if prev is not None and x < prev - DAY / 2:
            day += 1
        out[i], prev = day, x
    return out


def iso_utc(t: float) -> str:
    """ISO 8601 (UTC, ``Z``) of epoch seconds."""
    return datetime.fromtimestamp(t, timezone.utc).isoformat().replace("+00:00", "Z")

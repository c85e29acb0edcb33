"""A flight log as read: the raw columns of one format, and the :class:`RawTrack` made of them.

Every format reader (:mod:`fieldmap.nav.logs.read` for CSV and tables,
:mod:`fieldmap.nav.logs.gnss` for GPX, NMEA 0183 and IGC) returns a :class:`Parsed`: raw
columns in file order, the line (or record) of each fix, the altitude columns by height
reference. :func:`fieldmap.nav.logs.read.read_track` checks it, converts units and heights and
returns a :class:`RawTrack`, what the conditioning (:mod:`fieldmap.nav.logs.condition`) takes.

Times are epoch seconds UTC where the source has absolute times: :func:`utc_seconds` reads a
``datetime`` (naive = UTC), :func:`iso_utc` writes one.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime, timezone

import numpy as np


@dataclass(frozen=True, eq=False)
class RawTrack:
    """One flight log, read but not conditioned (samples in file order, repeats kept).

    Attributes
    ----------
    t : numpy.ndarray
        Times (float64, s): epoch seconds UTC when the source has absolute times, else as given.
    lat, lon : numpy.ndarray
        Geodetic latitude and longitude. Units: degrees.
    h : numpy.ndarray
        Height above the ellipsoid after the height-reference conversion. Units: m.
    lines : numpy.ndarray
        int64 line (or record) number of each sample in the source, for messages.
    source : str
        File name, or ``"DataFrame"``, ``"Dataset"``, ``"arrays"``.
    height_ref : str
        What the source heights were: ``"ellipsoid"``, ``"msl"`` or ``"pressure"``.
    notes : tuple of str
        Human-readable notes (layout, units, dropped rows, height conversion).
    t0_utc : str or None
        ISO 8601 time of the first sample when known.
    time_guess : str or None
        How the times were read where their units were guessed from their size (epoch
        milliseconds), for messages about what follows from the guess; None otherwise.
    """

    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    h: np.ndarray
    lines: np.ndarray
    source: str
    height_ref: str
    notes: tuple[str, ...] = ()
    t0_utc: str | None = None
    time_guess: str | None = None

    def __len__(self) -> int:
        return int(self.t.size)


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


def utc_seconds(d: datetime) -> float:
    """Epoch seconds of a ``datetime``; a naive one is UTC."""
    return (d if d.tzinfo else d.replace(tzinfo=timezone.utc)).timestamp()


def iso_utc(t: float) -> str:
    """ISO 8601 (UTC, ``Z``) of epoch seconds."""
    return datetime.fromtimestamp(t, timezone.utc).isoformat().replace("+00:00", "Z")

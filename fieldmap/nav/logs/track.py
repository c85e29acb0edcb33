"""A flight log as read: the raw columns of one format, and the :class:`RawTrack` made of them.

Every format reader of :mod:`fieldmap.nav.logs.read` (CSV, tables, GPX, NMEA 0183 and IGC)
returns a :class:`Parsed`: raw columns in file order, the line (or record) of each fix, the
altitude columns by height reference. :func:`fieldmap.nav.logs.read.read_track` checks it,
converts units and heights and returns a :class:`RawTrack`, what the conditioning
(:mod:`fieldmap.nav.logs.condition`) takes.

Times are epoch seconds UTC where the source has absolute times: :func:`utc_seconds` reads a
``datetime`` (naive = UTC), :func:`iso_utc` writes one.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime, timezone

import numpy as np


@dataclass(frozen=True, eq=False)
class Velocities:
    """The velocities a log carries with its fixes (ADS-B, NMEA RMC, GPX), as the log gives them.

    Attributes
    ----------
    speed : numpy.ndarray
        Ground speed at each sample (NaN where none). Units: m/s.
    track : numpy.ndarray
        Track angle over the ground, clockwise from true north (NaN where none). Units: degrees.
    climb : numpy.ndarray or None
        Vertical speed, up positive (NaN where none); None when the log has none. Units: m/s.
    resolution : tuple of float
        Quantisation step of each (ground speed m/s, track degrees, vertical speed m/s): the
        uniform rounding error's σ is step/√12. ADS-B: 1 kt, 1° (the 1 kt east/north
        components at 250 m/s), 64 ft/min (DO-260B §2.2.3.2.6).
    names : tuple of str
        The columns (or fields) read, for the report.
    """

    speed: np.ndarray
    track: np.ndarray
    climb: np.ndarray | None
    resolution: tuple[float, float, float]
    names: tuple[str, ...] = ()


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
    velocity : Velocities or None
        The log's own velocities at the samples, when it carries them.
    category : str or None
        An ADS-B emitter category (``"A3"``) when the log gives one.
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
    velocity: Velocities | None = None
    category: str | None = None

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
    #: the velocities the source carries (units converted), or None
    velocity: Velocities | None = None
    #: an ADS-B emitter category, when the source gives one
    category: str | None = None


def utc_seconds(d: datetime) -> float:
    """Epoch seconds of a ``datetime``; a naive one is UTC."""
    return (d if d.tzinfo else d.replace(tzinfo=timezone.utc)).timestamp()


def iso_utc(t: float) -> str:
    """ISO 8601 (UTC, ``Z``) of epoch seconds."""
    return datetime.fromtimestamp(t, timezone.utc).isoformat().replace("+00:00", "Z")

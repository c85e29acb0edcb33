r"""Flight logs as they come (CSV, GPX, NMEA, IGC, tables) read into one ``RawTrack``.

:func:`read_track` reads a log *without* smoothing, sorting or outlier rejection (that is the
conditioning step's job): samples stay in file order, repeats kept, each with the line (or
record) it came from. What it does is give every log the same meaning: times in seconds (epoch
seconds UTC when the source has absolute times), latitude and longitude in degrees, and the
height **above the ellipsoid** in metres, converted from the source's height reference (its
own, or the ``height_ref`` given to :func:`read_track`):

- ``ellipsoid``: used as is;
- ``msl`` (orthometric height H, above the geoid): h = H + N, N the geoid height of fieldmap's
  own model (:func:`fieldmap.geoid_height`, ``eigen-6s`` by default), evaluated every
  :data:`GEOID_STEP` of track (and at both ends of longer steps) and interpolated linearly
  along it: N varies slowly (≤ 2 cm from N at every sample on the ADS-B samples of the tests);
- ``pressure`` (pressure altitude: the height of the measured pressure in the ICAO standard
  atmosphere, ISO 2533:1975 = ICAO Doc 7488/3, 1013.25 hPa datum): a *geopotential* height,
  carried to a geometric one (z = r H / (r - H), r = 6 356 766 m, ISO 2533) and taken as the
  height above MSL, then + N. Approximate: a real atmosphere 10 K warmer or 10 hPa higher
  than the standard one puts the aircraft ~4 % of its height or ~80 m higher (a note says so).

Layouts recognised by their header when no ``columns`` mapping is given (:data:`LAYOUTS`):

- ``fieldmap``: ``time_s, lat_deg, lon_deg, height_m``; metres above the ellipsoid.
- ``opensky``: ``time, lat, lon`` and ``geoaltitude`` (MSL) or ``baroaltitude`` (pressure);
  metres.
- ``opensky-api``: ``time_position, latitude, longitude`` and ``geo_altitude`` (MSL) or
  ``baro_altitude`` (pressure); metres.
- ``traffic``: ``timestamp, latitude, longitude`` and ``geoaltitude`` (MSL) or ``altitude``
  (pressure); feet.
- a mapping ``columns={"time": ..., "lat": ..., "lon": ..., "alt": ...}``: metres, MSL.

The geometric altitude of ADS-B is used when at least half the rows have one, else the
barometric one. OpenSky documents ``geoaltitude`` only as "geometric altitude": DO-260B
transponders report GNSS height above the ellipsoid, older ones above MSL, so it is read as
MSL (a note says so; ``height_ref="ellipsoid"`` reads it as ellipsoidal). Times: seconds as
given, epoch seconds (> 1e8), epoch milliseconds (> 1e11: a guess of the units, which the notes
and any later refusal of the log mention), ISO 8601 strings (naive = UTC) or a ``strptime``
pattern (``time_format``). Rows with an empty latitude or longitude (``""``, ``nan``,
``null``) are dropped and counted in the notes; a row with a position and an empty altitude
keeps its position and time, without a height (:attr:`RawTrack.no_height`: an ADS-B table's
rows between altitude messages, a taxi's surface reports), counted in the notes; anything
else that is not a number is refused with its line and column. Rows with an empty time are
dropped and counted too; an infinite value (``inf``) is read as empty, and said. Lines that
are no samples (a repeat of the header, a row of empty cells, a last line cut short by the
end of the file) are dropped and said (:func:`csv_table`). An altitude column of an ADS-B
layout that is zero in every row is the recorder's "none", not a flight at sea level: not used
(:func:`_zero_columns`); an altitude of exactly 0 in some rows is a surface report's
placeholder (they carry no altitude), read as empty (:func:`_surface_zeros`). A table of
several aircraft (``icao24``) is refused: a flight is one aircraft's. GPX, NMEA 0183 and IGC:
below.

Refused with one :class:`~fieldmap.errors.InputError` naming file, line and column: unknown
columns (the message lists them and the ``--columns`` mapping), unparsable times or numbers,
latitudes beyond ±90° or longitudes beyond ±360°, heights outside -10 km..1e8 m, epoch times
outside the years 1..9999, radians, a header naming a column twice, one column mapped to two
fields, an empty file (or white space only), a directory, a file that is no flight log. A
log's *local* defects (one glitched record or value) cost that record, counted in the notes
with its line, never the log. Units are checked, not guessed, where
neither ``alt_units``, the column name (``height_m``) nor the format's specification (GPX,
NMEA, IGC: metres) fixes them: an aircraft-like track (median ground speed below 700 m/s) with
altitudes above 30 km or a vertical rate above 300 m/s sustained over 5 samples (of the running
median of 5 altitudes, so that isolated spikes are not taken for a unit error; step by step and
net, so that glitches alternating with the true altitudes are not either), or fast steps over
most of the log, is refused as feet read as metres (or a wrong column). Messages name keyword
arguments (an :class:`~fieldmap.errors.InputError` about one has it as ``param``; the command
line rewords them with its options).

The format is recognised by its content (:func:`load_text`): CSV text and tables are read here
(:func:`csv_table`, :func:`object_table`; cells by :func:`numbers` and :func:`times`), the GNSS
receiver and flight-recorder logs by :func:`read_gpx`, :func:`read_nmea` and :func:`read_igc`;
each gives a :class:`Parsed` (raw columns in file order, the line or record of each fix, the
altitude columns by height reference) that :func:`read_track` checks and converts (heights:
:func:`check_units`, :func:`to_ellipsoid`) into a :class:`RawTrack`, what the conditioning
(:mod:`fieldmap.nav.logs.condition`) takes: the records a reader fills are defined here, with
what reads them. Times are epoch seconds UTC where the source has absolute times:
:func:`utc_seconds` reads a ``datetime`` (naive = UTC), :func:`iso_utc` writes one.

GNSS receiver and flight-recorder logs (GPX 1.1, NMEA 0183 and IGC):

- **GPX 1.1** (Topografix, https://www.topografix.com/GPX/1/1/): ``<trkpt>`` of all tracks and
  segments in document order (``<rtept>`` when there is no track), read with ``gpxpy``. The
  schema calls ``<ele>`` the "elevation (in meters) of the point" and ``<geoidheight>`` the
  "height of geoid (mean sea level) above WGS84 earth ellipsoid, as defined in NMEA GGA": ``<ele>``
  is the height above mean sea level (MSL). With ``<geoidheight>`` on every point the file's own
  ellipsoidal height ``ele + geoidheight`` is used. The receiver's velocity, where the file has
  it: GPX 1.0's ``<speed>`` (m/s) and ``<course>`` (degrees from true north), or the same two in
  a GPX 1.1 ``<extensions>`` block (Garmin's ``TrackPointExtension`` v2 ``speed``/``course``, or
  any extension element so named).
- **NMEA 0183** (NMEA 0183 v4.11, GGA and RMC sentences; parsed with ``pynmea2``): GGA gives
  the UTC time of day, position, the altitude above MSL (field 9) and the geoid separation
  (field 11, geoid above the WGS84 ellipsoid): h = altitude + separation when every fix has it.
  RMC gives the date (field 9, ``ddmmyy``) and the receiver's velocity over the ground: speed
  (field 7, knots) and course (field 8, degrees from true north), attached to the GGA fix of the
  same time of day (the sentence next to it) when the RMC status (field 2) is ``A``. Sentences
  with a wrong checksum (XOR of the bytes between ``$`` and ``*``) are skipped and counted, as
  are fixes of quality 0 (no fix).
- **IGC** (FAI/IGC *Technical Specification for IGC-approved GNSS Flight Recorders*, appendix
  A): ``HFDTE`` date (``HFDTEDDMMYY`` or ``HFDTEDATE:DDMMYY,NN``), ``B`` fixes
  ``BHHMMSSDDMMmmmNDDDMMmmmEVPPPPPGGGGG``: pressure altitude (m, ICAO ISA, 1013.25 hPa datum)
  and GNSS altitude (m, "above the WGS84 ellipsoid" per the specification; the ``HFALG`` header
  ``GEO`` of recent recorders says MSL). ``LAD``/``LOD`` extensions (``I`` record) add
  decimals of minutes.

Times of day roll over at midnight; a record whose time of day leaves the log's sequence and
comes back (a time fault), or that no clock shows (hour 25), is dropped (:func:`days_of`).

The velocities become a :class:`Velocities` (no vertical speed: neither format has one): the
conditioning checks them against the positions and fits the path to them
(:func:`fieldmap.nav.logs.fit.observations`). Their resolution is the last digit the file prints
(the rounding's σ is that step/√12); a receiver's Doppler noise above it is estimated from the
values themselves. A speed without a course (or the reverse) gives no velocity vector and is left
out, and said.
"""

from __future__ import annotations

import csv
import gzip
import math
import os
import re
import zlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from fieldmap.errors import Advice, InputError, Keyword, Message, Part, Pass, Setting
from fieldmap.field.ellipsoid import WGS84, Ellipsoid
from fieldmap.limits import MAX_HEIGHT, MIN_HEIGHT, number_text

# -- what reading produces: the records a reader fills ----------------------------------


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
    #: the samples without a height of their own (an empty altitude, or a surface report's
    #: placeholder): positions only, their ``h`` interpolated in time between the others'
    #: (bool), or None
    no_height: np.ndarray | None = None
    #: the samples that are ADS-B surface reports: on the ground by the transponder's own
    #: word (bool), or None
    surface_report: np.ndarray | None = None

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
    #: which column an explicit ``height_ref`` the source has no column for may read:
    #: ``"datum"`` (GPX, NMEA, IGC, whose specifications say what each altitude is): only the
    #: datum of a GNSS altitude (ellipsoid or MSL, which receivers write either way);
    #: ``"geometric"`` (a table's layout): any column read as a geometric height, but no
    #: pressure altitude made of a geometric one; ``"any"`` (a column mapping: ``height_ref``
    #: says what the mapped column is)
    declares: str = "datum"
    #: height reference -> per row, 1 where the altitude is a surface report's placeholder, 2
    #: where it is resampled from one, 0 elsewhere (:func:`_surface_zeros`): positions without
    #: a height
    surface: dict[str, np.ndarray] = field(default_factory=dict)


def utc_seconds(d: datetime) -> float:
    """Epoch seconds of a ``datetime``; a naive one is UTC."""
    return (d if d.tzinfo else d.replace(tzinfo=timezone.utc)).timestamp()


def iso_utc(t: float) -> str:
    """ISO 8601 (UTC, ``Z``) of epoch seconds."""
    return datetime.fromtimestamp(t, timezone.utc).isoformat().replace("+00:00", "Z")


# -- options and layouts --------------------------------------------------------------------

#: the cells of a table's column j
Getter = Callable[[Any], Any]
#: "<source> line <n>" of sample i
Where = Callable[[int], str]

#: how a column mapping is written (the messages about columns show it)
HINT = "--columns time=...,lat=...,lon=...,alt=..."
#: cells read as empty
_EMPTY = frozenset({"", "nan", "na", "<na>", "n/a", "null", "none", "-"})
FT = 0.3048
#: spacing along the track of the geoid-height evaluations (m)
GEOID_STEP = 5000.0
#: ISO 2533 earth radius for geopotential -> geometric height (m)
R_ISA = 6_356_766.0
#: checks of the altitude units on aircraft-like tracks
MAX_AIRCRAFT_SPEED, MAX_ALTITUDE, MAX_CLIMB = 700.0, 30_000.0, 300.0

HEIGHT_REFS = ("ellipsoid", "msl", "pressure")
_KEYS = ("time", "lat", "lon", "alt")
#: name -> (time, lat, lon, {height reference: altitude column}, units); first match wins
LAYOUTS = {
    "fieldmap": ("time_s", "lat_deg", "lon_deg", {"ellipsoid": "height_m"}, "m"),
    "opensky": ("time", "lat", "lon", {"msl": "geoaltitude", "pressure": "baroaltitude"}, "m"),
    "opensky-api": (
        "time_position",
        "latitude",
        "longitude",
        {"msl": "geo_altitude", "pressure": "baro_altitude"},
        "m",
    ),
    "traffic": (
        "timestamp",
        "latitude",
        "longitude",
        {"msl": "geoaltitude", "pressure": "altitude"},
        "ft",
    ),
}

KT, FPM = 1852.0 / 3600.0, FT / 60.0
#: ADS-B velocity resolution (DO-260B airborne velocity, subsonic): 1 kt east/north (ground
#: speed 1 kt, track about 1° at airliner speeds), vertical rate 64 ft/min
ADSB_RESOLUTION = (KT, 1.0, 64.0 * FPM)
#: layout -> (ground speed, its factor to m/s, track, vertical speed, its factor to m/s)
VELOCITY_COLUMNS = {
    "opensky": ("velocity", 1.0, "heading", "vertrate", 1.0),
    "opensky-api": ("velocity", 1.0, "true_track", "vertical_rate", 1.0),
    "traffic": ("groundspeed", KT, "track", "vertical_rate", FPM),
}


def parse_columns(text: str) -> dict[str, str]:
    """Parse a column mapping ``time=timestamp,lat=latitude,lon=longitude,alt=altitude``.

    Parameters
    ----------
    text : str
        Comma-separated ``key=column`` pairs; keys ``time``, ``lat``, ``lon``, ``alt`` (all four).

    Returns
    -------
    dict
        Key -> column name.
    """
    out: dict[str, str] = {}
    for item in (s.strip() for s in str(text).split(",")):
        key, eq, name = (s.strip() for s in item.partition("="))
        if not eq or not name or key not in _KEYS:
            raise InputError(
                f"--columns: {item!r} is not one of time|lat|lon|alt=COLUMN ({HINT})",
                param="columns",
            )
        if key in out:
            raise InputError(f"--columns: {key} given twice ({HINT})", param="columns")
        out[key] = name
    missing = [k for k in _KEYS if k not in out]
    if missing:
        raise InputError(f"--columns: missing {', '.join(missing)} ({HINT})", param="columns")
    keys: dict[str, str] = {}
    for key, name in out.items():
        if name in keys:
            raise InputError(
                f"--columns: column {name!r} given for both {keys[name]} and {key} ({HINT})",
                param="columns",
            )
        keys[name] = key
    return out


def _table(
    header: list[str],
    get: Getter,
    lines: np.ndarray,
    source: str,
    where_word: str,
    columns: Mapping[str, str] | None,
    time_format: str | None,
) -> Parsed:
    """Recognise the layout (or apply ``columns``) and read the four columns."""
    found = {h.lower(): j for j, h in reversed(list(enumerate(header)))}
    exact = {h: j for j, h in reversed(list(enumerate(header)))}
    fields: dict[str, list[int]] = {}
    for j, h in enumerate(header):
        fields.setdefault(h.lower(), []).append(j + 1)

    def col(name: str) -> int | None:
        twice = fields.get(name.lower(), [])
        if len(twice) > 1:  # a column read (or looked for) that the header names twice
            raise InputError(
                f"{source}: the header names column {name!r} more than once (fields "
                f"{', '.join(map(str, twice))}): which one is meant is a guess; rename or drop one"
            )
        return exact.get(name, found.get(name.lower()))

    notes: list[str] = []
    if columns is not None:
        cols = [columns[k] for k in _KEYS]
        for k, name in zip(_KEYS, cols):
            if col(name) is None:
                raise InputError(
                    f"{source}: no column {name!r} (--columns {k}={name}); columns: "
                    f"{', '.join(header)}"
                )
        layout: tuple | None = ("mapping", cols[0], cols[1], cols[2], {"msl": cols[3]}, "m")
        notes.append(f"columns {', '.join(f'{k}={v}' for k, v in columns.items())}")
    else:
        layout = next(
            (
                (k, *v)
                for k, v in LAYOUTS.items()
                if all(col(c) is not None for c in v[:3])
                and any(col(c) is not None for c in v[3].values())
            ),
            None,
        )
    if layout is None:
        known = "; ".join(
            f"{k}: {a},{b},{c},{'|'.join(d.values())}" for k, (a, b, c, d, _) in LAYOUTS.items()
        )
        raise InputError(
            f"{source}: unrecognised columns ({', '.join(header)}): name them with "
            f"{HINT} (columns={{'time': ..., 'lat': ..., 'lon': ..., 'alt': ...}}); "
            f"known layouts: {known}"
        )
    notes += [] if layout[0] == "mapping" else [f"layout {layout[0]}"]
    kind, tname, latname, lonname, altmap, units = layout
    if col("icao24") is not None:
        _one_aircraft(get(col("icao24")), source)

    def where(i: int) -> str:
        return f"{source} {where_word} {lines[i]}"

    def column(name: str) -> np.ndarray:
        """Numbers of a column; an infinite value (a glitch, an overflow) read as empty, said."""
        v = numbers(get(col(name)), where, name)
        bad = np.isinf(v)
        if bad.any():
            notes.append(
                f"{name}: {_count(int(bad.sum()), 'value')} not finite ({v[bad][0]:g}) read as "
                f"empty ({_at(where_word, lines[bad])})"
            )
            v[bad] = np.nan
        return v

    t, absolute, tnote = times(get(col(tname)), where, tname, time_format)
    notes += [tnote] if tnote else []
    lat = column(latname)
    lon = column(lonname)
    alts = {r: (c, column(c)) for r, c in altmap.items() if col(c) is not None}
    if kind not in ("mapping", "fieldmap"):  # a recorder's columns; the others the user's heights
        alts = _zero_columns(alts, source, notes)
        alts, surface = _surface_zeros(alts, t, lines, where_word, notes)
    filled = {r: float(np.mean(np.isfinite(v))) for r, (_, v) in alts.items()}
    ref = next((r for r in alts if filled[r] >= 0.5), max(filled, key=filled.__getitem__))
    ref_note = None
    if kind == "mapping":
        ref_note = Message(
            "heights taken as MSL (the default for a column mapping",
            Advice(": give ", Keyword("height_ref")),
            ")",
        )
    elif ref == "msl":
        ref_note = Message(
            f"{alts[ref][0]}: ADS-B geometric altitude, read as MSL (DO-260B transponders "
            "report it above the ellipsoid",
            Advice(": ", Pass("height_ref", "ellipsoid")),
            ")",
        )
    names = (tname, latname, lonname)
    p = Parsed(t, lat, lon, alts, ref, units, lines, source, absolute, names, where_word, notes)
    p.surface = surface if kind not in ("mapping", "fieldmap") else {}
    vcols = VELOCITY_COLUMNS.get(kind)
    if vcols is not None and col(vcols[0]) is not None and col(vcols[2]) is not None:
        sname, sf, trname, cname, cf = vcols
        speed = column(sname) * sf
        track = column(trname)
        climb = column(cname) * cf if col(cname) is not None else None
        used = (sname, trname) + ((cname,) if climb is not None else ())
        p.velocity = Velocities(speed, track, climb, ADSB_RESOLUTION, used)
    if col("category") is not None:
        cats = [str(c).strip().upper() for c in get(col("category"))]
        cats = [c for c in cats if c and c.lower() not in _EMPTY]
        if cats:
            p.category = max(set(cats), key=cats.count)
    guess = tnote if tnote and GUESS_MS in tnote else None
    declares = "any" if kind == "mapping" else "geometric"
    return replace(
        p, ref_note=ref_note, units_fixed=kind == "fieldmap", time_guess=guess, declares=declares
    )


def _one_aircraft(cells: Any, source: str) -> None:
    """Refuse a table of several aircraft (``icao24`` addresses): one flight is one aircraft's."""
    ids = [str(c).strip().lower() for c in cells]
    rows: dict[str, int] = {}
    for a in ids:
        if a and a not in _EMPTY:
            rows[a] = rows.get(a, 0) + 1
    if len(rows) > 1:
        most = sorted(rows.items(), key=lambda item: -item[1])
        listed = ", ".join(f"{a}: {n} rows" for a, n in most[:5])
        more = f" and {len(most) - 5} more" if len(most) > 5 else ""
        raise InputError(
            f"{source}: {len(rows)} aircraft in one log (icao24 {listed}{more}): a flight is "
            "one aircraft's; give one flight per file"
        )


def _zero_columns(
    alts: dict[str, tuple[str, np.ndarray]], source: str, notes: list[str]
) -> dict[str, tuple[str, np.ndarray]]:
    """Altitude columns without those that are zero in every row (said in ``notes``).

    A recorder's altitude is never exactly zero all along a flight (a pressure altitude moves
    with the weather and the flight, a GNSS one with its noise): zero throughout is the
    recorder's "none" (no such sensor, or a field it fills with 0), not a flight at sea level.
    Refused where no altitude is left.
    """
    zero = [
        r for r, (_, v) in alts.items() if np.isfinite(v).any() and not np.any(v[np.isfinite(v)])
    ]
    if not zero:
        return alts
    names = " and ".join(alts[r][0] for r in zero)
    left = {r: a for r, a in alts.items() if r not in zero}
    if not left:
        raise InputError(
            f"{source} column {names}: zero in every row, a log without that altitude (no "
            "sensor), not a flight at sea level; the log has no other altitude column"
        )
    notes.append(
        f"{names}: zero in every row (a log without that altitude, not a flight at sea level): "
        f"not used; {', '.join(c for c, _ in left.values())} used"
    )
    return left


def _surface_zeros(
    alts: dict[str, tuple[str, np.ndarray]],
    t: np.ndarray,
    lines: np.ndarray,
    where: str,
    notes: list[str],
) -> tuple[dict[str, tuple[str, np.ndarray]], dict[str, np.ndarray]]:
    """ADS-B altitudes of exactly 0 read as none (said in ``notes``): a surface report's.

    An ADS-B surface position message carries no altitude (RTCA DO-260B, 2.2.3.2.4: the
    aircraft is on the ground), and the tables built from them (OpenSky's state vectors,
    ``traffic``'s flights) hold 0 in the altitude column there, whatever the field's
    elevation: a placeholder, not a height (Munich's 1,487 ft field read as 0 ft put the
    taxi 450 m below the runway the aircraft takes off from). Those rows keep their position
    and time, without a height (:attr:`RawTrack.no_height`); so do the rows of a table
    resampled between a placeholder and the altitude beside it, which lie on the straight
    line in time from the one to the other (:func:`_resampled_from`). A real altitude of
    exactly 0 (a pressure altitude at a field near sea level, in 25 ft steps) costs those rows'
    heights alone. Returns the columns (NaN there) and, per height reference, the rows.
    """
    out, surface = {}, {}
    for r, (name, v) in alts.items():
        zero = v == 0.0
        if zero.any():
            line = _resampled_from(v, t, zero)
            v = np.where(zero | line, np.nan, v)
            surface[r] = np.where(zero, 1, np.where(line, 2, 0)).astype(np.int8)
            notes.append(
                f"{name}: {_count(int(zero.sum()), 'row')} of 0 read as no altitude (ADS-B "
                f"surface reports, which carry none; {_at(where, lines[zero])})"
                + (
                    f" and {_count(int(line.sum()), 'row')} resampled between them and the "
                    f"altitudes beside them ({_at(where, lines[line])})"
                    if line.any()
                    else ""
                )
                + ": positions without a height"
            )
        out[r] = (name, v)
    return out, surface


def _resampled_from(v: np.ndarray, t: np.ndarray, zero: np.ndarray) -> np.ndarray:
    """Return the rows beside a run of placeholders that a resampling drew from them (bool).

    After a run of zeros ending at row :math:`z`, rows :math:`z+1 .. e-1` are resampled when
    each lies on the line from :math:`(t_z, 0)` to :math:`(t_e, v_e)` (to 1e-6 of the values,
    their printed digits), for the furthest such :math:`e` (an altitude of its own): a linear
    interpolation between the placeholder and the next altitude. Before a run, alike.
    """
    n = v.size
    out = np.zeros(n, bool)

    def on_line(z: int, e: int) -> bool:
        lo, hi = min(z, e), max(z, e)
        mid = np.arange(lo + 1, hi)
        if not np.all(np.isfinite(v[mid]) & ~zero[mid]) or t[e] == t[z]:
            return False
        want = v[e] * (t[mid] - t[z]) / (t[e] - t[z])
        return bool(np.all(np.abs(v[mid] - want) <= 1e-6 * max(abs(v[e]), 1.0) + 1e-3))

    for step in (1, -1):
        ends = np.flatnonzero(zero & ~np.roll(zero, -step)) if n > 1 else np.zeros(0, int)
        for z in ends.tolist():
            e, best = z + 2 * step, None
            while 0 <= e < n and np.isfinite(v[e]) and not zero[e] and on_line(z, e):
                best, e = e, e + step
            if best is not None:
                lo, hi = sorted((z, best))
                out[lo + 1 : hi] = True
    return out


def read_track(
    source: Any,
    *,
    columns: Mapping[str, str] | str | None = None,
    alt_units: str | None = None,
    height_ref: str | None = None,
    time_format: str | None = None,
    model: Any = None,
    ellipsoid: Ellipsoid = WGS84,
) -> RawTrack:
    """Read a flight log as it comes into a :class:`RawTrack` (no smoothing, no reordering).

    Parameters
    ----------
    source : str, Path, pandas.DataFrame, xarray.Dataset or dict of arrays
        A CSV (any delimiter of ``, ; tab``; ``#`` comments), GPX, NMEA 0183 or IGC file
        (gzip-compressed or not; the format is recognised by its content), or a table.
    columns : dict or str, optional
        Mapping ``time, lat, lon, alt -> column name`` (or its text, :func:`parse_columns`) for
        CSV files and tables whose layout is not recognised.
    alt_units : {"m", "ft"}, optional
        Units of the altitude column (default: the layout's; metres for a mapping). Given
        explicitly, the units checks are skipped.
    height_ref : {"ellipsoid", "msl", "pressure"}, optional
        Reference of the source heights (default: the layout's; the column of that kind when
        the source has several, e.g. ``pressure`` picks OpenSky's ``baroaltitude``). Where the
        source has no column of that kind, it declares what its altitude is: the datum of a
        GNSS altitude (``ellipsoid`` or ``msl``; GPX, NMEA, IGC), the reference of a column
        mapping's altitude, a geometric reading of a table's. A pressure altitude the log does
        not have (GPX, NMEA, an IGC recorder without a pressure sensor, an ADS-B table without
        its barometric column), or a GNSS altitude an IGC file does not have, is refused, never
        made of another column (:func:`_altitude`).
    time_format : str, optional
        ``"s"`` (as given), ``"epoch"``, ``"epoch_ms"``, ``"iso"`` or a ``strptime`` pattern.
    model : str or SHModel, optional
        Gravity model of the geoid heights N (default ``"eigen-6s"``).
    ellipsoid : Ellipsoid
        Ellipsoid of the heights.

    Returns
    -------
    RawTrack

    Raises
    ------
    InputError
        One line naming the source, line (or record) and column.
    """
    if alt_units not in (None, "m", "ft"):
        raise InputError(
            Keyword("alt_units"), f": {alt_units!r} is not one of m, ft", param="alt_units"
        )
    if height_ref not in (None, *HEIGHT_REFS):
        raise InputError(
            Keyword("height_ref"),
            f": {height_ref!r} is not one of {', '.join(HEIGHT_REFS)}",
            param="height_ref",
        )
    if time_format not in (None, "s", "epoch", "epoch_ms", "iso") and "%" not in time_format:
        raise InputError(
            Keyword("time_format"),
            f": {time_format!r} is not one of s, epoch, epoch_ms, iso or a "
            "strptime pattern (%Y-%m-%d %H:%M:%S)",
            param="time_format",
        )
    if isinstance(columns, str):
        columns = parse_columns(columns)
    elif columns is not None:
        columns = parse_columns(",".join(f"{k}={v}" for k, v in dict(columns).items()))
    if isinstance(source, (str, os.PathLike)):
        path = Path(source)
        if path.is_dir():
            raise InputError(f"{path}: a directory, not a flight log")
        if not path.is_file():
            raise InputError(f"{path}: flight log not found")
        text, kind = load_text(path)
        if kind == "csv":
            header, get, lines, dropped = csv_table(text, str(path))
            p = _table(header, get, lines, str(path), "line", columns, time_format)
            p.notes += dropped
        else:
            given = [k for k, v in (("columns", columns), ("time_format", time_format)) if v]
            if given:
                verb = "apply" if len(given) > 1 else "applies"
                names = [Keyword(given[0])] + [p for k in given[1:] for p in (" and ", Keyword(k))]
                raise InputError(
                    f"{path}: ", *names, f" {verb} to CSV files (a {kind})", param=given[0]
                )
            p = {"gpx": read_gpx, "nmea": read_nmea, "igc": read_igc}[kind](text, str(path))
    else:
        name = type(source).__name__
        name = name if name in ("DataFrame", "Dataset") else "arrays"
        header, get, lines = object_table(source, name)
        p = _table(header, get, lines, name, "record", columns, time_format)
    return _finish(p, alt_units, height_ref, model, ellipsoid)


#: how messages name the height references
_REF_WORDS = {"ellipsoid": "above the ellipsoid", "msl": "MSL", "pressure": "pressure altitude"}


def _altitude(p: Parsed, ref: str) -> tuple[str, np.ndarray]:
    """Name and values of the altitude read in the height reference ``ref``.

    The source's column of that reference; where it has none, what :attr:`Parsed.declares`
    allows (the default column read in ``ref``), else refused: a height reference asked for
    explicitly is never replaced by another quantity without a word.
    """
    if ref in p.alts:
        return p.alts[ref]
    geometric = [r for r in p.alts if r != "pressure"]
    if p.declares == "any" or (
        ref != "pressure" and (p.declares == "geometric" or p.height_ref in geometric)
    ):
        return p.alts[p.height_ref]
    want = "pressure altitude" if ref == "pressure" else "GNSS (geometric) altitude"
    have = ", ".join(f"{name} ({_REF_WORDS[r]})" for r, (name, _) in p.alts.items())
    raise InputError(
        f"{p.source}: ",
        Setting("height_ref", ref),
        f" asks for a {want}, which the log does not have (its altitudes: {have})",
        Advice(": leave out ", Keyword("height_ref"), " to read them as they are"),
        param="height_ref",
    )


def _finish(
    p: Parsed,
    alt_units: str | None,
    height_ref: str | None,
    model: Any,
    ellipsoid: Ellipsoid,
) -> RawTrack:
    """Check, convert units and the height reference: the :class:`RawTrack`."""
    ref = height_ref or p.height_ref
    aname, alt = _altitude(p, ref)
    notes = list(p.notes) + ([p.ref_note] if p.ref_note and height_ref is None else [])
    where = f"{p.source} {p.where}"
    for name, v, lim in ((p.names[1], p.lat, 90.0), (p.names[2], p.lon, 360.0)):
        bad = np.flatnonzero(np.abs(v) > lim)
        if bad.size:
            i = bad[0]
            raise InputError(f"{where} {p.lines[i]} column {name}: {v[i]:g} is beyond ±{lim:g}°")
    timed = np.isfinite(p.t)
    if not timed.all():
        notes.append(
            f"dropped {int((~timed).sum())} of {_count(timed.size, 'sample')} with an empty "
            f"{p.names[0]} ({_at(p.where, p.lines[~timed])})"
        )
    code = p.surface.get(ref if ref in p.alts else p.height_ref, np.zeros(p.t.size, np.int8))
    located = np.isfinite(p.lat) & np.isfinite(p.lon)
    keep = timed & located
    if not (keep & np.isfinite(alt)).any():
        raise InputError(f"{p.source}: no sample has a latitude, longitude and {aname}")
    if not located[timed].all():
        n, first = int((timed & ~located).sum()), int(p.lines[timed & ~located][0])
        notes.append(
            f"dropped {n} of {keep.size} samples with an empty latitude or longitude "
            f"(first at {p.where} {first})"
        )
    unheighted = keep & ~np.isfinite(alt) & (code == 0)
    if unheighted.any():
        notes.append(
            f"{aname}: {_count(int(unheighted.sum()), 'row')} without a value "
            f"({_at(p.where, p.lines[unheighted])}): positions without a height"
        )
    t, lat, lon, a, lines = (x[keep] for x in (p.t, p.lat, p.lon, alt, p.lines))
    blank = ~np.isfinite(a)  # no altitude (empty, or a placeholder): positions only
    on_ground = code[keep] == 1
    units = alt_units or p.alt_units
    if units == "ft":
        a = a * FT
        notes.append(f"{aname} in ft (converted to m)")
    bad = np.flatnonzero((a < MIN_HEIGHT) | (a > MAX_HEIGHT))
    if bad.size:
        i = int(bad[0])
        m = f"{number_text(a[i])} m"
        raw = f"{number_text(a[i] / FT)} ft ({m})" if units == "ft" else m
        raise InputError(
            f"{where} {lines[i]} column {aname}: {raw} is outside the heights of a flight "
            f"({MIN_HEIGHT / 1e3:g} km .. {MAX_HEIGHT:g} m)"
        )
    v = speeds(lat, lon, t)
    vmed = float(np.median(v)) if v.size else 0.0
    if (
        lat.size >= 10
        and np.all(np.abs(lat) <= np.pi / 2)
        and np.all(np.abs(lon) <= np.pi)
        and vmed < 17.5
        and 1.0 <= np.degrees(vmed) <= 1000.0
    ):
        raise InputError(
            f"{where} {lines[0]} column {p.names[1]}: latitudes and longitudes look like "
            f"radians (all within ±π/2, ±π; median speed {vmed:.2f} m/s read as degrees, "
            f"{np.degrees(vmed):.0f} m/s as radians): give degrees"
        )
    if alt_units is None and not p.units_fixed and v.size and vmed <= MAX_AIRCRAFT_SPEED:
        # a log with its own vertical rates has its heights' unit checked against them by the
        # conditioning (a constant factor between the two), where altitude glitches are
        # faults of their own: here the rate test is for logs without them
        rates = p.velocity is not None and p.velocity.climb is not None
        on = ~blank
        check_units(a[on], t[on], lines[on], units, vmed, f"{where}", aname, sustained=not rates)
    h = a
    if ref != "ellipsoid":
        h, note = to_ellipsoid(ref, lat, lon, a, model, ellipsoid)
        notes += note
    if blank.any():  # between the heights of the others, for what needs one per sample
        h = h.copy()
        h[blank] = np.interp(t[blank], t[~blank], h[~blank])
    t0 = iso_utc(float(t[0])) if p.absolute else None
    vel = p.velocity
    if vel is not None:
        vel = Velocities(
            vel.speed[keep],
            vel.track[keep],
            None if vel.climb is None else vel.climb[keep],
            vel.resolution,
            vel.names,
        )
    return RawTrack(
        t,
        lat,
        lon,
        h,
        lines,
        p.source,
        ref,
        tuple(notes),
        t0,
        p.time_guess,
        vel,
        p.category,
        blank if blank.any() else None,
        on_ground if on_ground.any() else None,
    )


# -- the format of a file ------------------------------------------------------------------

#: magic bytes of files that are certainly no flight log
_MAGIC = {
    b"\x89PNG": "a PNG image",
    b"%PDF": "a PDF document",
    b"PK\x03\x04": "a ZIP archive",
    b"\xff\xd8\xff": "a JPEG image",
    b"CDF\x01": "a NetCDF file (use fieldmap.nav.trajectory.read_flight)",
    b"\x89HDF": "an HDF5/NetCDF4 file (use fieldmap.nav.trajectory.read_flight)",
}


#: byte order marks of UTF-32 and UTF-16 text (UTF-32 first: its LE mark starts with UTF-16's),
#: which Python's codecs read and drop
_UNICODE_BOMS = (
    (b"\xff\xfe\x00\x00", "utf-32"),
    (b"\x00\x00\xfe\xff", "utf-32"),
    (b"\xff\xfe", "utf-16"),
    (b"\xfe\xff", "utf-16"),
)


def load_text(path: Path) -> tuple[str, str]:
    """Text of a flight log (gzip undone) and its kind: ``csv``, ``gpx``, ``nmea`` or ``igc``.

    UTF-8 (with or without a byte order mark), Latin-1, and UTF-16 or UTF-32 with a byte order
    mark (a spreadsheet's "Unicode text"). White space before the first line counts for nothing.
    """
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read the flight log ({exc.strerror})") from None
    if data[:2] == b"\x1f\x8b":
        try:
            data = gzip.decompress(data)
        except (OSError, EOFError, zlib.error) as exc:
            raise InputError(f"{path}: broken gzip file ({exc})") from None
    if not data.strip():
        raise InputError(f"{path}: empty flight log")
    for magic, what in _MAGIC.items():
        if data.startswith(magic):
            raise InputError(f"{path}: not a flight log ({what})")
    unicode = next((c for bom, c in _UNICODE_BOMS if data.startswith(bom)), None)
    if unicode is not None:  # text with the NUL bytes of its code units, not binary data
        try:
            text = data.decode(unicode)
        except UnicodeDecodeError as exc:
            raise InputError(
                f"{path}: not readable as the {unicode.upper()} text its byte order mark "
                f"announces ({exc.reason} at byte {exc.start})"
            ) from None
    elif b"\x00" in data[:65536]:
        raise InputError(f"{path}: not a text flight log (binary data)")
    else:
        try:
            text = data.decode("utf-8-sig")
        except UnicodeDecodeError:
            text = data.decode("latin-1")
    # a byte order mark alone, or white space that only Unicode calls so (no-break spaces,
    # the ASCII separators 0x1c-0x1f), is as empty as nothing
    body = text.lstrip()
    if not body:
        raise InputError(f"{path}: empty flight log (white space only)")
    suffix = "".join(s for s in path.suffixes[-2:] if s.lower() != ".gz").lower()
    head = [s.strip() for s in body[:20000].splitlines() if s.strip()][:50]
    if suffix == ".gpx" or head[0].startswith("<"):
        return text, "gpx"
    nmea = sum(1 for s in head if re.search(r"\$[A-Z]{5},", s))
    if suffix in (".nmea", ".nma") or nmea >= max(1, len(head) // 2):
        return text, "nmea"
    if suffix == ".igc" or (head[0].startswith("A") and any(s.startswith("HF") for s in head)):
        return text, "igc"
    return text, "csv"


# -- CSV text and tables ---------------------------------------------------------------------


def numbers(cells: Any, where: Where, name: str) -> np.ndarray:
    """Floats of a column: empty cells NaN, anything else that is no number refused.

    Infinite values (``inf``) are returned as they are: the caller reads them as empty and
    says so.
    """
    arr = np.asarray(cells)
    try:
        out = arr.astype(np.float64)
    except (TypeError, ValueError):
        out = np.empty(len(arr))
        for i, c in enumerate(arr):
            s = str(c).strip()
            try:
                out[i] = np.nan if c is None or s.lower() in _EMPTY else float(s)
            except ValueError:
                raise InputError(f"{where(i)} column {name}: {s!r} is not a number") from None
    return out


def _iso(s: str) -> float:
    """Epoch seconds of ISO 8601 text (``Z`` and any number of decimals also on Python 3.10)."""
    s = s[:-1] + "+00:00" if s[-1:] in "Zz" else s
    s = re.sub(r"(\.\d+)", lambda m: (m[1] + "00000")[:7], s, count=1) if "." in s[10:] else s
    return utc_seconds(datetime.fromisoformat(s))


def times(
    cells: Any, where: Where, name: str, fmt: str | None
) -> tuple[np.ndarray, bool, str | None]:
    """Return times in seconds, whether they are absolute, and a note on how they were read.

    Numbers without ``fmt`` are seconds as given, epoch seconds above 1e8, epoch milliseconds
    above 1e11 (the median): the last is a guess of their units, and the note says so. Epoch
    times beyond the years 1..9999 are refused with the line, the column and how they were read.
    An empty time is NaN (its sample is dropped and counted, :func:`read_track`); a column
    without any time is refused.
    """
    arr = np.asarray(cells)
    if arr.dtype.kind == "M":
        nat = np.isnat(arr)
        if nat.all():
            raise InputError(f"{where(0)} column {name}: empty time")
        t = (arr.astype("datetime64[ns]") - np.datetime64(0, "ns")) / np.timedelta64(1, "s")
        return np.where(nat, np.nan, t.astype(np.float64)), True, None
    kinds = {"s": 1.0, "epoch": 1.0, "epoch_ms": 1e-3}
    first = next((str(c) for c in arr if str(c).strip().lower() not in _EMPTY), "")
    numeric = fmt in kinds or (fmt is None and _isnum(first))
    out = np.empty(len(arr))
    for i, c in enumerate(arr):
        s = str(c).strip()
        if s.lower() in _EMPTY or s == "NaT":
            out[i] = np.nan
            continue
        try:
            if isinstance(c, datetime):
                out[i] = utc_seconds(c)
            elif numeric:
                out[i] = float(s)
            elif fmt and "%" in fmt:
                out[i] = utc_seconds(datetime.strptime(s, fmt))
            else:
                out[i] = _iso(s)
        except ValueError:
            what = "a number" if numeric else f"a time ({fmt or 'ISO 8601'})"
            raise InputError(f"{where(i)} column {name}: {s!r} is not {what}") from None
    if np.isnan(out).all():
        raise InputError(f"{where(0)} column {name}: empty time")
    if not numeric:
        return out, True, None
    med = float(np.nanmedian(np.abs(out)))
    if fmt == "epoch_ms" or (fmt is None and med > 1e11):
        how = "epoch milliseconds" + (f" ({GUESS_MS})" if fmt is None else "")
        _check_epoch(out * 1e-3, out, where, name, how)
        return out * 1e-3, True, f"times read as {how}"
    if fmt == "epoch" or (fmt is None and med > 1e8):
        _check_epoch(out, out, where, name, "epoch seconds")
        return out, True, "times read as epoch seconds (UTC)"
    return out, False, None


#: how the guess of epoch milliseconds is said in notes and messages
GUESS_MS = "guessed from their size: above 1e11"
#: epoch seconds of 0001-01-01 and 10000-01-01 UTC: the years a date can name
_EPOCH_MIN, _EPOCH_MAX = -62_135_596_800.0, 253_402_300_800.0


def _check_epoch(t: np.ndarray, raw: np.ndarray, where: Where, name: str, how: str) -> None:
    """Refuse epoch times ``t`` (s) outside the years 1..9999, naming the first and the units."""
    bad = np.flatnonzero((t < _EPOCH_MIN) | (t >= _EPOCH_MAX))
    if bad.size:
        i = int(bad[0])
        when = "before the year 1" if t[i] < _EPOCH_MIN else "after the year 9999"
        raise InputError(
            f"{where(i)} column {name}: {raw[i]:.17g} read as {how} is {when}",
            Advice(": give their units with ", Keyword("time_format"), " (s, epoch, epoch_ms)"),
            param="time_format",
        )


def _isnum(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False


def csv_table(text: str, source: str) -> tuple[list[str], Getter, np.ndarray, list[str]]:
    """Header, getter of a column's cells, line numbers and notes of a CSV text.

    Lines that are no samples of the log are dropped and said in the notes: a repeat of the
    header (two exports joined), a row of empty cells (a spreadsheet's), and the last line when
    it has fewer fields than the header (the file ends inside it: a write or a download cut
    short). Any other line with another number of fields than the header is refused.
    """
    header, hline, rows, lines = None, 0, [], []
    body = [(k, s) for k, s in enumerate(text.splitlines(), 1) if s.strip() and s[:1] != "#"]
    if not body:
        raise InputError(f"{source}: empty flight log (no header, no samples)")
    hline, first = body[0]
    delim = next((d for d in (",", "\t", ";") if d in first), ",")
    header = [c.strip() for c in next(csv.reader([first], delimiter=delim))]
    if all(_isnum(c) for c in header if c):
        raise InputError(
            f"{source} line {hline}: numbers where the header row naming the columns should be "
            f"(a flight log needs one; {HINT})"
        )
    repeats, empty, cut = [], [], None
    for (k, _), cells in zip(body[1:], csv.reader((s for _, s in body[1:]), delimiter=delim)):
        if [c.strip().lstrip("\ufeff") for c in cells] == header:
            repeats.append(k)
            continue
        if not any(c.strip() for c in cells):
            empty.append(k)
            continue
        if len(cells) != len(header):
            if k == body[-1][0] and len(cells) < len(header):
                cut = (k, len(cells))
                continue
            raise InputError(
                f"{source} line {k}: {len(cells)} fields, the header (line {hline}) has "
                f"{len(header)}"
            )
        rows.append(cells)
        lines.append(k)
    notes = []
    if repeats:
        notes.append(
            f"dropped {_count(len(repeats), 'repeat')} of the header (line {hline}) among the "
            f"samples ({_at('line', repeats)}: logs joined into one file?)"
        )
    if empty:
        notes.append(f"dropped {_count(len(empty), 'row')} of empty cells ({_at('line', empty)})")
    if cut is not None:
        notes.append(
            f"dropped the last line ({cut[0]}): {cut[1]} fields, the header (line {hline}) has "
            f"{len(header)}: the file ends inside it"
        )
    if not rows:
        raise InputError(f"{source}: a header (line {hline}) but no samples")
    return header, lambda j: [r[j] for r in rows], np.asarray(lines, dtype=np.int64), notes


def object_table(obj: Any, source: str) -> tuple[list[str], Getter, np.ndarray]:
    """Header, getter and record numbers of a DataFrame, Dataset or mapping of arrays."""
    if hasattr(obj, "data_vars"):
        obj = {str(k): obj[k].values for k in obj.variables if obj[k].ndim == 1}
    elif hasattr(obj, "columns") and getattr(obj.index, "name", None) not in (None, *obj.columns):
        obj = obj.reset_index()  # a DataFrame indexed by its (named) time column
    if not hasattr(obj, "keys"):
        raise InputError(f"{source}: not a DataFrame, Dataset or mapping of arrays")
    header = [str(k) for k in obj.keys()]
    cols = {str(k): np.asarray(obj[k]).ravel() for k in obj.keys()}
    n = max((c.size for c in cols.values()), default=0)
    if n == 0:
        raise InputError(f"{source}: no samples")
    for k, c in cols.items():
        if c.size != n:
            raise InputError(f"{source} column {k}: {c.size} values, other columns have {n}")
    return header, lambda j: cols[header[j]], np.arange(1, n + 1, dtype=np.int64)


# -- heights: units checked, references made ellipsoidal --------------------------------------


def _steps(lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
    """Distances between consecutive samples (m; haversine on a sphere of 6371 km)."""
    la, lo = np.radians(lat), np.radians(lon)
    a = (
        np.sin(np.diff(la) / 2) ** 2
        + np.cos(la[:-1]) * np.cos(la[1:]) * np.sin(np.diff(lo) / 2) ** 2
    )
    return 2 * 6_371_000.0 * np.arcsin(np.sqrt(np.clip(a, 0, 1)))


def speeds(lat: np.ndarray, lon: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Ground speed between consecutive samples with increasing time (m/s)."""
    d, dt = _steps(lat, lon), np.diff(t)
    return d[dt > 0] / dt[dt > 0]


def check_units(
    a: np.ndarray,
    t: np.ndarray,
    lines: np.ndarray,
    units: str,
    vmed: float,
    where: str,
    aname: str,
    sustained: bool = True,
) -> None:
    """Refuse altitudes in the wrong unit on an aircraft-like track (module docstring).

    ``sustained=False`` (a log with its own vertical rates, whose factor to the heights the
    conditioning checks, where local altitude glitches are faults of their own): the sustained
    rate refuses only a log that is wrong over most of its intervals.
    """
    hint: tuple[Part, ...] = (
        (Advice(" ", Pass("alt_units", "ft")),) if units == "m" else (" a wrong column?",)
    ) + (Advice(", or ", Pass("alt_units", "m"), " if these are metres"),)
    hi = float(np.percentile(a, 99))
    if hi > MAX_ALTITUDE:
        i = int(np.argmax(a))
        raise InputError(
            f"{where} {lines[i]} column {aname}: altitudes up to {hi:,.0f} m with an aircraft's "
            f"speed (median {vmed:.0f} m/s): feet read as metres?",
            *hint,
            param="alt_units",
        )
    # A unit error (or a wrong column) is in every sample: the rate it makes is the track's
    # trend, kept by a running median of 5 altitudes (the identity on a monotone climb, sample
    # for sample, so such a climb is judged on its own rates) while it removes any run of up to
    # 2 outlying samples in 5 (ADS-B spikes: 15850, 1150, 15800, 1700, 15750 ft at 1 Hz). Of
    # the rates between those medians, the median of 5 then ignores up to 2 steps in 5
    # intervals (the ends of a wrong level held for a while), which are no sustained rate
    # either. A log that is wrong throughout (a climb x 3.28, altitudes alternating all along)
    # is no outlier and is refused as before; the conditioning removes the outliers later.
    #
    # Sustained is also net: a wrong unit scales the climb itself, so the height the trend
    # gains over the 5 intervals is as fast as its steps. Altitude glitches that alternate
    # with the true ones faster than the median removes them (a relay aircraft's log that
    # interleaves another's altitude every sample or two: 7,050, 1,675, 7,275 ft every 5 s)
    # step fast both ways and gain nothing net: local faults for the conditioning to reject,
    # no unit error.
    dt = np.diff(t)
    ok = np.flatnonzero(dt > 0)
    window = np.lib.stride_tricks.sliding_window_view
    trend = np.median(window(np.pad(a, 2, mode="edge"), 5), axis=1)
    rate = np.abs(np.diff(trend))[ok] / dt[ok]
    if rate.size >= 5:
        med = np.median(window(rate, 5), axis=1)
        first, last = ok[:-4], ok[4:] + 1  # each window's first and last sample
        span = t[last] - t[first]
        net = np.abs(trend[last] - trend[first]) / np.where(span > 0, span, np.inf)
        climb = np.where(span > 0, np.minimum(med, net), med)
        throughout = np.mean(med > MAX_CLIMB) > 0.5
        if throughout or (sustained and climb.max() > MAX_CLIMB):
            fast = med if throughout else climb
            i = int(np.argmax(fast))
            raise InputError(
                f"{where} {lines[ok[i] + 1]} column {aname}: vertical rate {fast[i]:,.0f} m/s "
                f"sustained over 5 samples (an aircraft: < {MAX_CLIMB:g} m/s): altitudes in "
                f"{units}?",
                *hint,
                Advice("; give ", Keyword("alt_units"), " to skip this check"),
                param="alt_units",
            )


def to_ellipsoid(
    ref: str,
    lat: np.ndarray,
    lon: np.ndarray,
    a: np.ndarray,
    model: Any,
    ellipsoid: Ellipsoid,
) -> tuple[np.ndarray, list[str]]:
    """Return h = H + N (a pressure altitude first carried to a geometric MSL height)."""
    from fieldmap.field.geodesy import geoid_height

    notes = []
    if ref == "pressure":
        a = R_ISA * a / (R_ISA - a)
        top = float(np.nanmax(a))
        notes.append(
            "pressure altitude converted with the ISA standard atmosphere (ISO 2533, ICAO Doc "
            f"7488), taken as MSL height: approximate (±{0.04 * top + 80:.0f} m at {top:.0f} m "
            "for 10 K or 10 hPa off the standard atmosphere)"
        )
    steps = _steps(lat, lon)
    s = np.concatenate([[0.0], np.cumsum(steps)])
    big = np.flatnonzero(steps > GEOID_STEP)  # both ends of a gap or a jump are nodes
    nodes = np.searchsorted(s, np.arange(0.0, max(s[-1], 1.0), GEOID_STEP))
    nodes = np.unique(np.concatenate([nodes, big, big + 1]))
    nodes = np.append(nodes, s.size - 1) if s[-1] > s[nodes[-1]] else nodes
    m = "eigen-6s" if model is None else model
    n_nodes = geoid_height(lat[nodes], lon[nodes], model=m, ellipsoid=ellipsoid)
    n = np.interp(s, s[nodes], n_nodes) if nodes.size > 1 else np.full(s.size, n_nodes[0])
    label = m if isinstance(m, str) else getattr(m, "name", "the model")
    notes.append(f"geoid heights N of {label} added ({n.min():.1f} .. {n.max():.1f} m)")
    return a + n, notes


# -- GNSS receiver and flight-recorder logs: GPX 1.1, NMEA 0183, IGC ----------------------

DAY = 86400.0


def _step(texts: list[str]) -> float:
    """Return the finest step of printed decimal numbers: 10^-(most decimals printed), 1 if none."""
    dec = [len(x.partition(".")[2]) for x in texts if x]
    return 10.0 ** -max(dec) if dec else 1.0


def _velocities(
    speed: list[str], course: list[str], factor: float, names: tuple[str, str], notes: list[str]
) -> Velocities | None:
    """Velocities from the printed speeds (times ``factor`` to m/s) and courses; None if none."""
    both = [bool(a) and bool(b) for a, b in zip(speed, course)]
    one = sum(bool(a) != bool(b) for a, b in zip(speed, course))
    if not any(both):
        if one:
            notes.append(f"{one} fixes have a {names[0]} without a {names[1]} (or the reverse):"
                         " no velocity vector, not used")  # fmt: skip
        return None
    sp = np.array([float(a) if ok else np.nan for a, ok in zip(speed, both)]) * factor
    co = np.array([float(b) if ok else np.nan for b, ok in zip(course, both)])
    used_s = [a for a, ok in zip(speed, both) if ok]
    used_c = [b for b, ok in zip(course, both) if ok]
    res = (_step(used_s) * factor, _step(used_c), 0.0)
    notes.append(
        f"the receiver's velocities ({names[0]}, {names[1]}) at {sum(both)} fixes: observations "
        "of the flown path" + (f"; {one} with only one of the two left out" if one else "")
    )
    return Velocities(sp, co, None, res, names)


def _extension(point: object, name: str) -> str:
    """Text of a GPX 1.1 extension element ``name`` (any namespace, any depth), else ''."""
    for root in getattr(point, "extensions", None) or []:
        for el in root.iter():
            if str(el.tag).rpartition("}")[2].lower() == name and (el.text or "").strip():
                return str(el.text).strip()
    return ""


def _printed(v: float | None) -> str:
    """Return a number as the file printed it (the shortest repr of the float read), '' for None."""
    return "" if v is None else np.format_float_positional(float(v), trim="-")


def _line_of(text: str, pos: int) -> int:
    return text.count("\n", 0, pos) + 1


def _count(n: int, thing: str, things: str | None = None) -> str:
    """``1 B record``, ``2 B records`` (``things``: a plural other than ``thing + "s"``)."""
    return f"{n} {thing if n == 1 else things or thing + 's'}"


def _at(where: str, lines: Any, shown: int = 5) -> str:
    """Name the lines (or records) of dropped items: ``line 7``, ``lines 7, 9 and 3 more``."""
    lines = [int(k) for k in lines]
    if len(lines) == 1:
        return f"{where} {lines[0]}"
    more = f" and {len(lines) - shown} more" if len(lines) > shown else ""
    return f"{where}s {', '.join(map(str, lines[:shown]))}{more}"


#: the records after a jump in time that tell a gap from a time fault: as the running median
#: of 5 of :func:`check_units`, a run of up to 2 wrong records in 5 is outvoted
TIME_VOTES = 5


def _after(t_ref: float, tod: float) -> float:
    """Time (s from the log's first midnight) of the time of day ``tod`` recorded after ``t_ref``.

    The same day, unless the clock went back by more than 12 h: then the next day.
    """
    t = math.floor(t_ref / DAY) * DAY + tod
    return t + DAY if t_ref - t > DAY / 2 else t


def _follows(t_a: float, tod: float) -> float:
    """Step (s) from the time ``t_a`` to a later record's time of day; inf if it is before."""
    step = _after(t_a, tod) - t_a
    return step if step >= 0 else math.inf


def days_of(tods: list[float]) -> tuple[np.ndarray, np.ndarray]:
    r"""Day of each time of day of a log in file order, and which times are time faults.

    Times of day (``hhmmss`` of IGC B records and NMEA sentences) go forward by the log's
    ordinary step :math:`\Delta` (the median of its steps, each the shorter way round the
    clock): a recorder writes at its own interval. A time of day after a step back of more than
    12 h is read as the next day's, any other as the same day's: a step back from late in the
    day to early in the next is a **midnight rollover**.

    Only the day is at stake here: a record that is merely out of order (a few seconds back, an
    hour off within the day) keeps its time, for the conditioning to order or to judge
    (:func:`~fieldmap.nav.logs.condition.recordings_apart`). A step longer than :math:`\Delta`
    that puts a record on another day than the record before it, :math:`r`, is a rollover
    inside a gap, or a time fault that would move every later record by a day (one B record at
    ``000005`` in the afternoon). The next :data:`TIME_VOTES` records at other times than the
    record :math:`i` (a run of equal times, a stuck clock, counts as one record) each vote for
    the one they follow by the shorter step forward, :math:`i` or :math:`r` (a record before
    both votes for neither). Where more follow :math:`r`, the log comes back from :math:`i`: a
    **time fault**, dropped. Where the log goes on from :math:`i`, it is a rollover. With 3 or
    more faults among 5 records, the faults win the vote (as a median of 5 would).

    Returns the day index (0 for the first record's day; faults keep 0) and the fault mask.
    """
    x = np.asarray(tods, dtype=np.float64)
    day, fault = np.zeros(x.size), np.zeros(x.size, dtype=bool)
    step = np.diff(x) % DAY
    step = np.minimum(step, DAY - step)
    step = step[step > 0]
    ordinary = float(np.median(step)) if step.size else 0.0
    # where each run of equal times ends (the first later record at another time)
    run_end = np.full(x.size, x.size, dtype=np.int64)
    for i in range(x.size - 2, -1, -1):
        run_end[i] = run_end[i + 1] if x[i + 1] == x[i] else i + 1
    t_ref = float(x[0]) if x.size else 0.0
    for i in range(1, x.size):
        t = _after(t_ref, x[i])
        if abs(t - t_ref) > ordinary and t // DAY != t_ref // DAY:
            for_ref = for_i = votes = 0
            j = int(run_end[i])
            while j < x.size and votes < TIME_VOTES:
                votes += 1
                from_ref, from_i = _follows(t_ref, x[j]), _follows(t, x[j])
                for_ref += from_ref < from_i
                for_i += from_i < from_ref
                j = int(run_end[j])
            if for_ref > for_i:
                fault[i] = True
                continue
        t_ref, day[i] = t, round((t - x[i]) / DAY)
    return day, fault


def _hms(tod: float) -> str:
    """Return a time of day (s) as ``hh:mm:ss``."""
    s = int(tod)
    return f"{s // 3600:02d}:{s // 60 % 60:02d}:{s % 60:02d}"


def _time_faults(tods: list[float], fault: np.ndarray, lines: list[int], what: str) -> str:
    """Return the note on the time faults among ``what`` (``B record``) at ``lines``."""
    k = np.flatnonzero(fault)
    first = int(k[0])
    kept = np.flatnonzero(~fault[:first])
    near = f" after {_hms(tods[kept[-1]])}" if kept.size else ""
    return (
        f"dropped {_count(k.size, what)} whose time of day leaves the log's sequence and comes "
        "back "
        f"(a time fault; {_at('line', [lines[j] for j in k])}: {_hms(tods[first])}{near})"
    )


def _gpx_error_line(text: str, msg: str) -> int | None:
    """Line of the value a gpxpy error names (an attribute for ``<None>``), or None."""
    m = re.search(r"Invalid value for <(\w+)>\.\.\. (.*?) \(", msg)
    if m:
        value = re.escape(m[2].strip())
        if m[1] == "None":  # a point's attribute (lat, lon; a bounds' minlat...)
            pat = rf"\b(?:lat|lon|min\w*|max\w*)\s*=\s*[\"']\s*{value}\s*[\"']"
        else:
            pat = rf"<(?:\w+:)?{m[1]}\b[^>]*>\s*{value}\s*<"
        found = re.search(pat, text)
        return _line_of(text, found.start()) if found else None
    m = re.search(r"line (\d+), column \d+", msg)  # the XML parser's own position
    return int(m[1]) if m else None


def read_gpx(text: str, source: str) -> Parsed:
    """Track (else route) points of a GPX 1.0/1.1 file, segments concatenated in order.

    A point without a readable ``<time>`` (none, or text that is no ISO 8601 time: gpxpy reads
    both as none) is dropped and counted in the notes with its line: one bad point is no
    reason to refuse the track; a track without any time is refused. A speed or course that is
    empty, ``NaN`` or infinite is none (as a CSV cell).
    """
    import gpxpy
    import gpxpy.gpx

    # white space before the XML declaration (which XML forbids): blanked with the
    # declaration, so that every offset and line stays where the file has it
    decl = re.match(r"\s+(<\?xml[^>]*\?>)", text)
    xml = text if decl is None else " " * decl.start(1) + " " * len(decl[1]) + text[decl.end() :]
    try:
        gpx = gpxpy.parse(xml)
    except gpxpy.gpx.GPXException as exc:
        msg = str(exc).splitlines()[0]
        line = _gpx_error_line(text, msg)
        at = f" line {line}" if line is not None else ""
        raise InputError(f"{source}{at}: not a readable GPX file ({msg})") from None
    kind = "trkpt"
    pts: list = [p for trk in gpx.tracks for seg in trk.segments for p in seg.points]
    if not pts:
        kind, pts = "rtept", [p for r in gpx.routes for p in r.points]
    if not pts:
        raise InputError(f"{source}: no track or route points (<trkpt>, <rtept>) in the GPX file")
    tags = [m.start() for m in re.finditer(rf"<(?:\w+:)?{kind}\b", text)]
    if len(tags) == len(pts):
        lines, where = np.array([_line_of(text, p) for p in tags], dtype=np.int64), "line"
    else:
        lines, where = np.arange(1, len(pts) + 1, dtype=np.int64), kind
    timed = np.array([p.time is not None for p in pts])
    if not timed.any():
        raise InputError(f"{source} {where} {lines[0]} column time: <{kind}> without <time>")
    notes = []
    if not timed.all():
        notes.append(
            f"dropped {int((~timed).sum())} of {len(pts)} <{kind}> without a readable <time> "
            f"({_at(where, lines[~timed])})"
        )
        pts, lines = [p for p, ok in zip(pts, timed) if ok], lines[timed]
    t = np.array([utc_seconds(p.time) for p in pts], dtype=np.float64)
    lat = np.array([p.latitude for p in pts], dtype=np.float64)
    lon = np.array([p.longitude for p in pts], dtype=np.float64)
    ele = np.array([np.nan if p.elevation is None else p.elevation for p in pts])
    alts = {"msl": ("ele", ele)}
    notes.insert(0, f"GPX: {len(pts)} <{kind}> points; <ele> read as height above mean sea level")
    ref = "msl"
    if all(p.geoid_height is not None for p in pts):
        sep = np.array([p.geoid_height for p in pts], dtype=np.float64)
        alts["ellipsoid"] = ("ele+geoidheight", ele + sep)
        ref = "ellipsoid"
        notes[0] = f"GPX: {len(pts)} <{kind}> points; h = <ele> + <geoidheight> (the file's own)"
    speed = [_printed(getattr(p, "speed", None)) or _extension(p, "speed") for p in pts]
    course = [_printed(getattr(p, "course", None)) or _extension(p, "course") for p in pts]
    for values, name in ((speed, "speed"), (course, "course")):
        for k, x in enumerate(values):
            try:
                if x and (x.lower() in _EMPTY or not np.isfinite(float(x))):
                    values[k] = ""  # NaN or infinite: none, as an empty cell
            except ValueError:
                raise InputError(
                    f"{source} {where} {lines[k]} column {name}: {x!r} is not a number"
                ) from None
    velocity = _velocities(speed, course, 1.0, ("<speed>", "<course>"), notes)
    out = Parsed(
        t, lat, lon, alts, ref, "m", lines, source, True, ("time", "lat", "lon"), where, notes
    )
    out.velocity = velocity
    return out


def _dm(s: str, hemi: str, neg: str, where: str, name: str) -> float:
    """Degrees from NMEA ``(d)ddmm.mmmm`` and a hemisphere letter."""
    try:
        v = float(s)
        if not s[:1].isdigit() or v < 0 or hemi not in ("NS" if neg == "S" else "EW"):
            raise ValueError
    except ValueError:
        raise InputError(
            f"{where} column {name}: {s + ',' + hemi!r} is not ddmm.mmmm,N|S|E|W"
        ) from None
    d = np.floor(v / 100.0)
    return float((d + (v - 100.0 * d) / 60.0) * (-1.0 if hemi == neg else 1.0))


def _tod(s: str) -> float | None:
    """Seconds of the day from ``hhmmss[.ss]``; None for no time of day.

    Hours 00-23, minutes 00-59, seconds below 61 (60: a UTC leap second).
    """
    m = re.fullmatch(r"(\d{2})(\d{2})(\d{2}(?:\.\d*)?)", s)
    if not m or int(m[1]) > 23 or int(m[2]) > 59 or float(m[3]) >= 61:
        return None
    return int(m[1]) * 3600.0 + int(m[2]) * 60.0 + float(m[3])


def read_nmea(text: str, source: str) -> Parsed:
    """GGA fixes of an NMEA 0183 log, dated by RMC sentences (see the module docstring).

    A sentence with a valid checksum but a glitched value costs what the value serves, counted
    in the notes with its line: a time of day that is no ``hhmmss`` (hour 25) or a time fault
    (:func:`days_of`) its sentence; a GGA position that no chart shows (60 minutes or more,
    degrees beyond 90 or 180) its sentence; an RMC date that is no ``ddmmyy`` (``000000``) the
    date alone (the other RMC sentences date the fixes).
    """
    import pynmea2

    stamps: list[tuple[str, int, float, Any]] = []  # (GGA|RMC, line, time of day, payload)
    skipped = {"with a bad checksum": 0, "incomplete": 0, "without a fix": 0}
    no_time: list[tuple[int, str]] = []  # (line, field 1) of sentences with no time of day
    no_date: list[tuple[int, str]] = []  # (line, field 9) of RMC with no date
    no_place: list[tuple[int, str]] = []  # (line, fields 2-5) of GGA positions no chart shows
    for lineno, raw in enumerate(text.splitlines(), start=1):
        i = raw.find("$")
        s = raw[i:].strip() if i >= 0 else ""
        if s[3:6] not in ("GGA", "RMC"):
            continue
        has_sum = bool(re.search(r"\*[0-9A-Fa-f]{2}$", s))
        try:
            msg = pynmea2.parse(s, check=has_sum)
            f = list(msg.data) + [""] * 14
        except pynmea2.ChecksumError:
            skipped["with a bad checksum"] += 1
            continue
        except pynmea2.ParseError:
            skipped["incomplete"] += 1
            continue
        where = f"{source} line {lineno}"
        if s[3:6] == "RMC":
            if not f[0]:
                continue
            tod = _tod(f[0])
            if tod is None:  # one sentence's glitch: its date and velocity are not used
                no_time.append((lineno, f[0]))
                continue
            day0 = None
            if re.fullmatch(r"\d{6}", f[8]):
                d = (int(f[8][4:]) + 2000, int(f[8][2:4]), int(f[8][:2]))
                try:
                    day0 = datetime(*d, tzinfo=timezone.utc).timestamp()
                except ValueError:  # one sentence's glitch (000000): the other RMC date it
                    no_date.append((lineno, f[8]))
            vel = ("", "")
            if f[1] == "A":
                for j, name in ((6, "field 7 (speed, knots)"), (7, "field 8 (course)")):
                    try:
                        if f[j] and not np.isfinite(float(f[j])):
                            raise ValueError
                    except ValueError:
                        raise InputError(f"{where} column RMC {name}: {f[j]!r} is not a number")
                vel = (f[6], f[7])
            stamps.append(("RMC", lineno, tod, (day0, vel)))
            continue
        if not has_sum and (len(msg.data) < 11 or not f[8]):
            skipped["incomplete"] += 1
            continue
        if f[5] in ("", "0") or not f[1] or not f[3]:
            skipped["without a fix"] += 1
            continue
        try:
            alt = float(f[8]) if f[8] else np.nan
            sep = float(f[10]) if f[10] else np.nan
        except ValueError:
            raise InputError(f"{where} column GGA field 9/11 (altitude, separation): not a number")
        pos = (
            _dm(f[1], f[2], "S", where, "GGA field 2 (latitude)"),
            _dm(f[3], f[4], "W", where, "GGA field 4 (longitude)"),
        )
        tod = _tod(f[0])
        if tod is None:
            no_time.append((lineno, f[0]))
            continue
        dm = [float(x) for x in (f[1], f[3])]
        if not all(
            _place_shown(str(int(v // 100)), str(int(v % 100)), lim)
            for v, lim in zip(dm, (90, 180))
        ):
            no_place.append((lineno, f"{f[1]},{f[2]},{f[3]},{f[4]}"))
            continue
        stamps.append(("GGA", lineno, tod, (*pos, alt, sep)))
    days, fault = days_of([s[2] for s in stamps])
    dropped = []
    if no_time:
        dropped.append(
            f"dropped {_count(len(no_time), 'sentence')} whose time of day (field 1) is no hhmmss "
            f"({_at('line', [k for k, _ in no_time])}: {no_time[0][1]!r})"
        )
    if fault.any():
        tods, where_of = [s[2] for s in stamps], [s[1] for s in stamps]
        dropped.append(_time_faults(tods, fault, where_of, "sentence"))
        stamps = [s for s, bad in zip(stamps, fault) if not bad]
        days = days[~fault]
    if no_place:
        dropped.append(
            f"dropped {_count(len(no_place), 'GGA sentence')} whose position (fields 2-5) no "
            "chart shows: minutes of 60 or more, or degrees beyond 90 (latitude) or 180 "
            f"(longitude) ({_at('line', [k for k, _ in no_place])}: {no_place[0][1]!r})"
        )
    if no_date:
        dropped.append(
            f"{_count(len(no_date), 'RMC date')} (field 9) that is no ddmmyy not used "
            f"({_at('line', [k for k, _ in no_date])}: {no_date[0][1]!r})"
        )
    fixes = [k for k, s in enumerate(stamps) if s[0] == "GGA"]
    why = ", ".join(f"{n} sentences {k}" for k, n in skipped.items() if n)
    if not fixes:
        raise InputError(
            f"{source}: no usable GGA fix in the NMEA log ({why or 'no GGA sentence'})"
        )
    anchors = [
        (k, s[3][0] - days[k] * DAY)
        for k, s in enumerate(stamps)
        if s[0] == "RMC" and s[3][0] is not None
    ]
    t, lines, cols = np.empty(len(fixes)), np.empty(len(fixes), np.int64), []
    base, a = (anchors[0][1] if anchors else 0.0), 0
    for j, k in enumerate(fixes):
        while a < len(anchors) and anchors[a][0] <= k:  # the latest RMC date before the fix
            base, a = anchors[a][1], a + 1
        t[j], lines[j] = base + days[k] * DAY + stamps[k][2], stamps[k][1]
        cols.append(stamps[k][3])
    lat, lon, alt, sep = np.array(cols, dtype=np.float64).T
    notes = [f"NMEA 0183: {len(fixes)} GGA fixes" + (f"; skipped {why}" if why else "")]
    notes += dropped
    speed: list[str] = []
    course: list[str] = []
    for k in fixes:  # the RMC of the same epoch: the sentence before or after the GGA
        same = [
            j
            for j in (k - 1, k + 1)
            if 0 <= j < len(stamps)
            and stamps[j][0] == "RMC"
            and stamps[j][2] == stamps[k][2]
            and days[j] == days[k]
        ]
        sp_k, co_k = stamps[same[0]][3][1] if same else ("", "")
        speed.append(sp_k)
        course.append(co_k)
    if not anchors:
        notes.append("no RMC date: times are seconds from 00:00 UTC of the log's first day")
    alts = {"msl": ("GGA field 9 (altitude)", alt)}
    ref = "msl"
    if np.all(np.isfinite(sep[np.isfinite(alt)])):
        alts["ellipsoid"] = ("GGA fields 9+11", alt + sep)
        ref = "ellipsoid"
        notes.append("h = GGA altitude (MSL) + the receiver's geoid separation (field 11)")
    names = ("GGA field 1 (UTC time)", "GGA field 2 (latitude)", "GGA field 4 (longitude)")
    velocity = _velocities(
        speed, course, KT, ("RMC field 7 (speed)", "RMC field 8 (course)"), notes
    )
    out = Parsed(t, lat, lon, alts, ref, "m", lines, source, bool(anchors), names, "line", notes)
    out.velocity = velocity
    return out


#: fields of an IGC B record: name, first byte, last byte (1-based, inclusive)
_B_FIELDS = (
    ("time", 2, 7, r"\d{6}"),
    ("latitude", 8, 15, r"\d{7}[NS]"),
    ("longitude", 16, 24, r"\d{8}[EW]"),
    ("fix validity", 25, 25, r"[AV]"),
    ("pressure altitude", 26, 30, r"-\d{4}|\d{5}"),
    ("GNSS altitude", 31, 35, r"-\d{4}|\d{5}"),
)


def _place_shown(degrees: str, minutes: str, limit: int) -> bool:
    """Return whether whole degrees and minutes (digits) name a place on the Earth.

    Minutes 0-59, degrees up to ``limit`` (90 for a latitude, 180 for a longitude) with no
    minutes beyond it.
    """
    d, m = int(degrees), int(minutes)
    return m < 60 and (d < limit or (d == limit and m == 0))


def _igc_dm(digits: str, extra: str, deg: int) -> float:
    minutes = float(digits[deg : deg + 2] + "." + digits[deg + 2 :] + extra)
    return int(digits[:deg]) + minutes / 60.0


def read_igc(text: str, source: str) -> Parsed:
    """B fixes of an IGC flight recorder file (see the module docstring).

    Local defects of a recorder cost their record, counted in the notes with its line: a time
    of day that no clock shows (hour 24 or more, minute 60 or more, second 61 or more; 60 is a
    leap second), a time fault (:func:`days_of`), and the last B record of the file when the
    file ends inside it (fewer than its 35 bytes: the recorder stopped while writing, or the
    file was cut). Any other B record that does not match the format is refused. An altitude
    that is zero in every B record is the recorder's "none" (no pressure sensor, or no 3D fix),
    not a flight at sea level: it is not used (as a table's, :func:`_zero_columns`).
    """
    day0, alg, ext, rows, tods = None, None, {}, [], []
    no_time: list[tuple[int, str]] = []
    no_place: list[tuple[int, str]] = []  # (line, bytes 8-24) of positions no chart shows
    cut: tuple[int, int] | None = None
    all_lines = text.splitlines()
    last = max((k for k, r in enumerate(all_lines, start=1) if r.strip()), default=0)
    for lineno, raw in enumerate(all_lines, start=1):
        s = raw.rstrip()
        if s.startswith("HFDTE") or s.startswith("HODTE"):
            m = re.match(r"H[FO]DTE(?:[A-Z ]*:)?\s*(\d{2})(\d{2})(\d{2})", s)
            try:
                dd, mm, yy = (int(m[k]) for k in (1, 2, 3)) if m else (0, 0, 0)
                day0 = datetime(yy + (2000 if yy < 80 else 1900), mm, dd, tzinfo=timezone.utc)
            except ValueError:
                raise InputError(f"{source} line {lineno} column HFDTE: {s!r} has no DDMMYY date")
        elif s.startswith("HFALG"):
            alg = s.split(":")[-1].strip().upper()[:3]
        elif s.startswith("I") and re.fullmatch(r"I\d{2}(\d{4}[A-Z0-9]{3})*", s):
            ext = {
                s[k + 4 : k + 7]: (int(s[k : k + 2]), int(s[k + 2 : k + 4]))
                for k in range(3, len(s), 7)
            }
        elif s.startswith("B"):
            if lineno == last and len(s) < _B_FIELDS[-1][2]:
                cut = (lineno, len(s))
                continue
            for name, a, b, pat in _B_FIELDS:
                if not re.fullmatch(pat, s[a - 1 : b]):
                    raise InputError(
                        f"{source} line {lineno} column {name} (B record bytes {a}-{b}): "
                        f"{s[a - 1 : b]!r} does not match the IGC B record"
                    )
            tod = _tod(s[1:7])
            if tod is None:
                no_time.append((lineno, s[1:7]))
                continue
            if not _place_shown(s[7:9], s[9:11], 90) or not _place_shown(s[15:18], s[18:20], 180):
                no_place.append((lineno, s[7:24]))
                continue
            lad, lod = (s[ext[k][0] - 1 : ext[k][1]] if k in ext else "" for k in ("LAD", "LOD"))
            y = _igc_dm(s[7:14], lad if lad.isdigit() else "", 2) * (-1 if s[14] == "S" else 1)
            x = _igc_dm(s[15:23], lod if lod.isdigit() else "", 3) * (-1 if s[23] == "W" else 1)
            rows.append(
                (lineno, y, x, float(s[25:30]), float(s[30:35]) if s[24] == "A" else np.nan)
            )
            tods.append(tod)
    dropped = []
    if cut is not None:
        dropped.append(
            f"dropped the last B record (line {cut[0]}): the file ends inside it "
            f"({cut[1]} of its {_B_FIELDS[-1][2]} bytes)"
        )
    if no_time:
        dropped.append(
            f"dropped {_count(len(no_time), 'B record')} whose time (bytes 2-7) no clock shows "
            f"({_at('line', [k for k, _ in no_time])}: {no_time[0][1]!r})"
        )
    if no_place:
        dropped.append(
            f"dropped {_count(len(no_place), 'B record')} whose position (bytes 8-24) no chart "
            "shows: minutes of 60 or more, or degrees beyond 90 (latitude) or 180 (longitude) "
            f"({_at('line', [k for k, _ in no_place])}: {no_place[0][1]!r})"
        )
    day, fault = days_of(tods)
    if fault.any():
        dropped.append(_time_faults(tods, fault, [r[0] for r in rows], "B record"))
        rows = [r for r, bad in zip(rows, fault) if not bad]
        tods = [x for x, bad in zip(tods, fault) if not bad]
        day = day[~fault]
    if not rows:
        why = f" ({'; '.join(dropped)})" if dropped else ""
        raise InputError(f"{source}: no B record (fix) in the IGC file{why}")
    lines, lat, lon, press, gnss = (np.array(c) for c in zip(*rows))
    t = np.asarray(tods) + day * DAY + (day0.timestamp() if day0 else 0.0)
    gref = "msl" if alg == "GEO" else "ellipsoid"
    has_press, has_gnss = bool(np.any(press != 0.0)), bool(np.any(np.nan_to_num(gnss) != 0.0))
    if not (has_press or has_gnss):
        raise InputError(
            f"{source}: no altitude: the pressure altitude (B bytes 26-30) is zero in every B "
            "record and there is no GNSS altitude (bytes 31-35 zero, or 2D fixes): a recorder "
            "without either, not a flight at sea level"
        )
    alts = {"pressure": ("pressure altitude (B bytes 26-30)", press)} if has_press else {}
    notes, ref_note = [f"IGC: {len(rows)} B fixes", *dropped], None
    if not has_gnss:
        ref = "pressure"
        notes.append("no GNSS altitude (all zero or 2D fixes): pressure altitude used")
    else:
        alts[gref] = ("GNSS altitude (B bytes 31-35)", gnss)
        ref = gref
        if alg is None:
            ref_note = Message(
                "GNSS altitude read as height above the WGS84 ellipsoid (IGC specification; no "
                "HFALG header)",
                Advice(": ", Pass("height_ref", "msl"), " if your recorder writes MSL"),
            )
        if not has_press:
            notes.append(
                "no pressure altitude (zero in every B record: no pressure sensor): GNSS "
                "altitude used"
            )
    if day0 is None:
        notes.append("no HFDTE date: times are seconds from 00:00 UTC of the flight's first day")
    return Parsed(
        t,
        lat,
        lon,
        alts,
        ref,
        "m",
        lines.astype(np.int64),
        source,
        day0 is not None,
        ("time (B bytes 2-7)", "latitude", "longitude"),
        "line",
        notes,
        ref_note,
    )

r"""Flight logs as they come (CSV, GPX, NMEA, IGC, tables) read into one ``RawTrack``.

:func:`read_track` reads a log *without* smoothing, sorting or outlier rejection (that is the
conditioning step's job): samples stay in file order, repeats kept, each with the line (or
record) it came from. What it does is give every log the same meaning: times in seconds (epoch
seconds UTC when the source has absolute times), latitude and longitude in degrees, and the
height **above the ellipsoid** in metres, converted from the source's height reference:

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
pattern (``time_format``). Rows with an empty latitude, longitude or altitude
(``""``, ``nan``, ``null``) are dropped and counted in the notes; anything else that is not a
number is refused with its line and column. GPX, NMEA 0183 and IGC: below.

Refused with one :class:`~fieldmap.errors.InputError` naming file, line and column: unknown
columns (the message lists them and the ``--columns`` mapping), unparsable times or numbers,
latitudes beyond ±90° or longitudes beyond ±360°, heights outside -10 km..1e8 m, epoch times
outside the years 1..9999, radians, a header naming a column twice, one column mapped to two
fields, an empty file, a file that is no flight log. Units are checked, not guessed, where
neither ``alt_units``, the column name (``height_m``) nor the format's specification (GPX,
NMEA, IGC: metres) fixes them: an aircraft-like track (median ground speed below 700 m/s) with
altitudes above 30 km or a vertical rate above 300 m/s sustained over 5 samples (of the running
median of 5 altitudes, so that isolated spikes are not taken for a unit error) is refused as
feet read as metres (or a wrong column). Messages name keyword arguments (an
:class:`~fieldmap.errors.InputError` about one has it as ``param``; the command line rewords
them with its options).

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

Times of day roll over at midnight (a step back by more than 12 h adds a day).

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
import os
import re
import zlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from fieldmap.errors import Advice, InputError, Keyword, Message, Part, Pass
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

    def where(i: int) -> str:
        return f"{source} {where_word} {lines[i]}"

    t, absolute, tnote = times(get(col(tname)), where, tname, time_format)
    notes += [tnote] if tnote else []
    lat = numbers(get(col(latname)), where, latname)
    lon = numbers(get(col(lonname)), where, lonname)
    alts = {r: (c, numbers(get(col(c)), where, c)) for r, c in altmap.items() if col(c) is not None}
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
    vcols = VELOCITY_COLUMNS.get(kind)
    if vcols is not None and col(vcols[0]) is not None and col(vcols[2]) is not None:
        sname, sf, trname, cname, cf = vcols
        speed = numbers(get(col(sname)), where, sname) * sf
        track = numbers(get(col(trname)), where, trname)
        climb = numbers(get(col(cname)), where, cname) * cf if col(cname) is not None else None
        used = (sname, trname) + ((cname,) if climb is not None else ())
        p.velocity = Velocities(speed, track, climb, ADSB_RESOLUTION, used)
    if col("category") is not None:
        cats = [str(c).strip().upper() for c in get(col("category"))]
        cats = [c for c in cats if c and c.lower() not in _EMPTY]
        if cats:
            p.category = max(set(cats), key=cats.count)
    guess = tnote if tnote and GUESS_MS in tnote else None
    return replace(p, ref_note=ref_note, units_fixed=kind == "fieldmap", time_guess=guess)


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
        the source has several, e.g. ``pressure`` picks OpenSky's ``baroaltitude``).
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
        if not path.is_file():
            raise InputError(f"{path}: flight log not found")
        text, kind = load_text(path)
        if kind == "csv":
            header, get, lines = csv_table(text, str(path))
            p = _table(header, get, lines, str(path), "line", columns, time_format)
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


def _finish(
    p: Parsed,
    alt_units: str | None,
    height_ref: str | None,
    model: Any,
    ellipsoid: Ellipsoid,
) -> RawTrack:
    """Check, convert units and the height reference: the :class:`RawTrack`."""
    ref = height_ref or p.height_ref
    aname, alt = p.alts.get(ref, p.alts[p.height_ref])
    notes = list(p.notes) + ([p.ref_note] if p.ref_note and height_ref is None else [])
    where = f"{p.source} {p.where}"
    for name, v, lim in ((p.names[1], p.lat, 90.0), (p.names[2], p.lon, 360.0)):
        bad = np.flatnonzero(np.abs(v) > lim)
        if bad.size:
            i = bad[0]
            raise InputError(f"{where} {p.lines[i]} column {name}: {v[i]:g} is beyond ±{lim:g}°")
    keep = np.isfinite(p.lat) & np.isfinite(p.lon) & np.isfinite(alt)
    if not keep.any():
        raise InputError(f"{p.source}: no sample has a latitude, longitude and {aname}")
    if not keep.all():
        n, first = int((~keep).sum()), int(p.lines[np.flatnonzero(~keep)[0]])
        notes.append(
            f"dropped {n} of {keep.size} samples with empty latitude, longitude or "
            f"{aname} (first at {p.where} {first})"
        )
    t, lat, lon, a, lines = (x[keep] for x in (p.t, p.lat, p.lon, alt, p.lines))
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
        check_units(a, t, lines, units, vmed, f"{where}", aname, sustained=not rates)
    h = a
    if ref != "ellipsoid":
        h, note = to_ellipsoid(ref, lat, lon, a, model, ellipsoid)
        notes += note
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
        t, lat, lon, h, lines, p.source, ref, tuple(notes), t0, p.time_guess, vel, p.category
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


def load_text(path: Path) -> tuple[str, str]:
    """Text of a flight log (gzip undone) and its kind: ``csv``, ``gpx``, ``nmea`` or ``igc``."""
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
    if b"\x00" in data[:65536]:
        raise InputError(f"{path}: not a text flight log (binary data)")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = data.decode("latin-1")
    suffix = "".join(s for s in path.suffixes[-2:] if s.lower() != ".gz").lower()
    head = [s.strip() for s in text[:20000].splitlines() if s.strip()][:50]
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
    """Floats of a column: empty cells NaN, anything else that is no number refused."""
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
    bad = np.flatnonzero(np.isinf(out))
    if bad.size:
        raise InputError(f"{where(bad[0])} column {name}: {out[bad[0]]} is not finite")
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
    """
    arr = np.asarray(cells)
    if arr.dtype.kind == "M":
        if np.isnat(arr).any():
            raise InputError(f"{where(np.flatnonzero(np.isnat(arr))[0])} column {name}: empty time")
        t = (arr.astype("datetime64[ns]") - np.datetime64(0, "ns")) / np.timedelta64(1, "s")
        return t.astype(np.float64), True, None
    kinds = {"s": 1.0, "epoch": 1.0, "epoch_ms": 1e-3}
    first = next((str(c) for c in arr if str(c).strip().lower() not in _EMPTY), "")
    numeric = fmt in kinds or (fmt is None and _isnum(first))
    out = np.empty(len(arr))
    for i, c in enumerate(arr):
        s = str(c).strip()
        if s.lower() in _EMPTY or s == "NaT":
            raise InputError(f"{where(i)} column {name}: empty time")
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
    if not numeric:
        return out, True, None
    med = float(np.median(np.abs(out)))
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


def csv_table(text: str, source: str) -> tuple[list[str], Getter, np.ndarray]:
    """Header, getter of a column's cells and line numbers of a CSV text."""
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
    for (k, _), cells in zip(body[1:], csv.reader((s for _, s in body[1:]), delimiter=delim)):
        if len(cells) != len(header):
            raise InputError(
                f"{source} line {k}: {len(cells)} fields, the header (line {hline}) has "
                f"{len(header)}"
            )
        rows.append(cells)
        lines.append(k)
    if not rows:
        raise InputError(f"{source}: a header (line {hline}) but no samples")
    return header, lambda j: [r[j] for r in rows], np.asarray(lines, dtype=np.int64)


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
    dt = np.diff(t)
    ok = np.flatnonzero(dt > 0)
    window = np.lib.stride_tricks.sliding_window_view
    trend = np.median(window(np.pad(a, 2, mode="edge"), 5), axis=1)
    rate = np.abs(np.diff(trend))[ok] / dt[ok]
    if rate.size >= 5:
        med = np.median(window(rate, 5), axis=1)
        if med.max() > MAX_CLIMB and (sustained or np.mean(med > MAX_CLIMB) > 0.5):
            i = int(np.argmax(med))
            raise InputError(
                f"{where} {lines[ok[i] + 1]} column {aname}: vertical rate {med[i]:,.0f} m/s "
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
        top = float(np.max(a))
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


def _days(tods: list[float]) -> np.ndarray:
    """Day index of each time of day in order: a step back by more than 12 h is midnight."""
    day, out, prev = 0, np.zeros(len(tods)), None
    for i, x in enumerate(tods):
        if prev is not None and x < prev - DAY / 2:
            day += 1
        out[i], prev = day, x
    return out


def read_gpx(text: str, source: str) -> Parsed:
    """Track (else route) points of a GPX 1.0/1.1 file, segments concatenated in order."""
    import gpxpy
    import gpxpy.gpx

    try:
        gpx = gpxpy.parse(text)
    except gpxpy.gpx.GPXException as exc:
        msg = str(exc).splitlines()[0]
        m = re.search(r"\.\.\. (.*?) \(", msg)
        pos = text.find(m.group(1)) if m else -1
        at = f" line {_line_of(text, pos)}" if pos >= 0 else ""
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
    t = np.empty(len(pts))
    for i, p in enumerate(pts):
        if p.time is None:
            raise InputError(f"{source} {where} {lines[i]} column time: <{kind}> without <time>")
        t[i] = utc_seconds(p.time)
    lat = np.array([p.latitude for p in pts], dtype=np.float64)
    lon = np.array([p.longitude for p in pts], dtype=np.float64)
    ele = np.array([np.nan if p.elevation is None else p.elevation for p in pts])
    alts = {"msl": ("ele", ele)}
    notes = [f"GPX: {len(pts)} <{kind}> points; <ele> read as height above mean sea level"]
    ref = "msl"
    if all(p.geoid_height is not None for p in pts):
        sep = np.array([p.geoid_height for p in pts], dtype=np.float64)
        alts["ellipsoid"] = ("ele+geoidheight", ele + sep)
        ref = "ellipsoid"
        notes[0] = f"GPX: {len(pts)} <{kind}> points; h = <ele> + <geoidheight> (the file's own)"
    speed = [_printed(getattr(p, "speed", None)) or _extension(p, "speed") for p in pts]
    course = [_printed(getattr(p, "course", None)) or _extension(p, "course") for p in pts]
    for k, (a, b) in enumerate(zip(speed, course)):
        for name, x in (("speed", a), ("course", b)):
            try:
                if x and not np.isfinite(float(x)):
                    raise ValueError
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


def _tod(s: str, where: str) -> float:
    """Seconds of the day from ``hhmmss[.ss]``."""
    m = re.fullmatch(r"(\d{2})(\d{2})(\d{2}(?:\.\d*)?)", s)
    if not m or int(m[1]) > 23 or int(m[2]) > 59 or float(m[3]) >= 61:
        raise InputError(f"{where} column field 1 (UTC time): {s!r} is no hhmmss.ss")
    return int(m[1]) * 3600.0 + int(m[2]) * 60.0 + float(m[3])


def read_nmea(text: str, source: str) -> Parsed:
    """GGA fixes of an NMEA 0183 log, dated by RMC sentences (see the module docstring)."""
    import pynmea2

    stamps: list[tuple[str, int, float, Any]] = []  # (GGA|RMC, line, time of day, payload)
    skipped = {"with a bad checksum": 0, "incomplete": 0, "without a fix": 0}
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
            day0 = None
            if re.fullmatch(r"\d{6}", f[8]):
                d = (int(f[8][4:]) + 2000, int(f[8][2:4]), int(f[8][:2]))
                try:
                    day0 = datetime(*d, tzinfo=timezone.utc).timestamp()
                except ValueError:
                    raise InputError(f"{where} column RMC field 9 (date): {f[8]!r} is no ddmmyy")
            vel = ("", "")
            if f[1] == "A":
                for j, name in ((6, "field 7 (speed, knots)"), (7, "field 8 (course)")):
                    try:
                        if f[j] and not np.isfinite(float(f[j])):
                            raise ValueError
                    except ValueError:
                        raise InputError(f"{where} column RMC {name}: {f[j]!r} is not a number")
                vel = (f[6], f[7])
            stamps.append(("RMC", lineno, _tod(f[0], where), (day0, vel)))
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
        stamps.append(("GGA", lineno, _tod(f[0], where), (*pos, alt, sep)))
    fixes = [k for k, s in enumerate(stamps) if s[0] == "GGA"]
    why = ", ".join(f"{n} sentences {k}" for k, n in skipped.items() if n)
    if not fixes:
        raise InputError(
            f"{source}: no usable GGA fix in the NMEA log ({why or 'no GGA sentence'})"
        )
    days = _days([s[2] for s in stamps])
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


def _igc_dm(digits: str, extra: str, deg: int) -> float:
    minutes = float(digits[deg : deg + 2] + "." + digits[deg + 2 :] + extra)
    return int(digits[:deg]) + minutes / 60.0


def read_igc(text: str, source: str) -> Parsed:
    """B fixes of an IGC flight recorder file (see the module docstring)."""
    day0, alg, ext, rows, tods = None, None, {}, [], []
    for lineno, raw in enumerate(text.splitlines(), start=1):
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
            for name, a, b, pat in _B_FIELDS:
                if not re.fullmatch(pat, s[a - 1 : b]):
                    raise InputError(
                        f"{source} line {lineno} column {name} (B record bytes {a}-{b}): "
                        f"{s[a - 1 : b]!r} does not match the IGC B record"
                    )
            lad, lod = (s[ext[k][0] - 1 : ext[k][1]] if k in ext else "" for k in ("LAD", "LOD"))
            y = _igc_dm(s[7:14], lad if lad.isdigit() else "", 2) * (-1 if s[14] == "S" else 1)
            x = _igc_dm(s[15:23], lod if lod.isdigit() else "", 3) * (-1 if s[23] == "W" else 1)
            rows.append(
                (lineno, y, x, float(s[25:30]), float(s[30:35]) if s[24] == "A" else np.nan)
            )
            tods.append(int(s[1:3]) * 3600.0 + int(s[3:5]) * 60.0 + int(s[5:7]))
    if not rows:
        raise InputError(f"{source}: no B record (fix) in the IGC file")
    lines, lat, lon, press, gnss = (np.array(c) for c in zip(*rows))
    t = np.asarray(tods) + _days(tods) * DAY + (day0.timestamp() if day0 else 0.0)
    gref = "msl" if alg == "GEO" else "ellipsoid"
    alts = {"pressure": ("pressure altitude (B bytes 26-30)", press)}
    alts[gref] = ("GNSS altitude (B bytes 31-35)", gnss)
    notes, ref_note = [f"IGC: {len(rows)} B fixes"], None
    if not np.any(np.nan_to_num(gnss) != 0.0):
        ref = "pressure"
        notes.append("no GNSS altitude (all zero or 2D fixes): pressure altitude used")
    else:
        ref = gref
        if alg is None:
            ref_note = Message(
                "GNSS altitude read as height above the WGS84 ellipsoid (IGC specification; no "
                "HFALG header)",
                Advice(": ", Pass("height_ref", "msl"), " if your recorder writes MSL"),
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

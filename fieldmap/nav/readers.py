r"""Flight logs as they come: CSV layouts, GPX, NMEA 0183, IGC and tables, to one :class:`RawTrack`.

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
number is refused with its line and column. Text formats: see :mod:`fieldmap.nav.readers_formats`.

Refused with one :class:`~fieldmap.errors.InputError` naming file, line and column: unknown
columns (the message lists them and the ``--columns`` mapping), unparsable times or numbers,
latitudes beyond ±90° or longitudes beyond ±360°, heights outside -11 km..1e8 m, epoch times
outside the years 1..9999, radians, a header naming a column twice, one column mapped to two
fields, an empty file, a file that is no flight log. Units are checked, not guessed, where
neither ``alt_units``, the column name (``height_m``) nor the format's specification (GPX,
NMEA, IGC: metres) fixes them: an aircraft-like track (median ground speed below 700 m/s) with
altitudes above 30 km or a vertical rate above 300 m/s sustained over 5 samples is refused as
feet read as metres (or a wrong column). Messages name keyword arguments, or the CLI options
when called from ``fieldmap navsim`` (:mod:`fieldmap.nav.spelling`).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import WGS84, Ellipsoid
from fieldmap.limits import number_text
from fieldmap.nav.readers_formats import (
    HINT,
    Parsed,
    csv_table,
    iso_utc,
    load_text,
    numbers,
    object_table,
    read_gpx,
    read_igc,
    read_nmea,
    times,
)
from fieldmap.nav.readers_heights import FT as FT
from fieldmap.nav.readers_heights import GEOID_STEP as GEOID_STEP
from fieldmap.nav.readers_heights import MAX_AIRCRAFT_SPEED as MAX_AIRCRAFT_SPEED
from fieldmap.nav.readers_heights import MAX_ALTITUDE as MAX_ALTITUDE
from fieldmap.nav.readers_heights import MAX_CLIMB as MAX_CLIMB
from fieldmap.nav.readers_heights import MAX_HEIGHT as MAX_HEIGHT
from fieldmap.nav.readers_heights import MIN_HEIGHT as MIN_HEIGHT
from fieldmap.nav.readers_heights import R_ISA as R_ISA
from fieldmap.nav.readers_heights import check_units, speeds, to_ellipsoid
from fieldmap.nav.readers_tables import GUESS_MS
from fieldmap.nav.spelling import advice, keyword

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
            raise InputError(f"--columns: {item!r} is not one of time|lat|lon|alt=COLUMN ({HINT})")
        if key in out:
            raise InputError(f"--columns: {key} given twice ({HINT})")
        out[key] = name
    missing = [k for k in _KEYS if k not in out]
    if missing:
        raise InputError(f"--columns: missing {', '.join(missing)} ({HINT})")
    keys: dict[str, str] = {}
    for key, name in out.items():
        if name in keys:
            raise InputError(
                f"--columns: column {name!r} given for both {keys[name]} and {key} ({HINT})"
            )
        keys[name] = key
    return out


def _table(header, get, lines, source, where_word, columns, time_format) -> Parsed:
    """Recognise the layout (or apply ``columns``) and read the four columns."""
    found = {h.lower(): j for j, h in reversed(list(enumerate(header)))}
    exact = {h: j for j, h in reversed(list(enumerate(header)))}
    fields: dict[str, list[int]] = {}
    for j, h in enumerate(header):
        fields.setdefault(h.lower(), []).append(j + 1)

    def col(name):
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

    def where(i):
        return f"{source} {where_word} {lines[i]}"

    t, absolute, tnote = times(get(col(tname)), where, tname, time_format)
    notes += [tnote] if tnote else []
    lat = numbers(get(col(latname)), where, latname)
    lon = numbers(get(col(lonname)), where, lonname)
    alts = {r: (c, numbers(get(col(c)), where, c)) for r, c in altmap.items() if col(c) is not None}
    filled = {r: float(np.mean(np.isfinite(v))) for r, (_, v) in alts.items()}
    ref = next((r for r in alts if filled[r] >= 0.5), max(filled, key=filled.__getitem__))
    ref_note, option = None, keyword("height_ref")
    if kind == "mapping":
        ref_note = "heights taken as MSL (the default for a column mapping" + (
            f": give {option})" if option else ")"
        )
    elif ref == "msl":
        tip = advice("height_ref", "ellipsoid")
        ref_note = (
            f"{alts[ref][0]}: ADS-B geometric altitude, read as MSL (DO-260B transponders "
            "report it above the ellipsoid" + (f": {tip})" if tip else ")")
        )
    names = (tname, latname, lonname)
    p = Parsed(t, lat, lon, alts, ref, units, lines, source, absolute, names, where_word, notes)
    guess = tnote if tnote and GUESS_MS in tnote else None
    return dataclasses.replace(
        p, ref_note=ref_note, units_fixed=kind == "fieldmap", time_guess=guess
    )


def read_track(
    source,
    *,
    columns: Mapping[str, str] | str | None = None,
    alt_units: str | None = None,
    height_ref: str | None = None,
    time_format: str | None = None,
    model=None,
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
        raise InputError(f"{_kw('alt_units')}: {alt_units!r} is not one of m, ft")
    if height_ref not in (None, *HEIGHT_REFS):
        raise InputError(
            f"{_kw('height_ref')}: {height_ref!r} is not one of {', '.join(HEIGHT_REFS)}"
        )
    if time_format not in (None, "s", "epoch", "epoch_ms", "iso") and "%" not in time_format:
        raise InputError(
            f"{_kw('time_format')}: {time_format!r} is not one of s, epoch, epoch_ms, iso or a "
            "strptime pattern (%Y-%m-%d %H:%M:%S)"
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
            given = [_kw(k) for k, v in (("columns", columns), ("time_format", time_format)) if v]
            if given:
                verb = "apply" if len(given) > 1 else "applies"
                raise InputError(f"{path}: {' and '.join(given)} {verb} to CSV files (a {kind})")
            p = {"gpx": read_gpx, "nmea": read_nmea, "igc": read_igc}[kind](text, str(path))
    else:
        name = type(source).__name__
        name = name if name in ("DataFrame", "Dataset") else "arrays"
        header, get, lines = object_table(source, name)
        p = _table(header, get, lines, name, "record", columns, time_format)
    return _finish(p, alt_units, height_ref, model, ellipsoid)


def _finish(p: Parsed, alt_units, height_ref, model, ellipsoid) -> RawTrack:
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
        check_units(a, t, lines, units, vmed, f"{where}", aname)
    h = a
    if ref != "ellipsoid":
        h, note = to_ellipsoid(ref, lat, lon, a, model, ellipsoid)
        notes += note
    t0 = iso_utc(float(t[0])) if p.absolute else None
    return RawTrack(t, lat, lon, h, lines, p.source, ref, tuple(notes), t0, p.time_guess)


def _kw(name: str) -> str:
    """Return the keyword ``name`` as the reader of a message writes it (a CLI option)."""
    return keyword(name) or name

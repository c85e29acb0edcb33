r"""Flight samples: read and validate a user's flight log (times, positions, attitude).

Input: times (s), geodetic latitude, longitude (degrees) and height above the ellipsoid (m),
optionally roll, pitch and heading (degrees), from a CSV file (header row, ``#`` comment lines),
a NetCDF file, a pandas ``DataFrame``, an xarray ``Dataset`` or plain arrays. Sampling may be
irregular (a 1 Hz GNSS log is typical). :func:`read_flight` returns them as
:class:`FlightSamples`, the input of :class:`fieldmap.nav.flight.FlightTrajectory`.

A flight is refused with one :class:`fieldmap.errors.InputError` naming the source, line and
column when a column is missing, a value is not a finite number, times do not increase, there
are fewer than 6 points (a quintic spline's minimum), latitude/longitude look like radians or
the path jumps (> 8 km/s between samples).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import WGS84, Ellipsoid
from fieldmap.field.frames import geodetic_to_ecef
from fieldmap.limits import number_text

REQUIRED = ("time_s", "lat_deg", "lon_deg", "height_m")
ATTITUDE = ("roll_deg", "pitch_deg", "heading_deg")
G0 = 9.80665
#: accelerations beyond this are refused (m/s²)
MAX_ACCEL = 100.0 * G0
#: speeds between consecutive samples beyond this are a position jump (m/s)
MAX_SPEED = 8000.0
#: the quintic spline needs at least k + 1 points
MIN_POINTS = 6
#: heights a flight can have (m): the deepest ocean floor, the limit of fieldmap's models
MIN_HEIGHT, MAX_HEIGHT = -11_000.0, 1.0e8


@dataclass(frozen=True)
class FlightSamples:
    """Validated samples of one flight (times relative to the first sample).

    ``t`` (n,) s; ``lat``, ``lon`` (n,) degrees (longitude unwrapped); ``h`` (n,) m;
    ``attitude`` (n, 3) roll, pitch, heading in degrees or None; ``source`` and ``lines`` (the
    line, or record, of each sample in the source) for messages; ``t_start`` the first time.
    """

    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    h: np.ndarray
    attitude: np.ndarray | None
    source: str
    lines: np.ndarray
    t_start: float = 0.0


def _where(source, lines, i, column) -> str:
    return f"{source} line {int(lines[i])} column {column}"


def _columns_from_csv(path: Path):
    """Columns of a CSV file as float arrays plus the line number of each row."""
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read the flight file ({exc})") from None
    rows, lines, header, hline = [], [], None, 0
    for lineno, raw in enumerate(text.splitlines(), start=1):
        s = raw.strip()
        if not s or s.startswith("#"):
            continue
        cells = next(csv.reader([s]))
        if header is None:
            header, hline = [c.strip() for c in cells], lineno
            continue
        if len(cells) != len(header):
            raise InputError(
                f"{path} line {lineno}: {len(cells)} fields, the header (line {hline}) has "
                f"{len(header)}"
            )
        rows.append(cells)
        lines.append(lineno)
    if header is None:
        raise InputError(f"{path}: empty flight file (no header, no samples)")
    cols = {}
    for j, name in enumerate(header):
        if name not in REQUIRED + ATTITUDE:
            continue
        vals = np.empty(len(rows))
        for i, r in enumerate(rows):
            try:
                vals[i] = float(r[j])
            except ValueError:
                raise InputError(
                    f"{path} line {lines[i]} column {name}: {r[j].strip()!r} is not a number"
                ) from None
        cols[name] = vals
    return cols, np.array(lines, dtype=np.int64), str(path), header


def _columns_from_mapping(data, source: str):
    names = list(data.keys()) if hasattr(data, "keys") else []
    cols = {}
    for name in names:
        if name in REQUIRED + ATTITUDE:
            try:
                cols[name] = np.asarray(data[name], dtype=np.float64).ravel()
            except (TypeError, ValueError):
                raise InputError(f"{source} column {name}: values are not numbers") from None
    n = max((c.size for c in cols.values()), default=0)
    for name, c in cols.items():
        if c.size != n:
            raise InputError(f"{source} column {name}: {c.size} values, other columns have {n}")
    return cols, np.arange(1, n + 1), source, names


def read_flight(source, *, ellipsoid: Ellipsoid = WGS84) -> FlightSamples:
    """Read and validate a flight from a file, DataFrame, Dataset or mapping of arrays.

    Parameters
    ----------
    source : str, Path, pandas.DataFrame, xarray.Dataset or dict
        CSV (``.csv``/``.txt``: header row, ``#`` comments) or NetCDF (``.nc``) file, or
        columns ``time_s, lat_deg, lon_deg, height_m`` [``roll_deg, pitch_deg, heading_deg``].
        Units: s, degrees, degrees, m, degrees.
    ellipsoid : Ellipsoid
        Ellipsoid of the geodetic coordinates (for the speed and acceleration checks).

    Returns
    -------
    FlightSamples

    Raises
    ------
    InputError
        Naming the source, the line (file rows; record number for arrays) and the column.
    """
    if isinstance(source, (str, Path)):
        path = Path(source)
        if not path.is_file():
            raise InputError(f"{path}: flight file not found")
        if path.suffix.lower() in (".nc", ".nc4", ".cdf"):
            import xarray as xr

            try:
                with xr.open_dataset(path) as ds:
                    cols, lines, name, header = _columns_from_mapping(
                        {k: ds[k].values for k in ds.variables}, str(path)
                    )
            except (OSError, ValueError) as exc:
                raise InputError(f"{path}: not a readable NetCDF file ({exc})") from None
            name = f"{path} (record)"
        else:
            cols, lines, name, header = _columns_from_csv(path)
    else:
        kind = type(source).__name__
        mapping = source
        if kind == "Dataset":
            mapping = {k: source[k].values for k in source.variables}
        cols, lines, name, header = _columns_from_mapping(mapping, f"flight {kind} (record)")
    missing = [c for c in REQUIRED if c not in cols]
    if missing:
        raise InputError(
            f"{name}: missing column(s) {', '.join(missing)} (have: {', '.join(map(str, header))})"
        )
    att = [c for c in ATTITUDE if c in cols]
    if att and len(att) != 3:
        raise InputError(
            f"{name}: give all of {', '.join(ATTITUDE)} or none (coordinated flight), got "
            f"{', '.join(att)}"
        )
    n = cols["time_s"].size
    if n == 0:
        raise InputError(f"{name}: no samples")
    for c in REQUIRED + (ATTITUDE if att else ()):
        bad = np.flatnonzero(~np.isfinite(cols[c]))
        if bad.size:
            raise InputError(f"{_where(name, lines, bad[0], c)}: {cols[c][bad[0]]} is not finite")
    if n < MIN_POINTS:
        raise InputError(f"{name}: {n} samples, the quintic spline needs at least {MIN_POINTS}")
    t = cols["time_s"]
    dt = np.diff(t)
    bad = np.flatnonzero(dt <= 0)
    if bad.size:
        i = bad[0] + 1
        what = "repeats" if dt[bad[0]] == 0 else "goes back from"
        raise InputError(
            f"{_where(name, lines, i, 'time_s')}: time {t[i]:g} s {what} the previous "
            f"{t[i - 1]:g} s (times must increase)"
        )
    lat, lon, h = cols["lat_deg"], cols["lon_deg"], cols["height_m"]
    for c, v, lim in (("lat_deg", lat, 90.0), ("lon_deg", lon, 540.0)):
        bad = np.flatnonzero(np.abs(v) > lim)
        if bad.size:
            raise InputError(f"{_where(name, lines, bad[0], c)}: {v[bad[0]]:g} is beyond ±{lim:g}")
    bad = np.flatnonzero((h < MIN_HEIGHT) | (h > MAX_HEIGHT))
    if bad.size:
        raise InputError(
            f"{_where(name, lines, bad[0], 'height_m')}: {number_text(h[bad[0]])} m is outside "
            "-11 km..1e8 m"
        )
    lon = np.degrees(np.unwrap(np.radians(lon)))
    r = np.stack(geodetic_to_ecef(lat, lon, h, ellipsoid), -1)
    speed = np.linalg.norm(np.diff(r, axis=0), axis=1) / dt
    _check_radians(name, lines, lat, lon, speed)
    bad = np.flatnonzero(speed > MAX_SPEED)
    if bad.size:
        i = bad[0] + 1
        raise InputError(
            f"{_where(name, lines, i, 'lat_deg')}: position jump ({speed[bad[0]]:.0f} m/s from "
            f"the previous sample, more than {MAX_SPEED:g} m/s)"
        )
    attitude = None
    if att:
        attitude = np.stack([cols[c] for c in ATTITUDE], -1)
        attitude[:, 2] = np.degrees(np.unwrap(np.radians(attitude[:, 2])))
        bad = np.flatnonzero(np.abs(cols["pitch_deg"]) > 90.0)
        if bad.size:
            raise InputError(f"{_where(name, lines, bad[0], 'pitch_deg')}: beyond ±90 degrees")
    return FlightSamples(t - t[0], lat, lon, h, attitude, name, lines, float(t[0]))


def _check_radians(name, lines, lat, lon, speed) -> None:
    """Refuse latitudes/longitudes that look like radians.

    All values inside ±π/2, ±π and a path that would be an aircraft's speed (1..1000 m/s) only if
    the numbers were radians (57.3× the distance), i.e. at most 17 m/s read as degrees.
    """
    v_deg = float(np.median(speed))
    if (
        np.all(np.abs(lat) <= np.pi / 2)
        and np.all(np.abs(lon) <= np.pi)
        and 1.0 <= np.degrees(v_deg) <= 1000.0
        and v_deg < 17.5
    ):
        raise InputError(
            f"{_where(name, lines, 0, 'lat_deg')}: latitudes and longitudes look like radians "
            f"(all within ±π/2, ±π; median speed {v_deg:.2f} m/s read as degrees, "
            f"{np.degrees(v_deg):.0f} m/s as radians): give degrees"
        )

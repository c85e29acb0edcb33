"""Logs built in a test: a raw track, and a ``traffic`` CSV written from a test's own truth.

:func:`raw_track`: :class:`fieldmap.nav.logs.read.RawTrack` with a test's defaults.

The conditioning's tests build their logs' truth themselves and hand the samples to
:func:`fieldmap.nav.logs.condition.condition` as the reader would: heights above the
ellipsoid, a line per sample from line 2 (a header on line 1) unless given.
"""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import numpy as np

from fieldmap.nav.logs.read import RawTrack


def raw_track(
    t: np.ndarray,
    lat: np.ndarray,
    lon: np.ndarray,
    h: np.ndarray,
    lines: np.ndarray | None = None,
    *,
    source: str = "synthetic.csv",
    category: str | None = None,
) -> RawTrack:
    """Return the samples as a :class:`RawTrack` (heights above the ellipsoid)."""
    t = np.asarray(t, dtype=np.float64)
    lines = np.arange(t.size) + 2 if lines is None else np.asarray(lines)
    return RawTrack(t, lat, lon, h, lines, source, "ellipsoid", category=category)


#: WGS84 (the synthetic logs' geodesy, written here independently of fieldmap's)
A_WGS, F_WGS = 6378137.0, 1.0 / 298.257223563
E2_WGS = F_WGS * (2.0 - F_WGS)
#: the columns of a ``traffic`` CSV, in its order
TRAFFIC_COLUMNS = (
    "timestamp,icao24,callsign,latitude,longitude,altitude,groundspeed,track,vertical_rate"
)


def local_to_lat_lon(
    north: np.ndarray, east: np.ndarray, lat0: float, lon0: float
) -> tuple[np.ndarray, np.ndarray]:
    """Latitude and longitude (degrees) of north and east offsets (m) from ``(lat0, lon0)``.

    The meridian and prime-vertical radii of curvature at ``lat0`` (a local plane: metres of
    error over the tens of kilometres a synthetic log spans).
    """
    s2 = np.sin(np.radians(lat0)) ** 2
    m_lat = A_WGS * (1.0 - E2_WGS) / (1.0 - E2_WGS * s2) ** 1.5
    n_lon = A_WGS / np.sqrt(1.0 - E2_WGS * s2) * np.cos(np.radians(lat0))
    return lat0 + np.degrees(north / m_lat), lon0 + np.degrees(east / n_lon)


def write_traffic_csv(path: Path, t: np.ndarray, rows: list[str]) -> Path:
    """Write a ``traffic`` CSV: a row per time ``t`` (s after 2024-07-01 12:00 UTC).

    ``rows`` holds each row's columns after the timestamp, already printed
    (``icao24,callsign,latitude,...``): each test prints its values as its log would.
    """
    t0 = dt.datetime(2024, 7, 1, 12, 0, 0, tzinfo=dt.timezone.utc)
    lines = [TRAFFIC_COLUMNS]
    for ti, row in zip(t, rows):
        stamp = (t0 + dt.timedelta(seconds=float(ti))).strftime("%Y-%m-%dT%H:%M:%SZ")
        lines.append(f"{stamp},{row}")
    path.write_text("\n".join(lines) + "\n")
    return path

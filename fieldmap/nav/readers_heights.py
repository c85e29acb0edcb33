"""Heights of flight logs: units checked on aircraft-like tracks, references made ellipsoidal.

Internal to :func:`fieldmap.nav.readers.read_track` (the method is in its module docstring):
:func:`check_units` refuses altitudes that look like feet read as metres, :func:`to_ellipsoid`
turns MSL and pressure altitudes into heights above the ellipsoid, :func:`speeds` gives the
ground speeds both use.
"""

from __future__ import annotations

import numpy as np

from fieldmap.errors import InputError
from fieldmap.limits import MAX_HEIGHT as MAX_HEIGHT
from fieldmap.limits import MIN_HEIGHT as MIN_HEIGHT
from fieldmap.nav.spelling import advice, keyword

FT = 0.3048
#: spacing along the track of the geoid-height evaluations (m)
GEOID_STEP = 5000.0
#: ISO 2533 earth radius for geopotential -> geometric height (m)
R_ISA = 6_356_766.0
#: checks of the altitude units on aircraft-like tracks
MAX_AIRCRAFT_SPEED, MAX_ALTITUDE, MAX_CLIMB = 700.0, 30_000.0, 300.0


def _steps(lat, lon) -> np.ndarray:
    """Distances between consecutive samples (m; haversine on a sphere of 6371 km)."""
    la, lo = np.radians(lat), np.radians(lon)
    a = (
        np.sin(np.diff(la) / 2) ** 2
        + np.cos(la[:-1]) * np.cos(la[1:]) * np.sin(np.diff(lo) / 2) ** 2
    )
    return 2 * 6_371_000.0 * np.arcsin(np.sqrt(np.clip(a, 0, 1)))


def speeds(lat, lon, t) -> np.ndarray:
    """Ground speed between consecutive samples with increasing time (m/s)."""
    d, dt = _steps(lat, lon), np.diff(t)
    return d[dt > 0] / dt[dt > 0]


def check_units(a, t, lines, units, vmed, where, aname) -> None:
    """Refuse altitudes in the wrong unit on an aircraft-like track (module docstring)."""
    feet, metres, option = advice("alt_units", "ft"), advice("alt_units", "m"), keyword("alt_units")
    hint = (feet or "") if units == "m" else "a wrong column?"
    hint += f", or {metres} if these are metres" if metres else ""
    hi = float(np.percentile(a, 99))
    if hi > MAX_ALTITUDE:
        i = int(np.argmax(a))
        raise InputError(
            f"{where} {lines[i]} column {aname}: altitudes up to {hi:,.0f} m with an aircraft's "
            f"speed (median {vmed:.0f} m/s): feet read as metres?" + (f" {hint}" if hint else "")
        )
    dt = np.diff(t)
    ok = np.flatnonzero(dt > 0)
    rate = np.abs(np.diff(a))[ok] / dt[ok]
    if rate.size >= 5:
        med = np.median(np.lib.stride_tricks.sliding_window_view(rate, 5), axis=1)
        if med.max() > MAX_CLIMB:
            i = int(np.argmax(med))
            raise InputError(
                f"{where} {lines[ok[i] + 1]} column {aname}: vertical rate {med[i]:,.0f} m/s "
                f"sustained over 5 samples (an aircraft: < {MAX_CLIMB:g} m/s): altitudes in "
                f"{units}?"
                + (f" {hint}" if hint else "")
                + (f"; give {option} to skip this check" if option else "")
            )


def to_ellipsoid(ref, lat, lon, a, model, ellipsoid) -> tuple[np.ndarray, list[str]]:
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

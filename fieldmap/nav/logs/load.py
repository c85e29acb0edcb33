"""A user's flight log, as it comes, turned into a trajectory to fly (issue 16).

:func:`load_flight` reads a log with :func:`fieldmap.nav.logs.read.read_track` (CSV with any
column names, ADS-B exports, GPX, NMEA 0183, IGC, DataFrame/Dataset/arrays; MSL or pressure
heights made ellipsoidal), conditions it with :func:`fieldmap.nav.logs.condition.condition`
(order, outliers, gaps, ground, smoothing: the path's acceleration and jerk are the vehicle's,
not the noise's) and builds the :class:`fieldmap.nav.flight.FlightTrajectory` that the flight
study flies. ``smooth=False`` keeps the exact interpolation of the samples (and its refusals)
for clean, simulated inputs; fieldmap's own CSV with attitude columns and NetCDF files are flown
as recorded (their attitude would be lost by the smoothing).

Its messages name its own keywords: where the conditioning advises ``reorder=True``, which
:func:`load_flight` sets from ``smooth``, the advice is ``smooth=True``.
"""

from __future__ import annotations

from pathlib import Path

from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import WGS84, Ellipsoid

_EXACT_SUFFIXES = (".nc", ".nc4", ".cdf")


def _recorded_attitude(source) -> bool:
    """Whether ``source`` is a fieldmap CSV with roll/pitch/heading columns (flown as recorded)."""
    if not isinstance(source, (str, Path)):
        return hasattr(source, "keys") and "heading_deg" in list(source.keys())
    path = Path(source)
    if path.suffix.lower() in _EXACT_SUFFIXES:
        return True
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            for line in f:
                s = line.strip()
                if s and not s.startswith("#"):
                    return "heading_deg" in s and "time_s" in s
    except OSError:
        return False
    return False


def load_flight(
    source,
    *,
    columns=None,
    alt_units: str | None = None,
    height_ref: str | None = None,
    time_format: str | None = None,
    model=None,
    ellipsoid: Ellipsoid = WGS84,
    smooth: bool = True,
    position_noise_m=None,
    max_gap_s: float = 60.0,
    airborne_only: bool = True,
):
    """Read, condition and interpolate a flight log.

    Parameters
    ----------
    source : str, Path, pandas.DataFrame, xarray.Dataset or dict
        The log (formats of :func:`fieldmap.nav.logs.read.read_track`).
    columns, alt_units, height_ref, time_format, model
        As :func:`fieldmap.nav.logs.read.read_track` (``model``: the truth model whose geoid
        makes MSL heights ellipsoidal).
    ellipsoid : Ellipsoid
        Ellipsoid of the coordinates and of the flight.
    smooth : bool
        Condition the log (default; times going back are sorted, and said so); False: the
        exact interpolation of the samples, refused where times go back.
    position_noise_m : float or (float, float), optional
        Position noise (horizontal[, vertical]) of the smoothing fit; default estimated.
    max_gap_s : float
        Longest gap bridged; longer gaps split the log (the longest segment is flown).
    airborne_only : bool
        Trim leading and trailing ground segments (taxi).

    Returns
    -------
    (FlightTrajectory, ConditionedFlight or None)
        The trajectory and the conditioning (its ``report`` and figure); None when flown as
        recorded.
    """
    from fieldmap.nav.flight import FlightTrajectory

    if isinstance(source, (str, Path)) and not Path(source).is_file():
        raise InputError(f"{source}: flight file not found")
    reader_opts = {
        "columns": columns,
        "alt_units": alt_units,
        "height_ref": height_ref,
        "time_format": time_format,
    }
    if _recorded_attitude(source):
        given = [k for k, v in reader_opts.items() if v is not None]
        if given:
            raise InputError(
                f"{source}: a fieldmap flight file (time_s, lat_deg, lon_deg, height_m with "
                f"attitude, or NetCDF) takes no {', '.join(given)}",
                param=given[0],
            )
        return FlightTrajectory(source, ellipsoid=ellipsoid), None
    from fieldmap.nav.logs.condition import condition
    from fieldmap.nav.logs.read import read_track

    track = read_track(source, **reader_opts, model=model, ellipsoid=ellipsoid)
    try:
        cf = condition(
            track,
            position_noise_m=position_noise_m,
            max_gap_s=max_gap_s,
            airborne_only=airborne_only,
            smooth=smooth,
            reorder=smooth,  # unconditioned, times going back are refused (today's rule)
            ellipsoid=ellipsoid,
        )
        return FlightTrajectory(cf.samples, ellipsoid=ellipsoid), cf
    except InputError as exc:
        text, param = str(exc), exc.param
        if param == "reorder":  # reorder= is set from smooth=: the caller's keyword that sorts
            text, param = text.replace("pass reorder=True", "pass smooth=True"), "smooth"
        if track.time_guess is not None:
            # the guess of the time units may be what made the log fail: say it was a guess
            text = f"{text}; {track.time_guess}: pass time_format='s' if they are seconds"
            param = param or "time_format"
        if text == str(exc):
            raise
        raise InputError(text, param=param) from None

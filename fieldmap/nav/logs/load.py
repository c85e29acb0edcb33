"""A user's flight log, as it comes, turned into a trajectory to fly (issue 16).

:func:`load_flight` reads a log with :func:`fieldmap.nav.logs.read.read_track` (CSV with any
column names, ADS-B exports, GPX, NMEA 0183, IGC, DataFrame/Dataset/arrays; MSL or pressure
heights made ellipsoidal), conditions it with :func:`fieldmap.nav.logs.condition.condition`
(order, outliers, gaps, ground, smoothing: the path's acceleration and jerk are the vehicle's,
not the noise's) and builds the :class:`fieldmap.nav.flight.FlightTrajectory` that the flight
study flies, with the options of one :class:`~fieldmap.nav.logs.condition.Conditioning`.
``smooth=False`` keeps the exact interpolation of the samples (and its refusals)
for clean, simulated inputs; fieldmap's own CSV with attitude columns and NetCDF files are flown
as recorded (their attitude would be lost by the smoothing).

Its messages name the options' fields: where the conditioning without smoothing advises
``reorder=True``, which :func:`load_flight` sets from ``smooth``, the advice is ``smooth=True``.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

from fieldmap._compat import options_api
from fieldmap.errors import InputError
from fieldmap.nav.flight import FlightTrajectory
from fieldmap.nav.logs.condition import Conditioning, condition
from fieldmap.nav.logs.report import ConditionedFlight

_EXACT_SUFFIXES = (".nc", ".nc4", ".cdf")


def _recorded_attitude(source: Any) -> bool:
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


@options_api("options", Conditioning)
def load_flight(
    source: Any,
    options: Conditioning | None = None,
    *,
    columns: Any = None,
    alt_units: str | None = None,
    height_ref: str | None = None,
    time_format: str | None = None,
    model: Any = None,
) -> tuple[FlightTrajectory, ConditionedFlight | None]:
    """Read, condition and interpolate a flight log.

    Parameters
    ----------
    source : str, Path, pandas.DataFrame, xarray.Dataset or dict
        The log (formats of :func:`fieldmap.nav.logs.read.read_track`).
    options : Conditioning, optional
        The conditioning (default ``Conditioning()``); its ``ellipsoid`` is that of the
        coordinates and of the flight. With ``smooth=False``: the exact interpolation of the
        samples, refused where times go back (``reorder`` applies to the smoothing only). The
        0.1 keywords (``smooth=``, ``max_gap_s=`` …) still work, with a
        ``DeprecationWarning``.
    columns, alt_units, height_ref, time_format, model
        As :func:`fieldmap.nav.logs.read.read_track` (``model``: the truth model whose geoid
        makes MSL heights ellipsoidal).

    Returns
    -------
    (FlightTrajectory, ConditionedFlight or None)
        The trajectory and the conditioning (its ``report`` and figure); None when flown as
        recorded.
    """
    options = Conditioning() if options is None else options
    ellipsoid = options.ellipsoid
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
    from fieldmap.nav.logs.read import read_track

    track = read_track(source, **reader_opts, model=model, ellipsoid=ellipsoid)
    # unconditioned, times going back are refused (today's rule): smooth= is what sorts
    exact = not options.smooth
    try:
        cf = condition(track, replace(options, reorder=options.reorder and not exact))
        return FlightTrajectory(cf.samples, ellipsoid=ellipsoid), cf
    except InputError as exc:
        text, param = str(exc), exc.param
        if param == "reorder" and exact:  # the caller's keyword that sorts is smooth=
            text, param = text.replace("pass reorder=True", "pass smooth=True"), "smooth"
        if track.time_guess is not None:
            # the guess of the time units may be what made the log fail: say it was a guess
            text = f"{text}; {track.time_guess}: pass time_format='s' if they are seconds"
            param = param or "time_format"
        if text == str(exc):
            raise
        raise InputError(text, param=param) from None

"""Flight logs as they come, made flyable: read, conditioned, reported, loaded.

The path of a user's log, one module per step, and the package's own :func:`load_flight` that
takes it from file to flight:

1. :mod:`~fieldmap.nav.logs.read`: a CSV file (any column layout, ADS-B exports), a table
   (DataFrame, Dataset, arrays), a GPX, NMEA 0183 or IGC file, read as it comes
   (:func:`~fieldmap.nav.logs.read.read_track`): one meaning for every source, heights made
   ellipsoidal, units checked; the result is a :class:`~fieldmap.nav.logs.read.RawTrack`
   (the records a reader fills are defined with it).
2. :mod:`~fieldmap.nav.logs.condition`: order, stale values, outliers, breaks, ground, then
   the robust smoothing fit of :mod:`~fieldmap.nav.logs.fit` within the vehicle's limits
   (:func:`~fieldmap.nav.logs.condition.condition`).
3. :mod:`~fieldmap.nav.logs.report`: what was done, and the kinematics of the path that will
   be flown (:class:`~fieldmap.nav.logs.report.ConditionedFlight`, text and figure).
4. :func:`load_flight` (here): all three, and the :class:`~fieldmap.nav.trajectory.FlightTrajectory`
   that a flight study flies (what ``fieldmap navsim --trajectory`` calls; issue 16). It reads a
   log with :func:`~fieldmap.nav.logs.read.read_track` (CSV with any column names, ADS-B
   exports, GPX, NMEA 0183, IGC, DataFrame/Dataset/arrays; MSL or pressure heights made
   ellipsoidal), conditions it with :func:`~fieldmap.nav.logs.condition.condition` (order,
   outliers, gaps, ground, smoothing: the path's acceleration and jerk are the vehicle's, not
   the noise's) and builds the flight, with the options of one
   :class:`~fieldmap.nav.logs.condition.Conditioning`. ``smooth=False`` keeps the exact
   interpolation of the samples (and its refusals) for clean, simulated inputs, after the
   ordering step (a recording apart, days from the rest, is dropped there too); fieldmap's own
   CSV with attitude columns and NetCDF files are flown as recorded (their attitude would be
   lost by the smoothing).

Messages name the keyword arguments of these functions ("pass airborne_only=False to fly the
ground movement", "60 s (max_gap_s)"), and an :class:`~fieldmap.errors.InputError` about one
carries its name as ``param``. Where the conditioning without smoothing advises
``reorder=True``, which :func:`load_flight` sets from ``smooth``, the advice is
``smooth=True``. The command line rewords them with its options from one table
(:mod:`fieldmap.cli`).

Importing a step (``fieldmap.nav.logs.read``) imports this package and with it the options of
:func:`load_flight` (:mod:`~fieldmap.nav.logs.condition`, NumPy only); the reader, the flight
and the report are imported when a log is loaded.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fieldmap.errors import Advice, InputError, Message, Pass
from fieldmap.nav.logs.condition import Conditioning

if TYPE_CHECKING:
    from fieldmap.nav.logs.report import ConditionedFlight
    from fieldmap.nav.trajectory import FlightTrajectory

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
        samples (times that go back are sorted unless ``reorder=False``).
    columns, alt_units, height_ref, time_format, model
        As :func:`fieldmap.nav.logs.read.read_track` (``model``: the truth model whose geoid
        makes MSL heights ellipsoidal).

    Returns
    -------
    (FlightTrajectory, ConditionedFlight or None)
        The trajectory and the conditioning (its ``report`` and figure); None when flown as
        recorded.

    Examples
    --------
    A log of a climb north at 222 m/s, written as a CSV file, flown as an airliner:

    >>> import pathlib, tempfile
    >>> rows = ["time_s,lat_deg,lon_deg,height_m"]
    >>> rows += [f"{s},{47 + s * 2e-3:.6f},8.0,{1000 + 2 * s}" for s in range(300)]
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "climb.csv"
    >>> _ = path.write_text(chr(10).join(rows))
    >>> flight, conditioned = load_flight(path)
    >>> conditioned.report["vehicle"]["class"], round(conditioned.samples.t[-1])
    ('airliner', 299)
    """
    from fieldmap.nav.logs.condition import condition
    from fieldmap.nav.trajectory import FlightTrajectory

    options = Conditioning() if options is None else options
    ellipsoid = options.ellipsoid
    if isinstance(source, (str, Path)) and Path(source).is_dir():
        raise InputError(f"{source}: a directory, not a flight file")
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
    # unconditioned, times going back are refused: smooth= is what sorts
    exact = not options.smooth
    try:
        cf = condition(track, replace(options, reorder=options.reorder and not exact))
        return FlightTrajectory(cf.samples, ellipsoid=ellipsoid), cf
    except InputError as exc:
        message, param = Message(exc.args[0] if exc.args else ""), exc.param
        if param == "reorder" and exact:  # the caller's keyword that sorts is smooth=
            message = message.substitute(Pass("reorder", True), Pass("smooth", True))
            param = "smooth"
        if track.time_guess is not None:
            # the guess of the time units may be what made the log fail: say it was a guess
            message = Message(
                message,
                f"; {track.time_guess}",
                Advice(": ", Pass("time_format", "s"), " if they are seconds"),
            )
            param = param or "time_format"
        if param == exc.param and track.time_guess is None:
            raise
        raise InputError(message, param=param) from None

"""The accepted ranges of fieldmap's inputs, each rule in one place.

Points (:mod:`fieldmap.field`), grids (:mod:`fieldmap.grids`), map products and the command
line all validate through these functions, so that one rule gives one message whichever way it
is reached (the CLI prints the message of the API).

Heights: one range for points and grids, ``MIN_HEIGHT`` ≤ h ≤ ``MAX_HEIGHT``.

* Above: 1e8 m, a quarter of the lunar distance, beyond which an Earth gravity model is not the
  relevant field (and far above which, e.g. h = 1e300 m, r² overflows and the kernels would
  silently return NaN).
* Below: -10 km. The spherical-harmonic series is the exterior potential; below the topography
  it is a harmonic continuation that diverges somewhere under the Brillouin sphere, and the
  closed-form normal field is the continuation of the exterior normal field. A few km below sea
  level (the deepest basins, a navigation system's downward excursions) is as far as a user
  goes; the same limit holds for a map as for a point, since a map is points on a grid.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import SupportsFloat

import numpy as np
from numpy.typing import ArrayLike

from fieldmap.errors import InputError

#: Lowest accepted height above the ellipsoid, points and grids. Units: m.
MIN_HEIGHT = -10.0e3
#: Highest accepted height above the ellipsoid, points and grids. Units: m.
MAX_HEIGHT = 1.0e8
#: Accepted longitudes, half-open as GeographicLib's DMS::DecodeLatLon: [-540, 540). Units: deg.
LON_MIN, LON_MAX = -540.0, 540.0
#: Most Monte Carlo draws of one navigation study (the paper's and a flight study).
MAX_DRAWS = 10_000
#: Orders 2n of the truncated zonal normal fields J2, J4, J6 (Chen et al. 2022 eqs. 7-13).
J2N_ORDERS = (2, 4, 6)


def number_text(x: SupportsFloat | str) -> str:
    """``x`` in short form (``%g``), or in full where the short form would round it onto a limit.

    "height -10000.001 m is below -10000 m", not "height -10000 m is below -10000 m".
    """
    text = f"{float(x):g}"
    return text if float(text) == float(x) else repr(float(x))


_num = number_text  # short, for the messages below

_BELOW = "the models are not meant for points this far below the ellipsoid"
_ABOVE = "outside the range where an Earth gravity model is meant to be used"


def as_float(name: str, v: ArrayLike) -> np.ndarray:
    """``v`` as a float64 array, or InputError naming ``name`` (non-numeric or non-finite)."""
    try:
        arr = np.asarray(v, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name} must be numeric ({exc})") from None
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name} must be finite (got NaN or inf)")
    return arr


def point_errors(latitude: ArrayLike, longitude: ArrayLike, height: ArrayLike) -> list[str | None]:
    """Say what is wrong with each of a batch of finite geodetic points.

    Parameters
    ----------
    latitude, longitude, height : numpy.ndarray
        Finite, of one shape. Units: degrees, degrees, m.

    Returns
    -------
    list of str or None
        Per point (flattened): the reason it is refused, or None when it is accepted.
    """
    lat, lon, h = (np.asarray(v, dtype=np.float64).ravel() for v in (latitude, longitude, height))
    out: list[str | None] = [None] * lat.size
    checks = (
        (h > MAX_HEIGHT, lambda k: f"height {_num(h[k])} m is above {MAX_HEIGHT:g} m, {_ABOVE}"),
        (h < MIN_HEIGHT, lambda k: f"height {_num(h[k])} m is below {MIN_HEIGHT:.0f} m: {_BELOW}"),
        (
            (lon < LON_MIN) | (lon >= LON_MAX),
            lambda k: (
                f"longitude must be within [{LON_MIN:g}, {LON_MAX:g}) degrees, got {_num(lon[k])}"
            ),
        ),
        (
            np.abs(lat) > 90.0,
            lambda k: f"latitude must be within [-90, 90] degrees, got {_num(lat[k])}",
        ),
    )
    for bad, message in checks:  # the last one found is reported: latitude first
        for k in np.flatnonzero(bad):
            out[k] = message(k)
    return out


def check_geodetic(
    latitude: ArrayLike, longitude: ArrayLike, height: ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Validate geodetic points and broadcast them together.

    Parameters
    ----------
    latitude : array_like
        Geodetic latitude in [-90, 90]. Units: degrees.
    longitude : array_like
        Longitude in [-540, 540) (GeographicLib's range). Units: degrees.
    height : array_like
        Height above the ellipsoid in [``MIN_HEIGHT``, ``MAX_HEIGHT``]. Units: m.

    Returns
    -------
    tuple of numpy.ndarray
        ``(latitude, longitude, height)`` float64, broadcast to one shape (read-only views).

    Raises
    ------
    InputError
        Non-numeric, non-finite or out-of-range values, or shapes that do not broadcast.
    """
    lat = as_float("latitude", latitude)
    lon = as_float("longitude", longitude)
    h = as_float("height", height)
    try:
        lat, lon, h = np.broadcast_arrays(lat, lon, h)
    except ValueError:
        raise InputError(
            f"latitude, longitude and height of shapes {lat.shape}, {lon.shape}, {h.shape} do "
            "not broadcast to one shape"
        ) from None
    if lat.size:
        ok = (np.abs(lat) <= 90.0) & (lon >= LON_MIN) & (lon < LON_MAX)
        ok &= (h >= MIN_HEIGHT) & (h <= MAX_HEIGHT)
        if not np.all(ok):
            first = int(np.flatnonzero(~ok.ravel())[0])
            k = np.unravel_index(first, lat.shape)
            msg = point_errors(lat[k], lon[k], h[k])[0]
            raise InputError(msg)
    return lat, lon, h


def _numbers(values: object, what: str, unit: str) -> list[float]:
    """Numbers of a scalar or a sequence (strings of numbers allowed: the CLI passes them)."""
    items = values if isinstance(values, Iterable) and not isinstance(values, str) else [values]
    out = []
    for v in np.asarray(list(items), dtype=object).ravel():
        try:
            out.append(float(v))
        except (TypeError, ValueError):
            raise InputError(f"{what} must be numbers ({unit}): {v!r} is not a number") from None
    if not out:
        raise InputError(f"{what}: no value given")
    return out


def check_heights(
    height: float | str | Iterable[float | str], *, distinct: bool = False
) -> np.ndarray:
    """Validate the heights of a grid.

    Parameters
    ----------
    height : float or sequence of float
        Heights above the ellipsoid in [``MIN_HEIGHT``, ``MAX_HEIGHT``]. Units: m.
    distinct : bool
        Refuse a repeated height (a sweep over the same height twice is a typing slip).

    Returns
    -------
    numpy.ndarray
        1-D float64 heights. Units: m.
    """
    return _check_heights(_numbers(height, "heights", "m"), 1.0, "m", distinct)


def heights_from_km(
    height_km: float | str | Iterable[float | str], *, distinct: bool = True, one: str | None = None
) -> np.ndarray:
    """Validate heights given in km (map products, ``--height-km``) and convert them to m.

    Checked in km, so that 1e306 km is "above 100000 km" rather than an overflow to inf.

    Parameters
    ----------
    height_km : float or sequence of float
        Heights above the ellipsoid in [-10, 1e5]. Units: km.
    distinct : bool
        Refuse a repeated height.
    one : str, optional
        The message of the error raised unless there is exactly one height.

    Returns
    -------
    numpy.ndarray
        1-D float64 heights. Units: m.
    """
    km = _numbers(height_km, "heights", "km")
    if one is not None and len(km) != 1:
        raise InputError(one)
    return 1e3 * _check_heights(km, 1e3, "km", distinct)


def _check_heights(values: list[float], scale: float, unit: str, distinct: bool) -> np.ndarray:
    v = np.asarray(values, dtype=np.float64)
    if not np.all(np.isfinite(v)):
        raise InputError(f"heights must be finite, got {v.tolist()} {unit}")
    lo, hi = MIN_HEIGHT / scale, MAX_HEIGHT / scale
    if np.any(v > hi):
        raise InputError(f"height {_num(v.max())} {unit} is above {hi:g} {unit}, {_ABOVE}")
    if np.any(v < lo):
        raise InputError(f"height {_num(v.min())} {unit} is below {lo:g} {unit}: {_BELOW}")
    if distinct:
        values_u, counts = np.unique(v, return_counts=True)
        if np.any(counts > 1):
            raise InputError(
                f"heights must be distinct: {values_u[counts > 1][0]:g} {unit} is repeated in "
                f"{v.tolist()}"
            )
    return v


def check_orders(orders: int | str | Iterable[int | str]) -> tuple[int, ...]:
    """Validate the J2n orders of a truncation map: distinct values among 2, 4, 6.

    Parameters
    ----------
    orders : int, str or sequence of them
        2, 4, 6, or the names of the normal models ``"j2"``, ``"j4"``, ``"j6"``
        (:data:`fieldmap.field.normal.NORMAL_MODELS`); 2.5 or "x" is an error, not order 2.

    Returns
    -------
    tuple of int
    """
    items = orders if isinstance(orders, Iterable) and not isinstance(orders, str) else [orders]
    vals = []
    for o in items:
        try:
            vals.append(float(o[1:] if isinstance(o, str) and o[:1] in "jJ" else o))
        except (TypeError, ValueError):
            raise InputError(f"orders must be among 2, 4, 6 (or j2, j4, j6), got {o!r}") from None
    if not vals:
        raise InputError("orders: no value given")
    if any(v not in J2N_ORDERS for v in vals) or len(set(vals)) != len(vals):
        got = ", ".join(f"{v:g}" for v in vals)
        raise InputError(f"orders must be distinct values among 2, 4, 6, got [{got}]")
    return tuple(int(v) for v in vals)

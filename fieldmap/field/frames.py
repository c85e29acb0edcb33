"""Earth-fixed frames: geodetic <-> ECEF, geocentric coordinates, local ENU/NED bases (NumPy).

Conventions: geodetic latitude and longitude in degrees in the public API, height in metres
above the ellipsoid; everything else SI. ``C_e_to_enu`` rotates an ECEF vector into the local
east-north-up frame at a geodetic position; NED is (north, east, -up).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fieldmap.field.ellipsoid import WGS84, Ellipsoid


def geodetic_to_ecef(
    lat_deg: ArrayLike, lon_deg: ArrayLike, h: ArrayLike, ellipsoid: Ellipsoid = WGS84
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Geodetic latitude, longitude (degrees) and height (m) to ECEF x, y, z (m).

    Units: degrees, degrees, m -> m.
    """
    lat = np.radians(np.asarray(lat_deg, dtype=np.float64))
    lon = np.radians(np.asarray(lon_deg, dtype=np.float64))
    h = np.asarray(h, dtype=np.float64)
    sl, cl = np.sin(lat), np.cos(lat)
    N = ellipsoid.a / np.sqrt(1.0 - ellipsoid.e2 * sl * sl)
    x = (N + h) * cl * np.cos(lon)
    y = (N + h) * cl * np.sin(lon)
    z = (N * (1.0 - ellipsoid.e2) + h) * sl
    return x, y, z


def ecef_to_geodetic(
    x: ArrayLike, y: ArrayLike, z: ArrayLike, ellipsoid: Ellipsoid = WGS84
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """ECEF x, y, z (m) to geodetic latitude, longitude (degrees) and height (m).

    Bowring's parametric-latitude iteration, run to convergence (3 passes reach 1e-12 m for
    heights from -1e5 to 1e7 m). Units: m -> degrees, degrees, m.
    """
    x, y, z = (np.asarray(v, dtype=np.float64) for v in (x, y, z))
    a, b, e2, ep2 = ellipsoid.a, ellipsoid.b, ellipsoid.e2, ellipsoid.ep2
    p = np.hypot(x, y)
    lon = np.arctan2(y, x)
    beta = np.arctan2(z * a, p * b)
    for _ in range(4):
        lat = np.arctan2(z + ep2 * b * np.sin(beta) ** 3, p - e2 * a * np.cos(beta) ** 3)
        beta = np.arctan2(b * np.sin(lat), a * np.cos(lat))
    sl, cl = np.sin(lat), np.cos(lat)
    N = a / np.sqrt(1.0 - e2 * sl * sl)
    # height formula that stays accurate near the poles as well as the equator
    h = p * cl + z * sl - a * a / N
    return np.degrees(lat), np.degrees(lon), h


def C_e_to_enu(lat_deg: ArrayLike, lon_deg: ArrayLike) -> NDArray[np.float64]:
    """Rotation matrices ECEF -> local ENU at geodetic latitude/longitude (degrees).

    Returns an array of shape ``(..., 3, 3)`` whose rows are the east, north and up unit vectors
    expressed in ECEF.
    """
    lat = np.radians(np.asarray(lat_deg, dtype=np.float64))
    lon = np.radians(np.asarray(lon_deg, dtype=np.float64))
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    zero = np.zeros_like(sl * so)
    east = np.stack([-so + zero, co + zero, zero], axis=-1)
    north = np.stack([-sl * co, -sl * so, cl + zero], axis=-1)
    up = np.stack([cl * co, cl * so, sl + zero], axis=-1)
    return np.stack([east, north, up], axis=-2)


def ecef_to_enu_vector(
    v_ecef: ArrayLike, lat_deg: ArrayLike, lon_deg: ArrayLike
) -> NDArray[np.float64]:
    """Rotate ECEF vectors ``(..., 3)`` into ENU at the given geodetic position."""
    return np.einsum("...ij,...j->...i", C_e_to_enu(lat_deg, lon_deg), np.asarray(v_ecef))


def enu_to_ned(v_enu: ArrayLike) -> NDArray[np.float64]:
    """Reorder ENU components ``(..., 3)`` to NED."""
    v = np.asarray(v_enu)
    return np.stack([v[..., 1], v[..., 0], -v[..., 2]], axis=-1)


def centrifugal_ecef(
    x: ArrayLike, y: ArrayLike, z: ArrayLike, omega: float = WGS84.omega
) -> NDArray[np.float64]:
    """Centrifugal acceleration ω²(x, y, 0) (Groves 2013 eq. 3.7.5 second term). Units: m/s²."""
    x, y, z = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (x, y, z)))
    return np.stack([omega**2 * x, omega**2 * y, np.zeros_like(z)], axis=-1)

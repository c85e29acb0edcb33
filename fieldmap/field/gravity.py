"""Gravitation, gravity and gravity disturbance of a spherical-harmonic model at geodetic points.

Public API (degrees and metres in, NumPy out):

* :func:`gravitation` — gradient of the model potential (Chen et al. 2022 eqs. 1-3);
* :func:`gravity` — gravitation plus the centrifugal acceleration ω²(x, y, 0) (Groves 2013
  eq. 3.7.5), ω of the ellipsoid;
* :func:`disturbance` — δg = g_model − γ at the same point (Chen et al. 2022 §2.3). Both gravity
  vectors carry the same centrifugal term, so δg is the difference of the *gravitations*: the
  spherical-harmonic one with the model's own GM and radius, the exact level-ellipsoid one
  (Heiskanen & Moritz 1967 §2-7…2-9, :mod:`fieldmap.field.normal`) with the ellipsoid's GM and a.
  Nothing is rescaled: the degree-0 difference (GM_model − GM_ell)/r² (≈ 0.0007 mGal for
  EIGEN-6S vs WGS84) and the differing zonal terms are part of δg.

Points are geodetic latitude/longitude (degrees) and height above the ellipsoid (metres). The
local frames are the geodetic ENU/NED frames at the point (``fieldmap.field.frames``).
"""

from __future__ import annotations

import numpy as np

from fieldmap.errors import InputError
from fieldmap.field import frames
from fieldmap.field.ellipsoid import WGS84, Ellipsoid, get_ellipsoid
from fieldmap.field.normal import MAX_HEIGHT as _NORMAL_MAX_HEIGHT
from fieldmap.field.normal import check_geodetic
from fieldmap.field.sh import sh_gravitation
from fieldmap.models.shmodel import SHModel

#: Lowest accepted height above the ellipsoid. The series is the exterior potential; below the
#: topography it is a harmonic continuation that diverges somewhere under the Brillouin sphere,
#: and a few km below sea level is as far as a navigation user goes. Units: m.
MIN_HEIGHT = -10.0e3
#: Highest accepted height, :data:`fieldmap.field.normal.MAX_HEIGHT` (1e8 m): beyond it an
#: Earth model
#: is not the relevant field, and far above it (h = 1e300) the series silently returned NaN.
#: Units: m.
MAX_HEIGHT = _NORMAL_MAX_HEIGHT

#: Units of the disturbance: factor from m/s². 1 mGal = 1e-5 m/s², 1 mg = 9.80665e-3 m/s².
UNITS = {"m/s2": 1.0, "mgal": 1.0e5, "mg": 1.0 / 9.80665e-3}
FRAMES = ("enu", "ned", "ecef")


def _model(model, epoch) -> SHModel:
    if isinstance(model, SHModel):
        return model
    from fieldmap.models.registry import load_model

    return load_model(model, epoch=epoch)


def _points(lat_deg, lon_deg, h_m):
    """Return the validated, broadcast (lat, lon, h).

    See :func:`fieldmap.field.normal.check_geodetic`.
    """
    return check_geodetic(
        lat_deg,
        lon_deg,
        h_m,
        "too deep under the surface for the spherical-harmonic series",
        min_height=MIN_HEIGHT,
    )


def _inputs(lat, lon, h, frame: str, ellipsoid):
    """Return the validated (frame, ellipsoid, lat, lon, h) of the public calls."""
    f = str(frame).lower()
    if f not in FRAMES:
        raise InputError(f"frame must be one of {', '.join(FRAMES)}, got {frame!r}")
    return (f, get_ellipsoid(ellipsoid), *_points(lat, lon, h))


def _to_frame(v_ecef: np.ndarray, lat, lon, frame: str) -> np.ndarray:
    if frame == "ecef":
        return v_ecef
    v_enu = frames.ecef_to_enu_vector(v_ecef, lat, lon)
    return v_enu if frame == "enu" else frames.enu_to_ned(v_enu)


def _gravitation_ecef(model, lat, lon, h, lmax, ellipsoid, device, epoch):
    m = _model(model, epoch)
    x, y, z = frames.geodetic_to_ecef(lat, lon, h, ellipsoid)
    return sh_gravitation(m, x, y, z, lmax=lmax, device=device), (x, y, z)


def gravitation(
    lat,
    lon,
    h,
    model="eigen-6s",
    lmax=None,
    frame="enu",
    device=None,
    epoch=None,
    ellipsoid: Ellipsoid | str = WGS84,
) -> np.ndarray:
    """Gravitational acceleration of a spherical-harmonic model (no centrifugal term).

    Chen et al. (2022) eqs. 1-3, evaluated by the Warp kernel of :mod:`fieldmap.kernels.sh`.

    Parameters
    ----------
    lat, lon : array_like
        Geodetic latitude in [-90, 90] and longitude in [-540, 540) (GeographicLib's range),
        broadcast with ``h``. Units: degrees.
    h : array_like
        Height above ``ellipsoid``, ``MIN_HEIGHT`` ≤ h ≤ ``MAX_HEIGHT`` (1e8 m). Units: m.
    model : SHModel or str
        A model, a bundled model name or the path of an ICGEM file.
    lmax : int, optional
        Truncation degree (default: the model's).
    frame : {"enu", "ned", "ecef"}
        Output frame (local geodetic ENU/NED at the point, or ECEF).
    device : str, optional
        Warp device (default: first CUDA device, else CPU).
    epoch : float or str, optional
        Epoch of time-variable terms when ``model`` is a file or name (an ``SHModel`` already
        holds its evaluated coefficients). Units: decimal year or ``'YYYY-MM-DD'``.
    ellipsoid : Ellipsoid or str
        Ellipsoid of the geodetic coordinates (default WGS84).

    Returns
    -------
    numpy.ndarray
        Shape ``broadcast(lat, lon, h).shape + (3,)``. Units: m/s².
    """
    f, ell, lat, lon, h = _inputs(lat, lon, h, frame, ellipsoid)
    g, _ = _gravitation_ecef(model, lat, lon, h, lmax, ell, device, epoch)
    return _to_frame(g, lat, lon, f)


def gravity(
    lat,
    lon,
    h,
    model="eigen-6s",
    lmax=None,
    frame="enu",
    device=None,
    epoch=None,
    ellipsoid: Ellipsoid | str = WGS84,
) -> np.ndarray:
    """Gravity = model gravitation + centrifugal ω²(x, y, 0), ω of ``ellipsoid``.

    Groves (2013) eq. 3.7.5. Parameters as :func:`gravitation`.

    Returns
    -------
    numpy.ndarray
        Shape ``broadcast(lat, lon, h).shape + (3,)``. Units: m/s².
    """
    f, ell, lat, lon, h = _inputs(lat, lon, h, frame, ellipsoid)
    g, (x, y, z) = _gravitation_ecef(model, lat, lon, h, lmax, ell, device, epoch)
    g = g + frames.centrifugal_ecef(x, y, z, ell.omega)
    return _to_frame(g, lat, lon, f)


def disturbance(
    lat,
    lon,
    h,
    model="eigen-6s",
    lmax=None,
    ellipsoid: Ellipsoid | str = WGS84,
    unit="mGal",
    frame="enu",
    device=None,
    epoch=None,
) -> np.ndarray:
    """Gravity disturbance vector δg = g_model − γ_exact at the same point.

    The centrifugal terms cancel, so this is the model gravitation (model GM and radius) minus
    the exact normal gravitation of the level ellipsoid (its own GM and a; Heiskanen & Moritz
    1967 §2-7…2-9), Chen et al. (2022) eq. 14 with the exact normal field.

    Parameters
    ----------
    lat, lon : array_like
        Geodetic latitude in [-90, 90] and longitude in [-540, 540). Units: degrees.
    h : array_like
        Height above ``ellipsoid``, ``MIN_HEIGHT`` ≤ h ≤ ``MAX_HEIGHT``. Units: m.
    model : SHModel or str
        A model, a bundled model name or the path of an ICGEM file.
    lmax : int, optional
        Truncation degree.
    ellipsoid : Ellipsoid or str
        Level ellipsoid of the normal field and of the coordinates (default WGS84).
    unit : {"mGal", "mg", "m/s2"}
        Output unit (1 mGal = 1e-5 m/s², 1 mg = 9.80665e-3 m/s²).
    frame : {"enu", "ned", "ecef"}
        Output frame.
    device : str, optional
        Warp device.
    epoch : float or str, optional
        Epoch of time-variable terms. Units: decimal year.

    Returns
    -------
    numpy.ndarray
        Shape ``broadcast(lat, lon, h).shape + (3,)``. Units: ``unit``.
    """
    from fieldmap.field.normal import normal_gravity

    ukey = str(unit).lower().replace("²", "2").replace("^", "")
    if ukey not in UNITS:
        raise InputError(f"unit must be one of mGal, mg, m/s2, got {unit!r}")
    f, ell, lat, lon, h = _inputs(lat, lon, h, frame, ellipsoid)
    g, _ = _gravitation_ecef(model, lat, lon, h, lmax, ell, device, epoch)
    gamma = normal_gravity(
        lat, lon, h, ellipsoid=ell, kind="exact", centrifugal=False, frame="ecef", device=device
    )
    return _to_frame((g - gamma) * UNITS[ukey], lat, lon, f)

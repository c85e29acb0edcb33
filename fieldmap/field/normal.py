"""Normal gravity of a level ellipsoid: exact closed form, J2/J4/J6 truncations, Groves' J2 model.

Public API (NumPy in, NumPy out; the work runs in the Warp kernels of ``fieldmap.kernels.normal``):

* :func:`normal_gravity` — normal gravity (or gravitation) vectors at geodetic points, in ECEF,
  ENU or NED.
* :func:`normal_gravitation_ecef` — the same at ECEF points, ECEF result.
* :func:`somigliana` — the closed Somigliana formula for the magnitude on the ellipsoid.
* :func:`normal_params` — the ``NormalParams`` struct the device functions take.

Kinds: ``"exact"`` (Heiskanen & Moritz 1967 §2-7 to 2-9), ``"j2"``, ``"j4"``, ``"j6"`` (Chen et al.
2022 eqs. 7–13, corrected; J2n from the ellipsoid, H&M eq. 2-92, reference radius a) and
``"groves_j2"`` (Groves 2013 eq. 3.7.7 with its printed J2 = 1.082627e-3; centrifugal eqs.
3.7.5/3.7.6).
"""

from __future__ import annotations

import numpy as np
import warp as wp

from fieldmap import _warp
from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import WGS84, Ellipsoid, get_ellipsoid
from fieldmap.field.frames import ecef_to_geodetic
from fieldmap.kernels import normal as _k

#: J2 printed in Groves (2013) below eq. 3.7.7. The WGS84 value derived from
#: (a, f, GM, ω) is 1.08262982e-3 (``WGS84.J2``).
GROVES_J2 = 1.082627e-3

#: Lowest accepted height above the ellipsoid. Below the ellipsoid the formulas give the harmonic
#: continuation of the exterior normal field (exact down to the focal disc), which is what a
#: navigation system uses a few km below sea level; deeper points are rejected. Units: m.
MIN_HEIGHT = -10.0e3
#: Highest accepted height above the ellipsoid: 1e8 m, a quarter of the lunar distance, beyond
#: which an Earth gravity model is no longer the relevant field (and far below the heights where
#: r² overflows and the kernels would silently return NaN, e.g. h = 1e300). Units: m.
MAX_HEIGHT = 1.0e8
#: Accepted longitudes, half-open as GeographicLib's DMS::DecodeLatLon: [-540, 540). Units: deg.
LON_MIN, LON_MAX = -540.0, 540.0

KINDS = {"exact": 0, "j2": 2, "j4": 4, "j6": 6, "groves_j2": 2}
FRAMES = {"ecef": 0, "enu": 1, "ned": 2}


def normal_params(ellipsoid: Ellipsoid | str = WGS84, j2: float | None = None) -> _k.NormalParams:
    """Build the device-side constants of a level ellipsoid.

    Parameters
    ----------
    ellipsoid : Ellipsoid or str
        The level ellipsoid (``WGS84``, ``GRS80`` or a name).
    j2 : float, optional
        Override of J2 (used for Groves' printed value); default: the ellipsoid's J2.

    Returns
    -------
    NormalParams
        Warp struct with a, b, E, e2, gm, omega, q0, j2, j4, j6 (SI units).
    """
    _warp.init()
    ell = get_ellipsoid(ellipsoid)
    p = _k.NormalParams()
    p.a = ell.a
    p.b = ell.b
    p.E = ell.E
    p.e2 = ell.e2
    p.gm = ell.GM
    p.omega = ell.omega
    p.q0 = ell.q0
    p.j2 = ell.J2 if j2 is None else float(j2)
    p.j4 = ell.J4
    p.j6 = ell.J6
    return p


def _check_kind(kind: str) -> str:
    key = str(kind).lower()
    if key not in KINDS:
        raise InputError(f"unknown normal-gravity kind {kind!r} (known: {', '.join(KINDS)})")
    return key


def _check_frame(frame: str) -> str:
    key = str(frame).lower()
    if key not in FRAMES:
        raise InputError(f"unknown frame {frame!r} (known: {', '.join(FRAMES)})")
    return key


def _as_float(name: str, v) -> np.ndarray:
    try:
        arr = np.asarray(v, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name} must be numeric ({exc})") from None
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name} must be finite (got NaN or inf)")
    return arr


def _worst(a: np.ndarray, bad: np.ndarray) -> float:
    """First offending value of ``a`` where ``bad`` (for the error message)."""
    return float(a[bad].ravel()[0])


def check_geodetic(lat_deg, lon_deg, h_m, below: str, min_height: float = MIN_HEIGHT):
    """Validate geodetic points and broadcast them together.

    Parameters
    ----------
    lat_deg, lon_deg : array_like
        Geodetic latitude in [-90, 90] and longitude in [-540, 540) (GeographicLib's range).
        Units: degrees.
    h_m : array_like
        Height above the ellipsoid in [``min_height``, ``MAX_HEIGHT``]. Units: m.
    below : str
        End of the message for a height below ``min_height`` (why the caller refuses it).
    min_height : float
        Lowest accepted height. Units: m.

    Returns
    -------
    tuple of numpy.ndarray
        ``(lat, lon, h)`` float64, broadcast to one shape (read-only views).

    Raises
    ------
    InputError
        Non-numeric, non-finite or out-of-range values, or shapes that do not broadcast.
    """
    lat = _as_float("latitude", lat_deg)
    lon = _as_float("longitude", lon_deg)
    h = _as_float("height", h_m)
    try:
        lat, lon, h = np.broadcast_arrays(lat, lon, h)
    except ValueError:
        raise InputError(
            f"latitude, longitude and height of shapes {lat.shape}, {lon.shape}, {h.shape} do "
            "not broadcast to one shape"
        ) from None
    bad = np.abs(lat) > 90.0
    if np.any(bad):
        raise InputError(f"latitude must be within [-90, 90] degrees, got {_worst(lat, bad):g}")
    bad = (lon < LON_MIN) | (lon >= LON_MAX)
    if np.any(bad):
        raise InputError(
            f"longitude must be within [{LON_MIN:g}, {LON_MAX:g}) degrees, got {_worst(lon, bad):g}"
        )
    bad = h < min_height
    if np.any(bad):
        raise InputError(f"height {_worst(h, bad):g} m is below {min_height:.0f} m: {below}")
    bad = h > MAX_HEIGHT
    if np.any(bad):
        raise InputError(
            f"height {_worst(h, bad):g} m is above {MAX_HEIGHT:g} m, outside the range where an "
            "Earth gravity model is meant to be used"
        )
    return lat, lon, h


def _params_for(ell: Ellipsoid, kind: str, groves_j2: float | None) -> _k.NormalParams:
    if kind == "groves_j2":
        return normal_params(ell, j2=ell.J2 if groves_j2 is None else groves_j2)
    return normal_params(ell)


def normal_gravity(
    lat_deg,
    lon_deg,
    h_m,
    ellipsoid: Ellipsoid | str = WGS84,
    kind: str = "exact",
    centrifugal: bool = True,
    frame: str = "enu",
    device: str | None = None,
    groves_j2: float | None = GROVES_J2,
) -> np.ndarray:
    """Compute the normal gravity vector at geodetic points.

    Parameters
    ----------
    lat_deg, lon_deg : array_like
        Geodetic latitude in [-90, 90] and longitude in [-540, 540) (broadcast together with
        ``h_m``). Units: degrees.
    h_m : array_like
        Height above the ellipsoid, ``MIN_HEIGHT`` ≤ h ≤ ``MAX_HEIGHT``. Units: m.
    ellipsoid : Ellipsoid or str
        Level ellipsoid, default WGS84.
    kind : {"exact", "j2", "j4", "j6", "groves_j2"}
        Exact closed form (Heiskanen & Moritz 1967 §2-7…2-9) or the truncated zonal models of
        Chen et al. (2022) eqs. (7)–(13) (corrected), or Groves (2013) eq. 3.7.7.
    centrifugal : bool
        Add the centrifugal acceleration ω²(x, y, 0) (Groves eq. 3.7.5/3.7.6): gravity; else
        gravitation only.
    frame : {"ecef", "enu", "ned"}
        Output frame; ENU/NED are the local geodetic frames at the point.
    device : str, optional
        Warp device (default: first CUDA device, else CPU).
    groves_j2 : float or None
        J2 of ``kind="groves_j2"``: Groves' printed 1.082627e-3 by default, ``None`` for the
        ellipsoid's own J2 (then identical to ``kind="j2"``).

    Returns
    -------
    numpy.ndarray
        Shape ``broadcast(lat, lon, h).shape + (3,)``. Units: m/s².
    """
    key = _check_kind(kind)
    fkey = _check_frame(frame)
    ell = get_ellipsoid(ellipsoid)
    lat, lon, h = check_geodetic(
        lat_deg,
        lon_deg,
        h_m,
        "deep inside the level ellipsoid, outside the domain of the normal-gravity model",
    )
    shape = lat.shape
    n = lat.size
    if n == 0:
        return np.zeros(shape + (3,))
    dev = _warp.resolve_device(device)
    _warp.init()
    arrs = [
        wp.array(np.ascontiguousarray(np.radians(v).ravel()), dtype=wp.float64, device=dev)
        for v in (lat, lon)
    ]
    arrs.append(wp.array(np.ascontiguousarray(h.ravel()), dtype=wp.float64, device=dev))
    out = wp.empty(n, dtype=wp.vec3d, device=dev)
    params = _params_for(ell, key, groves_j2)
    _warp.launch_chunked(
        _k.normal_points_kernel,
        n,
        [*arrs, params, KINDS[key], int(bool(centrifugal)), FRAMES[fkey], out],
        dev,
    )
    return out.numpy().reshape(shape + (3,))


def normal_gravitation_ecef(
    x,
    y,
    z,
    ellipsoid: Ellipsoid | str = WGS84,
    kind: str = "exact",
    device: str | None = None,
    centrifugal: bool = False,
    groves_j2: float | None = GROVES_J2,
) -> np.ndarray:
    """Compute normal gravitation (default) or gravity at ECEF points, ECEF components.

    Parameters
    ----------
    x, y, z : array_like
        ECEF coordinates (broadcast together), at most ``MAX_HEIGHT`` above and
        ``-MIN_HEIGHT`` below the ellipsoid. Units: m.
    ellipsoid, kind, device, groves_j2
        As in :func:`normal_gravity`.
    centrifugal : bool
        Add ω²(x, y, 0) (default False: gravitation only).

    Returns
    -------
    numpy.ndarray
        Shape ``broadcast(x, y, z).shape + (3,)``. Units: m/s².
    """
    key = _check_kind(kind)
    ell = get_ellipsoid(ellipsoid)
    xyz = [_as_float(nm, v) for nm, v in zip("xyz", (x, y, z))]
    try:
        x, y, z = np.broadcast_arrays(*xyz)
    except ValueError:
        raise InputError(
            f"x, y and z of shapes {', '.join(str(v.shape) for v in xyz)} do not broadcast to "
            "one shape"
        ) from None
    shape = x.shape
    if x.size == 0:
        return np.zeros(shape + (3,))
    # bound the components first: squares of ~1e200 m overflow to inf in the geodetic conversion
    far = ell.a + MAX_HEIGHT
    if np.any((np.abs(x) > far) | (np.abs(y) > far) | (np.abs(z) > far)):
        raise InputError(
            f"ECEF point more than {MAX_HEIGHT:g} m above the ellipsoid (a coordinate exceeds "
            f"{far:g} m): outside the range where an Earth gravity model is meant to be used"
        )
    _, _, h = ecef_to_geodetic(x, y, z, ell)
    if np.any(~(h >= MIN_HEIGHT)):
        raise InputError(
            f"ECEF point more than {-MIN_HEIGHT:.0f} m below the ellipsoid: outside the domain "
            "of the normal-gravity model"
        )
    if np.any(h > MAX_HEIGHT):
        raise InputError(
            f"ECEF point more than {MAX_HEIGHT:g} m above the ellipsoid: outside the range where "
            "an Earth gravity model is meant to be used"
        )
    dev = _warp.resolve_device(device)
    pts = np.ascontiguousarray(np.stack([x.ravel(), y.ravel(), z.ravel()], axis=-1))
    p_wp = wp.array(pts, dtype=wp.vec3d, device=dev)
    out = wp.empty(x.size, dtype=wp.vec3d, device=dev)
    params = _params_for(ell, key, groves_j2)
    _warp.launch_chunked(
        _k.normal_ecef_kernel, x.size, [p_wp, params, KINDS[key], int(bool(centrifugal)), out], dev
    )
    return out.numpy().reshape(shape + (3,))


def somigliana(lat_deg, ellipsoid: Ellipsoid | str = WGS84) -> np.ndarray:
    r"""Magnitude of normal gravity on the ellipsoid (h = 0), Somigliana's closed formula.

    .. math::
        \gamma = \frac{a\gamma_a\cos^2\varphi + b\gamma_b\sin^2\varphi}
                      {\sqrt{a^2\cos^2\varphi + b^2\sin^2\varphi}}

    Heiskanen & Moritz (1967) eq. 2-78, with γ_a, γ_b from eq. 2-141.

    Parameters
    ----------
    lat_deg : array_like
        Geodetic latitude. Units: degrees.
    ellipsoid : Ellipsoid or str
        Level ellipsoid.

    Returns
    -------
    numpy.ndarray
        Normal gravity magnitude. Units: m/s².
    """
    ell = get_ellipsoid(ellipsoid)
    lat = _as_float("latitude", lat_deg)
    if np.any(np.abs(lat) > 90.0):
        raise InputError("latitude must be within [-90, 90] degrees")
    phi = np.radians(lat)
    c2, s2 = np.cos(phi) ** 2, np.sin(phi) ** 2
    a, b = ell.a, ell.b
    return (a * ell.gamma_a * c2 + b * ell.gamma_b * s2) / np.sqrt(a * a * c2 + b * b * s2)

"""Normal gravity of a level ellipsoid: exact closed form, J2/J4/J6 truncations, Groves' J2 model.

Public API (NumPy in, NumPy out; the work runs in the Warp kernels of ``fieldmap.kernels.normal``):

* :func:`normal_gravity` — normal gravity (or gravitation) vectors at geodetic points, in ECEF,
  ENU or NED.
* :func:`normal_gravitation_ecef` — the same at ECEF points, ECEF result.
* :func:`somigliana` — the closed Somigliana formula for the magnitude on the ellipsoid.
* :func:`normal_params` — the ``NormalParams`` struct the device functions take.

Models (``normal=``, the same names as the CLI's ``--normal``): ``"exact"`` (Heiskanen & Moritz
1967 §2-7 to 2-9), ``"j2"``, ``"j4"``, ``"j6"`` (Chen et al. 2022 eqs. 7–13, corrected; J2n from
the ellipsoid, H&M eq. 2-92, reference radius a) and ``"groves-j2"`` (Groves 2013 eq. 3.7.7
with its printed J2 = 1.082627e-3; centrifugal eqs. 3.7.5/3.7.6).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import warp as wp
from numpy.typing import ArrayLike

from fieldmap import _warp, limits
from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import WGS84, Ellipsoid, get_ellipsoid
from fieldmap.field.frames import ecef_to_geodetic
from fieldmap.kernels import normal as _k

#: J2 printed in Groves (2013) below eq. 3.7.7. The WGS84 value derived from
#: (a, f, GM, ω) is 1.08262982e-3 (``WGS84.J2``).
GROVES_J2 = 1.082627e-3

#: Accepted heights and longitudes (one rule for points and grids, :mod:`fieldmap.limits`).
MIN_HEIGHT = limits.MIN_HEIGHT
MAX_HEIGHT = limits.MAX_HEIGHT
LON_MIN, LON_MAX = limits.LON_MIN, limits.LON_MAX

#: The normal-gravity models, one vocabulary for the API and the CLI (``normal=``,
#: ``--normal``): name -> J2n order of the kernel (0: the exact closed form).
NORMAL_MODELS = {"exact": 0, "j2": 2, "j4": 4, "j6": 6, "groves-j2": 2}
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


def normal_model(normal: str) -> str:
    """Return the canonical name of a normal-gravity model.

    Parameters
    ----------
    normal : str
        ``"exact"``, ``"j2"``, ``"j4"``, ``"j6"`` or ``"groves-j2"``, in any case, ``_`` for
        ``-`` allowed (the navigation models of :mod:`fieldmap.nav` use the same names).

    Returns
    -------
    str
        A key of :data:`NORMAL_MODELS`.

    Raises
    ------
    InputError
        An unknown model.
    """
    key = str(normal).strip().lower().replace("_", "-")
    if key not in NORMAL_MODELS:
        raise InputError(
            f"unknown normal-gravity model {normal!r} (known: {', '.join(NORMAL_MODELS)})"
        )
    return key


def _check_frame(frame: str) -> str:
    key = str(frame).lower()
    if key not in FRAMES:
        raise InputError(f"unknown frame {frame!r} (known: {', '.join(FRAMES)})")
    return key


def _as_float(name: str, v: ArrayLike) -> np.ndarray:
    return limits.as_float(name, v)


def _params_for(ell: Ellipsoid, kind: str, groves_j2: float | None) -> _k.NormalParams:
    if kind == "groves-j2":
        return normal_params(ell, j2=ell.J2 if groves_j2 is None else groves_j2)
    return normal_params(ell)


def normal_gravity(
    latitude: ArrayLike,
    longitude: ArrayLike,
    height: ArrayLike,
    *,
    normal: str = "exact",
    ellipsoid: Ellipsoid | str = WGS84,
    centrifugal: bool = True,
    frame: str = "enu",
    device: str | None = None,
) -> np.ndarray:
    """Compute the normal gravity vector at geodetic points.

    Parameters
    ----------
    latitude : array_like
        Geodetic latitude in [-90, 90], broadcast with ``longitude`` and ``height``.
        Units: degrees.
    longitude : array_like
        Longitude in [-540, 540) (GeographicLib's range). Units: degrees.
    height : array_like
        Height above the ellipsoid, ``MIN_HEIGHT`` ≤ h ≤ ``MAX_HEIGHT``. Units: m.
    normal : {"exact", "j2", "j4", "j6", "groves-j2"}
        Exact closed form (Heiskanen & Moritz 1967 §2-7…2-9), the truncated zonal models of
        Chen et al. (2022) eqs. (7)–(13) (corrected), or Groves (2013) eq. 3.7.7 with its
        printed J2 = 1.082627e-3 (:data:`GROVES_J2`; with the ellipsoid's own J2 it is
        ``"j2"``) (:func:`normal_model`).
    ellipsoid : Ellipsoid or str
        Level ellipsoid, default WGS84.
    centrifugal : bool
        Add the centrifugal acceleration ω²(x, y, 0) (Groves eq. 3.7.5/3.7.6): gravity; else
        gravitation only.
    frame : {"ecef", "enu", "ned"}
        Output frame; ENU/NED are the local geodetic frames at the point.
    device : str, optional
        Warp device (default: first CUDA device, else CPU).

    Returns
    -------
    numpy.ndarray
        Shape ``broadcast(latitude, longitude, height).shape + (3,)``. Units: m/s².

    Examples
    --------
    The up component of normal gravity (WGS84, exact level ellipsoid) at the equator and the
    pole, on the ellipsoid: Somigliana's γ_e and γ_p.

    >>> import numpy as np
    >>> from fieldmap.field.normal import normal_gravity
    >>> g = normal_gravity([0.0, 90.0], 0.0, 0.0)
    >>> np.round(g[:, 2], 6)  # m/s²
    array([-9.780325, -9.832185])
    """
    key = normal_model(normal)
    fkey = _check_frame(frame)
    ell = get_ellipsoid(ellipsoid)
    lat, lon, h = limits.check_geodetic(latitude, longitude, height)
    shape = lat.shape
    n = lat.size
    if n == 0:
        return np.zeros(shape + (3,))
    dev = _warp.resolve_device(device)
    _warp.init()
    arrs: Any = [
        wp.array(np.ascontiguousarray(np.radians(v).ravel()), dtype=wp.float64, device=dev)
        for v in (lat, lon)
    ]
    arrs.append(wp.array(np.ascontiguousarray(h.ravel()), dtype=wp.float64, device=dev))
    out = wp.empty(n, dtype=wp.vec3d, device=dev)
    params = _params_for(ell, key, GROVES_J2)
    _warp.launch_chunked(
        _k.normal_points_kernel,
        n,
        [*arrs, params, NORMAL_MODELS[key], int(bool(centrifugal)), FRAMES[fkey], out],
        dev,
    )
    return out.numpy().reshape(shape + (3,))


def normal_gravitation_ecef(
    x: ArrayLike,
    y: ArrayLike,
    z: ArrayLike,
    *,
    normal: str = "exact",
    ellipsoid: Ellipsoid | str = WGS84,
    centrifugal: bool = False,
    device: str | None = None,
    groves_j2: float | None = GROVES_J2,
) -> np.ndarray:
    """Compute normal gravitation (default) or gravity at ECEF points, ECEF components.

    Parameters
    ----------
    x, y, z : array_like
        ECEF coordinates (broadcast together), at most ``MAX_HEIGHT`` above and
        ``-MIN_HEIGHT`` below the ellipsoid. Units: m.
    normal, ellipsoid, device
        As in :func:`normal_gravity`.
    groves_j2 : float or None
        J2 of ``normal="groves-j2"``: Groves' printed value (:data:`GROVES_J2`) by default,
        ``None`` for the ellipsoid's own J2.
    centrifugal : bool
        Add ω²(x, y, 0) (default False: gravitation only).

    Returns
    -------
    numpy.ndarray
        Shape ``broadcast(x, y, z).shape + (3,)``. Units: m/s².
    """
    key = normal_model(normal)
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
    # Geodetic height h is the signed distance to the ellipsoid. With d = |r| - R, R the
    # ellipsoid's radius in the direction of r: inside, h >= -(R - |r|) = d (the radial surface
    # point is at that distance); outside, 0 <= h <= d. So MIN_HEIGHT <= d <= MAX_HEIGHT
    # guarantees MIN_HEIGHT <= h <= MAX_HEIGHT, and only the other points (none, in practice)
    # need the geodetic conversion, which costs more than the normal gravity itself (IMU
    # synthesis calls this for every quadrature point). d = |r| (1 - 1/sqrt(q)), with
    # q = (x² + y²)/a² + z²/b² (R = |r|/sqrt(q)).
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.sqrt(x * x + y * y + z * z)
        d = r * (1.0 - 1.0 / np.sqrt((x * x + y * y) / ell.a**2 + z * z / ell.b**2))
    unsure = ~((d >= MIN_HEIGHT) & (d <= MAX_HEIGHT))
    if not np.any(unsure):
        h = np.zeros(0)
    else:
        _, _, h = ecef_to_geodetic(x[unsure], y[unsure], z[unsure], ell)
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
    p_wp: Any = wp.array(pts, dtype=wp.vec3d, device=dev)
    out = wp.empty(x.size, dtype=wp.vec3d, device=dev)
    params = _params_for(ell, key, groves_j2)
    _warp.launch_chunked(
        _k.normal_ecef_kernel,
        x.size,
        [p_wp, params, NORMAL_MODELS[key], int(bool(centrifugal)), out],
        dev,
    )
    return out.numpy().reshape(shape + (3,))


def somigliana(latitude: ArrayLike, *, ellipsoid: Ellipsoid | str = WGS84) -> np.ndarray:
    r"""Magnitude of normal gravity on the ellipsoid (h = 0), Somigliana's closed formula.

    .. math::
        \gamma = \frac{a\gamma_a\cos^2\varphi + b\gamma_b\sin^2\varphi}
                      {\sqrt{a^2\cos^2\varphi + b^2\sin^2\varphi}}

    Heiskanen & Moritz (1967) eq. 2-78, with γ_a, γ_b from eq. 2-141.

    Parameters
    ----------
    latitude : array_like
        Geodetic latitude. Units: degrees.
    ellipsoid : Ellipsoid or str
        Level ellipsoid.

    Returns
    -------
    numpy.ndarray
        Normal gravity magnitude. Units: m/s².
    """
    ell = get_ellipsoid(ellipsoid)
    lat = _as_float("latitude", latitude)
    if np.any(np.abs(lat) > 90.0):
        raise InputError("latitude must be within [-90, 90] degrees")
    phi = np.radians(lat)
    c2, s2 = np.cos(phi) ** 2, np.sin(phi) ** 2
    a, b = ell.a, ell.b
    return (a * ell.gamma_a * c2 + b * ell.gamma_b * s2) / np.sqrt(a * a * c2 + b * b * s2)

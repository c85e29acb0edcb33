"""Host side of the spherical-harmonic Warp kernels: model tables, caching, launches.

:func:`kernel_model` turns an :class:`~fieldmap.models.shmodel.SHModel` into the device struct
:class:`fieldmap.kernels.sh.SHKernelModel` (coefficients and recursion tables transposed to
``[m, n]``, see Holmes & Featherstone 2002 eqs. 11-16); :func:`sh_gravitation` and
:func:`sh_potential` evaluate the series at ECEF points with every CPU core or on CUDA.
"""

from __future__ import annotations

import threading
import weakref
from typing import Any

import numpy as np
import warp as wp

from fieldmap import _warp
from fieldmap.errors import InputError
from fieldmap.models.shmodel import SHModel

_cache_lock = threading.Lock()
_cache: dict = {}  # (id(model), lmax, device) -> (weakref(model), SHKernelModel)
_CACHE_MAX = 32  # structs only: their arrays are shared through the two caches below
_tables: dict = {}  # device -> (lmax, (anm, bnm, fnm, sect)) for the largest lmax seen
_coefs: dict = {}  # (id(model), device) -> (weakref(model), lmax, (cnm, snm))
_COEF_MAX = 3  # (model, device) pairs kept; a degree-2190 model holds 77 MB


def recursion_tables(lmax: int) -> dict[str, np.ndarray]:
    """Recursion tables of the scaled column recursion, indexed ``[m, n]``.

    Holmes & Featherstone (2002) eqs. 11-13 and 15 (fully normalised):
    ``a_nm = sqrt((2n−1)(2n+1)/((n−m)(n+m)))``,
    ``b_nm = sqrt((2n+1)(n+m−1)(n−m−1)/((n−m)(n+m)(2n−3)))``,
    ``f_nm = sqrt((n²−m²)(2n+1)/(2n−1))`` for n > m (0 elsewhere); row m = 0 of ``f`` holds
    ``sqrt(n(n+1)/2)`` (factor of dP̄n0/dφ = sqrt(n(n+1)/2) P̄n1); ``sect[m]`` = P̄mm/u^m
    (s_0 = 1, s_1 = √3, s_m = s_{m−1} sqrt((2m+1)/(2m))).

    Parameters
    ----------
    lmax : int
        Maximum degree.

    Returns
    -------
    dict
        ``anm``, ``bnm``, ``fnm`` of shape ``(lmax+1, lmax+1)`` and ``sect`` of length lmax+1.
    """
    L = int(lmax)
    m = np.arange(L + 1, dtype=np.float64)[:, None]
    n = np.arange(L + 1, dtype=np.float64)[None, :]
    lower = n > m
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.sqrt((2 * n - 1) * (2 * n + 1) / ((n - m) * (n + m)))
        b = np.sqrt((2 * n + 1) * (n + m - 1) * (n - m - 1) / ((n - m) * (n + m) * (2 * n - 3)))
        f = np.sqrt((n * n - m * m) * (2 * n + 1) / (2 * n - 1))
    a = np.where(lower, a, 0.0)
    b = np.where(lower & (n - m >= 2), b, 0.0)
    f = np.where(lower, f, 0.0)
    f[0, :] = np.sqrt(n[0] * (n[0] + 1) / 2.0)
    sect = np.ones(L + 1)
    if L >= 1:
        k = np.arange(2, L + 1, dtype=np.float64)
        sect[1] = np.sqrt(3.0)
        sect[2:] = np.sqrt(3.0) * np.cumprod(np.sqrt((2 * k + 1) / (2 * k)))
    return {"anm": a, "bnm": b, "fnm": f, "sect": sect}


#: Highest degree the 1e-280-scaled recursion keeps in range at every latitude (Holmes &
#: Featherstone 2002 give 2700; near the poles P̄nm/u^m reaches ~e^(n/2), and at degree 2800
#: the scaled values overflow above 88.8° — checked with a Kaula model on a latitude sweep).
MAX_DEGREE = 2700


def _check_lmax(model: SHModel, lmax) -> int:
    if lmax is None:
        lmax_i = model.lmax
    else:
        try:
            lmax_i = int(lmax)
        except (TypeError, ValueError):
            raise InputError(f"lmax must be an integer, got {lmax!r}") from None
        if lmax_i != lmax or lmax_i < 0 or lmax_i > model.lmax:
            raise InputError(f"lmax {lmax} is outside the model {model.name} (0..{model.lmax})")
    if lmax_i > MAX_DEGREE:
        raise InputError(
            f"degree {lmax_i} is above {MAX_DEGREE}, the limit of the scaled Legendre recursion; "
            f"truncate the model with lmax <= {MAX_DEGREE}"
        )
    return lmax_i


def kernel_model(model: SHModel, device: str | None = None, lmax: int | None = None):
    """Build (or fetch from the cache) the device struct of ``model`` truncated to ``lmax``.

    Parameters
    ----------
    model : SHModel
        Fully normalised coefficients.
    device : str, optional
        Warp device name (default: :func:`fieldmap._warp.resolve_device`).
    lmax : int, optional
        Truncation degree (default: the model's).

    Returns
    -------
    fieldmap.kernels.sh.SHKernelModel
        Cached by (model identity, lmax, device); entries die with the model object. The
        recursion tables are shared by all models on a device, and a truncation reuses the
        coefficient arrays of a higher one.
    """
    _warp.init()
    from fieldmap.kernels import sh as ksh

    device = _warp.resolve_device(device)
    L = _check_lmax(model, lmax)
    key = (id(model), L, device)
    with _cache_lock:
        hit = _cache.get(key)
        if hit is not None and hit[0]() is model:
            return hit[1]
    # The kernel reads rows m <= lmax and columns n <= lmax only, so larger tables and the
    # coefficient arrays of a higher truncation of the same model serve any smaller lmax.
    tab = _device_tables(L, device)
    cnm, snm = _device_coefficients(model, L, device)
    km = ksh.SHKernelModel()
    km.cnm, km.snm = cnm, snm
    km.anm, km.bnm, km.fnm, km.sect = tab
    km.lmax = L
    km.gm = wp.float64(model.gm)
    km.radius = wp.float64(model.radius)
    with _cache_lock:
        if len(_cache) >= _CACHE_MAX:
            _cache.pop(next(iter(_cache)))
        _cache[key] = (weakref.ref(model), km)
    return km


def _device_tables(L: int, device: str):
    with _cache_lock:
        hit = _tables.get(device)
        if hit is not None and hit[0] >= L:
            return hit[1]
    from fieldmap.models.cache import cached_tables

    # high degrees: verified tables from the on-disk cache (0.4 s to compute at degree 2190);
    # on the CPU the Warp arrays alias the NumPy ones (Warp keeps a reference), no copy
    tab = cached_tables(L, recursion_tables)
    arrs: Any = tuple(
        wp.array(tab[k], dtype=wp.float64, device=device, copy=device != "cpu")
        for k in ("anm", "bnm", "fnm", "sect")
    )
    with _cache_lock:
        _tables[device] = (L, arrs)
    return arrs


def _device_coefficients(model: SHModel, L: int, device: str):
    key = (id(model), device)
    with _cache_lock:
        hit = _coefs.get(key)
        if hit is not None and hit[0]() is model and hit[1] >= L:
            return hit[2]
    # transposed to [m, n]: one column recursion then reads contiguous memory
    arrs: Any = tuple(
        wp.array(
            np.ascontiguousarray(A[: L + 1, : L + 1].T),
            dtype=wp.float64,
            device=device,
            copy=device != "cpu",  # the transposed copy is ours: alias it on the CPU
        )
        for A in (model.C, model.S)
    )
    with _cache_lock:
        _coefs.pop(key, None)
        while len(_coefs) >= _COEF_MAX:
            _coefs.pop(next(iter(_coefs)))
        _coefs[key] = (weakref.ref(model), L, arrs)
    return arrs


def _positions(x, y, z) -> tuple[np.ndarray, tuple]:
    x, y, z = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (x, y, z)))
    shape = x.shape
    pos = np.ascontiguousarray(np.stack([x.ravel(), y.ravel(), z.ravel()], axis=-1))
    if not np.all(np.isfinite(pos)):
        raise InputError("positions must be finite")
    if np.any(np.einsum("ij,ij->i", pos, pos) == 0.0):
        raise InputError("position at the Earth's centre: the series is undefined there")
    return pos, shape


def _launch_points(
    kernel: str, model: SHModel, lmax, device, columns: list, consts=(), out_dtype=wp.vec3d
) -> np.ndarray:
    """Run the point kernel ``kernel`` of :mod:`fieldmap.kernels.sh`, one thread per point.

    ``columns`` are ``(array, warp dtype)`` pairs of per-point inputs, ``consts`` the scalar
    inputs after them; returns the kernel's output array, one row per point.
    """
    from fieldmap.kernels import sh as ksh

    device = _warp.resolve_device(device)
    km = kernel_model(model, device, lmax)
    n = columns[0][0].shape[0]
    ins: Any = [wp.array(np.ascontiguousarray(a), dtype=t, device=device) for a, t in columns]
    out = wp.zeros(n, dtype=out_dtype, device=device)
    _warp.launch_chunked(getattr(ksh, kernel), n, [km, *ins, *consts, out], device)
    return out.numpy()


def sh_gravitation(model: SHModel, x, y, z, lmax: int | None = None, device: str | None = None):
    """Gravitation (gradient of the potential, no centrifugal term) at ECEF points.

    Chen et al. (2022) eqs. 2-3, evaluated with the Warp kernel ``sh_points_ecef_kernel``.

    Parameters
    ----------
    model : SHModel
        Gravity model.
    x, y, z : array_like
        ECEF coordinates (broadcast together). Units: m.
    lmax : int, optional
        Truncation degree.
    device : str, optional
        Warp device.

    Returns
    -------
    numpy.ndarray
        Shape ``(..., 3)``, ECEF components. Units: m/s².
    """
    pos, shape = _positions(x, y, z)
    g = _launch_points("sh_points_ecef_kernel", model, lmax, device, [(pos, wp.vec3d)])
    return g.reshape(*shape, 3)


def sh_potential(model: SHModel, x, y, z, lmax: int | None = None, device: str | None = None):
    """Gravitational potential at ECEF points (Chen et al. 2022 eq. 1).

    Parameters
    ----------
    model : SHModel
        Gravity model.
    x, y, z : array_like
        ECEF coordinates. Units: m.
    lmax : int, optional
        Truncation degree.
    device : str, optional
        Warp device.

    Returns
    -------
    numpy.ndarray
        Potential, the broadcast shape of the inputs. Units: m²/s².
    """
    pos, shape = _positions(x, y, z)
    v = _launch_points(
        "sh_potential_kernel", model, lmax, device, [(pos, wp.vec3d)], out_dtype=wp.float64
    )
    return v.reshape(shape)


def sh_gravitation_geodetic(
    model: SHModel,
    lat_deg,
    lon_deg,
    h_m,
    ellipsoid=None,
    lmax: int | None = None,
    device: str | None = None,
):
    """Gravitation at geodetic points, ECEF components (kernel ``sh_points_geodetic_kernel``).

    The geodetic → ECEF conversion runs inside the kernel (``kernels.frames.geodetic_to_ecef``).

    Parameters
    ----------
    model : SHModel
        Gravity model.
    lat_deg, lon_deg : array_like
        Geodetic latitude and longitude (broadcast with ``h_m``). Units: degrees.
    h_m : array_like
        Height above ``ellipsoid``. Units: m.
    ellipsoid : Ellipsoid, optional
        Default WGS84.
    lmax : int, optional
        Truncation degree.
    device : str, optional
        Warp device.

    Returns
    -------
    numpy.ndarray
        Shape ``broadcast(lat, lon, h).shape + (3,)``. Units: m/s².
    """
    from fieldmap.field.ellipsoid import WGS84

    ell = WGS84 if ellipsoid is None else ellipsoid
    lat, lon, h = np.broadcast_arrays(
        *(np.asarray(v, dtype=np.float64) for v in (lat_deg, lon_deg, h_m))
    )
    if not (np.all(np.isfinite(lat)) and np.all(np.isfinite(lon)) and np.all(np.isfinite(h))):
        raise InputError("latitude, longitude and height must be finite")
    if np.any(np.abs(lat) > 90.0):
        raise InputError("latitude must be within [-90, 90] degrees")
    cols = [(v.ravel(), wp.float64) for v in (np.radians(lat), np.radians(lon), h)]
    g = _launch_points(
        "sh_points_geodetic_kernel",
        model,
        lmax,
        device,
        cols,
        (wp.float64(ell.a), wp.float64(ell.e2)),
    )
    return g.reshape(*lat.shape, 3)

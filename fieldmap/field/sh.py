"""Host side of the spherical-harmonic Warp kernels: model tables, caching, launches.

:func:`kernel_model` turns an :class:`~fieldmap.models.shmodel.SHModel` into the device struct
:class:`fieldmap.kernels.sh.SHKernelModel` (coefficients and recursion tables transposed to
``[m, n]``, see Holmes & Featherstone 2002 eqs. 11-16); :func:`sh_gravitation` and
:func:`sh_potential` evaluate the series at ECEF points with every CPU core or on CUDA.

Degree limits: the ``[m, n]`` tables and the 1e-280 scaling serve degrees up to
:data:`MAX_DEGREE_GRID` (2700, grids and the default of :func:`kernel_model`). Points go to
:data:`MAX_DEGREE_POINTS` (10,800): above 2700 their struct is the extended-range one
(``xrange``: X-numbers, coefficients packed by order, recursion factors computed in the kernel
from square-root tables; see :mod:`fieldmap.kernels.sh`). Memory at degree 10,800: the packed
coefficients, 0.93 GB, besides the model's own C and S (1.87 GB).
"""

from __future__ import annotations

import threading
import weakref
from typing import TYPE_CHECKING, Any

import numpy as np
import warp as wp
from numpy.typing import ArrayLike

from fieldmap import _warp
from fieldmap.errors import InputError
from fieldmap.models.shmodel import SHModel

if TYPE_CHECKING:
    from fieldmap.field.ellipsoid import Ellipsoid

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
#: The grid kernels use that recursion, so grids refuse higher degrees.
MAX_DEGREE_GRID = 2700
#: Former name of :data:`MAX_DEGREE_GRID`.
MAX_DEGREE = MAX_DEGREE_GRID
#: Highest degree of point evaluation (the extended-range path of :mod:`fieldmap.kernels.sh`;
#: the readers' limit, EGM2008 / XGM2019e reach 2190 / 5540 and the NGA format 10,800).
MAX_DEGREE_POINTS = 10800


def _check_lmax(model: SHModel, lmax: int | None, limit: int = MAX_DEGREE_GRID) -> int:
    if lmax is None:
        lmax_i = model.lmax
    else:
        try:
            lmax_i = int(lmax)
        except (TypeError, ValueError):
            raise InputError(f"lmax must be an integer, got {lmax!r}") from None
        if lmax_i != lmax or lmax_i < 0 or lmax_i > model.lmax:
            raise InputError(f"lmax {lmax} is outside the model {model.name} (0..{model.lmax})")
    if lmax_i > limit:
        if limit == MAX_DEGREE_GRID:
            raise InputError(
                f"degree {lmax_i} is above {limit}, the limit of the scaled Legendre recursion; "
                f"truncate the model with lmax <= {limit}"
            )
        raise InputError(
            f"degree {lmax_i} is above {limit}, the highest degree of point evaluation; "
            f"truncate the model with lmax <= {limit}"
        )
    return lmax_i


def kernel_model(
    model: SHModel,
    device: str | None = None,
    lmax: int | None = None,
    *,
    points: bool = False,
    xrange: bool | None = None,
) -> Any:
    """Build (or fetch from the cache) the device struct of ``model`` truncated to ``lmax``.

    Parameters
    ----------
    model : SHModel
        Fully normalised coefficients.
    device : str, optional
        Warp device name (default: :func:`fieldmap._warp.resolve_device`).
    lmax : int, optional
        Truncation degree (default: the model's).
    points : bool
        The struct serves the point kernels only (``sh_spherical`` and what calls it): degrees
        up to :data:`MAX_DEGREE_POINTS` are accepted. Otherwise (grids, the default) degrees
        above :data:`MAX_DEGREE_GRID` are refused.
    xrange : bool, optional
        Extended-range struct (``xrange = 1``: packed coefficients and square-root tables, no
        ``[m, n]`` tables; only the point kernels can use it). Default: above
        :data:`MAX_DEGREE_GRID` only; True forces it at any degree (tests, benchmarks).

    Returns
    -------
    fieldmap.kernels.sh.SHKernelModel
        Cached by (model identity, lmax, device, xrange); entries die with the model object. The
        recursion tables are shared by all models on a device, and a truncation reuses the
        coefficient arrays of a higher one.
    """
    _warp.init()
    from fieldmap.kernels import sh as ksh

    device = _warp.resolve_device(device)
    L = _check_lmax(model, lmax, MAX_DEGREE_POINTS if points else MAX_DEGREE_GRID)
    xr = L > MAX_DEGREE_GRID if xrange is None else bool(xrange)
    if not xr and L > MAX_DEGREE_GRID:
        _check_lmax(model, L)  # raises: the [m, n] tables stop at MAX_DEGREE_GRID
    key = (id(model), L, device, xr)
    with _cache_lock:
        hit = _cache.get(key)
        if hit is not None and hit[0]() is model:
            return hit[1]
    km = ksh.SHKernelModel()
    km.lmax = L
    km.gm = wp.float64(model.gm)
    km.radius = wp.float64(model.radius)
    if xr:
        km.xrange = 1
        km.xsq, km.xisq, km.xrn, km.xirn = _device_xtables(L, device)
        km.xpack, km.xcs = _device_packed(model, L, device)
    else:
        # The kernel reads rows m <= lmax and columns n <= lmax only, so larger tables and the
        # coefficient arrays of a higher truncation of the same model serve any smaller lmax.
        tab = _device_tables(L, device)
        cnm, snm = _device_coefficients(model, L, device)
        km.cnm, km.snm = cnm, snm
        km.anm, km.bnm, km.fnm, km.sect = tab
        km.xrange = 0
    with _cache_lock:
        if len(_cache) >= _CACHE_MAX:
            _cache.pop(next(iter(_cache)))
        _cache[key] = (weakref.ref(model), km)
    return km


def xrange_tables(lmax: int) -> dict[str, np.ndarray]:
    """Square-root tables of the extended-range path (recursion factors computed from them).

    ``sq[k] = sqrt(k)`` and ``isq[k] = 1/sqrt(k)`` (0 at k = 0) for k = 0..2 lmax + 2,
    ``rn[n] = sqrt((2n−1)(2n+1))`` and ``irn[n] = 1/rn[n]`` (0 at n = 0) for n = 0..lmax; the
    kernel forms ``a_nm = rn[n] isq[n−m] isq[n+m]``, ``1/a_nm = irn[n] sq[n−m] sq[n+m]``,
    ``b_nm = a_nm/a_{n−1,m}`` and ``f_nm = (2n+1)/a_nm`` (Holmes & Featherstone 2002 eqs. 11-15).
    Memory: 6 lmax float64 values (0.5 MB at degree 10,800) instead of three (lmax+1)² tables.
    """
    L = int(lmax)
    k = np.arange(2 * L + 3, dtype=np.float64)
    sq = np.sqrt(k)
    isq = np.zeros_like(sq)
    isq[1:] = 1.0 / sq[1:]
    n = np.arange(L + 1, dtype=np.float64)
    rn = np.sqrt(np.maximum((2 * n - 1) * (2 * n + 1), 0.0))
    rn[0] = 0.0
    irn = np.zeros_like(rn)
    irn[1:] = 1.0 / rn[1:]
    return {"sq": sq, "isq": isq, "rn": rn, "irn": irn}


def pack_coefficients(model: SHModel, lmax: int) -> np.ndarray:
    """C and S of degrees 0..lmax packed by order: shape ((lmax+1)(lmax+2)/2, 2).

    Column m (n = m..lmax) starts at row ``m (2 lmax + 3 − m) / 2``: one column recursion reads
    contiguous memory, and the zero upper triangle of the ``[n, m]`` arrays is not stored
    (0.93 GB at degree 10,800 instead of 1.87 GB for two transposed squares).
    """
    L = int(lmax)
    out = np.empty(((L + 1) * (L + 2) // 2, 2))
    off = 0
    step = 128  # transpose in blocks of orders: row segments stay in cache
    for m0 in range(0, L + 1, step):
        m1 = min(m0 + step, L + 1)
        for k, A in enumerate((model.C, model.S)):
            blk = np.ascontiguousarray(A[m0 : L + 1, m0:m1].T)  # [m - m0, n - m0]
            o = off
            for j in range(m1 - m0):
                cnt = L + 1 - (m0 + j)
                out[o : o + cnt, k] = blk[j, j : j + cnt]
                o += cnt
        off = o
    return out


def _device_xtables(L: int, device: str) -> Any:
    key = (device, "x")
    with _cache_lock:
        hit = _tables.get(key)
        if hit is not None and hit[0] >= L:
            return hit[1]
    tab = xrange_tables(L)
    arrs: Any = tuple(
        wp.array(tab[k], dtype=wp.float64, device=device) for k in ("sq", "isq", "rn", "irn")
    )
    with _cache_lock:
        _tables[key] = (L, arrs)
    return arrs


def _device_packed(model: SHModel, L: int, device: str) -> tuple[int, Any]:
    key = (id(model), device, "x")
    with _cache_lock:
        hit = _coefs.get(key)
        if hit is not None and hit[0]() is model and hit[1] >= L:
            return hit[1], hit[2]
    # on the CPU the Warp array aliases the packed NumPy copy (ours), no second copy
    arr: Any = wp.array(
        pack_coefficients(model, L), dtype=wp.vec2d, device=device, copy=device != "cpu"
    )
    with _cache_lock:
        _coefs.pop(key, None)
        while len(_coefs) >= _COEF_MAX:
            _coefs.pop(next(iter(_coefs)))
        _coefs[key] = (weakref.ref(model), L, arr)
    return L, arr


def _device_tables(L: int, device: str) -> Any:
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


def _device_coefficients(model: SHModel, L: int, device: str) -> Any:
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


def _positions(x: ArrayLike, y: ArrayLike, z: ArrayLike) -> tuple[np.ndarray, tuple[int, ...]]:
    x, y, z = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (x, y, z)))
    shape = x.shape
    pos = np.ascontiguousarray(np.stack([x.ravel(), y.ravel(), z.ravel()], axis=-1))
    if not np.all(np.isfinite(pos)):
        raise InputError("positions must be finite")
    if np.any(np.einsum("ij,ij->i", pos, pos) == 0.0):
        raise InputError("position at the Earth's centre: the series is undefined there")
    return pos, shape


def _launch_points(
    kernel: str,
    model: SHModel,
    lmax: int | None,
    device: str | None,
    columns: list[tuple[np.ndarray, Any]],
    consts: tuple[Any, ...] = (),
    out_dtype: Any = wp.vec3d,
) -> np.ndarray:
    """Run the point kernel ``kernel`` of :mod:`fieldmap.kernels.sh`, one thread per point.

    ``columns`` are ``(array, warp dtype)`` pairs of per-point inputs, ``consts`` the scalar
    inputs after them; returns the kernel's output array, one row per point.
    """
    from fieldmap.kernels import sh as ksh

    device = _warp.resolve_device(device)
    km = kernel_model(model, device, lmax, points=True)
    n = columns[0][0].shape[0]
    ins: Any = [wp.array(np.ascontiguousarray(a), dtype=t, device=device) for a, t in columns]
    out = wp.zeros(n, dtype=out_dtype, device=device)
    _warp.launch_chunked(getattr(ksh, kernel), n, [km, *ins, *consts, out], device)
    return out.numpy()


def sh_gravitation(
    model: SHModel,
    x: ArrayLike,
    y: ArrayLike,
    z: ArrayLike,
    lmax: int | None = None,
    device: str | None = None,
) -> np.ndarray:
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


def sh_potential(
    model: SHModel,
    x: ArrayLike,
    y: ArrayLike,
    z: ArrayLike,
    lmax: int | None = None,
    device: str | None = None,
) -> np.ndarray:
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
    lat_deg: ArrayLike,
    lon_deg: ArrayLike,
    h_m: ArrayLike,
    ellipsoid: Ellipsoid | None = None,
    lmax: int | None = None,
    device: str | None = None,
) -> np.ndarray:
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

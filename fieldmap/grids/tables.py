"""Packed recursion tables of the grid Legendre pass (kernels.grid.row_fourier8_kernel).

The engine's tables (:func:`fieldmap.field.sh.kernel_model`) are square ``[m, n]`` arrays, one
per quantity. The grid kernel walks one column m for eight rows at a time and needs, per degree
n, eight numbers: packed together they are one 64-byte load (one cache line) per step instead
of five loads from five arrays, and the products the engine forms in its loop are formed here
once (the same float64 products, so the sums keep their bits):

``rec[start[m] + n - m] = (a_nm, b_nm, C_nm, S_nm, (n+1) C_nm, (n+1) S_nm,
f_{n+1,m} C_{n+1,m}, f_{n+1,m} S_{n+1,m})`` for m <= n <= lmax (the last two 0 at n = lmax),

the latitude-derivative products shifted by one degree so that every product of a step
multiplies the same Q_nm. ``zon[n] = f_{n0} C_{n0}`` (f_{n0} = sqrt(n(n+1)/2)) feeds the zonal
north sum, which runs along column m = 1.

Above degree 2700 the engine builds no square tables (they would hold 3 (L+1)² doubles):
:func:`pack_columns_direct` forms the same entries order by order from the closed forms of
:func:`fieldmap.field.sh.recursion_tables` (the same float64 operations, so the same bits) and
:func:`grid_tables_x` serves the extended-range kernel
(:mod:`fieldmap.kernels.grid_xrange`). Memory: 64 bytes per (m, n), 0.98 GB at degree 5540.
"""

from __future__ import annotations

import threading
import weakref
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from fieldmap.models.shmodel import SHModel

_lock = threading.Lock()
_cache: dict[tuple, tuple[Any, tuple]] = {}
_CACHE_MAX = 4


def pack_columns(
    anm: np.ndarray, bnm: np.ndarray, fnm: np.ndarray, cnm: np.ndarray, snm: np.ndarray, lmax: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Build ``(rec, start, zon)`` (NumPy) from ``[m, n]`` tables; see the module docstring.

    Returns
    -------
    rec : numpy.ndarray
        Shape (ntri, 8), float64, ntri = (lmax + 1)(lmax + 2)/2.
    start : numpy.ndarray
        Shape (lmax + 1,), int64: first row of column m in ``rec``.
    zon : numpy.ndarray
        Shape (lmax + 1,), float64.
    """
    L = int(lmax)
    cnt = L + 1 - np.arange(L + 1)
    start = np.concatenate([[0], np.cumsum(cnt)[:-1]]).astype(np.int64)
    rec = np.zeros((int(cnt.sum()), 8))
    for m in range(L + 1):
        s0 = int(start[m])
        n = np.arange(m, L + 1)
        blk = rec[s0 : s0 + n.size]
        c = cnm[m, m : L + 1]
        s = snm[m, m : L + 1]
        blk[:, 0] = anm[m, m : L + 1]
        blk[:, 1] = bnm[m, m : L + 1]
        blk[:, 2] = c
        blk[:, 3] = s
        blk[:, 4] = (n + 1.0) * c
        blk[:, 5] = (n + 1.0) * s
        f = fnm[m, m + 1 : L + 1]
        blk[:-1, 6] = cnm[m, m + 1 : L + 1] * f
        blk[:-1, 7] = snm[m, m + 1 : L + 1] * f
    zon = fnm[0, : L + 1] * cnm[0, : L + 1]
    return rec, start, np.ascontiguousarray(zon)


def sectoral(lmax: int) -> np.ndarray:
    """``sect[m]`` = P̄mm/u^m (s_0 = 1, s_1 = √3, s_m = s_{m−1} sqrt((2m+1)/(2m)))."""
    L = int(lmax)
    sect = np.ones(L + 1)
    if L >= 1:
        k = np.arange(2, L + 1, dtype=np.float64)
        sect[1] = np.sqrt(3.0)
        sect[2:] = np.sqrt(3.0) * np.cumprod(np.sqrt((2 * k + 1) / (2 * k)))
    return sect


def pack_columns_direct(model: SHModel, lmax: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`pack_columns` of a model without square tables (any degree); same values.

    The recursion factors of each order m come from the closed forms of
    :func:`fieldmap.field.sh.recursion_tables` evaluated on that order's degrees, the
    coefficients from ``model.C``, ``model.S`` (``[n, m]``) read in blocks of orders.
    """
    L = int(lmax)
    cnt = L + 1 - np.arange(L + 1)
    start = np.concatenate([[0], np.cumsum(cnt)[:-1]]).astype(np.int64)
    rec = np.empty((int(cnt.sum()), 8))
    step = 128  # orders per block: the [n, m] -> [m, n] transposes stay in cache
    for m0 in range(0, L + 1, step):
        m1 = min(m0 + step, L + 1)
        cblk = np.ascontiguousarray(model.C[m0 : L + 1, m0:m1].T)  # [m - m0, n - m0]
        sblk = np.ascontiguousarray(model.S[m0 : L + 1, m0:m1].T)
        for m in range(m0, m1):
            s0 = int(start[m])
            n = np.arange(m, L + 1, dtype=np.float64)
            mm = np.float64(m)
            blk = rec[s0 : s0 + n.size]
            c = cblk[m - m0, m - m0 :]
            s = sblk[m - m0, m - m0 :]
            with np.errstate(divide="ignore", invalid="ignore"):
                a = np.sqrt((2 * n - 1) * (2 * n + 1) / ((n - mm) * (n + mm)))
                b = np.sqrt(
                    (2 * n + 1) * (n + mm - 1) * (n - mm - 1) / ((n - mm) * (n + mm) * (2 * n - 3))
                )
                f = np.sqrt((n * n - mm * mm) * (2 * n + 1) / (2 * n - 1))
            a[0] = 0.0
            b[:2] = 0.0
            if m == 0:
                f = np.sqrt(n * (n + 1) / 2.0)
            blk[:, 0] = a
            blk[:, 1] = b
            blk[:, 2] = c
            blk[:, 3] = s
            blk[:, 4] = (n + 1.0) * c
            blk[:, 5] = (n + 1.0) * s
            blk[:-1, 6] = c[1:] * f[1:]
            blk[:-1, 7] = s[1:] * f[1:]
            blk[-1, 6:] = 0.0
    n0 = np.arange(L + 1, dtype=np.float64)
    zon = np.sqrt(n0 * (n0 + 1) / 2.0) * np.asarray(model.C[: L + 1, 0], dtype=np.float64)
    return rec, start, np.ascontiguousarray(zon)


def grid_tables_x(model: SHModel, lmax: int, device: str) -> tuple[Any, Any, Any, Any]:
    """Warp arrays ``(rec, start, zon, sect)`` for the extended-range grid kernel, cached."""
    import warp as wp

    from fieldmap.kernels import grid as kgrid

    L = int(lmax)
    key = (id(model), L, device, "x")
    with _lock:
        hit = _cache.get(key)
        if hit is not None and hit[0]() is model:
            return hit[1]
    rec, start, zon = pack_columns_direct(model, L)
    out: tuple[Any, Any, Any, Any] = (
        wp.array(rec, dtype=kgrid.vec8d, device=device, copy=device != "cpu"),
        wp.array(start.astype(np.int32), dtype=wp.int32, device=device),
        wp.array(zon, dtype=wp.float64, device=device),
        wp.array(sectoral(L), dtype=wp.float64, device=device),
    )
    del rec
    with _lock:
        # tables of this size (GB above degree 5000) are kept for one model at a time and
        # leave with it
        for k in [k for k in _cache if k[-1] == "x"]:
            _cache.pop(k)
        if len(_cache) >= _CACHE_MAX:
            _cache.pop(next(iter(_cache)))
        _cache[key] = (weakref.ref(model), out)
    weakref.finalize(model, _forget, key)
    return out


def _forget(key: tuple[Any, ...]) -> None:
    with _lock:
        _cache.pop(key, None)


def grid_tables(model: SHModel, km: Any, device: str) -> tuple[Any, Any, Any]:
    """Warp arrays ``(rec, start, zon)`` of :func:`pack_columns` for a kernel model, cached.

    Parameters
    ----------
    model : fieldmap.models.shmodel.SHModel
        The model ``km`` was built from (cache key; entries die with it).
    km : fieldmap.kernels.sh.SHKernelModel
        Its kernel struct (:func:`fieldmap.field.sh.kernel_model`): tables and coefficients.
    device : str
    """
    import warp as wp

    from fieldmap.kernels import grid as kgrid

    L = int(km.lmax)
    key = (id(model), L, device)
    with _lock:
        hit = _cache.get(key)
        if hit is not None and hit[0]() is model:
            return hit[1]

    rec, start, zon = pack_columns(
        km.anm.numpy(), km.bnm.numpy(), km.fnm.numpy(), km.cnm.numpy(), km.snm.numpy(), L
    )
    out: tuple[Any, Any, Any] = (
        wp.array(rec, dtype=kgrid.vec8d, device=device),
        wp.array(start.astype(np.int32), dtype=wp.int32, device=device),
        wp.array(zon, dtype=wp.float64, device=device),
    )
    with _lock:
        if len(_cache) >= _CACHE_MAX:
            _cache.pop(next(iter(_cache)))
        _cache[key] = (weakref.ref(model), out)
    return out


def tensor_tables(model: SHModel, km: Any, device: str) -> tuple[Any, Any]:
    """Warp arrays ``(rec, start)`` of the tensor kernel's packed table, cached.

    ``rec[start[m] + n - m]`` = (a_nm, b_nm, C, S, (n+1) C, (n+1) S, (n+1)(n+2) C,
    (n+1)(n+2) S, f_{n+1} C_{n+1}, f_{n+1} S_{n+1}, (n+3) f_{n+1} C_{n+1},
    (n+3) f_{n+1} S_{n+1}) (see :func:`fieldmap.kernels.grid_tensor.tensor_column_packed`);
    :func:`pack_columns` plus four columns. 96 bytes per (m, n): 230 MB at degree 2190.
    """
    import warp as wp

    from fieldmap.kernels import grid_tensor as kten

    L = int(km.lmax)
    key = (id(model), L, device, "tensor")
    with _lock:
        hit = _cache.get(key)
        if hit is not None and hit[0]() is model:
            return hit[1]
    rec8, start, _ = pack_columns(
        km.anm.numpy(), km.bnm.numpy(), km.fnm.numpy(), km.cnm.numpy(), km.snm.numpy(), L
    )
    n = np.concatenate([np.arange(m, L + 1) for m in range(L + 1)]).astype(np.float64)
    rec = np.empty((rec8.shape[0], 12))
    rec[:, :6] = rec8[:, :6]
    w2 = (n + 1.0) * (n + 2.0)
    rec[:, 6] = w2 * rec8[:, 2]
    rec[:, 7] = w2 * rec8[:, 3]
    rec[:, 8:10] = rec8[:, 6:8]
    rec[:, 10] = (n + 3.0) * rec8[:, 6]
    rec[:, 11] = (n + 3.0) * rec8[:, 7]
    del rec8
    out: tuple[Any, Any] = (
        wp.array(rec, dtype=kten.vec12d, device=device),
        wp.array(start.astype(np.int32), dtype=wp.int32, device=device),
    )
    with _lock:
        if len(_cache) >= _CACHE_MAX:
            _cache.pop(next(iter(_cache)))
        _cache[key] = (weakref.ref(model), out)
    return out

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
"""

from __future__ import annotations

import threading
import weakref
from typing import Any

import numpy as np

_lock = threading.Lock()
_cache: dict[tuple, tuple[Any, tuple]] = {}
_CACHE_MAX = 4


def pack_columns(anm, bnm, fnm, cnm, snm, lmax: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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


def grid_tables(model, km, device: str):
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

"""Longitude sums of a grid row: sum_m (A_m cos m lon + B_m sin m lon) at every node.

Regular longitudes lon0 + k 360/L go through inverse real FFTs of length L, one per series
(orders fold onto 0..L/2 exactly on the nodes), the series shared out over the CPU threads
(:func:`map_rows`): straight from the coefficients where they are written as the FFT reads them
(:func:`spectrum_layout`), else chunk by chunk in small per-thread work arrays; any other longitudes
through a direct-sum Warp kernel (:func:`fieldmap.kernels.grid.longitude_sum_kernel`). Used by
:func:`fieldmap.grids.synthesis.synthesize`.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any, TypeVar

import numpy as np

_T = TypeVar("_T")


def regular_period(lon_deg: np.ndarray) -> int | None:
    """Return L if the longitudes are lon0 + k*360/L (k = 0, 1, ...), else None.

    More than L nodes are allowed (a grid holding both 0 and 360 deg): they wrap around.
    """
    if lon_deg.size < 2:
        return None
    step = (lon_deg[-1] - lon_deg[0]) / (lon_deg.size - 1)
    if step <= 0:
        return None
    period = 360.0 / step
    nper = int(round(period))
    if abs(period - nper) > 1e-8 * period or nper > 2**22:
        return None
    k = np.arange(lon_deg.size)
    if np.max(np.abs(lon_deg - (lon_deg[0] + k * 360.0 / nper))) > 1e-9:
        return None
    return nper


def _lattice(lon_deg: np.ndarray, nper: int) -> tuple[int, bool]:
    """(node of the transform at the first longitude, whether lon0 is off the node lattice).

    Node k sits at lon0 + k * 2 pi / L: a lon0 on the node lattice is a rotation of the output
    (exact), any other lon0 a phase factor on the series.
    """
    step = 360.0 / nper
    k0 = round(lon_deg[0] / step)
    if abs(lon_deg[0] - k0 * step) > 1e-9 * max(1.0, abs(lon_deg[0])):
        return 0, True
    return int(k0) % nper, False


def spectrum_layout(lon_deg: np.ndarray, nm: int) -> tuple[int, np.ndarray, bool]:
    """How to write a row's series of ``nm`` orders so that the FFT reads them as they are.

    Returns ``(ncol, osc, ready)``. When ``ready`` (whole turns of regular longitudes starting
    at node 0 or half a turn away, e.g. lon0 = 0 or -180, and nm <= L/2 + 1), a series
    written as ``osc[m] W_m`` into ``ncol = L/2 + 1`` columns (zeros past nm) is the half
    spectrum of the inverse real FFT: ``osc`` = 1 for m = 0, else 1/2 (times (-1)^m for the
    half-turn start, which rotates the output). Pass ``ready=True`` to
    :func:`longitude_sums` with it. Otherwise ``ncol = nm``, ``osc`` = 1: the plain series.
    """
    lon_deg = np.asarray(lon_deg, dtype=np.float64)
    return _layout(lon_deg, regular_period(lon_deg), nm)


def _layout(lon_deg: np.ndarray, nper: int | None, nm: int) -> tuple[int, np.ndarray, bool]:
    """:func:`spectrum_layout` with the period ``nper`` of the longitudes already known."""
    osc = np.ones(nm)
    if nper is None or lon_deg.size != nper or nm > nper // 2 + 1:
        return nm, osc, False
    src0, off = _lattice(lon_deg, nper)
    if off or src0 not in (0, nper / 2):
        return nm, osc, False
    osc[1:] = 0.5
    if src0:
        osc[1::2] = -0.5
    return nper // 2 + 1, osc, True


def longitude_sums(
    W: np.ndarray,
    lon_deg: np.ndarray,
    device: str = "cpu",
    out: np.ndarray | None = None,
    ready: bool = False,
) -> np.ndarray:
    """Evaluate Re(sum_m W[..., m] e^{i m lon}) at every longitude.

    Parameters
    ----------
    W : numpy.ndarray
        Complex, shape (..., nm): W_m = A_m - i B_m for the series sum A_m cos + B_m sin.
    lon_deg : numpy.ndarray
        Longitudes. Units: degrees.
    device : str
        Warp device for the direct-sum fallback (irregular longitudes).
    out : numpy.ndarray, optional
        Real array of shape (..., nlon) to fill (may be a view into a larger buffer).
    ready : bool
        ``W`` is written as :func:`spectrum_layout` says for a ``ready`` layout: the inverse
        FFTs read it as it is (its Nyquist column is doubled in place).

    Returns
    -------
    numpy.ndarray
        Real, shape (..., nlon) (``out`` when given).
    """
    lon_deg = np.asarray(lon_deg, dtype=np.float64)
    lead, nm = W.shape[:-1], W.shape[-1]
    nlon = lon_deg.size
    W = W.reshape(-1, nm)
    ns = W.shape[0]
    if out is None:
        out = np.empty((*lead, nlon))
    res = out.reshape(ns, nlon)  # a view for the contiguous buffers the callers pass
    nper = regular_period(lon_deg)
    if ready:
        ncol, _, fits = _layout(lon_deg, nper, nm)
        if not fits or ncol != nm or nper is None:
            raise ValueError("longitude_sums: W is not in a ready layout for these longitudes")
        if nper % 2 == 0:
            W[:, -1] *= 2.0  # the Nyquist term (-1)^k enters once
        map_rows(lambda a, b: _irfft(W[a:b], nper, res[a:b]), ns, CHUNK_MIN)
        if not np.shares_memory(res, out):
            out[...] = res.reshape(out.shape)
        return out
    if nper is None:
        res[...] = _direct_sums(W, lon_deg, device)
        return out
    src0, off = _lattice(lon_deg, nper)
    phase = np.exp(1j * np.radians(lon_deg[0]) * np.arange(nm)) if off else None
    # contiguous parts of the series, taken by the CPU threads, each transformed chunk by chunk
    # in work arrays that stay in the core's cache (a series' values do not depend on the split)
    map_rows(lambda a, b: _fft_rows(W[a:b], phase, nper, src0, res[a:b]), ns, CHUNK_MIN)
    if not np.shares_memory(res, out):
        out[...] = res.reshape(out.shape)
    return out


#: Series per chunk of the longitude FFTs: at least this many (pocketfft transforms a few
#: series at a time with SIMD), and as many as fit a work area of :data:`CHUNK_BYTES`.
CHUNK_MIN = 8
#: Bytes of one chunk's half spectra and transforms: small enough for a core's cache.
CHUNK_BYTES = 2**19

_work = threading.local()
_pool_lock = threading.Lock()
_pool_obj: list = [None, 0]


#: Parts per CPU thread of :func:`map_rows`. The threads take the parts as they come free, so
#: a thread that the machine's other work delays leaves its part to the others; more parts
#: cost more joining than they save (measured on the statistics of a 0.5 deg map).
PARTS_PER_THREAD = 1


def map_rows(fn: Callable[[int, int], _T], nrows: int, min_rows: int = 16) -> list[_T]:
    """Return ``[fn(a, b), ...]`` over contiguous parts ``[a, b)`` of ``nrows`` rows, in order.

    The parts (:data:`PARTS_PER_THREAD` per CPU thread of :func:`fieldmap._warp.cpu_workers`,
    at least ``min_rows`` rows each; they depend only on ``nrows`` and the thread count) are
    taken in turn by this thread and a small pool: for NumPy work (FFTs included) on
    independent rows, which releases the GIL.
    """
    nthreads = _threads()
    nparts = max(1, min(nthreads * PARTS_PER_THREAD, nrows // max(1, min_rows)))
    cuts = [nrows * i // nparts for i in range(nparts + 1)]
    parts = list(zip(cuts, cuts[1:]))
    if nparts == 1 or nthreads == 1:
        return [fn(a, b) for a, b in parts]
    results: list = [None] * nparts
    todo = iter(range(nparts))
    lock = threading.Lock()

    def work() -> None:
        while True:
            with lock:
                i = next(todo, None)
            if i is None:
                return
            results[i] = fn(*parts[i])

    futs = [_pool(nthreads - 1).submit(work) for _ in range(min(nthreads, nparts) - 1)]
    try:
        work()
    finally:
        for f in futs:  # every part is taken: a worker that has not started is not needed
            if not f.cancel():
                f.result()
    return results


def _threads() -> int:
    from fieldmap import _warp

    return _warp.cpu_workers()


def _pool(n: int) -> ThreadPoolExecutor:
    """Return a pool of at least ``n`` threads for the parts of :func:`longitude_sums`."""
    with _pool_lock:
        if _pool_obj[1] < n:
            if _pool_obj[0] is not None:
                _pool_obj[0].shutdown(wait=False)
            _pool_obj[0] = ThreadPoolExecutor(max_workers=n, thread_name_prefix="fieldmap-fft")
            _pool_obj[1] = n
        return _pool_obj[0]


def _fft_rows(
    W: np.ndarray, phase: np.ndarray | None, nper: int, src0: int, res: np.ndarray
) -> None:
    """Longitude sums of the series ``W`` (ns, nm) into ``res`` (ns, nlon), chunk by chunk.

    ``phase``: factors of the series for a lon0 off the node lattice (else None); ``src0``:
    node of the transform at the first longitude. Re sum_m F_m e^{i m x} on x_k = 2 pi k / L is
    the inverse real FFT of the half spectrum H_0 = Re F_0, H_j = F_j / 2 (0 < j < L/2),
    H_{L/2} = F_{L/2}: orders m >= L fold onto m mod L, and m mod L = r > L/2 onto L - r
    conjugated (exact on the nodes). Each series is transformed on its own.
    """
    ns, nm = W.shape
    nlon = res.shape[1]
    nh = nper // 2 + 1
    direct = src0 == 0 and nlon == nper  # the transforms write straight into the result
    rows = max(CHUNK_MIN, CHUNK_BYTES // (nh * 16 + (0 if direct else nper * 8)))
    rows = min(rows, ns)
    H, z = _workspace(rows, nh, 0 if direct else rows * nper)
    z = z.reshape(-1, nper) if not direct else z
    for c0 in range(0, ns, rows):
        c1 = min(ns, c0 + rows)
        F = W[c0:c1] if phase is None else W[c0:c1] * phase
        h = H[: c1 - c0]
        if nm <= nh:
            np.multiply(F, 0.5, out=h[:, :nm])
            h[:, nm:] = 0.0
            h[:, 0] = F[:, 0]
        elif nm <= nper:  # one fold; x 0.5 is exact, so (F_j + conj F_(L-j)) / 2 term by term
            np.multiply(F[:, :nh], 0.5, out=h)
            h[:, 0] = F[:, 0]
            h[:, nper - nm + 1 : nper - nh + 1] += np.conj(F[:, nh:nm][:, ::-1]) * 0.5
        else:
            h[...] = 0.0
            for m0 in range(0, nm, nper):
                blk = F[:, m0 : min(nm, m0 + nper)]
                nb = blk.shape[1]
                h[:, : min(nb, nh)] += blk[:, :nh]
                if nb > nh:  # r = nh .. nb-1 folds onto L - r (distinct targets L-nh .. L-nb+1)
                    h[:, nper - nb + 1 : nper - nh + 1] += np.conj(blk[:, nh:nb][:, ::-1])
            h[:, 1:] *= 0.5
        if nper % 2 == 0 and nm > nper // 2:
            h[:, -1] *= 2.0  # the Nyquist term (-1)^k enters once
        if direct:
            _irfft(h, nper, res[c0:c1])
            continue
        zc = z[: c1 - c0]
        _irfft(h, nper, zc)
        # node k of the result is node (k + k0) mod L of z (beyond one turn the nodes repeat)
        k, src = 0, src0
        while k < nlon:
            take = min(nlon - k, nper - src)
            res[c0:c1, k : k + take] = zc[:, src : src + take]
            k += take
            src = (src + take) % nper


#: Largest work area (bytes) kept from one call to the next, per thread (fresh memory costs
#: page faults, more than the transforms of a small grid); larger ones are freed after use.
WORK_BYTES = 8 * 2**20


def _workspace(rows: int, nh: int, nz: int) -> tuple[np.ndarray, np.ndarray]:
    """Half spectra (rows, nh) complex and ``nz`` float64 values, uninitialised."""
    nbytes = rows * nh * 16 + nz * 8
    buf = getattr(_work, "buf", None)
    if buf is None or buf.size < nbytes:
        buf = np.empty(nbytes, dtype=np.uint8)
        if nbytes <= WORK_BYTES:
            _work.buf = buf
    H = buf[: rows * nh * 16].view(np.complex128).reshape(rows, nh)
    return H, buf[rows * nh * 16 : nbytes].view(np.float64)


#: NumPy's ``fft.irfft`` writes into ``out=`` from NumPy 2.0 on (its pocketfft C++ code).
IRFFT_OUT = int(np.__version__.split(".")[0]) >= 2


def _irfft(H: np.ndarray, n: int, out: np.ndarray) -> None:
    """``out[...] = irfft(H, n, norm="forward")`` along the last axis, written into ``out``.

    Public APIs only: ``numpy.fft.irfft(..., out=)`` (NumPy >= 2.0), else ``scipy.fft.irfft``
    and a copy. Both run pocketfft's C++ code, as SciPy's private binding that fieldmap 0.2
    called: the same bits (``benchmarks/bench_fft.py`` measured these against it and ducc0's
    ``c2r``, whose bits depend on the other rows of the call), and a row's bits do not depend
    on the rows transformed with it, so not on the threads or chunks.
    """
    if IRFFT_OUT:
        np.fft.irfft(H, n=n, axis=-1, norm="forward", out=out)
    else:
        import scipy.fft

        out[...] = scipy.fft.irfft(H, n=n, axis=-1, norm="forward", workers=1)


def _direct_sums(W: np.ndarray, lon_deg: np.ndarray, device: str) -> np.ndarray:
    import warp as wp

    from fieldmap import _warp
    from fieldmap.kernels import grid as kgrid

    _warp.init()  # launch_chunked compiles the module once, before its threads launch
    nser, nm = W.shape
    ab = np.stack([W.real, -W.imag], axis=-1)
    coef: Any = wp.array(np.ascontiguousarray(ab), dtype=wp.vec2d, device=device)
    lon: Any = wp.array(np.radians(lon_deg), dtype=wp.float64, device=device)
    out = wp.zeros((nser, lon_deg.size), dtype=wp.float64, device=device)
    _warp.launch_chunked(
        kgrid.longitude_sum_kernel,
        nser * lon_deg.size,
        [coef, lon, nm, lon_deg.size, out],
        device,
    )
    return out.numpy()

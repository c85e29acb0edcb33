"""Block engine: map products computed block by block, locally or on a Dask cluster.

A product (disturbance map or altitude sweep) is split into blocks of latitude rows at one
height. A block holds whole mirror units of :func:`fieldmap.grids.synthesis.mirror_pairs` (a row
and its mirror at minus the latitude share one Legendre recursion), grouped exactly as
:func:`fieldmap.grids.synthesis.synthesize` groups them, and is computed by ``synthesize`` on the
sub-grid of its rows. The plan depends only on the grid and ``rows_per_block``, never on the
executor, so a product is bitwise the same whether its blocks run here one after the other (each
on every core through the Warp thread pool), on ``local:N`` worker processes, or on a remote
cluster; a block that is run again after a worker died gives the same bits.

Statistics are combined from per-block partial results in block order (so exactly the same on
every executor): maximum, minimum, area-weighted sums for the mean and RMS, area above each
threshold. Percentiles come from a mergeable histogram of the area weight over bins of the
modulus read from its float64 bits: the exponent and the leading ``HIST_MANTISSA_BITS`` bits of
the mantissa (``HIST_BINS`` bins over ``HIST_RANGE_MG``, each at most ``2**-12`` of its lower
edge wide; a shift of the bits, no logarithm). The bin holding the percentile is exact and its
centre is returned, within a relative ``PERCENTILE_RTOL`` (``2**-13``) of the weighted
percentile of :func:`fieldmap.products.stats.weighted_percentile`.

Memory: one block of ``nb`` rows and ``nlon`` longitudes takes about ``nb * (per_item + 104 *
nlon)`` bytes on the process computing it (``per_item`` of ``synthesize``: Fourier coefficients
and FFT work arrays, ``nm * 144 + nlon * 144`` bytes for ``nm = lmax + 1``; 104 = the five output
variables and the vector), plus the model (``16 * nm**2`` bytes) and the interpreter (~0.3 GB);
see :func:`block_bytes`. The client holds at most ``window`` blocks (NetCDF) or only their
boundary rows and statistics (zarr). Nothing is proportional to the grid but the row weights.

Writing (:mod:`fieldmap.products.blockio`): zarr stores are written by the workers in parallel;
NetCDF-4 files by one writer, the client, as blocks arrive (HDF5 has no safe parallel writer
without MPI). Both go to a temporary name renamed at the end.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import os
import weakref
from collections.abc import Iterator
from typing import Any

import numpy as np

from fieldmap.errors import InputError

__all__ = [
    "HIST_BINS",
    "HIST_MANTISSA_BITS",
    "HIST_RANGE_MG",
    "PERCENTILE_RTOL",
    "Block",
    "block_bytes",
    "compute_block",
    "open_client",
    "plan_blocks",
]

#: Leading mantissa bits of the modulus that select its histogram bin (with the exponent).
HIST_MANTISSA_BITS = 12
_SHIFT = 52 - HIST_MANTISSA_BITS
#: Range of the histogram of the modulus (mg), powers of two: values outside fall into the end bins.
HIST_RANGE_MG = (2.0**-40, 2.0**14)
_BITS_LO = int(np.array(HIST_RANGE_MG[0]).view(np.int64)) >> _SHIFT
#: Number of histogram bins (54 octaves of 2**12 bins).
HIST_BINS = (int(np.array(HIST_RANGE_MG[1]).view(np.int64)) >> _SHIFT) - _BITS_LO
#: Largest relative error of a percentile: half a bin of relative width 2**-12 (1.2e-4).
PERCENTILE_RTOL = 2.0 ** -(HIST_MANTISSA_BITS + 1)
#: Blocks per height of the default plan (at least; more where memory asks for it).
BLOCKS_PER_HEIGHT = 32
#: Variables of a disturbance block, in the order of :func:`fieldmap.products.cf.vector_vars`.
VARIABLES = ("east", "north", "up", "modulus", "modulus_mg")


@dataclasses.dataclass(frozen=True)
class Block:
    """One block of a product: rows (ascending indices into the grid's latitudes) at one height.

    Attributes
    ----------
    index : int
        Position in the plan (statistics are folded in this order).
    layer : int
        Height index.
    rows : numpy.ndarray
        Row indices, ascending (one or two contiguous runs: south rows and their mirrors).
    """

    index: int
    layer: int
    rows: np.ndarray

    def runs(self) -> list[tuple[int, int]]:
        """Contiguous runs ``[r0, r1)`` of the rows."""
        r = self.rows
        cut = np.flatnonzero(np.diff(r) != 1) + 1
        starts = np.concatenate([[0], cut])
        stops = np.concatenate([cut, [r.size]])
        return [(int(r[a]), int(r[b - 1]) + 1) for a, b in zip(starts, stops)]


def _per_item(nm: int, nlon: int, lon: np.ndarray) -> int:
    """Bytes per row of one ``synthesize`` block (its own formula), plus the five outputs."""
    from fieldmap.grids.longitude import regular_period

    nper = regular_period(lon) or nlon
    return nm * 3 * 16 * 3 + nper * 3 * 16 * 2 + nlon * 3 * 8 * 2 + nlon * 8 * 8


def block_bytes(nb: int, lmax: int, nlon: int, lon: np.ndarray | None = None) -> int:
    """Working memory of one block of ``nb`` rows (bytes), without interpreter and model.

    ``nb * (nm * 144 + nper * 96 + nlon * 112)`` with ``nm = lmax + 1`` and ``nper`` the FFT
    length (``nlon`` for a global grid): Fourier coefficients, FFT work arrays, the vector and
    the five output variables (east, north, up, modulus, modulus_mg).
    """
    lon = np.arange(nlon) * (360.0 / nlon) if lon is None else lon
    return nb * _per_item(lmax + 1, nlon, lon)


def plan_blocks(grid, lmax: int, rows_per_block: int | None = None) -> list[Block]:
    """Split a grid into blocks of whole mirror units, height by height.

    Parameters
    ----------
    grid : fieldmap.grids.spec.GridSpec
    lmax : int
        Degree of the synthesis (for the default block size).
    rows_per_block : int, optional
        Most rows per block (a mirrored pair counts two; at least 2). Default: the smaller of
        what :func:`fieldmap.grids.synthesis.synthesize` keeps in one block
        (``BLOCK_BYTES / per_item``) and ``nlat / BLOCKS_PER_HEIGHT`` rounded up to a multiple
        of 8 rows (whole groups of the grid kernel).

    Returns
    -------
    list of Block
        Independent of the executor: the same grid and ``rows_per_block`` give the same plan.
    """
    from fieldmap.grids.synthesis import BLOCK_BYTES, mirror_pairs

    nh, nlat, nlon = grid.shape
    if rows_per_block is None:
        per = _per_item(lmax + 1, nlon, grid.lon)
        # whole groups of four mirror pairs (8 rows): the grid kernel runs four units per
        # thread, and a block of 5 pairs would leave 3 of 8 lanes of its last group idle
        want = 8 * math.ceil(nlat / BLOCKS_PER_HEIGHT / 8)
        rows_per_block = max(1, min(BLOCK_BYTES // per, want))
    else:
        try:
            rows_per_block = int(rows_per_block)
        except (TypeError, ValueError):
            raise InputError(f"rows per block must be an integer, got {rows_per_block!r}") from None
        if rows_per_block < 1:
            raise InputError(f"rows per block must be >= 1, got {rows_per_block}")
    size = max(2, min(nlat, rows_per_block))
    units = mirror_pairs(grid.lat)
    blocks: list[Block] = []
    for layer in range(nh):
        u0 = 0
        while u0 < len(units):  # the grouping rule of synthesize
            u1, count = u0, 0
            while u1 < len(units) and (count == 0 or count + 1 + (units[u1][1] >= 0) <= size):
                count += 1 if units[u1][1] < 0 else 2
                u1 += 1
            rows = np.sort([i for a, b in units[u0:u1] for i in ((a,) if b < 0 else (a, b))])
            blocks.append(Block(len(blocks), layer, rows.astype(np.int64)))
            u0 = u1
    return blocks


# ---------------------------------------------------------------------------- statistics


def _hist_index(v: np.ndarray) -> np.ndarray:
    """Histogram bin of each (finite, non-negative) modulus: a shift of its float64 bits."""
    k = (np.ascontiguousarray(v, dtype=np.float64).view(np.int64) >> _SHIFT) - _BITS_LO
    return np.clip(k, 0, HIST_BINS - 1)


def _bin_centre(k: int) -> float:
    """Middle of histogram bin ``k`` (mg)."""
    lo, hi = (np.array([k + _BITS_LO, k + 1 + _BITS_LO], dtype=np.int64) << _SHIFT).view(np.float64)
    return float(0.5 * (lo + hi))


def block_partial(modulus_mg: np.ndarray, row_weights: np.ndarray, thresholds) -> dict:
    """Partial statistics of one block: extrema, weighted sums, weighted histogram.

    ``row_weights`` are the (unnormalised) area weights of the block's rows
    (:func:`fieldmap.products.stats.area_weights` of the whole grid, taken at the rows).
    """
    v = modulus_mg
    if not np.all(np.isfinite(v)):
        raise InputError("map holds non-finite values")
    w = np.repeat(row_weights, v.shape[1])
    return {
        "max": float(v.max()),
        "min": float(v.min()),
        "sw": float(row_weights @ v.sum(axis=1)),
        "sw2": float(row_weights @ (v * v).sum(axis=1)),
        "above": [float(row_weights @ (v > t).sum(axis=1)) for t in thresholds],
        "hist": _sparse(np.bincount(_hist_index(v.ravel()), weights=w, minlength=HIST_BINS)),
    }


def scalar_partial(v: np.ndarray, row_weights: np.ndarray) -> dict:
    """Partial statistics of a signed quantity on one block: extrema and weighted sums."""
    if not np.all(np.isfinite(v)):
        raise InputError("map holds non-finite values")
    return {
        "min": float(v.min()),
        "max": float(v.max()),
        "sw": float(row_weights @ v.sum(axis=1)),
        "sw2": float(row_weights @ (v * v).sum(axis=1)),
    }


def _sparse(h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(bins, weights) of the non-empty bins: a block touches few of them, and travels light."""
    nz = np.flatnonzero(h)
    return nz.astype(np.int32), h[nz]


def merge_partials(acc: dict | None, part: dict) -> dict:
    """Fold one block's partial statistics into the running total (call in block order)."""
    if "vars" in part:  # signed quantities: extrema and sums per variable
        if acc is None:
            return {"vars": {k: dict(v) for k, v in part["vars"].items()}}
        for k, p in part["vars"].items():
            a = acc["vars"][k]
            a["min"] = min(a["min"], p["min"])
            a["max"] = max(a["max"], p["max"])
            a["sw"] += p["sw"]
            a["sw2"] += p["sw2"]
        return acc
    if acc is None:
        acc = {**part, "above": list(part["above"]), "hist": np.zeros(HIST_BINS)}
        acc["hist"][part["hist"][0]] = part["hist"][1]
        return acc
    acc["max"] = max(acc["max"], part["max"])
    acc["min"] = min(acc["min"], part["min"])
    acc["sw"] += part["sw"]
    acc["sw2"] += part["sw2"]
    acc["above"] = [a + b for a, b in zip(acc["above"], part["above"])]
    acc["hist"][part["hist"][0]] += part["hist"][1]  # distinct bins: no repeated index
    return acc


def finish_statistics(acc: dict, total_weight: float, thresholds, percentiles) -> dict:
    """Statistics in the form of :func:`fieldmap.products.stats.map_statistics`.

    For the signed quantities: {variable: {"min", "max", "mean", "rms"}}, the form of
    :func:`fieldmap.products.quantity_maps.statistics_fields`.
    """
    from fieldmap.products.stats import threshold_key

    if "vars" in acc:
        return {
            k: {
                "min": a["min"],
                "max": a["max"],
                "mean": a["sw"] / total_weight,
                "rms": math.sqrt(a["sw2"] / total_weight),
            }
            for k, a in acc["vars"].items()
        }

    out = {
        "max_mg": acc["max"],
        "min_mg": acc["min"],
        "mean_mg": acc["sw"] / total_weight,
        "rms_mg": math.sqrt(acc["sw2"] / total_weight),
    }
    cw = np.cumsum(acc["hist"])
    for q in percentiles:
        k = int(np.searchsorted(cw, q / 100.0 * cw[-1], side="left"))
        k = min(k, HIST_BINS - 1)
        out[f"p{q:g}_mg"] = _bin_centre(k)
    out["area_fraction_above"] = {
        threshold_key(t): a / total_weight for t, a in zip(thresholds, acc["above"])
    }
    return out


class OrderedFold:
    """Fold partial statistics in block order whatever order they arrive in."""

    def __init__(self, nlayers: int):
        self.acc: list[dict | None] = [None] * nlayers
        self._next = 0
        self._waiting: dict[int, tuple[int, dict]] = {}

    def add(self, index: int, layer: int, part: dict) -> None:
        """Record block ``index``'s partial; fold every block now in sequence."""
        self._waiting[index] = (layer, part)
        while self._next in self._waiting:
            lay, p = self._waiting.pop(self._next)
            self.acc[lay] = merge_partials(self.acc[lay], p)
            self._next += 1


# ---------------------------------------------------------------------------- one block


@dataclasses.dataclass(frozen=True)
class Job:
    """Everything a worker needs for one block except the model (shipped once per worker)."""

    block: Block
    lat: np.ndarray  # the block's latitudes (deg)
    lon: np.ndarray
    height: float
    step_deg: float
    is_global: bool
    row_weights: np.ndarray
    ellipsoid: str
    device: str | None
    units: str
    thresholds: tuple
    store: Any = None  # a blockio.ZarrTarget when workers write, else None
    quantity: str = "disturbance"  # or a quantity of fieldmap.field.geodesy.grid_quantities
    degree0: bool = False  # keep the degree-0 term of T (quantities)


_WORKER_READY = False


def worker_setup() -> None:
    """Prepare a Dask worker process for the kernels (once per process; a no-op elsewhere).

    - Warp launches use the worker's share of the cores (``FIELDMAP_THREADS`` = its threads,
      unless set).
    - glibc's allocator gets back the dynamic thresholds of a plain process: Dask's nanny
      starts workers with ``MALLOC_TRIM_THRESHOLD_=65536``, which freezes the mmap threshold at
      128 KiB, so that every array of a block is a fresh ``mmap`` whose pages fault in on first
      touch. Measured here: a block's CPU time doubled (0.56 s -> 1.17 s for the blocks of a
      0.1 deg map). Large blocks are then served from the heap, as in the client process, and
      at most ``2 * 32 MiB`` of freed memory is kept before it is returned to the system.
    """
    global _WORKER_READY
    if _WORKER_READY:
        return
    try:
        from distributed import get_worker

        w = get_worker()
    except (ImportError, ValueError):
        return
    if "FIELDMAP_THREADS" not in os.environ:
        os.environ["FIELDMAP_THREADS"] = str(max(1, int(w.state.nthreads)))
    _glibc_thresholds(mmap_bytes=32 * 2**20)
    _WORKER_READY = True


def _glibc_thresholds(mmap_bytes: int) -> bool:
    """Set glibc's mmap and trim thresholds (``mallopt``); False where there is no glibc."""
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("c")
    if not name or not hasattr(os, "confstr"):
        return False
    try:
        if "glibc" not in (os.confstr("CS_GNU_LIBC_VERSION") or "").lower():
            return False
        libc = ctypes.CDLL(name)
    except (OSError, ValueError):
        return False
    m_trim_threshold, m_mmap_threshold = -1, -3  # <malloc.h>
    ok = libc.mallopt(m_mmap_threshold, ctypes.c_int(mmap_bytes))
    ok &= libc.mallopt(m_trim_threshold, ctypes.c_int(2 * mmap_bytes))
    return bool(ok)


def compute_block(job: Job, model) -> dict:
    """Synthesise one block; write it to the zarr store if ``job.store``, return the rest.

    Returns
    -------
    dict
        ``index``, ``layer``, ``rows``, ``partial`` (statistics) and ``data``: the variables
        {name: (nb, nlon) array} when the caller writes them, else only the boundary rows the
        workers cannot write alone (``blockio.ZarrTarget.write_block``).
    """
    from fieldmap.field.ellipsoid import get_ellipsoid
    from fieldmap.grids.spec import GridSpec
    from fieldmap.grids.synthesis import synthesize
    from fieldmap.products.cf import vector_vars

    worker_setup()
    ell = get_ellipsoid(job.ellipsoid)
    sub = GridSpec(
        lat=job.lat,
        lon=job.lon,
        heights=np.array([job.height]),
        step_deg=job.step_deg,
        is_global=job.is_global,
    )
    if job.quantity == "disturbance":
        vec = synthesize(model, sub, ell, "disturbance", job.device, progress=False)[0]
        # the variables of the in-memory map, by the same function (the same bits)
        data = {k: v[1] for k, v in vector_vars(vec, (), job.units, "", overwrite=True).items()}
        del vec
        partial = block_partial(data["modulus_mg"], job.row_weights, job.thresholds)
    else:
        from fieldmap.field.geodesy import grid_quantities

        vals = grid_quantities(
            model, sub, job.quantity, ellipsoid=ell, degree0=job.degree0, device=job.device
        )
        data = {k: v[0] for k, v in vals.items()}
        partial = {"vars": {k: scalar_partial(v, job.row_weights) for k, v in data.items()}}
    out = {"index": job.block.index, "layer": job.block.layer, "rows": job.block.rows}
    if job.store is not None:
        data = job.store.write_block(job.block, data)
    out["data"] = data
    out["partial"] = partial
    return out


# ---------------------------------------------------------------------------- executors


def parse_scheduler(text: str | None):
    """``None``/"threads" (local thread pool), ``("local", N)`` or a scheduler address."""
    if text is None or text in ("threads", "none", ""):
        return None
    if text.startswith("local:"):
        try:
            n = int(text.split(":", 1)[1])
        except ValueError:
            n = 0
        if n < 1:
            raise InputError(f"--scheduler local:N needs a worker count N >= 1, got {text!r}")
        return ("local", n)
    if text == "local":
        return ("local", max(1, os.cpu_count() or 1))
    return text


@contextlib.contextmanager
def open_client(scheduler, connect_timeout: float = 5.0) -> Iterator[object]:
    """Yield a ``dask.distributed.Client`` for a parsed scheduler; close what was opened.

    ``("local", N)`` starts a LocalCluster of N single-threaded worker processes on 127.0.0.1
    (no dashboard) and shuts it down afterwards; an address connects to a running scheduler.
    An unreachable scheduler is an :class:`InputError` (one line, CLI exit 2).
    """
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise InputError(
            "Dask is not installed: pip install 'fieldmap[distributed]' (dask[distributed], zarr)"
        ) from None
    import logging

    if isinstance(scheduler, tuple):
        n = scheduler[1]
        cores = max(1, os.cpu_count() or 1)
        cluster = LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address="127.0.0.1:0",
            silence_logs=logging.ERROR,
            env={"FIELDMAP_THREADS": str(max(1, cores // n))},
        )
        try:
            with Client(cluster) as client:
                yield client
        finally:
            cluster.close()
        return
    _probe(scheduler, connect_timeout)
    try:
        client = Client(scheduler, timeout=connect_timeout)
    except (OSError, TimeoutError, ValueError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"cannot reach the Dask scheduler at {scheduler!r}: {msg}") from None
    try:
        yield client
    finally:
        client.close()


def _probe(address: str, timeout: float) -> None:
    """Fail in milliseconds, not after Dask's connect retries, when nothing listens (tcp)."""
    import socket
    from urllib.parse import urlsplit

    if not isinstance(address, str) or not address.startswith("tcp://"):
        return
    try:
        u = urlsplit(address)
        host, port = u.hostname, u.port
    except ValueError:
        raise InputError(f"bad Dask scheduler address {address!r}") from None
    if host is None or port is None:
        raise InputError(f"Dask scheduler address {address!r} needs tcp://HOST:PORT")
    try:
        socket.create_connection((host, port), timeout=timeout).close()
    except OSError as exc:
        why = exc.strerror or type(exc).__name__
        raise InputError(f"cannot reach the Dask scheduler at {address!r}: {why}") from None


def _run_local(jobs, model, on_result, progress) -> None:
    from tqdm.auto import tqdm

    bar = tqdm(total=len(jobs), unit="block", desc="blocks", disable=_bar_off(progress))
    try:
        for job in jobs:
            on_result(compute_block(job, model))
            bar.update(1)
    finally:
        bar.close()


def _bar_off(progress):
    return (not progress) if progress is not None else None


def _run_dask(client, jobs, model, on_result, progress, window: int | None) -> None:
    """Submit the blocks to ``client`` (at most ``window`` in flight), handle results."""
    from distributed import as_completed
    from tqdm.auto import tqdm

    nworkers = max(1, len(client.scheduler_info(n_workers=-1).get("workers", {})))
    # the coefficients travel once to every worker, not once per task (nor per product)
    model_f = scattered(client, model)
    window = window or 4 * nworkers
    bar = tqdm(total=len(jobs), unit="block", desc="blocks (dask)", disable=_bar_off(progress))
    pending = iter(jobs)
    # a lost worker's tasks are rescheduled by Dask itself; an exception is not retried
    futures = [
        client.submit(compute_block, job, model_f, pure=False) for job in _take(pending, window)
    ]
    seq = as_completed(futures)
    try:
        for fut in seq:
            res = fut.result()
            fut.release()
            on_result(res)
            del res
            bar.update(1)
            for job in _take(pending, 1):
                futures.append(client.submit(compute_block, job, model_f, pure=False))
                seq.add(futures[-1])
    except BaseException:
        client.cancel(futures)
        raise
    finally:
        bar.close()


#: client -> {id(model): (weak reference to the model, its future on the cluster)}
_SCATTERED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def scattered(client, model):
    """Return the future of ``model`` broadcast to every worker of ``client``, once per client.

    Products made one after the other on the same client (a notebook, a study over several
    maps) reuse the copy the workers already hold: a degree-2190 model is 77 MB per worker.
    The copy lives as long as the model object and the client; a model that is garbage
    collected, or a client that is closed, releases it.
    """
    try:
        per_client = _SCATTERED.setdefault(client, {})
    except TypeError:  # a client that cannot be weakly referenced: no reuse
        return client.scatter(model, broadcast=True, hash=False)
    entry = per_client.get(id(model))
    if entry is not None and entry[0]() is model and entry[1].status == "finished":
        return entry[1]
    fut = client.scatter(model, broadcast=True, hash=False)
    key = id(model)

    def forget(_ref, key=key, per_client=per_client):
        old = per_client.pop(key, None)
        if old is not None:
            try:  # no module globals here: this may run at interpreter exit
                old[1].release()
            except Exception:  # the client may be closed by now
                pass

    try:
        per_client[key] = (weakref.ref(model, forget), fut)
    except TypeError:  # a model that cannot be weakly referenced: not kept
        pass
    return fut


def _take(it, n):
    out = []
    for _ in range(n):
        try:
            out.append(next(it))
        except StopIteration:
            break
    return out


# ---------------------------------------------------------------------------- products


def make_jobs(
    grid,
    blocks,
    ellipsoid,
    device,
    units,
    thresholds,
    store=None,
    quantity: str = "disturbance",
    degree0: bool = False,
) -> list[Job]:
    """One :class:`Job` per block."""
    from fieldmap.products.stats import area_weights

    aw = area_weights(grid.lat)
    return [
        Job(
            block=b,
            lat=grid.lat[b.rows],
            lon=grid.lon,
            height=float(grid.heights[b.layer]),
            step_deg=grid.step_deg,
            is_global=grid.is_global,
            row_weights=aw[b.rows],
            ellipsoid=ellipsoid,
            device=device,
            units=units,
            thresholds=tuple(thresholds),
            store=store,
            quantity=quantity,
            degree0=degree0,
        )
        for b in blocks
    ]


def run_blocks(
    grid,
    model,
    *,
    ellipsoid: str = "WGS84",
    device: str | None = None,
    units: str = "mGal",
    thresholds=(0.02, 0.05, 0.06, 0.10),
    percentiles=(50.0, 90.0, 99.0),
    rows_per_block: int | None = None,
    client=None,
    sink=None,
    store=None,
    progress: bool | None = None,
    window: int | None = None,
    quantity: str = "disturbance",
    degree0: bool = False,
) -> list[dict]:
    """Compute every block of a product; return the statistics per height.

    Parameters
    ----------
    grid : GridSpec
    model : SHModel
    client : dask.distributed.Client, optional
        Run the blocks on this cluster; default: here, one after the other.
    sink : callable, optional
        ``sink(block, data)`` receives every block's variables (or, with ``store``, the
        boundary rows the workers left), in completion order.
    store : blockio.ZarrTarget, optional
        Workers write their blocks straight into this zarr store.
    window : int, optional
        Blocks in flight on the cluster (default: four per worker), which bounds the memory.
    quantity : str
        ``"disturbance"`` (the vector, its modulus and the threshold statistics) or a quantity
        of :func:`fieldmap.field.geodesy.grid_quantities` (``degree0`` as there).

    Returns
    -------
    list of dict
        Per height, in the form of :func:`fieldmap.products.stats.map_statistics` (the
        disturbance) or {variable: {"min", "max", "mean", "rms"}} (the quantities).
    """
    from fieldmap.products.stats import area_weights

    blocks = plan_blocks(grid, model.lmax, rows_per_block)
    jobs = make_jobs(grid, blocks, ellipsoid, device, units, thresholds, store, quantity, degree0)
    fold = OrderedFold(grid.heights.size)

    def on_result(res):
        if sink is not None:
            sink(blocks[res["index"]], res["data"])
        fold.add(res["index"], res["layer"], res["partial"])

    if client is None:
        _run_local(jobs, model, on_result, progress)
    else:
        _run_dask(client, jobs, model, on_result, progress, window)
    total = float(area_weights(grid.lat).sum()) * grid.lon.size
    stats = []
    for a in fold.acc:
        if a is None:  # every height has blocks: a missing one is a bug, never silent
            raise RuntimeError("a height of the plan received no block")
        stats.append(finish_statistics(a, total, thresholds, percentiles))
    return stats

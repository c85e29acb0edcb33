"""Block engine: map products computed block by block, locally or on a Dask cluster.

A product (a disturbance or quantity map, at one height or a sweep) is split into blocks of
latitude rows at one height. A block holds whole mirror units of
:func:`fieldmap.grids.synthesis.mirror_pairs` (a row and its mirror at minus the latitude share
one Legendre recursion), grouped exactly as :func:`fieldmap.grids.synthesis.synthesize` groups
them, and is computed by ``synthesize`` on the sub-grid of its rows. The plan depends only on
the grid and ``rows_per_block``, never on the executor, so a product is bitwise the same whether
its blocks run here one after the other (each on every core through the Warp thread pool), on
``local:N`` worker processes, or on a remote cluster; a block that is run again after a worker
died gives the same bits.

Statistics are combined from per-block partial results in block order, so exactly the same on
every executor (:mod:`fieldmap.products.blockstats`); the Dask side (connecting, starting a
LocalCluster, preparing the workers, shipping the model once) is :mod:`fieldmap.products.cluster`.

Memory: one block of ``nb`` rows and ``nlon`` longitudes takes about ``nb * (per_item + 104 *
nlon)`` bytes on the process computing it (``per_item`` of ``synthesize``: Fourier coefficients
and FFT work arrays, ``nm * 144 + nlon * 144`` bytes for ``nm = lmax + 1``; 104 = the five output
variables and the vector), plus the model (``16 * nm**2`` bytes) and the interpreter (~0.3 GB);
see :func:`block_bytes`. The client holds at most ``window`` blocks (NetCDF) or only their
boundary rows and statistics (zarr). Nothing is proportional to the grid but the row weights.

Writing (:mod:`fieldmap.products.blockio`): zarr stores are written by the workers in parallel;
NetCDF-4 files by one writer, the client, as blocks arrive (HDF5 has no safe parallel writer
without MPI). Both go to a temporary name renamed at the end. A product returned in memory is
written by workers of the client's machine into shared memory, else sent back to the client.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from typing import Any

import numpy as np

from fieldmap.errors import InputError
from fieldmap.products.blockstats import (
    OrderedFold,
    disturbance_partial,
    finish_statistics,
    scalar_partial,
)
from fieldmap.products.cluster import scattered, worker_setup

__all__ = [
    "Block",
    "block_bytes",
    "compute_block",
    "make_jobs",
    "plan_blocks",
    "run_blocks",
]

#: Blocks per height of the default plan (at least; more where memory asks for it).
BLOCKS_PER_HEIGHT = 32
#: The same, for blocks computed here into memory or a NetCDF file: each block is one
#: synthesis (its own launches, uploads and Python set-up), and the grid kernel and the FFTs
#: already spread a block over the cores, so one block per height (as large as the memory
#: budget allows) costs least; any plan gives the same bits.
LOCAL_BLOCKS_PER_HEIGHT = 1
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


def plan_blocks(
    grid,
    lmax: int,
    rows_per_block: int | None = None,
    *,
    blocks_per_height: int = BLOCKS_PER_HEIGHT,
) -> list[Block]:
    """Split a grid into blocks of whole mirror units, height by height.

    Parameters
    ----------
    grid : fieldmap.grids.spec.GridSpec
    lmax : int
        Degree of the synthesis (for the default block size).
    rows_per_block : int, optional
        Most rows per block (a mirrored pair counts two; at least 2). Default: the smaller of
        what :func:`fieldmap.grids.synthesis.synthesize` keeps in one block
        (``BLOCK_BYTES / per_item``) and ``nlat / blocks_per_height`` rounded up to a multiple
        of 8 rows (whole groups of the grid kernel).
    blocks_per_height : int
        Blocks per height of the default size (:data:`BLOCKS_PER_HEIGHT`).

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
        want = 8 * math.ceil(nlat / blocks_per_height / 8)
        rows_per_block = max(1, min(BLOCK_BYTES // per, want))
    else:
        try:
            rows_per_block = int(rows_per_block)
        except (TypeError, ValueError):
            raise InputError(f"rows per block must be an integer, got {rows_per_block!r}") from None
        if rows_per_block < 1:
            raise InputError(f"rows per block must be >= 1, got {rows_per_block}")
    size = max(2, min(nlat, rows_per_block))
    if size >= nlat:  # one block per height holds every row (what the grouping gives)
        return [Block(k, k, np.arange(nlat, dtype=np.int64)) for k in range(nh)]
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


#: Grids of at least this many nodes (all heights together; a 0.1° global map has 5.8e6) show
#: a progress bar on a terminal by default: they take seconds to compute and longer to write.
PROGRESS_NODES = 2_000_000


def show_progress(nodes: int, progress: bool | None = None) -> bool:
    """Whether to show a progress bar (on stderr) for a product of ``nodes`` grid nodes.

    ``progress`` True or False decides; None (the default of every product) shows one for
    grids of at least :data:`PROGRESS_NODES` nodes when stderr is a terminal, never in a pipe,
    a file or a test.
    """
    if progress is not None:
        return bool(progress)
    return nodes >= PROGRESS_NODES and sys.stderr.isatty()


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
    hist_weights: np.ndarray
    ellipsoid: str
    device: str | None
    units: str
    thresholds: tuple
    store: Any = None  # a blockio.ZarrTarget when workers write, else None
    quantity: str = "disturbance"  # or a quantity of products.quantity_product.VARIABLES
    degree0: bool = False  # keep the degree-0 term of T (quantities)


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
        # converted in place and reduced in one pass (vector_vars and block_partial, same bits)
        data, partial = disturbance_partial(
            vec, job.units, job.row_weights, job.thresholds, job.hist_weights
        )
    else:
        from fieldmap.products.quantity_product import GRADIENT_QUANTITIES, SIGMA_QUANTITIES

        if job.quantity in GRADIENT_QUANTITIES:
            from fieldmap.field.gradient import grid_gradient

            vals = grid_gradient(model, sub, job.quantity, ellipsoid=ell, device=job.device)
        elif job.quantity in SIGMA_QUANTITIES:
            from fieldmap.field.commission_grid import grid_commission

            vals = grid_commission(model, sub, job.quantity, ellipsoid=ell)
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


def _run_local(jobs, model, on_result, progress) -> None:
    from tqdm.auto import tqdm

    if _bar_off(progress):  # no bar object: it costs as much as a small map's statistics
        for job in jobs:
            on_result(compute_block(job, model))
        return
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
    from fieldmap.products.blockstats import histogram_weights
    from fieldmap.products.stats import area_weights

    aw = area_weights(grid.lat)
    hw = histogram_weights(aw, grid.lon.size)
    return [
        Job(
            block=b,
            lat=grid.lat[b.rows],
            lon=grid.lon,
            height=float(grid.heights[b.layer]),
            step_deg=grid.step_deg,
            is_global=grid.is_global,
            row_weights=aw[b.rows],
            hist_weights=hw[b.rows],
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

    local = client is None and store is None  # here, into memory or a NetCDF file
    blocks = plan_blocks(
        grid,
        model.lmax,
        rows_per_block,
        blocks_per_height=LOCAL_BLOCKS_PER_HEIGHT if local else BLOCKS_PER_HEIGHT,
    )
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

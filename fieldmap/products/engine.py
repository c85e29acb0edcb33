"""The block engine: every map product, planned in blocks of rows, run here, on Dask or lazily.

A product (a disturbance or quantity map, a truncation or component map, at one height or a
sweep) is split into blocks of latitude rows at one layer (a height, or an order of the
truncation map). A block holds whole mirror units of
:func:`fieldmap.grids.synthesis.mirror_pairs` (a row and its mirror at minus the latitude share
one Legendre recursion), grouped exactly as :func:`fieldmap.grids.synthesis.synthesize` groups
them, and is computed by ``synthesize`` on the sub-grid of its rows (:func:`compute_block`).
The plan (:func:`plan_blocks`) depends only on the grid and ``rows_per_block``, never on the
executor, so a product is bitwise the same whether its blocks run here one after the other
(each on every core through the Warp thread pool), on ``local:N`` worker processes, on a remote
cluster, or lazily when a dask-backed Dataset is read; a block that is run again after a worker
died gives the same bits.

The engine takes one :class:`fieldmap.products.request._Request` (validated at its
construction, trusted here): :func:`compute` returns the product in memory, :func:`lazy`
a dask-backed Dataset; :func:`write_product` streams it to a NetCDF file or zarr store
(the targets of :mod:`fieldmap.products.sinks`).

Statistics are combined from per-block partial results in block order, so exactly the same on
every executor (:mod:`fieldmap.products.statistics`). The Dask cluster itself (scheduler
strings, clients, worker set-up, the model shipped once per worker) is :mod:`fieldmap.cluster`,
which the navigation studies share.

Memory: one block of ``nb`` rows and ``nlon`` longitudes takes about ``nb * (per_item + 104 *
nlon)`` bytes on the process computing it (``per_item`` of ``synthesize``: Fourier coefficients
and FFT work arrays, ``nm * 144 + nlon * 144`` bytes for ``nm = lmax + 1``; 104 = the five output
variables and the vector), plus the model (``16 * nm**2`` bytes) and the interpreter (~0.3 GB);
see :func:`block_bytes`. The client holds at most ``window`` blocks (NetCDF) or only their
boundary rows and statistics (zarr). Nothing is proportional to the grid but the row weights.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import os
import sys
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
import xarray as xr

from fieldmap.errors import InputError
from fieldmap.grids.spec import GridSpec
from fieldmap.products.sinks import memory_target
from fieldmap.products.statistics import (
    OrderedFold,
    finish_statistics,
)
from fieldmap.products.variables import Template, index_height_km

if TYPE_CHECKING:
    from fieldmap.field.ellipsoid import Ellipsoid
    from fieldmap.models.shmodel import SHModel

#: Blocks per height of the default plan (at least; more where memory asks for it).
BLOCKS_PER_HEIGHT = 32
#: The same, for blocks computed here into memory or a NetCDF file: each block is one
#: synthesis (its own launches, uploads and Python set-up), and the grid kernel and the FFTs
#: already spread a block over the cores, so one block per height (as large as the memory
#: budget allows) costs least; any plan gives the same bits.
LOCAL_BLOCKS_PER_HEIGHT = 1


class _Request(Protocol):
    """What the engine reads of a :class:`fieldmap.products.request.MapRequest`.

    (A protocol, not that class: the request module imports the engine.)
    """

    @property
    def model(self) -> Any: ...
    @property
    def grid(self) -> GridSpec: ...
    @property
    def ellipsoid(self) -> Ellipsoid: ...
    @property
    def output(self) -> Any: ...
    @property
    def execution(self) -> Any: ...


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
    grid: GridSpec,
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
    """Everything a worker needs for one block except the model (shipped once per worker).

    Attributes
    ----------
    block : Block
    grid : GridSpec
        The block's rows (latitudes, all longitudes) at its one height.
    weights : (numpy.ndarray, numpy.ndarray)
        Area weights of its rows and their whole-number histogram weights.
    output : fieldmap.products.request.Output
        What the product holds (quantity, units, thresholds, degree0).
    ellipsoid : str
    device : str or None
    order : int
        The J2n order of a truncation map's layer (0 otherwise).
    store : fieldmap.products.sinks.ZarrTarget, optional
        Where the worker writes its block (zarr), else None.
    """

    block: Block
    grid: GridSpec
    weights: tuple[np.ndarray, np.ndarray]
    output: Any
    ellipsoid: str
    device: str | None
    order: int = 0
    store: Any = None

    @property
    def quantity(self) -> str:
        """The product's quantity (``"disturbance"``, ``"truncation"``...)."""
        return str(self.output.quantity)

    @property
    def thresholds(self) -> tuple:
        """Thresholds of the area fractions (mg): those of the layout's statistics."""
        from fieldmap.products.layouts import layout_of

        return layout_of(self.quantity).thresholds(self.output)


def compute_block(job: Job, model: SHModel | None) -> dict[str, Any]:
    """Synthesise one block; write it to the zarr store if ``job.store``, return the rest.

    The quantity's entry (:mod:`fieldmap.products.quantities`) computes the block's terms, its
    layout (:mod:`fieldmap.products.layouts`) turns them into variables and statistics.

    Returns
    -------
    dict
        ``index``, ``layer``, ``rows``, ``partial`` (statistics) and ``data``: the variables
        {name: (nb, nlon) array} when the caller writes them, else only the boundary rows the
        workers cannot write alone (:meth:`fieldmap.products.sinks.ZarrTarget.write_block`).
    """
    from fieldmap.field.ellipsoid import get_ellipsoid
    from fieldmap.products.layouts import layout_of
    from fieldmap.products.quantities import quantity

    if "distributed" in sys.modules:  # a Dask worker; a process without Dask is none
        from fieldmap.cluster import worker_setup

        worker_setup()
    q = quantity(job.quantity)
    terms = q.synthesis(model, job, get_ellipsoid(job.ellipsoid))
    data, partial = layout_of(q).block(job, terms)
    out = {"index": job.block.index, "layer": job.block.layer, "rows": job.block.rows}
    if job.store is not None:
        data = job.store.write_block(job.block, data)
    out["data"] = data
    out["partial"] = partial
    return out


# ---------------------------------------------------------------------------- executors


def _run_local(
    jobs: list[Job],
    model: SHModel | None,
    on_result: Callable[[dict[str, Any]], None],
    progress: bool | None,
) -> None:
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


def _bar_off(progress: bool | None) -> bool | None:
    return (not progress) if progress is not None else None


def _run_dask(
    client: Any,
    jobs: list[Job],
    model: SHModel | None,
    on_result: Callable[[dict[str, Any]], None],
    progress: bool | None,
    window: int | None,
) -> None:
    """Submit the blocks to ``client`` (at most ``window`` in flight), handle results."""
    from distributed import as_completed
    from tqdm.auto import tqdm

    from fieldmap.cluster import scattered

    nworkers = max(1, len(client.scheduler_info(n_workers=-1).get("workers", {})))
    # the coefficients travel once to every worker, not once per task (nor per product)
    model_f = scattered(client, model) if model is not None else None
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


def _take(it: Iterator[Job], n: int) -> list[Job]:
    out = []
    for _ in range(n):
        try:
            out.append(next(it))
        except StopIteration:
            break
    return out


# ---------------------------------------------------------------------------- products


def product_grid(request: _Request) -> GridSpec:
    """Return the grid the blocks cover: one layer per order for a truncation map.

    A layer is a height of the grid; the orders of a truncation map (one height) are its
    layers, each at that height.
    """
    from fieldmap.products.layouts import layout_of

    return layout_of(request.output.quantity).grid(request)


def plan(request: _Request, local: bool = True) -> list[Block]:
    """Return the blocks of a request's product (:func:`plan_blocks` of its grid).

    ``local``: the blocks run here into memory or a NetCDF file (the fewest blocks), else on a
    cluster or into a zarr store (:data:`BLOCKS_PER_HEIGHT` at least).
    """
    lmax = request.model.lmax if request.model is not None else 2
    return plan_blocks(
        product_grid(request),
        lmax,
        request.execution.rows_per_block,
        blocks_per_height=LOCAL_BLOCKS_PER_HEIGHT if local else BLOCKS_PER_HEIGHT,
    )


def make_jobs(request: _Request, blocks: list[Block], store: Any = None) -> list[Job]:
    """One :class:`Job` per block of a request's product (``store``: workers write there)."""
    from fieldmap.products.layouts import layout_of
    from fieldmap.products.statistics import area_weights, histogram_weights

    grid = product_grid(request)
    out = request.output
    layout = layout_of(out.quantity)
    aw = area_weights(grid.lat)
    hw = histogram_weights(aw, grid.lon.size)
    return [
        Job(
            block=b,
            grid=dataclasses.replace(
                grid, lat=grid.lat[b.rows], heights=np.array([float(grid.heights[b.layer])])
            ),
            weights=(aw[b.rows], hw[b.rows]),
            output=out,
            ellipsoid=request.ellipsoid.name,
            device=request.execution.device,
            order=layout.order(out, b.layer),
            store=store,
        )
        for b in blocks
    ]


def run_blocks(
    request: _Request,
    *,
    client: Any = None,
    sink: Any = None,
    store: Any = None,
    progress: bool | None = None,
) -> list[dict[str, Any]]:
    """Compute every block of a request's product; return the statistics per layer.

    Parameters
    ----------
    request : fieldmap.products.request._Request
    client : dask.distributed.Client, optional
        Run the blocks on this cluster (the request's executor, opened); default: here, one
        after the other. At most ``request.execution.window`` blocks are in flight (default:
        four per worker), which bounds the memory.
    sink : callable, optional
        ``sink(block, data)`` receives every block's variables (or, with ``store``, the
        boundary rows the workers left), in completion order.
    store : fieldmap.products.sinks.ZarrTarget, optional
        Workers write their blocks straight into this zarr store.
    progress : bool, optional
        Progress bar (default: the request's).

    Returns
    -------
    list of dict
        Per layer, in the form of :func:`fieldmap.products.statistics.map_statistics` (the
        disturbance and the truncation) or {variable: {"min", "max", "mean", "rms"}} (the
        quantities).
    """
    from fieldmap.products.statistics import DEFAULT_PERCENTILES, area_weights

    grid = product_grid(request)
    model = request.model
    local = client is None and store is None  # here, into memory or a NetCDF file
    blocks = plan(request, local)
    jobs = make_jobs(request, blocks, store)
    fold = OrderedFold(grid.heights.size)
    progress = request.execution.progress if progress is None else progress

    def on_result(res: dict[str, Any]) -> None:
        if sink is not None:
            sink(blocks[res["index"]], res["data"])
        fold.add(res["index"], res["layer"], res["partial"])

    if client is None:
        _run_local(jobs, model, on_result, progress)
    else:
        _run_dask(client, jobs, model, on_result, progress, request.execution.window)
    total = float(area_weights(grid.lat).sum()) * grid.lon.size
    stats = []
    for a in fold.acc:
        if a is None:  # every height has blocks: a missing one is a bug, never silent
            raise RuntimeError("a height of the plan received no block")
        stats.append(finish_statistics(a, total, jobs[0].thresholds, DEFAULT_PERCENTILES))
    return stats


def _chunk_rows(chunks: Any) -> Any:
    if isinstance(chunks, dict):
        chunks = chunks.get("latitude")
    return None if chunks in (None, True, "auto") else chunks


def lazy(request: _Request) -> xr.Dataset:
    """Return a lazy, dask-backed Dataset of the request's product; blocks run when read.

    ``request.execution.chunks``: most latitude rows per block (int, or {"latitude": n});
    "auto"/True: the default plan. The latitude chunks of the arrays are the runs of rows of
    the blocks; both runs of a block come from one task; with a Dask client as executor the
    blocks run on that cluster. The values, once computed, are those of :func:`compute` bit
    for bit; the statistics are not in the attributes (they need the whole map): compute them
    from the data, or stream the product with :func:`fieldmap.products.engine.write_product`.
    """
    import dask
    import dask.array as da

    from fieldmap.cluster import scattered
    from fieldmap.products.layouts import layout_of

    grid, mod, client = request.grid, request.model, request.execution.client
    tmpl = template(request)
    blocks = plan_blocks(grid, mod.lmax, _chunk_rows(request.execution.chunks))
    jobs = make_jobs(request, blocks)
    model_d = scattered(client, mod) if client is not None else mod
    model_d = dask.delayed(model_d) if client is None else model_d
    results = [dask.delayed(compute_block, pure=True)(job, model_d) for job in jobs]
    nh, nlat, nlon = grid.shape
    pieces = {}  # (layer, r0) -> (block result, offset in block, r1)
    for b, res in zip(blocks, results):
        off = 0
        for r0, r1 in b.runs():
            pieces[(b.layer, r0)] = (res, off, r1)
            off += r1 - r0

    def column(name: str, layer: int) -> Any:
        parts, r = [], 0
        while r < nlat:
            res, off, r1 = pieces[(layer, r)]
            part = dask.delayed(_rows)(res, name, off, off + r1 - r)
            parts.append(da.from_delayed(part, shape=(r1 - r, nlon), dtype=np.float64))
            r = r1
        return da.concatenate(parts, axis=0)

    ds = tmpl.skeleton()
    for name, va in tmpl.variables.items():
        cols = [column(name, k) for k in range(nh)]
        ds[name] = (tmpl.dims, da.stack(cols) if tmpl.stacked else cols[0], va)
    ds.attrs.update(layout_of(request.output.quantity).lazy_attrs(request))
    return index_height_km(ds)


def _rows(res: dict, name: str, a: int, b: int) -> np.ndarray:
    return res["data"][name][a:b]


# ---------------------------------------------------------------------------- in memory


@contextlib.contextmanager
def executor_client(request: _Request) -> Iterator[Any]:
    """Yield the Dask client of a request's executor (None: here); close what was opened.

    A scheduler string is connected (or its LocalCluster started) before anything runs: an
    unreachable scheduler computes and writes nothing.
    """
    ex = request.execution
    if ex.client is not None:
        yield ex.client
    elif ex.scheduler is None:  # here
        yield None
    else:
        from fieldmap.cluster import open_client

        with open_client(ex.scheduler) as c:
            yield c


def template(request: _Request) -> Template:
    """Return the request's product without data: coordinates, attributes, variables, dims.

    Built by the layout of the request's quantity (:mod:`fieldmap.products.layouts`) from the
    quantity's entry (:mod:`fieldmap.products.quantities`).
    """
    from fieldmap.products.layouts import layout_of

    return layout_of(request.output.quantity).template(request)


def compute(request: _Request) -> xr.Dataset:
    """Compute a request's product and return it whole, statistics included (or lazy).

    The blocks run on the request's executor, into memory; with ``execution.chunks`` the
    result is :func:`lazy`. The statistics are folded from the blocks' partial results in
    block order (the same bits on every executor); ``percentile_method="exact"`` and the
    truncation map take them from the whole arrays. Warns (:class:`fieldmap.errors.UnitWarning`)
    of a disturbance map that looks like a unit typed wrong (:mod:`fieldmap.products.unit_hints`).
    """
    from fieldmap.grids.spec import check_memory
    from fieldmap.products.layouts import layout_of
    from fieldmap.products.quantities import quantity

    if request.execution.chunks is not None:
        return lazy(request)
    out = request.output
    q = quantity(out.quantity)
    layout = layout_of(q)
    grid = product_grid(request)
    check_memory(request.grid, layers=grid.heights.size // request.grid.heights.size)
    progress = show_progress(int(np.prod(grid.shape)), request.execution.progress)
    with (
        executor_client(request) as c,
        memory_target(grid, layout.stacked(out), q.names, c) as (sink, store, arrays),
    ):
        stats = run_blocks(request, client=c, sink=sink, store=store, progress=progress)
        values = arrays()
    _hints(request, stats)
    return layout.assemble(request, values, stats)


def _hints(request: _Request, stats: list[dict[str, Any]]) -> None:
    """Warn of a disturbance map or sweep that looks like a unit typed wrong."""
    if request.output.quantity == "disturbance":
        from fieldmap.products.unit_hints import check_disturbance

        check_disturbance(stats, request.output.thresholds_mg, request.grid.heights)


# ---------------------------------------------------------------------------- to a store

FORMATS = ("netcdf", "zarr")


def check_format(fmt: Any) -> str:
    """Return ``fmt`` if it is a store format (:data:`FORMATS`), else raise InputError."""
    if fmt not in FORMATS:
        raise InputError(f"format must be one of {', '.join(FORMATS)}, got {fmt!r}")
    return fmt


def write_product(
    request: _Request, path: str | os.PathLike[str], fmt: str = "netcdf", *, atomic: bool = True
) -> dict[str, Any]:
    """Compute a request's product block by block and stream it to ``path``.

    Everything the product is (model, degree, heights, grid, ellipsoid, units, thresholds,
    quantity) comes from ``request``, validated at its construction; nothing else is taken.

    Parameters
    ----------
    request : fieldmap.products.request._Request
        A disturbance map or sweep, or a quantity map; its executor runs the blocks (a Dask
        client, ``"local:N"``, an address; none: here, one after the other), at most
        ``execution.window`` in flight.
    path : str or os.PathLike
        Final name of the NetCDF file or zarr folder; it appears only when complete.
    fmt : {"netcdf", "zarr"}
        NetCDF-4 (zlib, one writer: the client) or zarr (written by the workers).
    atomic : bool
        Write to a temporary name renamed at the end (default); False when ``path`` is already
        a temporary name of the caller's.

    Returns
    -------
    dict
        ``stats`` (a disturbance: a list per height in the form of
        :func:`fieldmap.products.statistics.map_statistics`; a quantity: {variable:
        [statistics per height]}), ``grid``, ``model`` (name, lmax) and ``path``.
    """
    from fieldmap.products import sinks
    from fieldmap.products.io import writing
    from fieldmap.products.layouts import layout_of

    check_format(fmt)
    out, grid, mod = request.output, request.grid, request.model
    layout = layout_of(out.quantity)
    if not layout.streamable:
        raise InputError(f"a {out.quantity} map is computed in memory: it is not streamed")
    if out.percentile_method != "histogram":
        raise InputError(
            f"percentile_method {out.percentile_method!r} needs the whole map in memory: "
            "a streamed product takes the histogram percentiles"
        )
    tmpl = template(request)
    place = sinks.atomic_store(path) if atomic else contextlib.nullcontext(path)
    # connect (or start the local cluster) before anything is written
    with executor_client(request) as c, writing(path), place as tmp:
        writer = None
        try:
            if fmt == "zarr":
                blocks = plan(request, local=False)
                target = sinks.create_zarr(str(tmp), tmpl, grid, max(b.rows.size for b in blocks))
                sink, store = target.sink, target
            else:
                writer = sinks.NetCDFWriter(str(tmp), tmpl, grid)
                sink, store = writer.sink, None
            stats = run_blocks(request, client=c, sink=sink, store=store)
            attrs, extra, var_attrs = layout.streamed_statistics(request, tmpl, stats)
            if fmt == "zarr":
                target.check_complete()
                sinks.finish_zarr(str(tmp), attrs, extra, var_attrs)
            else:
                assert writer is not None  # opened above for the netcdf format
                writer.finish(attrs, extra, var_attrs)
        finally:
            if writer is not None:
                writer.close()
    _hints(request, stats)
    return {
        "stats": layout.statistics(stats),
        "grid": grid,
        "model": (mod.name, mod.lmax),
        "path": path,
    }

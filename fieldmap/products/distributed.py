"""Map products on the block engine: in memory, lazy (dask-backed) or streamed to a store.

:func:`fieldmap.products.maps.disturbance_map`, :func:`~fieldmap.products.maps.altitude_sweep`
and :func:`~fieldmap.products.maps.truncation_map` route here when given ``client=`` (a
``dask.distributed.Client``), ``scheduler=`` (``"local:N"`` or an address) or ``chunks=``;
``fieldmap map|sweep --scheduler ... --format netcdf|zarr`` uses :func:`write_disturbance`,
which streams blocks to the store so that no process holds the whole product.
"""

from __future__ import annotations

import contextlib

import numpy as np
import xarray as xr

from fieldmap.errors import InputError
from fieldmap.products import blockio, blocks

__all__ = [
    "disturbance_blocks",
    "lazy_disturbance",
    "normal_rows_on",
    "route",
    "write_disturbance",
]

FORMATS = ("netcdf", "zarr")


def prepare(model, lmax, heights_m, step_deg, lat_max, region, ellipsoid, device, epoch, units):
    """Validate grid (not whole in memory), ellipsoid and device; load the model."""
    from fieldmap.field.ellipsoid import get_ellipsoid
    from fieldmap.grids.spec import make_grid
    from fieldmap.grids.synthesis import resolve_device
    from fieldmap.models.registry import load_model
    from fieldmap.units import get_unit

    get_unit(units)  # InputError naming the accepted spellings
    grid = make_grid(step_deg, lat_max, region, heights_m, whole_in_memory=False)
    try:
        ell = get_ellipsoid(ellipsoid)
    except (KeyError, ValueError) as exc:
        raise InputError(f"unknown ellipsoid {ellipsoid!r}") from exc
    if device is not None:
        resolve_device(device)  # checked here; each worker resolves it again for itself
    mod = load_model(model, lmax=lmax, epoch=epoch)
    return grid, ell, mod


@contextlib.contextmanager
def _client(client, scheduler):
    if client is not None:
        yield client
    elif scheduler is not None:
        parsed = blocks.parse_scheduler(scheduler)
        if parsed is None:
            yield None
        else:
            with blocks.open_client(parsed) as c:
                yield c
    else:
        yield None


def disturbance_blocks(
    model="eigen-6s",
    lmax=None,
    heights_m=(20000.0,),
    step_deg=1.0,
    lat_max=80.0,
    region=None,
    thresholds_mg=(0.02, 0.05, 0.06, 0.10),
    device=None,
    ellipsoid="WGS84",
    epoch=None,
    units="mGal",
    progress=None,
    *,
    stacked: bool,
    client=None,
    scheduler=None,
    rows_per_block=None,
) -> xr.Dataset:
    """Disturbance map (``stacked=False``) or sweep computed on the block engine, in memory.

    Same Dataset as :func:`fieldmap.products.maps.disturbance_map` /
    :func:`~fieldmap.products.maps.altitude_sweep`; statistics from the block partials
    (percentiles within :data:`fieldmap.products.blocks.PERCENTILE_RTOL`).
    """
    from fieldmap.grids.spec import check_memory
    from fieldmap.products.stats import parse_thresholds

    thresholds = parse_thresholds(thresholds_mg)
    grid, ell, mod = prepare(
        model, lmax, heights_m, step_deg, lat_max, region, ellipsoid, device, epoch, units
    )
    check_memory(grid)  # the result is returned whole
    tmpl = blockio.template(mod, grid, ell, units, thresholds, stacked)
    mem = blockio.MemorySink(grid, stacked)
    with _client(client, scheduler) as c:
        stats = blocks.run_blocks(
            grid,
            mod,
            ellipsoid=ell.name,
            device=device,
            units=units,
            thresholds=thresholds,
            rows_per_block=rows_per_block,
            client=c,
            sink=mem.sink,
            progress=progress,
        )
    return _assemble(tmpl, mem.arrays, stats, thresholds, stacked)


def _assemble(tmpl, arrays, stats, thresholds, stacked) -> xr.Dataset:
    ds = tmpl.copy()
    var_attrs = ds.attrs.pop("variables")
    dims = ds.attrs.pop("dims")
    for name in blockio.VARIABLES:
        ds[name] = (dims, arrays[name], var_attrs[name])
    if stacked:
        for name, var in blockio.sweep_statistics(stats, thresholds).items():
            ds[name] = var
    else:
        ds.attrs.update(blockio.map_attrs(stats[0], thresholds))
    return ds


def write_disturbance(
    path,
    fmt: str = "netcdf",
    model="eigen-6s",
    lmax=None,
    heights_m=(20000.0,),
    step_deg=1.0,
    lat_max=80.0,
    region=None,
    thresholds_mg=(0.02, 0.05, 0.06, 0.10),
    device=None,
    ellipsoid="WGS84",
    epoch=None,
    units="mGal",
    progress=None,
    *,
    stacked: bool,
    client=None,
    scheduler=None,
    rows_per_block=None,
    window=None,
    setup=None,
    atomic: bool = True,
) -> dict:
    """Compute a disturbance map or sweep block by block and stream it to ``path``.

    Parameters
    ----------
    path : str or os.PathLike
        Final name of the NetCDF file or zarr folder; it appears only when complete.
    fmt : {"netcdf", "zarr"}
        NetCDF-4 (zlib, one writer: the client) or zarr (written by the workers).
    client, scheduler
        A ``dask.distributed.Client``, or ``"local:N"`` / a scheduler address; neither: the
        blocks run here one after the other.
    setup : (grid, ellipsoid, model), optional
        Already validated and loaded (the CLI does it once).
    atomic : bool
        Write to a temporary name renamed at the end (default); False when ``path`` is already
        a temporary name of the caller's.

    Returns
    -------
    dict
        ``stats`` (list per height, :func:`fieldmap.products.stats.map_statistics` form),
        ``grid``, ``model`` (name, lmax) and ``path``.
    """
    from fieldmap.products.stats import parse_thresholds

    if fmt not in FORMATS:
        raise InputError(f"format must be one of {', '.join(FORMATS)}, got {fmt!r}")
    thresholds = parse_thresholds(thresholds_mg)
    if setup is None:
        setup = prepare(
            model, lmax, heights_m, step_deg, lat_max, region, ellipsoid, device, epoch, units
        )
    grid, ell, mod = setup
    tmpl = blockio.template(mod, grid, ell, units, thresholds, stacked)
    place = blockio.atomic_store(path) if atomic else contextlib.nullcontext(path)
    # connect (or start the local cluster) before anything is written
    with _client(client, scheduler) as c, place as tmp:
        writer = None
        try:
            if fmt == "zarr":
                plan = blocks.plan_blocks(grid, mod.lmax, rows_per_block)
                target = blockio.create_zarr(str(tmp), tmpl, grid, max(b.rows.size for b in plan))
                sink, store = target.sink, target
            else:
                writer = blockio.NetCDFWriter(str(tmp), tmpl, grid)
                sink, store = writer.sink, None
            stats = blocks.run_blocks(
                grid,
                mod,
                ellipsoid=ell.name,
                device=device,
                units=units,
                thresholds=thresholds,
                rows_per_block=rows_per_block,
                client=c,
                sink=sink,
                store=store,
                progress=progress,
                window=window,
            )
            if stacked:
                attrs, extra = {}, blockio.sweep_statistics(stats, thresholds)
            else:
                attrs, extra = blockio.map_attrs(stats[0], thresholds), None
            if fmt == "zarr":
                blockio.finish_zarr(str(tmp), attrs, extra)
            else:
                assert writer is not None  # opened above for the netcdf format
                writer.finish(attrs, extra)
        finally:
            if writer is not None:
                writer.close()
    return {"stats": stats, "grid": grid, "model": (mod.name, mod.lmax), "path": path}


def lazy_disturbance(
    model="eigen-6s",
    lmax=None,
    heights_m=(20000.0,),
    step_deg=1.0,
    lat_max=80.0,
    region=None,
    thresholds_mg=(0.02, 0.05, 0.06, 0.10),
    device=None,
    ellipsoid="WGS84",
    epoch=None,
    units="mGal",
    *,
    stacked: bool,
    chunks=None,
    client=None,
) -> xr.Dataset:
    """Return a lazy, dask-backed disturbance Dataset; blocks are computed when the data is read.

    ``chunks``: most latitude rows per block (int, or {"latitude": n}); "auto"/True: the
    default plan. The latitude chunks of the arrays are the runs of rows of the blocks; both
    runs of a block come from one task. Statistics are not in the attributes (they need the
    whole map): compute them from ``ds.modulus_mg`` or write with :func:`write_disturbance`.
    """
    import dask
    import dask.array as da

    from fieldmap.products.stats import parse_thresholds

    if isinstance(chunks, dict):
        chunks = chunks.get("latitude")
    rows = None if chunks in (None, True, "auto") else chunks
    thresholds = parse_thresholds(thresholds_mg)
    grid, ell, mod = prepare(
        model, lmax, heights_m, step_deg, lat_max, region, ellipsoid, device, epoch, units
    )
    tmpl = blockio.template(mod, grid, ell, units, thresholds, stacked)
    plan = blocks.plan_blocks(grid, mod.lmax, rows)
    jobs = blocks.make_jobs(grid, plan, ell.name, device, units, thresholds)
    model_d = client.scatter(mod, broadcast=True, hash=False) if client is not None else mod
    model_d = dask.delayed(model_d) if client is None else model_d
    results = [dask.delayed(blocks.compute_block, pure=True)(job, model_d) for job in jobs]
    nh, nlat, nlon = grid.shape
    pieces = {}  # (layer, r0) -> (block result, offset in block, r1)
    for b, res in zip(plan, results):
        off = 0
        for r0, r1 in b.runs():
            pieces[(b.layer, r0)] = (res, off, r1)
            off += r1 - r0

    def column(name, layer):
        parts, r = [], 0
        while r < nlat:
            res, off, r1 = pieces[(layer, r)]
            part = dask.delayed(_rows)(res, name, off, off + r1 - r)
            parts.append(da.from_delayed(part, shape=(r1 - r, nlon), dtype=np.float64))
            r = r1
        return da.concatenate(parts, axis=0)

    ds = tmpl.copy()
    var_attrs = ds.attrs.pop("variables")
    dims = ds.attrs.pop("dims")
    for name in blockio.VARIABLES:
        cols = [column(name, k) for k in range(nh)]
        ds[name] = (dims, da.stack(cols) if stacked else cols[0], var_attrs[name])
    ds.attrs["thresholds_mg"] = np.array(thresholds)
    return ds


def _rows(res: dict, name: str, a: int, b: int) -> np.ndarray:
    return res["data"][name][a:b]


def route(args: dict, heights_m, *, stacked: bool) -> xr.Dataset:
    """Entry from :mod:`fieldmap.products.maps`: ``args`` are the caller's arguments."""
    common = {
        k: args[k]
        for k in (
            "model",
            "lmax",
            "step_deg",
            "lat_max",
            "region",
            "thresholds_mg",
            "device",
            "ellipsoid",
            "epoch",
            "units",
        )
    }
    if args.get("chunks") is not None:
        if args.get("scheduler") is not None:
            raise InputError("chunks= returns a lazy Dataset: pass client=, not scheduler=")
        return lazy_disturbance(
            heights_m=heights_m,
            **common,
            stacked=stacked,
            chunks=args["chunks"],
            client=args.get("client"),
        )
    return disturbance_blocks(
        heights_m=heights_m,
        **common,
        progress=args.get("progress"),
        stacked=stacked,
        client=args.get("client"),
        scheduler=args.get("scheduler"),
    )


def _normal_task(grid, ell, order, device):
    from fieldmap.grids.synthesis import normal_rows

    blocks.worker_setup()
    return normal_rows(grid, ell, order, device)


def normal_rows_on(client):
    """Return a drop-in for ``normal_rows`` that evaluates blocks of rows on the cluster.

    The normal gravitation of a row does not depend on the other rows of its launch, so the
    result is that of :func:`fieldmap.grids.synthesis.normal_rows` bit for bit.
    """
    import dataclasses

    def rows_fn(grid, ell, order, device):
        n = grid.lat.size
        step = max(1, -(-n // 8))
        parts = [
            client.submit(
                _normal_task,
                dataclasses.replace(grid, lat=grid.lat[i : i + step]),
                ell,
                order,
                device,
                pure=False,
            )
            for i in range(0, n, step)
        ]
        return np.concatenate(client.gather(parts), axis=1)

    return rows_fn

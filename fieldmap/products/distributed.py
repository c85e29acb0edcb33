"""Map products on the block engine: in memory, lazy (dask-backed) or streamed to a store.

:func:`fieldmap.products.maps.disturbance_map`, :func:`~fieldmap.products.maps.altitude_sweep`,
:func:`~fieldmap.products.maps.truncation_map` and
:func:`fieldmap.products.quantity_maps.quantity_map` route here when given ``client=`` (a
``dask.distributed.Client``), ``scheduler=`` (``"local:N"`` or an address) or ``chunks=``;
lazy Datasets (``chunks=``) are :mod:`fieldmap.products.lazy`;
``fieldmap map|sweep --scheduler ... --format netcdf|zarr`` uses :func:`write_disturbance` and
(with ``--quantity``) :func:`write_quantity`, which stream blocks to the store so that no
process holds the whole product.
"""

from __future__ import annotations

import contextlib

import numpy as np
import xarray as xr

from fieldmap.errors import InputError
from fieldmap.products import blockio, blockmeta, blocks, blockstore, cf, cluster, io

__all__ = [
    "disturbance_blocks",
    "normal_rows_on",
    "prepare_quantity",
    "quantity_blocks",
    "write_disturbance",
    "write_quantity",
]

FORMATS = ("netcdf", "zarr")


def prepare(
    model, lmax, heights_m, step_deg, lat_max, region, ellipsoid, device, epoch, units, load=None
):
    """Validate grid (not whole in memory), ellipsoid and device; then load the model.

    ``load``: a callable returning the model (the CLI's, with its model-file options), used
    instead of ``load_model(model, lmax, epoch)``.
    """
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
    mod = load() if load is not None else load_model(model, lmax=lmax, epoch=epoch)
    return grid, ell, mod


@contextlib.contextmanager
def _client(client, scheduler):
    if client is not None:
        yield client
    else:
        with cluster.open_client(cluster.parse_scheduler(scheduler)) as c:
            yield c


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
    percentile_method: str = "histogram",
) -> xr.Dataset:
    """Disturbance map (``stacked=False``) or sweep computed on the block engine, in memory.

    The engine of :func:`fieldmap.products.maps.disturbance_map` and
    :func:`~fieldmap.products.maps.altitude_sweep`; statistics from the block partials
    (``percentile_method="histogram"``: within
    :data:`fieldmap.products.blockstats.PERCENTILE_RTOL` of the exact ones; ``"exact"``: the
    weighted percentiles of the whole map, computed from the assembled arrays).
    """
    from fieldmap.grids.spec import check_memory
    from fieldmap.products.blocks import show_progress
    from fieldmap.products.blockstats import check_percentile_method
    from fieldmap.products.stats import parse_thresholds

    check_percentile_method(percentile_method)
    thresholds = parse_thresholds(thresholds_mg)
    grid, ell, mod = prepare(
        model, lmax, heights_m, step_deg, lat_max, region, ellipsoid, device, epoch, units
    )
    check_memory(grid)  # the result is returned whole
    progress = show_progress(int(np.prod(grid.shape)), progress)
    tmpl = blockmeta.template_parts(mod, grid, ell, units, thresholds, stacked)
    stats, values = _in_memory(
        (grid, ell, mod),
        blockio.VARIABLES,
        stacked,
        client,
        scheduler,
        device=device,
        units=units,
        thresholds=thresholds,
        rows_per_block=rows_per_block,
        progress=progress,
    )
    if percentile_method == "exact":
        from fieldmap.products.stats import DEFAULT_PERCENTILES, area_weights, weighted_percentiles

        w = area_weights(grid.lat)[:, None]
        mod_mg = values["modulus_mg"].reshape(grid.shape)
        for k, st in enumerate(stats):
            qs = weighted_percentiles(mod_mg[k], w, DEFAULT_PERCENTILES)
            st.update({f"p{q:g}_mg": float(v) for q, v in zip(DEFAULT_PERCENTILES, qs)})
    return _assemble(tmpl, values, stats, thresholds, stacked, percentile_method)


def _in_memory(setup, names, stacked, client, scheduler, **run_kw):
    """Run every block of a product returned whole; (statistics, {name: array})."""
    grid, ell, mod = setup
    with (
        _client(client, scheduler) as c,
        blockio.memory_target(grid, stacked, names, c) as (sink, store, arrays),
    ):
        stats = blocks.run_blocks(
            grid, mod, ellipsoid=ell.name, client=c, sink=sink, store=store, **run_kw
        )
        return stats, arrays()


def _assemble(parts, arrays, stats, thresholds, stacked, method="histogram") -> xr.Dataset:
    """Build the product Dataset from :func:`blockmeta.template_parts` and the arrays."""
    attrs = dict(parts["attrs"])
    dims, var_attrs = parts["dims"], parts["variables"]
    data = {name: xr.Variable(dims, arrays[name], var_attrs[name]) for name in blockio.VARIABLES}
    if stacked:
        data.update(cf.sweep_statistics(stats, thresholds))
        attrs["percentile_method"] = blockmeta.percentile_method_text(method)
    else:
        attrs.update(blockmeta.map_attrs(stats[0], thresholds, method))
    # one Dataset, built at once (an update would align the variables again)
    return blockmeta.dataset(data, parts["coords"], attrs)


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

    thresholds = parse_thresholds(thresholds_mg)
    if setup is None:
        _check_format(fmt)
        setup = prepare(
            model, lmax, heights_m, step_deg, lat_max, region, ellipsoid, device, epoch, units
        )
    grid, ell, mod = setup
    tmpl = blockmeta.template(mod, grid, ell, units, thresholds, stacked)

    def finish(stats):
        if stacked:
            attrs = {"percentile_method": blockmeta.percentile_method_text()}
            return attrs, cf.sweep_statistics(stats, thresholds), None
        return blockmeta.map_attrs(stats[0], thresholds), None, None

    stats = _write_blocks(
        path,
        fmt,
        tmpl,
        setup,
        finish,
        client=client,
        scheduler=scheduler,
        atomic=atomic,
        device=device,
        units=units,
        thresholds=thresholds,
        rows_per_block=rows_per_block,
        progress=progress,
        window=window,
    )
    return {"stats": stats, "grid": grid, "model": (mod.name, mod.lmax), "path": path}


def _check_format(fmt) -> None:
    if fmt not in FORMATS:
        raise InputError(f"format must be one of {', '.join(FORMATS)}, got {fmt!r}")


def _write_blocks(path, fmt, tmpl, setup, finish, *, client, scheduler, atomic, **run_kw):
    """Stream a product's blocks to ``path``; ``finish(stats)``: (attrs, extra, var attrs)."""
    _check_format(fmt)
    grid, ell, mod = setup
    place = blockstore.atomic_store(path) if atomic else contextlib.nullcontext(path)
    # connect (or start the local cluster) before anything is written
    with _client(client, scheduler) as c, io.writing(path), place as tmp:
        writer = None
        try:
            if fmt == "zarr":
                plan = blocks.plan_blocks(grid, mod.lmax, run_kw.get("rows_per_block"))
                target = blockio.create_zarr(str(tmp), tmpl, grid, max(b.rows.size for b in plan))
                sink, store = target.sink, target
            else:
                writer = blockio.NetCDFWriter(str(tmp), tmpl, grid)
                sink, store = writer.sink, None
            stats = blocks.run_blocks(
                grid, mod, ellipsoid=ell.name, client=c, sink=sink, store=store, **run_kw
            )
            attrs, extra, var_attrs = finish(stats)
            if fmt == "zarr":
                target.check_complete()
                blockio.finish_zarr(str(tmp), attrs, extra, var_attrs)
            else:
                assert writer is not None  # opened above for the netcdf format
                writer.finish(attrs, extra, var_attrs)
        finally:
            if writer is not None:
                writer.close()
    return stats


def prepare_quantity(
    quantity, model, lmax, heights_m, step_deg, lat_max, region, ellipsoid, device, epoch, load=None
):
    """:func:`prepare` for a quantity map (the geoid is a property of the surface: h = 0)."""
    from fieldmap.products.quantity_product import SIGMA_QUANTITIES, SURFACE_QUANTITIES, VARIABLES

    if quantity not in VARIABLES:
        raise InputError(f"quantity must be one of {', '.join(VARIABLES)}, got {quantity!r}")
    heights = [0.0] if quantity in SURFACE_QUANTITIES else heights_m
    out = prepare(
        model, lmax, heights, step_deg, lat_max, region, ellipsoid, device, epoch, "mGal", load
    )
    mod = out[-1]
    if quantity in SIGMA_QUANTITIES and (mod.sigma_c is None or mod.sigma_s is None):
        raise InputError(
            f"model {mod.name} carries no coefficient standard deviations (sigma C, sigma S):"
            f" --quantity {quantity} needs an ICGEM file with sigma columns"
        )
    return out


def _per_variable(stats: list[dict]) -> dict:
    """[{var: s} per height] -> {var: [s per height]}."""
    return {name: [s[name] for s in stats] for name in stats[0]}


def quantity_blocks(
    quantity: str,
    model="eigen-6s",
    lmax=None,
    heights_m=(20000.0,),
    step_deg=1.0,
    lat_max=80.0,
    region=None,
    device=None,
    ellipsoid="WGS84",
    epoch=None,
    degree0: bool = False,
    progress=None,
    *,
    client=None,
    scheduler=None,
    rows_per_block=None,
) -> xr.Dataset:
    """Compute a quantity map (as :func:`~fieldmap.products.quantity_maps.quantity_map`) in blocks.

    The values are those of the in-memory map bit for bit; the statistics are summed block by
    block in block order (the same on every executor).
    """
    from fieldmap.grids.spec import check_memory
    from fieldmap.products import quantity_product as qm
    from fieldmap.products.blocks import show_progress

    setup = prepare_quantity(
        quantity, model, lmax, heights_m, step_deg, lat_max, region, ellipsoid, device, epoch
    )
    grid, ell, mod = setup
    check_memory(grid)  # the result is returned whole
    progress = show_progress(int(np.prod(grid.shape)), progress)
    tmpl = qm.template(quantity, mod, grid, ell, degree0)
    stats, values = _in_memory(
        setup,
        tuple(tmpl.attrs["variables"]),
        True,
        client,
        scheduler,
        device=device,
        thresholds=(),
        rows_per_block=rows_per_block,
        progress=progress,
        quantity=quantity,
        degree0=degree0,
    )
    return qm.assemble(tmpl, values, _per_variable(stats))


def write_quantity(
    path,
    fmt: str,
    quantity: str,
    *,
    degree0: bool = False,
    device=None,
    client=None,
    scheduler=None,
    rows_per_block=None,
    progress=None,
    window=None,
    setup,
    atomic: bool = True,
) -> dict:
    """Stream a quantity map (or sweep) block by block to ``path`` (NetCDF-4 or zarr).

    ``setup``: (grid, ellipsoid, model) from :func:`prepare_quantity`. Returns ``stats``
    ({variable: [statistics per height]}), ``grid``, ``model`` and ``path``.
    """
    from fieldmap.products import quantity_product as qm

    grid, ell, mod = setup
    tmpl = qm.template(quantity, mod, grid, ell, degree0)

    def finish(stats):
        per_var, extra = qm.statistics_fields(tmpl, _per_variable(stats))
        return {}, extra or None, per_var

    stats = _write_blocks(
        path,
        fmt,
        tmpl,
        setup,
        finish,
        client=client,
        scheduler=scheduler,
        atomic=atomic,
        device=device,
        thresholds=(),
        rows_per_block=rows_per_block,
        progress=progress,
        window=window,
        quantity=quantity,
        degree0=degree0,
    )
    return {
        "stats": _per_variable(stats),
        "grid": grid,
        "model": (mod.name, mod.lmax),
        "path": path,
    }


def _normal_task(grid, ell, order, device):
    from fieldmap.grids.synthesis import normal_rows

    cluster.worker_setup()
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

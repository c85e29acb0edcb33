"""Lazy, dask-backed map products (``chunks=``): blocks computed when the data is read.

The blocks are those of :mod:`fieldmap.products.blocks` (the same plan, the same bits as the
products computed at once, :mod:`fieldmap.products.distributed`); a lazy Dataset carries no
statistics, which need the whole map.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from fieldmap.products import blockmeta, blocks, cluster
from fieldmap.products.distributed import prepare, prepare_quantity

__all__ = ["lazy_disturbance", "lazy_quantity"]


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
    from fieldmap.products.stats import parse_thresholds

    thresholds = parse_thresholds(thresholds_mg)
    grid, ell, mod = prepare(
        model, lmax, heights_m, step_deg, lat_max, region, ellipsoid, device, epoch, units
    )
    tmpl = blockmeta.template(mod, grid, ell, units, thresholds, stacked)
    rows = _chunk_rows(chunks)
    plan = blocks.plan_blocks(grid, mod.lmax, rows)
    jobs = blocks.make_jobs(grid, plan, ell.name, device, units, thresholds)
    ds = _lazy(tmpl, grid, mod, plan, jobs, client)
    ds.attrs["thresholds_mg"] = np.array(thresholds)
    return ds


def _chunk_rows(chunks):
    if isinstance(chunks, dict):
        chunks = chunks.get("latitude")
    return None if chunks in (None, True, "auto") else chunks


def _lazy(tmpl, grid, mod, plan, jobs, client) -> xr.Dataset:
    """Return the template's variables as dask arrays, one delayed computation per block."""
    import dask
    import dask.array as da

    model_d = cluster.scattered(client, mod) if client is not None else mod
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
    stacked = "height" in dims
    for name, va in var_attrs.items():
        cols = [column(name, k) for k in range(nh)]
        ds[name] = (dims, da.stack(cols) if stacked else cols[0], va)
    return ds


def lazy_quantity(
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
    *,
    chunks=None,
    client=None,
) -> xr.Dataset:
    """Return a lazy, dask-backed quantity map (as :func:`lazy_disturbance`).

    The values, once computed, are those of the in-memory map bit for bit; the statistics are
    not in the attributes (compute them from the data, or write with :func:`write_quantity`).
    """
    from fieldmap.products import quantity_product as qm

    grid, ell, mod = prepare_quantity(
        quantity, model, lmax, heights_m, step_deg, lat_max, region, ellipsoid, device, epoch
    )
    tmpl = qm.template(quantity, mod, grid, ell, degree0)
    plan = blocks.plan_blocks(grid, mod.lmax, _chunk_rows(chunks))
    jobs = blocks.make_jobs(
        grid, plan, ell.name, device, "mGal", (), quantity=quantity, degree0=degree0
    )
    return _lazy(tmpl, grid, mod, plan, jobs, client)


def _rows(res: dict, name: str, a: int, b: int) -> np.ndarray:
    return res["data"][name][a:b]

"""Maps of the geodesist's quantities: gravity anomaly, deflection, geoid height, potential T.

:func:`quantity_map` returns an ``xarray.Dataset`` with CF-1.8 attributes, as the disturbance
products of :mod:`fieldmap.products.maps` do, on (latitude, longitude) — plus ``height`` for
several heights (a sweep); :func:`plot_quantity` draws each variable with coastlines and a
diverging colour scale centred on zero (the quantities are signed). Definitions (GeographicLib's
``Gravity -A``/``-H`` conventions, degree 0 left out by default) are those of
:mod:`fieldmap.field.geodesy`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from fieldmap.errors import InputError
from fieldmap.products.quantity_product import (
    GRADIENT_QUANTITIES,
    QUANTITIES,
    SIGMA_QUANTITIES,
    SURFACE_QUANTITIES,
    VARIABLES,
)


def quantity_map(
    quantity: str,
    *,
    model="eigen-6s",
    lmax: int | None = None,
    height_km=20.0,
    step_deg: float = 1.0,
    lat_max: float = 80.0,
    region=None,
    device: str | None = None,
    ellipsoid="WGS84",
    epoch=None,
    degree0: bool = False,
    progress: bool | None = None,
    client=None,
    scheduler: str | None = None,
    chunks=None,
    rows_per_block: int | None = None,
) -> xr.Dataset:
    """Map of a geodetic quantity on a global or regional grid, at one or several heights.

    Parameters
    ----------
    quantity : {"disturbance", "anomaly", "deflection", "geoid", "potential", "gradient", \
"gradient-disturbance"}
        ``disturbance`` is :func:`fieldmap.products.maps.disturbance_map` (one height) or
        :func:`fieldmap.products.maps.altitude_sweep`; ``gradient`` and
        ``gradient-disturbance`` the six ENU components of the gradient tensor of gravity or
        of the disturbance (:func:`fieldmap.field.gradient.grid_gradient`, Eötvös); the
        others are :func:`fieldmap.field.geodesy.grid_quantities`.
    model : str, path or SHModel
        Model (bundled name, file, or object).
    lmax : int, optional
        Truncation degree.
    height_km : float or sequence of float
        Height(s) above the ellipsoid (ignored for the geoid, a property of the surface).
        Units: km.
    step_deg, lat_max : float
        Grid spacing and latitude limit of a global grid. Units: degrees.
    region : (west, east, south, north), optional
        Regional grid instead. Units: degrees.
    device : str, optional
        Warp device.
    ellipsoid : str
        Normal field and coordinates (``"WGS84"`` or ``"GRS80"``).
    epoch : float or str, optional
        Epoch of time-variable models.
    degree0 : bool
        Keep the degree-0 term of T (default False, as GeographicLib).
    progress : bool, optional
        Progress bar.
    client : dask.distributed.Client, optional
        Compute on this cluster, block by block (:mod:`fieldmap.products.distributed`).
    scheduler : str, optional
        ``"local:N"``, a scheduler address or ``"threads"`` (blocks here) instead of ``client``.
        The values are those of the in-memory map bit for bit; the statistics are summed block
        by block (within 1e-14 relative of the whole-map sums).
    chunks : int, dict or "auto", optional
        Return a lazy dask-backed Dataset instead (latitude rows per block; with ``client=``
        the blocks run on that cluster when the data is read); no statistics attributes.
    rows_per_block : int, optional
        Most latitude rows per block (default: from the memory budget); the results do not
        depend on it.

    Returns
    -------
    xarray.Dataset
        The quantity's variables (:data:`VARIABLES`) with ``units``, ``long_name`` (and
        ``standard_name`` where CF has one), area-weighted ``min``, ``max``, ``mean``, ``rms``
        in each variable's attributes (per height for a sweep: ``<var>_max`` etc. on height).
    """
    from fieldmap.products import maps

    if quantity not in QUANTITIES:
        raise InputError(f"quantity must be one of {', '.join(QUANTITIES)}, got {quantity!r}")
    hs = np.atleast_1d(np.asarray(height_km, dtype=object)).ravel()
    if quantity == "disturbance":
        if degree0:
            raise InputError("degree0 applies to the potential T and its quantities, not to δg")
        kw = dict(
            model=model,
            lmax=lmax,
            step_deg=step_deg,
            lat_max=lat_max,
            region=region,
            device=device,
            ellipsoid=ellipsoid,
            epoch=epoch,
            progress=progress,
            client=client,
            scheduler=scheduler,
            chunks=chunks,
            rows_per_block=rows_per_block,
        )
        if hs.size == 1:
            return maps.disturbance_map(height_km=hs[0], **kw)
        return maps.altitude_sweep(height_km=list(hs), **kw)
    if degree0 and (quantity in GRADIENT_QUANTITIES or quantity in SIGMA_QUANTITIES):
        raise InputError(
            f"degree0 applies to the potential T and its quantities, not to {quantity}"
        )
    if quantity in SURFACE_QUANTITIES:
        hs = np.zeros(1, dtype=object)
    h = maps.heights_m(list(hs))
    from fieldmap.products import distributed, lazy

    # one engine: blocks of latitude rows, here or on a cluster, statistics folded per block
    common = dict(
        model=model,
        lmax=lmax,
        heights_m=h,
        step_deg=step_deg,
        lat_max=lat_max,
        region=region,
        device=device,
        ellipsoid=ellipsoid,
        epoch=epoch,
        degree0=degree0,
    )
    if chunks is None:
        return distributed.quantity_blocks(
            quantity,
            **common,
            progress=progress,
            client=client,
            scheduler=scheduler,
            rows_per_block=rows_per_block,
        )
    if scheduler is not None:
        raise InputError("chunks= returns a lazy Dataset: pass client=, not scheduler=")
    if rows_per_block is not None:
        raise InputError("chunks= sets the rows of a lazy Dataset's blocks: no rows_per_block")
    return lazy.lazy_quantity(quantity, **common, chunks=chunks, client=client)


def summary(ds: xr.Dataset) -> dict:
    """JSON-ready statistics of a :func:`quantity_map` Dataset (not the disturbance)."""
    a = ds.attrs
    out = {
        "product": a.get("quantity"),
        "model": a.get("model"),
        "lmax": a.get("model_lmax"),
        "ellipsoid": a.get("ellipsoid"),
        "grid_step_deg": a.get("grid_step_deg"),
        "region_deg": [float(x) for x in a["region_west_east_south_north_deg"]],
        "definition": a.get("definition"),
    }
    stacked = "height" in ds.dims
    out["height_m"] = (
        [float(x) for x in ds["height"].values] if stacked else float(ds["height"].values)
    )
    for name, units, _, _ in VARIABLES[a["quantity"]]:
        stats: dict[str, Any]
        if stacked:
            stats = {
                k: [float(x) for x in ds[f"{name}_{k}"].values]
                for k in ("min", "max", "mean", "rms")
            }
        else:
            v = ds[name].attrs
            stats = {
                "min": float(v["actual_range"][0]),
                "max": float(v["actual_range"][1]),
                "mean": float(v["area_weighted_mean"]),
                "rms": float(v["area_weighted_rms"]),
            }
        out[name] = {"units": units, **stats}
    return out


def plot_quantity(ds: xr.Dataset, name: str, height_index: int | None = None):
    """Map of one variable with coastlines and a diverging colour scale centred on zero.

    Parameters
    ----------
    ds : xarray.Dataset
        From :func:`quantity_map`.
    name : str
        Variable (``anomaly``, ``xi``, ``eta``, ``geoid``, ``potential``).
    height_index : int, optional
        Height of a sweep (default: the first).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import TwoSlopeNorm

    from fieldmap.products import coastline
    from fieldmap.products.mapaxes import node_step

    var = ds[name]
    values = var.values
    if "height" in ds.dims:
        k = 0 if height_index is None else int(height_index)
        values = values[k]
        height = float(ds["height"].values[k])
    else:
        height = float(ds["height"].values)
    lon = ds["longitude"].values
    lat = ds["latitude"].values
    top = float(np.nanmax(np.abs(values))) or 1.0
    aspect = max(0.25, (lat[-1] - lat[0] + 1e-9) / max(lon[-1] - lon[0], 1e-9))
    w = min(8.0, 6.5 / aspect)
    fig, ax = plt.subplots(figsize=(w + 1.3, w * aspect + 1.1), constrained_layout=True)
    mesh = ax.pcolormesh(
        lon,
        lat,
        values,
        cmap="RdBu_r",
        norm=TwoSlopeNorm(vcenter=0.0, vmin=-top, vmax=top),
        shading="nearest",
        rasterized=True,
    )
    step = node_step(ds)
    ax.set_xlim(lon[0] - step / 2, lon[-1] + step / 2)
    ax.set_ylim(lat[0] - step / 2, lat[-1] + step / 2)
    ax.set_aspect("equal")
    coastline.draw(ax, lon_min=lon[0] - step / 2 - 1e-9)
    ax.set_xlabel("longitude (°E)")
    ax.set_ylabel("latitude (°N)")
    ax.tick_params(labelsize=8)
    cb = fig.colorbar(mesh, ax=ax, shrink=0.9, pad=0.015, aspect=25, fraction=0.04)
    cb.set_label(f"{name} ({var.attrs['units']})", fontsize=9)
    surface = ds.attrs.get("quantity") in SURFACE_QUANTITIES
    where = "h = 0" if surface else f"h = {height / 1e3:g} km"
    a = ds.attrs
    source = (
        f"{a['model']} degree {a.get('model_lmax')}"
        if a.get("model")
        else f"{a.get('ellipsoid')} normal field"
    )
    ax.set_title(f"{var.attrs['long_name']}\n{source}, {where}", fontsize=9)
    return fig

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

from fieldmap import __version__
from fieldmap.errors import InputError

#: quantity -> variables: (name, units, long name, CF standard name or None)
VARIABLES: dict[str, list[tuple[str, str, str, str | None]]] = {
    "anomaly": [
        (
            "anomaly",
            "mGal",
            "gravity anomaly, spherical approximation: -dT/dr - 2T/r",
            None,
        )
    ],
    "deflection": [
        ("xi", "arcsec", "northerly component of the deflection of the vertical", None),
        ("eta", "arcsec", "easterly component of the deflection of the vertical", None),
    ],
    "geoid": [
        (
            "geoid",
            "m",
            "geoid height above the reference ellipsoid (Bruns: T/gamma0)",
            "geoid_height_above_reference_ellipsoid",
        )
    ],
    "potential": [("potential", "m2 s-2", "disturbing potential T = W - U", None)],
}
QUANTITIES = ("disturbance", *VARIABLES)


def _definition(degree0: bool) -> str:
    zero = (
        "the degree-0 term (GM - GM_ellipsoid)/r is included"
        if degree0
        else "the degree-0 term (GM - GM_ellipsoid)/r is left out, as GeographicLib's Gravity"
    )
    return (
        "T = W - U, model minus level-ellipsoid normal potential; "
        + zero
        + "; anomaly and deflection in the spherical approximation (Heiskanen & Moritz 1967 "
        "eq. 2-151c), gamma the normal gravity at the point; geoid N = T(h=0)/gamma0 "
        "(Somigliana) + HeightOffset and correction terms of a GeographicLib model"
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
) -> xr.Dataset:
    """Map of a geodetic quantity on a global or regional grid, at one or several heights.

    Parameters
    ----------
    quantity : {"disturbance", "anomaly", "deflection", "geoid", "potential"}
        ``disturbance`` is :func:`fieldmap.products.maps.disturbance_map` (one height) or
        :func:`fieldmap.products.maps.altitude_sweep`; the others are
        :func:`fieldmap.field.geodesy.grid_quantities`.
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

    Returns
    -------
    xarray.Dataset
        The quantity's variables (:data:`VARIABLES`) with ``units``, ``long_name`` (and
        ``standard_name`` where CF has one), area-weighted ``min``, ``max``, ``mean``, ``rms``
        in each variable's attributes (per height for a sweep: ``<var>_max`` etc. on height).
    """
    from fieldmap.field import geodesy
    from fieldmap.products import maps
    from fieldmap.products.cf import coords, global_attrs
    from fieldmap.products.stats import weights_2d

    if quantity not in QUANTITIES:
        raise InputError(f"quantity must be one of {', '.join(QUANTITIES)}, got {quantity!r}")
    hs = np.atleast_1d(np.asarray(height_km, dtype=object)).ravel()
    if quantity == "disturbance":
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
        )
        if hs.size == 1:
            return maps.disturbance_map(height_km=hs[0], **kw)
        return maps.altitude_sweep(height_km=list(hs), **kw)
    if quantity == "geoid":
        hs = np.zeros(1, dtype=object)
    h = maps.heights_m(list(hs))
    grid, ell, device = maps.setup_grid(step_deg, lat_max, region, h, ellipsoid, device)
    mod = maps.resolve_model(model, lmax, epoch)
    vals = geodesy.grid_quantities(
        mod, grid, quantity, ellipsoid=ell, degree0=degree0, device=device, progress=progress
    )
    stacked = grid.heights.size > 1
    dims = ("height", "latitude", "longitude") if stacked else ("latitude", "longitude")
    w = weights_2d(grid.lat, grid.lon.size)
    data, extra = {}, {}
    for name, units, long_name, std in VARIABLES[quantity]:
        v = vals[name]
        attrs: dict[str, Any] = {"units": units, "long_name": long_name}
        if std:
            attrs["standard_name"] = std
        per_h = [
            {
                "min": float(v[k].min()),
                "max": float(v[k].max()),
                "mean": float(np.sum(w * v[k])),
                "rms": float(np.sqrt(np.sum(w * v[k] ** 2))),
            }
            for k in range(v.shape[0])
        ]
        if stacked:
            for key in ("min", "max", "mean", "rms"):
                extra[f"{name}_{key}"] = (
                    "height",
                    np.array([s[key] for s in per_h]),
                    {"units": units, "long_name": f"area-weighted {key} of {name}"},
                )
        else:
            # CF attribute names: letters, digits, underscores (CF 1.8 §2.3)
            s0 = per_h[0]
            attrs["actual_range"] = np.array([s0["min"], s0["max"]])
            attrs["area_weighted_mean"] = s0["mean"]
            attrs["area_weighted_rms"] = s0["rms"]
        data[name] = (dims, v if stacked else v[0], attrs)
    heights_txt = ", ".join(f"{x / 1e3:g}" for x in grid.heights)
    title = (
        f"{VARIABLES[quantity][0][2].split(',')[0].split(' (')[0]} at {heights_txt} km, "
        f"{mod.name} degree {mod.lmax}"
    )
    attrs = global_attrs(
        title,
        mod,
        ell,
        grid,
        f"fieldmap {__version__}: {mod.name} degree {mod.lmax} minus the {ell.name} normal field",
    )
    attrs.update({"quantity": quantity, "definition": _definition(degree0)})
    attrs["frame"] = "geocentric spherical (deflection components), values are scalars otherwise"
    ds = xr.Dataset({**data, **extra}, coords=coords(grid, stacked), attrs=attrs)
    return ds


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
    step = float(ds.attrs.get("grid_step_deg", 1.0))
    ax.set_xlim(lon[0] - step / 2, lon[-1] + step / 2)
    ax.set_ylim(lat[0] - step / 2, lat[-1] + step / 2)
    ax.set_aspect("equal")
    coastline.draw(ax, lon_min=lon[0] - step / 2 - 1e-9)
    ax.set_xlabel("longitude (°E)")
    ax.set_ylabel("latitude (°N)")
    ax.tick_params(labelsize=8)
    cb = fig.colorbar(mesh, ax=ax, shrink=0.9, pad=0.015, aspect=25, fraction=0.04)
    cb.set_label(f"{name} ({var.attrs['units']})", fontsize=9)
    where = f"h = {height / 1e3:g} km" if ds.attrs.get("quantity") != "geoid" else "h = 0"
    ax.set_title(
        f"{var.attrs['long_name']}\n{ds.attrs.get('model')} degree "
        f"{ds.attrs.get('model_lmax')}, {where}",
        fontsize=9,
    )
    return fig

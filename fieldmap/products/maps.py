"""Map products of Chen et al. (2022) §4: disturbance, component, truncation maps and sweeps.

Every function returns an ``xarray.Dataset`` with CF-1.8 attributes on (latitude, longitude)
(and ``height`` or ``order`` for stacks). Vectors are in the local geodetic east-north-up frame.
Statistics use area weights (:mod:`fieldmap.products.stats`). Files are written by
:mod:`fieldmap.cli.maps` through the atomic writers of :mod:`fieldmap.products.io`.
"""

from __future__ import annotations

import sys

import numpy as np
import xarray as xr

from fieldmap import __version__, limits
from fieldmap.errors import InputError
from fieldmap.grids.synthesis import (
    check_memory,
    make_grid,
    normal_rows,
    resolve_device,
    synthesize,
)
from fieldmap.products.cf import (
    COMPONENTS,
    UNITS,
    coords,
    disturbance_attrs,
    fraction_attr,
    global_attrs,
    mg_attrs,
    stats_attrs,
    sweep_statistics,
    vector_vars,
)
from fieldmap.products.stats import map_statistics, parse_thresholds, threshold_key
from fieldmap.units import get_unit

__all__ = [
    "UNITS",
    "altitude_sweep",
    "component_maps",
    "disturbance_map",
    "summary",
    "truncation_map",
]


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


def _check_units(units: str) -> float:
    return get_unit(units).si


def heights_m(height_km, one: str | None = None) -> np.ndarray:
    """Distinct heights in m from km; ``one``: the message raised unless there is one height.

    The rule is :func:`fieldmap.limits.heights_from_km`.
    """
    return limits.heights_from_km(height_km, distinct=True, one=one)


def _orders(orders) -> tuple[int, ...]:
    """Distinct J2n orders among 2, 4, 6 (:func:`fieldmap.limits.check_orders`)."""
    return limits.check_orders(orders)


def resolve_model(model, lmax, epoch):
    from fieldmap.models.registry import load_model

    return load_model(model, lmax=lmax, epoch=epoch)


def setup_grid(step_deg, lat_max, region, h, ellipsoid, device):
    """Return the validated (grid, ellipsoid, device) of a product."""
    from fieldmap.field.ellipsoid import get_ellipsoid

    grid = make_grid(step_deg, lat_max, region, h)
    try:
        ell = get_ellipsoid(ellipsoid)
    except (KeyError, ValueError) as exc:
        raise InputError(f"unknown ellipsoid {ellipsoid!r}") from exc
    return grid, ell, resolve_device(device)


def _disturbance(mod, grid, ell, device, units, progress, stacked: bool) -> xr.Dataset:
    """Disturbance vectors on every node as a Dataset; ``stacked``: with a height dimension."""
    vec = synthesize(
        mod, grid, ell, "disturbance", device, show_progress(int(np.prod(grid.shape)), progress)
    )
    dims = ("height", "latitude", "longitude") if stacked else ("latitude", "longitude")
    return xr.Dataset(
        vector_vars(vec if stacked else vec[0], dims, units, "gravity disturbance", overwrite=True),
        coords=coords(grid, stacked),
        attrs=disturbance_attrs(mod, grid, ell),
    )


def disturbance_map(
    model="eigen-6s",
    lmax=None,
    height_km=20.0,
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
    client=None,
    scheduler=None,
    chunks=None,
) -> xr.Dataset:
    """Gravity disturbance map δg = g_model − γ_exact at one height (Chen et al. 2022 §4.1).

    Parameters
    ----------
    model : str, path or SHModel
        Bundled name (default ``"eigen-6s"``), ICGEM file, or a model object.
    lmax : int, optional
        Truncation degree (default: the model's).
    height_km : float
        Height above the ellipsoid, -10 ≤ h ≤ 1e5 (:mod:`fieldmap.limits`). Units: km.
    step_deg, lat_max : float
        Grid spacing and latitude limit of a global grid. Units: degrees.
    region : (west, east, south, north), optional
        Regional grid instead. Units: degrees.
    thresholds_mg : sequence of float
        Thresholds of the area fractions. Units: mg.
    device : str, optional
        Warp device.
    ellipsoid : str
        Normal field (``"WGS84"`` or ``"GRS80"``).
    epoch : float or str, optional
        Epoch for time-variable models.
    units : {"mGal", "mg", "m/s2"}
        Units of east, north, up, modulus (``modulus_mg`` is always added); any spelling of
        :mod:`fieldmap.units` (``"m s-2"``, any case).
    client : dask.distributed.Client, optional
        Compute on this cluster, block by block (:mod:`fieldmap.products.distributed`).
    scheduler : str, optional
        ``"local:N"`` (a LocalCluster of N processes for this call) or a scheduler address.
    chunks : int or "auto", optional
        Return a lazy dask-backed Dataset, blocks of at most this many latitude rows.
    progress : bool, optional
        Progress bar over the row blocks of the synthesis, on stderr. Default: shown for
        grids of 2e6 nodes or more when stderr is a terminal (:func:`show_progress`); False
        keeps it quiet.

    Returns
    -------
    xarray.Dataset
        Variables east, north, up, modulus, modulus_mg on (latitude, longitude); area-weighted
        statistics (max_mg, mean_mg, rms_mg, p50_mg, ..., area_fraction_above_<t>_mg, the
        threshold written with "p" for its point, e.g. ``area_fraction_above_0p05_mg``: see
        :func:`fieldmap.products.cf.fraction_attr`) in the attributes.
    """
    _check_units(units)
    thresholds = parse_thresholds(thresholds_mg)
    h = heights_m(height_km, "disturbance_map takes one height; use altitude_sweep for several")
    if client is not None or scheduler is not None or chunks is not None:
        from fieldmap.products import distributed

        return distributed.route(locals(), h, stacked=False)
    grid, ell, device = setup_grid(step_deg, lat_max, region, h, ellipsoid, device)
    mod = resolve_model(model, lmax, epoch)
    ds = _disturbance(mod, grid, ell, device, units, progress, stacked=False)
    stats = map_statistics(ds["modulus_mg"].values, grid.lat, thresholds)
    ds.attrs.update(stats_attrs(stats))
    ds.attrs["thresholds_mg"] = np.array(thresholds)
    return ds


def altitude_sweep(
    model="eigen-6s",
    lmax=None,
    height_km=(20.0, 30.0, 50.0, 70.0, 100.0),
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
    client=None,
    scheduler=None,
    chunks=None,
) -> xr.Dataset:
    """Disturbance maps and their statistics over a list of heights (Chen et al. 2022 Fig. 7).

    Parameters are those of :func:`disturbance_map`; ``height_km`` is a sequence of distinct
    heights (km).

    Returns
    -------
    xarray.Dataset
        east, north, up, modulus, modulus_mg on (height, latitude, longitude); ``max_mg``,
        ``mean_mg`` on (height) and ``area_fraction_above`` on (height, threshold_mg).
    """
    _check_units(units)
    thresholds = parse_thresholds(thresholds_mg)
    h = heights_m(height_km)
    if client is not None or scheduler is not None or chunks is not None:
        from fieldmap.products import distributed

        return distributed.route(locals(), h, stacked=True)
    grid, ell, device = setup_grid(step_deg, lat_max, region, h, ellipsoid, device)
    mod = resolve_model(model, lmax, epoch)
    ds = _disturbance(mod, grid, ell, device, units, progress, stacked=True)
    stats = [
        map_statistics(ds["modulus_mg"].values[k], grid.lat, thresholds) for k in range(h.size)
    ]
    ds = ds.assign_coords(
        threshold_mg=xr.Variable(
            "threshold_mg",
            np.array(thresholds),
            mg_attrs("threshold of the disturbance modulus"),
        )
    )
    for name, var in sweep_statistics(stats, thresholds).items():
        ds[name] = var
    return ds


def truncation_map(
    height_km=20.0,
    orders=(2, 4, 6),
    step_deg=1.0,
    lat_max=80.0,
    region=None,
    device=None,
    ellipsoid="WGS84",
    units="mGal",
    *,
    client=None,
) -> xr.Dataset:
    """Map the truncation error of the J2/J4/J6 normal gravitation against the exact one (Fig. 8).

    δg_Jn = g_Jn − γ_exact with g_Jn from eqs. (7)-(13) of Chen et al. (2022) (gradient
    corrected) and γ_exact the closed-form level-ellipsoid gravitation.

    Parameters
    ----------
    height_km : float
        Height above the ellipsoid, -10 ≤ h ≤ 1e5. Units: km.
    orders : sequence of int
        Distinct orders among 2, 4, 6 (2.5 is an error, not order 2).
    step_deg, lat_max, region, device, ellipsoid, units
        As in :func:`disturbance_map`.
    client : dask.distributed.Client, optional
        Evaluate the rows on this cluster (the same numbers, bit for bit).

    Returns
    -------
    xarray.Dataset
        east, north, up, modulus, modulus_mg on (order, latitude, longitude); ``max_mg`` and
        the area-weighted ``mean_mg`` and ``rms_mg`` on (order). The field is independent of
        longitude (both are axisymmetric).
    """
    _check_units(units)
    orders = _orders(orders)
    h = heights_m(height_km, "truncation_map takes one height")
    grid, ell, device = setup_grid(step_deg, lat_max, region, h, ellipsoid, device)
    check_memory(grid, layers=len(orders))
    rows = normal_rows
    if client is not None:
        from fieldmap.products.distributed import normal_rows_on

        rows = normal_rows_on(client)
    exact = rows(grid, ell, "exact", device)[0]
    err = np.stack([rows(grid, ell, f"j{o}", device)[0] - exact for o in orders])
    vec = np.broadcast_to(err[:, :, None, :], (len(orders), grid.lat.size, grid.lon.size, 3))
    ds = xr.Dataset(
        vector_vars(
            vec, ("order", "latitude", "longitude"), units, "normal gravitation truncation error"
        ),
        coords={
            **coords(grid, False),
            "order": xr.Variable(
                "order",
                np.array(orders),
                {"long_name": "highest zonal J2n term kept", "units": "1"},
            ),
        },
        attrs=global_attrs(
            f"J-series truncation error at {h[0] / 1e3:g} km ({ell.name})",
            None,
            ell,
            grid,
            f"fieldmap {__version__}: J{'/J'.join(map(str, orders))} normal gravitation minus "
            f"exact normal gravitation of {ell.name}",
        ),
    )
    # the same area-weighted statistics as the disturbance maps (a plain node mean would
    # over-weight the high latitudes, where the J2n errors are largest)
    st = [map_statistics(m, grid.lat, thresholds_mg=()) for m in ds["modulus_mg"].values]
    for key, long in (
        ("max_mg", "maximum"),
        ("mean_mg", "area-weighted mean"),
        ("rms_mg", "area-weighted root mean square"),
    ):
        ds[key] = ("order", np.array([s[key] for s in st]), mg_attrs(f"{long} truncation error"))
    return ds


def component_maps(
    model="eigen-6s",
    lmax=None,
    height_km=20.0,
    step_deg=1.0,
    lat_max=80.0,
    region=None,
    device=None,
    ellipsoid="WGS84",
    epoch=None,
    progress=None,
) -> xr.Dataset:
    """Model gravity and normal gravity components at one height (Chen et al. 2022 Figs. 2-3).

    Both include the centrifugal acceleration of the ellipsoid's rotation rate.

    Returns
    -------
    xarray.Dataset
        ``model_east``, ``model_north``, ``model_up`` and ``normal_east``, ``normal_north``,
        ``normal_up`` on (latitude, longitude). Units: m s-2.
    """
    h = heights_m(height_km, "component_maps takes one height")
    grid, ell, device = setup_grid(step_deg, lat_max, region, h, ellipsoid, device)
    mod = resolve_model(model, lmax, epoch)
    from fieldmap.grids.synthesis import centrifugal_rows

    g = synthesize(
        mod, grid, ell, "gravity", device, show_progress(int(np.prod(grid.shape)), progress)
    )[0]
    gam = (normal_rows(grid, ell, "exact", device) + centrifugal_rows(grid, ell))[0]
    gam = np.broadcast_to(gam[:, None, :], g.shape)
    dims = ("latitude", "longitude")
    data = {}
    for k, (c, cf_name) in enumerate(COMPONENTS.items()):
        data[f"model_{c}"] = (
            dims,
            g[..., k],
            {"units": "m s-2", "long_name": f"{cf_name} component of gravity from {mod.name}"},
        )
        data[f"normal_{c}"] = (
            dims,
            np.array(gam[..., k]),
            {"units": "m s-2", "long_name": f"{cf_name} component of normal gravity ({ell.name})"},
        )
    return xr.Dataset(
        data,
        coords=coords(grid, False),
        attrs=global_attrs(
            f"Gravity components at {h[0] / 1e3:g} km, {mod.name} degree {mod.lmax} and {ell.name}",
            mod,
            ell,
            grid,
            f"fieldmap {__version__}: {mod.name} degree {mod.lmax} gravity and exact "
            f"normal gravity of {ell.name}, both with centrifugal acceleration",
        ),
    )


def summary(ds: xr.Dataset) -> dict:
    """JSON-ready statistics of a disturbance map, sweep or truncation Dataset.

    Keys: ``model``, ``lmax``, ``height_m``, ``max_mg``, ``mean_mg``, percentiles and
    ``area_fraction_above`` {threshold in mg: fraction 0..1}; for a sweep, lists per height
    (``height_m`` is a list); for a truncation map, ``max_mg``, ``mean_mg`` and ``rms_mg``
    = {"j2": ..., ...} (area-weighted, as every product's).
    """
    a = ds.attrs
    out = {
        "product": None,
        "model": a.get("model"),
        "lmax": a.get("model_lmax"),
        "ellipsoid": a.get("ellipsoid"),
        "grid_step_deg": a.get("grid_step_deg"),
        "region_deg": [float(x) for x in a["region_west_east_south_north_deg"]],
    }
    if "order" in ds.dims:
        out.update(
            product="truncation",
            height_m=float(ds["height"].values),
            max_mg={
                f"j{int(o)}": float(v) for o, v in zip(ds["order"].values, ds["max_mg"].values)
            },
            mean_mg={
                f"j{int(o)}": float(v) for o, v in zip(ds["order"].values, ds["mean_mg"].values)
            },
            rms_mg={
                f"j{int(o)}": float(v) for o, v in zip(ds["order"].values, ds["rms_mg"].values)
            },
        )
        return out
    if "height" in ds.dims:
        thr = [threshold_key(t) for t in ds["threshold_mg"].values]
        out.update(
            product="sweep",
            height_m=[float(x) for x in ds["height"].values],
            max_mg=[float(x) for x in ds["max_mg"].values],
            mean_mg=[float(x) for x in ds["mean_mg"].values],
            area_fraction_above={
                k: [float(x) for x in ds["area_fraction_above"].values[:, j]]
                for j, k in enumerate(thr)
            },
        )
        return out
    out.update(product="disturbance", height_m=float(ds["height"].values))
    for k, v in a.items():
        if k.endswith("_mg") and not k.startswith("area_fraction_above") and k != "thresholds_mg":
            out[k] = float(v)
    out["area_fraction_above"] = {
        threshold_key(t): float(a[fraction_attr(t)]) for t in a["thresholds_mg"]
    }
    return out

"""Map products of Chen et al. (2022) §4: disturbance, component, truncation maps and sweeps.

Every function returns an ``xarray.Dataset`` with CF-1.8 attributes on (latitude, longitude)
(and ``height`` or ``order`` for stacks). Vectors are in the local geodetic east-north-up frame.
Statistics use area weights (:mod:`fieldmap.stats`). Files are written by
:mod:`fieldmap.cli_maps` through the atomic writers of :mod:`fieldmap.io`.
"""

from __future__ import annotations

import datetime as _dt

import numpy as np
import xarray as xr

from . import __version__
from .errors import InputError
from .grid import make_grid, normal_rows, resolve_device, synthesize
from .stats import MG, MGAL, map_statistics, parse_thresholds, threshold_key

UNITS = {"mGal": MGAL, "mg": MG, "m s-2": 1.0}
REFERENCE = (
    "Chen, Wang, Chen, Liu (2022), Normal gravity model for inertial navigation of a hypersonic "
    "boost-glide vehicle, Section 4"
)
_COMP = {"east": "eastward", "north": "northward", "up": "upward"}


def _check_units(units: str) -> float:
    if units not in UNITS:
        raise InputError(f"units must be one of {', '.join(UNITS)}, got {units!r}")
    return UNITS[units]


def _heights_m(height_km) -> np.ndarray:
    try:
        h = np.atleast_1d(np.asarray(height_km, dtype=np.float64)).ravel() * 1e3
    except (TypeError, ValueError):
        raise InputError(f"heights must be numbers in km, got {height_km!r}") from None
    return h


def _model(model, lmax, epoch):
    from .models import load_model

    return load_model(model, lmax=lmax, epoch=epoch)


def _ellipsoid(ellipsoid):
    from .ellipsoid import get_ellipsoid

    try:
        return get_ellipsoid(ellipsoid)
    except (KeyError, ValueError) as exc:
        raise InputError(f"unknown ellipsoid {ellipsoid!r}") from exc


def _coords(grid, stacked_heights: bool) -> dict:
    lat = xr.Variable(
        "latitude",
        grid.lat,
        {"units": "degrees_north", "standard_name": "latitude", "long_name": "geodetic latitude"},
    )
    lon = xr.Variable(
        "longitude",
        grid.lon,
        {"units": "degrees_east", "standard_name": "longitude", "long_name": "longitude"},
    )
    hattrs = {
        "units": "m",
        "standard_name": "height_above_reference_ellipsoid",
        "positive": "up",
        "long_name": "height above the ellipsoid",
    }
    if stacked_heights:
        height = xr.Variable("height", grid.heights, hattrs)
    else:
        height = xr.Variable((), grid.heights[0], hattrs)
    return {"latitude": lat, "longitude": lon, "height": height}


def _global_attrs(title, model, ellipsoid, grid, source) -> dict:
    now = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    attrs = {
        "Conventions": "CF-1.8",
        "title": title,
        "institution": "fieldmap",
        "source": source,
        "history": f"{now} created by fieldmap {__version__}",
        "references": REFERENCE,
        "ellipsoid": ellipsoid.name,
        "grid_step_deg": float(grid.step_deg),
        "grid_kind": "global" if grid.is_global else "regional",
        "region_west_east_south_north_deg": np.array(grid.region),
        "frame": "local geodetic east-north-up",
    }
    if model is not None:
        attrs.update(
            {
                "model": model.name,
                "model_lmax": int(model.lmax),
                "model_max_degree": int(model.max_degree),
                "model_epoch": "static" if model.epoch is None else f"{model.epoch:.4f}",
                "model_tide_system": model.tide_system,
                "model_gm": float(model.gm),
                "model_radius": float(model.radius),
            }
        )
    if grid.heights.size == 1:
        attrs["height_m"] = float(grid.heights[0])
    return attrs


def _vector_vars(vec, dims, units, what) -> dict:
    """east/north/up/modulus variables (in ``units``) plus modulus_mg, from m/s² ``vec``."""
    scale = UNITS[units]
    out = {}
    for k, name in enumerate(("east", "north", "up")):
        out[name] = (
            dims,
            vec[..., k] / scale,
            {"units": units, "long_name": f"{_COMP[name]} component of the {what}"},
        )
    mod = np.sqrt(np.sum(vec * vec, axis=-1))
    out["modulus"] = (dims, mod / scale, {"units": units, "long_name": f"modulus of the {what}"})
    out["modulus_mg"] = (
        dims,
        mod / MG,
        {
            "units": "mg",
            "long_name": f"modulus of the {what} in mg",
            "comment": "1 mg = 1e-3 g_n = 9.80665e-3 m s-2 (milli-g, not milligram)",
        },
    )
    return out


def _stats_attrs(stats: dict) -> dict:
    attrs = {k: v for k, v in stats.items() if k != "area_fraction_above"}
    for key, frac in stats["area_fraction_above"].items():
        attrs[f"area_fraction_above_{key}_mg"] = frac
    return attrs


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
) -> xr.Dataset:
    """Gravity disturbance map δg = g_model − γ_exact at one height (Chen et al. 2022 §4.1).

    Parameters
    ----------
    model : str, path or SHModel
        Bundled name (default ``"eigen-6s"``), ICGEM file, or a model object.
    lmax : int, optional
        Truncation degree (default: the model's).
    height_km : float
        Units: km above the ellipsoid.
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
    units : {"mGal", "mg", "m s-2"}
        Units of east, north, up, modulus (``modulus_mg`` is always added).

    Returns
    -------
    xarray.Dataset
        Variables east, north, up, modulus, modulus_mg on (latitude, longitude); statistics
        (max_mg, mean_mg, percentiles, area_fraction_above_<t>_mg) in the attributes.
    """
    _check_units(units)
    thresholds = parse_thresholds(thresholds_mg)
    h = _heights_m(height_km)
    if h.size != 1:
        raise InputError("disturbance_map takes one height; use altitude_sweep for several")
    grid = make_grid(step_deg, lat_max, region, h)
    ell = _ellipsoid(ellipsoid)
    device = resolve_device(device)
    mod = _model(model, lmax, epoch)
    vec = synthesize(mod, grid, ell, "disturbance", device, progress)[0]
    ds = xr.Dataset(
        _vector_vars(vec, ("latitude", "longitude"), units, "gravity disturbance"),
        coords=_coords(grid, False),
        attrs=_global_attrs(
            f"Gravity disturbance at {h[0] / 1e3:g} km, {mod.name} degree {mod.lmax}",
            mod,
            ell,
            grid,
            f"fieldmap {__version__}: {mod.name} degree {mod.lmax} gravitation minus exact "
            f"normal gravitation of {ell.name}",
        ),
    )
    stats = map_statistics(ds["modulus_mg"].values, grid.lat, thresholds)
    ds.attrs.update(_stats_attrs(stats))
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
) -> xr.Dataset:
    """Disturbance maps and their statistics over a list of heights (Chen et al. 2022 Fig. 7).

    Parameters are those of :func:`disturbance_map`; ``height_km`` is a sequence (km).

    Returns
    -------
    xarray.Dataset
        east, north, up, modulus, modulus_mg on (height, latitude, longitude); ``max_mg``,
        ``mean_mg`` on (height) and ``area_fraction_above`` on (height, threshold_mg).
    """
    _check_units(units)
    thresholds = parse_thresholds(thresholds_mg)
    h = _heights_m(height_km)
    grid = make_grid(step_deg, lat_max, region, h)
    ell = _ellipsoid(ellipsoid)
    device = resolve_device(device)
    mod = _model(model, lmax, epoch)
    vec = synthesize(mod, grid, ell, "disturbance", device, progress)
    dims = ("height", "latitude", "longitude")
    ds = xr.Dataset(
        _vector_vars(vec, dims, units, "gravity disturbance"),
        coords=_coords(grid, True),
        attrs=_global_attrs(
            f"Gravity disturbance at {', '.join(f'{x / 1e3:g}' for x in h)} km, "
            f"{mod.name} degree {mod.lmax}",
            mod,
            ell,
            grid,
            f"fieldmap {__version__}: {mod.name} degree {mod.lmax} gravitation minus exact "
            f"normal gravitation of {ell.name}",
        ),
    )
    stats = [
        map_statistics(ds["modulus_mg"].values[k], grid.lat, thresholds) for k in range(h.size)
    ]
    ds = ds.assign_coords(
        threshold_mg=xr.Variable(
            "threshold_mg",
            np.array(thresholds),
            {"units": "mg", "long_name": "threshold of the disturbance modulus"},
        )
    )
    for key, long in (
        ("max_mg", "maximum"),
        ("mean_mg", "area-weighted mean"),
        ("p50_mg", "area-weighted median"),
        ("p99_mg", "area-weighted 99th percentile"),
    ):
        ds[key] = (
            "height",
            np.array([s[key] for s in stats]),
            {"units": "mg", "long_name": f"{long} of the disturbance modulus"},
        )
    frac = np.array(
        [[s["area_fraction_above"][threshold_key(t)] for t in thresholds] for s in stats]
    )
    ds["area_fraction_above"] = (
        ("height", "threshold_mg"),
        frac,
        {
            "units": "1",
            "long_name": "fraction of the map area where the modulus exceeds the threshold",
        },
    )
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
) -> xr.Dataset:
    """Map the truncation error of the J2/J4/J6 normal gravitation against the exact one (Fig. 8).

    δg_Jn = g_Jn − γ_exact with g_Jn from eqs. (7)-(13) of Chen et al. (2022) (gradient
    corrected) and γ_exact the closed-form level-ellipsoid gravitation.

    Returns
    -------
    xarray.Dataset
        east, north, up, modulus, modulus_mg on (order, latitude, longitude); ``max_mg`` on
        (order). The field is independent of longitude (both are axisymmetric).
    """
    _check_units(units)
    try:
        orders = tuple(int(o) for o in orders)
    except (TypeError, ValueError):
        raise InputError(f"orders must be among 2, 4, 6, got {orders!r}") from None
    if not orders or any(o not in (2, 4, 6) for o in orders) or len(set(orders)) != len(orders):
        raise InputError(f"orders must be distinct values among 2, 4, 6, got {orders!r}")
    h = _heights_m(height_km)
    if h.size != 1:
        raise InputError("truncation_map takes one height")
    grid = make_grid(step_deg, lat_max, region, h)
    ell = _ellipsoid(ellipsoid)
    device = resolve_device(device)
    exact = normal_rows(grid, ell, 0, device)[0]
    err = np.stack([normal_rows(grid, ell, o, device)[0] - exact for o in orders])
    vec = np.broadcast_to(err[:, :, None, :], (len(orders), grid.lat.size, grid.lon.size, 3))
    ds = xr.Dataset(
        _vector_vars(
            vec, ("order", "latitude", "longitude"), units, "normal gravitation truncation error"
        ),
        coords={
            **_coords(grid, False),
            "order": xr.Variable(
                "order",
                np.array(orders),
                {"long_name": "highest zonal J2n term kept", "units": "1"},
            ),
        },
        attrs=_global_attrs(
            f"J-series truncation error at {h[0] / 1e3:g} km ({ell.name})",
            None,
            ell,
            grid,
            f"fieldmap {__version__}: J{'/J'.join(map(str, orders))} normal gravitation minus "
            f"exact normal gravitation of {ell.name}",
        ),
    )
    ds["max_mg"] = (
        "order",
        ds["modulus_mg"].max(dim=("latitude", "longitude")).values,
        {"units": "mg", "long_name": "maximum truncation error"},
    )
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
    h = _heights_m(height_km)
    if h.size != 1:
        raise InputError("component_maps takes one height")
    grid = make_grid(step_deg, lat_max, region, h)
    ell = _ellipsoid(ellipsoid)
    device = resolve_device(device)
    mod = _model(model, lmax, epoch)
    from .grid import centrifugal_rows

    g = synthesize(mod, grid, ell, "gravity", device, progress)[0]
    gam = (normal_rows(grid, ell, 0, device) + centrifugal_rows(grid, ell))[0]
    gam = np.broadcast_to(gam[:, None, :], g.shape)
    dims = ("latitude", "longitude")
    data = {}
    for k, c in enumerate(("east", "north", "up")):
        data[f"model_{c}"] = (
            dims,
            g[..., k],
            {"units": "m s-2", "long_name": f"{_COMP[c]} component of gravity from {mod.name}"},
        )
        data[f"normal_{c}"] = (
            dims,
            np.array(gam[..., k]),
            {"units": "m s-2", "long_name": f"{_COMP[c]} component of normal gravity ({ell.name})"},
        )
    return xr.Dataset(
        data,
        coords=_coords(grid, False),
        attrs=_global_attrs(
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
    (``height_m`` is a list); for a truncation map, ``max_mg`` = {"j2": ..., ...}.
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
                f"j{int(o)}": float(v)
                for o, v in zip(
                    ds["order"].values, ds["modulus_mg"].mean(dim=("latitude", "longitude")).values
                )
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
        threshold_key(t): float(a[f"area_fraction_above_{threshold_key(t)}_mg"])
        for t in a["thresholds_mg"]
    }
    return out

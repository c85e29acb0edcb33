"""Map products of Chen et al. (2022) §4: disturbance, component, truncation maps and sweeps.

Every function returns an ``xarray.Dataset`` with CF-1.8 attributes on (latitude, longitude)
(and ``height`` or ``order`` for stacks). Vectors are in the local geodetic east-north-up frame.
Statistics use area weights (:mod:`fieldmap.products.stats`). Files are written by
:mod:`fieldmap.cli.maps` through the atomic writers of :mod:`fieldmap.products.io`.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from fieldmap import __version__, _compat, limits
from fieldmap.errors import InputError
from fieldmap.grids.synthesis import (
    check_memory,
    make_grid,
    normal_rows,
    resolve_device,
    synthesize,
)
from fieldmap.products.blocks import PROGRESS_NODES, show_progress  # noqa: F401 - public here
from fieldmap.products.blockstats import PERCENTILE_METHODS, check_percentile_method
from fieldmap.products.cf import (
    COMPONENTS,
    UNITS,
    coords,
    global_attrs,
    mg_attrs,
    vector_vars,
)
from fieldmap.products.stats import map_statistics
from fieldmap.products.summary import summary
from fieldmap.units import get_unit

__all__ = [
    "PERCENTILE_METHODS",
    "UNITS",
    "altitude_sweep",
    "component_maps",
    "disturbance_map",
    "summary",
    "truncation_map",
]


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


#: Options of the map products that followed ``model`` positionally in fieldmap 0.1 (now
#: keyword-only; positional calls keep working for one release, with a DeprecationWarning).
_OLD_ORDER = (
    "lmax",
    "height_km",
    "step_deg",
    "lat_max",
    "region",
    "thresholds_mg",
    "device",
    "ellipsoid",
    "epoch",
    "units",
    "progress",
)


@_compat.keyword_api(1, _OLD_ORDER)
def disturbance_map(
    model="eigen-6s",
    *,
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
    client=None,
    scheduler=None,
    chunks=None,
    rows_per_block=None,
    percentile_method="histogram",
) -> xr.Dataset:
    """Gravity disturbance map δg = g_model − γ_exact at one height (Chen et al. 2022 §4.1).

    One engine computes every map: the grid is split into blocks of latitude rows
    (:func:`fieldmap.products.blocks.plan_blocks`), the blocks run here (default) or on a Dask
    cluster, and the statistics are folded from per-block partial results in block order, so
    the values and statistics are the same bits whatever runs the blocks and however many rows
    a block holds.

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
        Epoch for time-variable models (applied to a model object too).
    units : {"mGal", "mg", "m/s2"}
        Units of east, north, up, modulus (``modulus_mg`` is always added); any spelling of
        :mod:`fieldmap.units` (``"m s-2"``, any case).
    progress : bool, optional
        Progress bar over the row blocks, on stderr. Default: shown for grids of 2e6 nodes or
        more when stderr is a terminal (:func:`show_progress`); False keeps it quiet.
    client : dask.distributed.Client, optional
        Run the blocks on this cluster.
    scheduler : str, optional
        ``"local:N"`` (a LocalCluster of N processes for this call), a scheduler address, or
        ``"threads"`` (here, as the default).
    chunks : int or "auto", optional
        Return a lazy dask-backed Dataset, blocks of at most this many latitude rows (no
        statistics: they need the whole map).
    rows_per_block : int, optional
        Most latitude rows per block (default: from the memory budget and the grid). The
        results do not depend on it.
    percentile_method : {"histogram", "exact"}
        ``"histogram"`` (default): percentiles from the merged per-block histograms, within a
        relative :data:`fieldmap.products.blockstats.PERCENTILE_RTOL` of the exact ones, the
        same on every executor and in streamed files; ``"exact"``: the weighted percentiles of
        the whole map. Recorded in the ``percentile_method`` attribute.

    Returns
    -------
    xarray.Dataset
        Variables east, north, up, modulus, modulus_mg on (latitude, longitude); area-weighted
        statistics (max_mg, mean_mg, rms_mg, p50_mg, ..., area_fraction_above_<t>_mg, the
        threshold written with "p" for its point, e.g. ``area_fraction_above_0p05_mg``: see
        :func:`fieldmap.products.cf.fraction_attr`) in the attributes.
    """
    h = heights_m(height_km, "disturbance_map takes one height; use altitude_sweep for several")
    return _disturbance_product(
        dict(
            model=model,
            lmax=lmax,
            step_deg=step_deg,
            lat_max=lat_max,
            region=region,
            thresholds_mg=thresholds_mg,
            device=device,
            ellipsoid=ellipsoid,
            epoch=epoch,
            units=units,
            progress=progress,
        ),
        h,
        stacked=False,
        engine=dict(
            client=client,
            scheduler=scheduler,
            chunks=chunks,
            rows_per_block=rows_per_block,
            percentile_method=percentile_method,
        ),
    )


@_compat.keyword_api(1, _OLD_ORDER)
def altitude_sweep(
    model="eigen-6s",
    *,
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
    client=None,
    scheduler=None,
    chunks=None,
    rows_per_block=None,
    percentile_method="histogram",
) -> xr.Dataset:
    """Disturbance maps and their statistics over a list of heights (Chen et al. 2022 Fig. 7).

    Parameters are those of :func:`disturbance_map`; ``height_km`` is a sequence of distinct
    heights (km).

    Returns
    -------
    xarray.Dataset
        east, north, up, modulus, modulus_mg on (height, latitude, longitude); ``max_mg``,
        ``mean_mg``, ``p50_mg``, ``p99_mg`` on (height) and ``area_fraction_above`` on
        (height, threshold_mg).
    """
    h = heights_m(height_km)
    return _disturbance_product(
        dict(
            model=model,
            lmax=lmax,
            step_deg=step_deg,
            lat_max=lat_max,
            region=region,
            thresholds_mg=thresholds_mg,
            device=device,
            ellipsoid=ellipsoid,
            epoch=epoch,
            units=units,
            progress=progress,
        ),
        h,
        stacked=True,
        engine=dict(
            client=client,
            scheduler=scheduler,
            chunks=chunks,
            rows_per_block=rows_per_block,
            percentile_method=percentile_method,
        ),
    )


def _disturbance_product(opts: dict, h: np.ndarray, *, stacked: bool, engine: dict) -> xr.Dataset:
    """Compute :func:`disturbance_map` or :func:`altitude_sweep`: the one path, the block engine."""
    from fieldmap.products import distributed, lazy

    _check_units(opts["units"])
    method = check_percentile_method(engine["percentile_method"])
    chunks, client, scheduler = engine["chunks"], engine["client"], engine["scheduler"]
    rows = engine["rows_per_block"]
    if chunks is not None:
        if scheduler is not None:
            raise InputError("chunks= returns a lazy Dataset: pass client=, not scheduler=")
        if method != "histogram":
            raise InputError("a lazy Dataset (chunks=) carries no statistics: no percentile_method")
        if rows is not None:
            raise InputError("chunks= sets the rows of a lazy Dataset's blocks: no rows_per_block")
        opts.pop("progress")
        return lazy.lazy_disturbance(
            heights_m=h, **opts, stacked=stacked, chunks=chunks, client=client
        )
    return distributed.disturbance_blocks(
        heights_m=h,
        **opts,
        stacked=stacked,
        client=client,
        scheduler=scheduler,
        rows_per_block=rows,
        percentile_method=method,
    )


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

"""The map products of Chen et al. (2022) §4 and the geodesist's quantity maps: thin façades.

Each function builds one :class:`fieldmap.products.request.MapRequest` from its keyword
options (validated there, once: :meth:`~fieldmap.products.request.MapRequest.build`) and runs
it on the one block engine (:func:`fieldmap.products.engine.compute`): disturbance maps and
sweeps, J2n truncation maps, model and normal gravity components, quantity maps. Every one
returns an ``xarray.Dataset`` with CF-1.8 attributes on (latitude, longitude) (and ``height``
or ``order`` for stacks); vectors are in the local geodetic east-north-up frame; statistics use
area weights (:mod:`fieldmap.products.statistics`). Each names its options in its signature
(``help()`` and an IDE show them); a request built once can be run again with
:meth:`MapRequest.compute <fieldmap.products.request.MapRequest.compute>`.

Examples
--------
>>> import fieldmap
>>> ds = fieldmap.disturbance_map(lmax=12, height_km=20, step_deg=30.0)
>>> sorted(ds.data_vars)
['east', 'modulus', 'modulus_mg', 'north', 'up']
>>> sweep = fieldmap.altitude_sweep(lmax=12, height_km=[10, 20], step_deg=30.0)
>>> float(sweep.sel(height_km=20)["max_mg"]) == ds.attrs["max_mg"]
True
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import xarray as xr

from fieldmap.errors import InputError
from fieldmap.products.request import DEFAULT_THRESHOLDS_MG, MapRequest

if TYPE_CHECKING:
    from fieldmap.field.ellipsoid import Ellipsoid
    from fieldmap.models.shmodel import SHModel

__all__ = [
    "altitude_sweep",
    "component_maps",
    "disturbance_map",
    "quantity_map",
    "truncation_map",
]

#: Heights of the sweeps (km).
SWEEP_HEIGHTS_KM = (20.0, 30.0, 50.0, 70.0, 100.0)


def _compute(request: MapRequest) -> xr.Dataset:
    from fieldmap.products.engine import compute

    return compute(request)


def disturbance_map(
    model: SHModel | str | os.PathLike[str] | None = None,
    *,
    lmax: int | None = None,
    epoch: float | str | None = None,
    height_km: float = 20.0,
    step_deg: float = 1.0,
    lat_max: float = 80.0,
    region: Sequence[float] | None = None,
    thresholds_mg: Sequence[float] = DEFAULT_THRESHOLDS_MG,
    ellipsoid: Ellipsoid | str = "WGS84",
    units: str = "mGal",
    device: str | None = None,
    progress: bool | None = None,
    client: Any = None,
    scheduler: str | None = None,
    chunks: int | str | None = None,
    rows_per_block: int | None = None,
    percentile_method: str = "histogram",
) -> xr.Dataset:
    """Gravity disturbance map δg = g_model − γ_exact at one height (Chen et al. 2022 §4.1).

    One engine computes every map: the grid is split into blocks of latitude rows
    (:func:`fieldmap.products.engine.plan_blocks`), the blocks run here (default) or on a Dask
    cluster, and the statistics are folded from per-block partial results in block order, so
    the values and statistics are the same bits whatever runs the blocks and however many rows
    a block holds. The options are checked once, by
    :meth:`fieldmap.products.request.MapRequest.build`.

    Parameters
    ----------
    model : str, path or SHModel, optional
        Bundled name (default ``"eigen-6s"``), ICGEM file, or a model object.
    lmax : int, optional
        Truncation degree (default: the model's).
    epoch : float or str, optional
        Epoch of time-variable models. Units: decimal year or ``'YYYY-MM-DD'``.
    height_km : float
        Height above the ellipsoid, -10 ≤ h ≤ 1e5 (:mod:`fieldmap.limits`). Units: km.
    step_deg, lat_max : float
        Grid spacing and latitude limit of a global grid. Units: degrees.
    region : (west, east, south, north), optional
        A regional grid instead. Units: degrees.
    thresholds_mg : sequence of float
        Thresholds of the area fractions (default 0.02, 0.05, 0.06, 0.10). Units: mg.
    ellipsoid : {"WGS84", "GRS80"} or Ellipsoid
        The normal field.
    units : str
        Units of east, north, up, modulus: ``"mGal"`` (default), ``"mg"``, ``"m/s2"``, any
        spelling of :mod:`fieldmap.units` (``modulus_mg`` is always added).
    device : str, optional
        Warp device.
    progress : bool, optional
        Progress bar over the blocks, on stderr (default: for grids of 2e6 nodes or more on a
        terminal).
    client : dask.distributed.Client, optional
        Run the blocks on this Dask cluster.
    scheduler : str, optional
        Or on this one: ``"local:N"``, an address, or ``"threads"``.
    chunks : int or "auto", optional
        Return a lazy dask-backed Dataset, blocks of at most this many latitude rows (no
        statistics: they need the whole map).
    rows_per_block : int, optional
        Most latitude rows per block (the results do not depend on it).
    percentile_method : {"histogram", "exact"}
        Percentiles from the merged per-block histograms, within a relative
        :data:`fieldmap.products.statistics.PERCENTILE_RTOL` of the exact ones, the same on
        every executor and in streamed files; or the weighted percentiles of the whole map.

    Returns
    -------
    xarray.Dataset
        Variables east, north, up, modulus, modulus_mg on (latitude, longitude); area-weighted
        statistics of the modulus (max_mg, min_mg, mean_mg, rms_mg, p50_mg, p90_mg, p99_mg,
        area_fraction_above_<t>_mg, the threshold written with "p" for its point, e.g.
        ``area_fraction_above_0p05_mg``: see :func:`fieldmap.products.variables.fraction_attr`)
        in the attributes; ``height`` (m) and ``height_km`` coordinates.

    Examples
    --------
    >>> import fieldmap
    >>> ds = fieldmap.disturbance_map(lmax=12, height_km=20, step_deg=30.0)
    >>> ds["modulus_mg"].dims, float(ds["height_km"])
    (('latitude', 'longitude'), 20.0)
    """
    return _compute(
        MapRequest.build(
            model=model,
            lmax=lmax,
            epoch=epoch,
            height_km=height_km,
            step_deg=step_deg,
            lat_max=lat_max,
            region=region,
            thresholds_mg=thresholds_mg,
            ellipsoid=ellipsoid,
            units=units,
            device=device,
            progress=progress,
            client=client,
            scheduler=scheduler,
            chunks=chunks,
            rows_per_block=rows_per_block,
            percentile_method=percentile_method,
            stacked=False,
        )  # fmt: skip
    )


def altitude_sweep(
    model: SHModel | str | os.PathLike[str] | None = None,
    *,
    lmax: int | None = None,
    epoch: float | str | None = None,
    height_km: Sequence[float] = SWEEP_HEIGHTS_KM,
    step_deg: float = 1.0,
    lat_max: float = 80.0,
    region: Sequence[float] | None = None,
    thresholds_mg: Sequence[float] = DEFAULT_THRESHOLDS_MG,
    ellipsoid: Ellipsoid | str = "WGS84",
    units: str = "mGal",
    device: str | None = None,
    progress: bool | None = None,
    client: Any = None,
    scheduler: str | None = None,
    chunks: int | str | None = None,
    rows_per_block: int | None = None,
    percentile_method: str = "histogram",
) -> xr.Dataset:
    """Disturbance maps and their statistics over a list of heights (Chen et al. 2022 Fig. 7).

    Parameters
    ----------
    height_km : sequence of float
        Distinct heights (default 20, 30, 50, 70, 100). Units: km.
    model, lmax, epoch, step_deg, lat_max, region, thresholds_mg, ellipsoid, units, device, \
progress, client, scheduler, chunks, rows_per_block, percentile_method
        As in :func:`disturbance_map`.

    Returns
    -------
    xarray.Dataset
        east, north, up, modulus, modulus_mg on (height, latitude, longitude); the statistics
        of a map, under the same names (``max_mg``, ``min_mg``, ``mean_mg``, ``rms_mg``,
        ``p50_mg``, ``p90_mg``, ``p99_mg``), as variables on (height), and
        ``area_fraction_above`` on (height, threshold_mg). ``height`` is in metres (CF) and
        ``height_km`` indexes the same dimension: ``sweep.sel(height_km=20)``.

    Examples
    --------
    >>> import fieldmap
    >>> sweep = fieldmap.altitude_sweep(lmax=12, height_km=[10, 20], step_deg=30.0)
    >>> sweep["max_mg"].dims, sweep.sel(height_km=10)["height"].item()
    (('height',), 10000.0)
    """
    return _compute(
        MapRequest.build(
            model=model,
            lmax=lmax,
            epoch=epoch,
            height_km=height_km,
            step_deg=step_deg,
            lat_max=lat_max,
            region=region,
            thresholds_mg=thresholds_mg,
            ellipsoid=ellipsoid,
            units=units,
            device=device,
            progress=progress,
            client=client,
            scheduler=scheduler,
            chunks=chunks,
            rows_per_block=rows_per_block,
            percentile_method=percentile_method,
            stacked=True,
        )  # fmt: skip
    )


def truncation_map(
    *,
    height_km: float = 20.0,
    orders: Sequence[int] = (2, 4, 6),
    step_deg: float = 1.0,
    lat_max: float = 80.0,
    region: Sequence[float] | None = None,
    ellipsoid: Ellipsoid | str = "WGS84",
    units: str = "mGal",
    device: str | None = None,
    progress: bool | None = None,
    client: Any = None,
    scheduler: str | None = None,
    rows_per_block: int | None = None,
) -> xr.Dataset:
    """Map the truncation error of the J2/J4/J6 normal gravitation against the exact one (Fig. 8).

    δg_Jn = g_Jn − γ_exact with g_Jn from eqs. (7)-(13) of Chen et al. (2022) (gradient
    corrected) and γ_exact the closed-form level-ellipsoid gravitation. Computed on the block
    engine as every map (one layer per order).

    Parameters
    ----------
    height_km : float
        One height. Units: km.
    orders : sequence of int
        Distinct orders among 2, 4, 6 (2.5 is an error, not order 2).
    step_deg, lat_max, region, ellipsoid, units, device, progress, client, scheduler, \
rows_per_block
        As in :func:`disturbance_map`.

    Returns
    -------
    xarray.Dataset
        east, north, up, modulus, modulus_mg on (order, latitude, longitude); ``max_mg`` and
        the area-weighted ``mean_mg`` and ``rms_mg`` on (order). The field is independent of
        longitude (both are axisymmetric).

    Examples
    --------
    >>> import fieldmap
    >>> tr = fieldmap.truncation_map(orders=(2, 4), step_deg=30.0)
    >>> tr["max_mg"].dims, tr["order"].values.tolist()
    (('order',), [2, 4])
    """
    return _compute(
        MapRequest.build(
            height_km=height_km,
            orders=orders,
            step_deg=step_deg,
            lat_max=lat_max,
            region=region,
            ellipsoid=ellipsoid,
            units=units,
            device=device,
            progress=progress,
            client=client,
            scheduler=scheduler,
            rows_per_block=rows_per_block,
            quantity="truncation",
        )  # fmt: skip
    )


def component_maps(
    model: SHModel | str | os.PathLike[str] | None = None,
    *,
    lmax: int | None = None,
    epoch: float | str | None = None,
    height_km: float = 20.0,
    step_deg: float = 1.0,
    lat_max: float = 80.0,
    region: Sequence[float] | None = None,
    ellipsoid: Ellipsoid | str = "WGS84",
    device: str | None = None,
    progress: bool | None = None,
    client: Any = None,
    scheduler: str | None = None,
    rows_per_block: int | None = None,
) -> xr.Dataset:
    """Model gravity and normal gravity components at one height (Chen et al. 2022 Figs. 2-3).

    Both include the centrifugal acceleration of the ellipsoid's rotation rate. Computed on the
    block engine as every map.

    Parameters
    ----------
    model, lmax, epoch, height_km, step_deg, lat_max, region, ellipsoid, device, progress, \
client, scheduler, rows_per_block
        As in :func:`disturbance_map` (one height).

    Returns
    -------
    xarray.Dataset
        ``model_east``, ``model_north``, ``model_up`` and ``normal_east``, ``normal_north``,
        ``normal_up`` on (latitude, longitude). Units: m s-2.

    Examples
    --------
    >>> import fieldmap
    >>> ds = fieldmap.component_maps(lmax=12, step_deg=30.0)
    >>> round(float(ds["normal_up"].min()), 2)  # at 60° N and S, 20 km up. Units: m/s²
    -9.76
    """
    return _compute(
        MapRequest.build(
            model=model,
            lmax=lmax,
            epoch=epoch,
            height_km=height_km,
            step_deg=step_deg,
            lat_max=lat_max,
            region=region,
            ellipsoid=ellipsoid,
            device=device,
            progress=progress,
            client=client,
            scheduler=scheduler,
            rows_per_block=rows_per_block,
            quantity="components",
        )  # fmt: skip
    )


def quantity_map(
    quantity: str,
    *,
    model: SHModel | str | os.PathLike[str] | None = None,
    lmax: int | None = None,
    epoch: float | str | None = None,
    height_km: float | Sequence[float] = 20.0,
    step_deg: float = 1.0,
    lat_max: float = 80.0,
    region: Sequence[float] | None = None,
    ellipsoid: Ellipsoid | str = "WGS84",
    device: str | None = None,
    progress: bool | None = None,
    client: Any = None,
    scheduler: str | None = None,
    chunks: int | str | None = None,
    rows_per_block: int | None = None,
    degree0: bool = False,
    omission_model: str | None = None,
) -> xr.Dataset:
    """Map of a geodetic quantity on a global or regional grid, at one or several heights.

    Parameters
    ----------
    quantity : str
        ``"disturbance"`` is :func:`disturbance_map` (one height) or :func:`altitude_sweep`;
        ``"gradient"``, ``"gradient-disturbance"``, ``"gradient-normal"`` the six ENU
        components of the gradient tensor of gravity, of the disturbance or of exact normal
        gravity (:func:`fieldmap.field.gradient.grid_gradient`, Eötvös);
        ``"disturbance-sigma"``, ``"anomaly-sigma"``, ``"geoid-sigma"`` the commission error
        from the model's coefficient sigma; ``"omission-sigma"`` the σ (north, east, down,
        modulus; mGal) of the field above the model's degree, from a degree-variance model
        (:class:`fieldmap.field.omission.Omission`); ``"anomaly"``, ``"deflection"``,
        ``"geoid"``, ``"potential"`` those of :func:`fieldmap.field.geodesy.grid_quantities`,
        as are ICGEM's functionals (Barthelmes 2013) ``"height-anomaly"`` (ζ on the ellipsoid,
        m), ``"anomaly-classical"`` (mGal), ``"disturbance-sa"`` (−∂T/∂r, mGal) and ``"trr"``
        (∂²T/∂r², E); ``"ewh"``: equivalent water height (m) of a difference of two fields
        (``model=fieldmap.field.water.field_difference(a, b)``; one field alone is refused).
    height_km : float or sequence of float
        One height or several (a sweep); ignored for the geoid, a property of the surface.
        Units: km.
    degree0 : bool
        Keep the degree-0 term of T (default False, as GeographicLib).
    omission_model : {"tscherning-rapp", "kaula", "fitted"}, optional
        The degree-variance model of ``"omission-sigma"`` (default ``"tscherning-rapp"``).
    model, lmax, epoch, step_deg, lat_max, region, ellipsoid, device, progress, client, \
scheduler, chunks, rows_per_block
        As in :func:`disturbance_map`.

    Returns
    -------
    xarray.Dataset
        The quantity's variables (:data:`fieldmap.products.variables.VARIABLES`) with
        ``units``, ``long_name`` (and ``standard_name`` where CF has one), area-weighted
        ``min``, ``max``, ``mean``, ``rms`` in each variable's attributes (per height for a
        sweep: ``<var>_max`` etc. on height).

    Examples
    --------
    >>> import fieldmap
    >>> ds = fieldmap.quantity_map("geoid", lmax=12, step_deg=30.0)
    >>> ds["geoid"].attrs["units"]
    'm'
    """
    import numpy as np

    run = dict(
        model=model, lmax=lmax, epoch=epoch, step_deg=step_deg, lat_max=lat_max, region=region,
        ellipsoid=ellipsoid, device=device, progress=progress, client=client,
        scheduler=scheduler, chunks=chunks, rows_per_block=rows_per_block,
    )  # fmt: skip
    if quantity == "disturbance":
        if degree0:
            raise InputError(
                "degree0 applies to the potential T and its quantities, not to δg", param="degree0"
            )
        if omission_model is not None:
            raise InputError(
                "omission_model applies to the omission-sigma quantity, not to disturbance",
                param="omission_model",
            )
        hs = np.atleast_1d(np.asarray(height_km, dtype=object)).ravel()
        if hs.size == 1:
            return disturbance_map(height_km=hs[0], **run)
        return altitude_sweep(height_km=list(hs), **run)
    from fieldmap.products.variables import QUANTITIES

    if quantity not in QUANTITIES:
        raise InputError(
            f"quantity must be one of {', '.join(QUANTITIES)}, got {quantity!r}", param="quantity"
        )
    if quantity == "ewh" and degree0:
        raise InputError(
            "degree0 applies to the potential T and its quantities, not to EWH", param="degree0"
        )
    return _compute(
        MapRequest.build(
            quantity=quantity,
            height_km=height_km,
            degree0=degree0,
            omission_model=omission_model,
            stacked=True,
            **run,
        )  # fmt: skip
    )

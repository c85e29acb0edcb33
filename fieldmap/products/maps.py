"""The map products of Chen et al. (2022) §4 and the geodesist's quantity maps: thin façades.

Each function builds one :class:`fieldmap.products.request.MapRequest` from its keyword
options (validated there, once) and runs it on the one block engine
(:func:`fieldmap.products.engine.compute`): disturbance maps and sweeps, J2n truncation maps,
model and normal gravity components, quantity maps. Every one returns an ``xarray.Dataset``
with CF-1.8 attributes on (latitude, longitude) (and ``height`` or ``order`` for stacks);
vectors are in the local geodetic east-north-up frame; statistics use area weights
(:mod:`fieldmap.products.statistics`).

Why ``**options``: the products share some seventeen options (model, degree, epoch, heights,
grid, ellipsoid, units, thresholds, device, executor, block rows...), the fields of a request.
Spelling them out in every signature wrote the same list five times and let them drift; the
façades take them by keyword, exactly as before (``disturbance_map(lmax=36, height_km=20)``),
and :meth:`~fieldmap.products.request.MapRequest.build` checks every name and value in one
place. A request built once can be run again with :meth:`MapRequest.compute
<fieldmap.products.request.MapRequest.compute>`.

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

from typing import Any

import xarray as xr

from fieldmap.errors import InputError
from fieldmap.products.request import MapRequest

__all__ = [
    "altitude_sweep",
    "component_maps",
    "disturbance_map",
    "quantity_map",
    "truncation_map",
]

#: Options each façade takes (the rest of a request is set by the façade itself).
_GRID = ("height_km", "step_deg", "lat_max", "region", "ellipsoid")
_MODEL = ("model", "lmax", "epoch")
_RUN = ("device", "progress", "client", "scheduler", "rows_per_block")
_DISTURBANCE = (*_MODEL, *_GRID, *_RUN, "thresholds_mg", "units", "chunks", "percentile_method")
_TRUNCATION = (*_GRID, *_RUN, "orders", "units")
_COMPONENTS = (*_MODEL, *_GRID, *_RUN)
_QUANTITY = (*_MODEL, *_GRID, *_RUN, "chunks", "degree0", "omission_model")


def _request(name: str, model: Any, options: dict, allowed: tuple, **fixed: Any) -> MapRequest:
    """Build the request of façade ``name`` from its options (refusing the ones it lacks)."""
    unknown = sorted(set(options) - set(allowed))
    if unknown:
        raise TypeError(f"{name}() got unexpected keyword arguments: {', '.join(unknown)}")
    if model is not None:
        if "model" in options:
            raise TypeError(f"{name}() got multiple values for argument 'model'")
        options["model"] = model
    return MapRequest.build(**options, **fixed)


def disturbance_map(model: Any = None, /, **options: Any) -> xr.Dataset:
    """Gravity disturbance map δg = g_model − γ_exact at one height (Chen et al. 2022 §4.1).

    One engine computes every map: the grid is split into blocks of latitude rows
    (:func:`fieldmap.products.engine.plan_blocks`), the blocks run here (default) or on a Dask
    cluster, and the statistics are folded from per-block partial results in block order, so
    the values and statistics are the same bits whatever runs the blocks and however many rows
    a block holds.

    Parameters
    ----------
    model : str, path or SHModel
        Bundled name (default ``"eigen-6s"``), ICGEM file, or a model object (also by
        keyword).
    **options
        Keyword options (fields of :class:`~fieldmap.products.request.MapRequest`):

        - ``lmax`` (int): truncation degree (default: the model's);
        - ``epoch`` (float or str): epoch of time-variable models;
        - ``height_km`` (float, default 20): height above the ellipsoid,
          -10 ≤ h ≤ 1e5 (:mod:`fieldmap.limits`). Units: km;
        - ``step_deg``, ``lat_max`` (float, default 1 and 80): grid spacing and latitude limit
          of a global grid. Units: degrees;
        - ``region`` ((west, east, south, north)): a regional grid instead. Units: degrees;
        - ``thresholds_mg`` (default 0.02, 0.05, 0.06, 0.10): thresholds of the area
          fractions. Units: mg;
        - ``ellipsoid`` (``"WGS84"`` default or ``"GRS80"``): the normal field;
        - ``units`` (``"mGal"`` default, ``"mg"``, ``"m/s2"``, any spelling of
          :mod:`fieldmap.units`): units of east, north, up, modulus (``modulus_mg`` is always
          added);
        - ``device`` (str): Warp device;
        - ``progress`` (bool): progress bar over the blocks, on stderr (default: for grids
          of 2e6 nodes or more on a terminal);
        - ``client`` (``dask.distributed.Client``) or ``scheduler`` (``"local:N"``, an
          address, or ``"threads"``): run the blocks on Dask;
        - ``chunks`` (int or ``"auto"``): return a lazy dask-backed Dataset, blocks of at most
          this many latitude rows (no statistics: they need the whole map);
        - ``rows_per_block`` (int): most latitude rows per block (the results do not depend
          on it);
        - ``percentile_method`` (``"histogram"`` default, or ``"exact"``): percentiles from
          the merged per-block histograms, within a relative
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
    from fieldmap.products.engine import compute

    return compute(_request("disturbance_map", model, options, _DISTURBANCE, stacked=False))


def altitude_sweep(model: Any = None, /, **options: Any) -> xr.Dataset:
    """Disturbance maps and their statistics over a list of heights (Chen et al. 2022 Fig. 7).

    The options are those of :func:`disturbance_map`; ``height_km`` is a sequence of distinct
    heights (km; default 20, 30, 50, 70, 100).

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
    from fieldmap.products.engine import compute

    options.setdefault("height_km", (20.0, 30.0, 50.0, 70.0, 100.0))
    return compute(_request("altitude_sweep", model, options, _DISTURBANCE, stacked=True))


def truncation_map(**options: Any) -> xr.Dataset:
    """Map the truncation error of the J2/J4/J6 normal gravitation against the exact one (Fig. 8).

    δg_Jn = g_Jn − γ_exact with g_Jn from eqs. (7)-(13) of Chen et al. (2022) (gradient
    corrected) and γ_exact the closed-form level-ellipsoid gravitation. Computed on the block
    engine as every map (one layer per order).

    Parameters
    ----------
    **options
        ``height_km`` (one height, default 20. Units: km), ``orders`` (distinct orders among
        2, 4, 6, default all; 2.5 is an error, not order 2), and ``step_deg``, ``lat_max``,
        ``region``, ``ellipsoid``, ``units``, ``device``, ``progress``, ``client``,
        ``scheduler``, ``rows_per_block`` as in :func:`disturbance_map`.

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
    from fieldmap.products.engine import compute

    options.setdefault("orders", (2, 4, 6))
    return compute(_request("truncation_map", None, options, _TRUNCATION, quantity="truncation"))


def component_maps(model: Any = None, /, **options: Any) -> xr.Dataset:
    """Model gravity and normal gravity components at one height (Chen et al. 2022 Figs. 2-3).

    Both include the centrifugal acceleration of the ellipsoid's rotation rate. Computed on the
    block engine as every map.

    Parameters
    ----------
    model : str, path or SHModel
        As in :func:`disturbance_map`.
    **options
        ``lmax``, ``epoch``, ``height_km`` (one height), ``step_deg``, ``lat_max``,
        ``region``, ``ellipsoid``, ``device``, ``progress``, ``client``, ``scheduler``,
        ``rows_per_block`` as in :func:`disturbance_map`.

    Returns
    -------
    xarray.Dataset
        ``model_east``, ``model_north``, ``model_up`` and ``normal_east``, ``normal_north``,
        ``normal_up`` on (latitude, longitude). Units: m s-2.
    """
    from fieldmap.products.engine import compute

    return compute(_request("component_maps", model, options, _COMPONENTS, quantity="components"))


def quantity_map(quantity: str, **options: Any) -> xr.Dataset:
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
    **options
        ``model``, ``lmax``, ``epoch``, ``height_km`` (one or several; ignored for the geoid,
        a property of the surface), ``step_deg``, ``lat_max``, ``region``, ``ellipsoid``,
        ``device``, ``progress``, ``client``, ``scheduler``, ``chunks``, ``rows_per_block`` as
        in :func:`disturbance_map`; ``degree0`` (bool): keep the degree-0 term of T (default
        False, as GeographicLib); ``omission_model`` (``"tscherning-rapp"`` default,
        ``"kaula"``, ``"fitted"``): the degree-variance model of ``"omission-sigma"``.

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

    from fieldmap.products.engine import compute

    if quantity == "disturbance":
        if options.pop("degree0", False):
            raise InputError("degree0 applies to the potential T and its quantities, not to δg")
        hs = np.atleast_1d(np.asarray(options.pop("height_km", 20.0), dtype=object)).ravel()
        if hs.size == 1:
            return disturbance_map(height_km=hs[0], **options)
        return altitude_sweep(height_km=list(hs), **options)
    from fieldmap.products.variables import QUANTITIES

    if quantity not in QUANTITIES:
        raise InputError(f"quantity must be one of {', '.join(QUANTITIES)}, got {quantity!r}")
    if quantity == "ewh" and options.get("degree0", False):
        raise InputError("degree0 applies to the potential T and its quantities, not to EWH")
    return compute(
        _request("quantity_map", None, options, _QUANTITY, quantity=quantity, stacked=True)
    )

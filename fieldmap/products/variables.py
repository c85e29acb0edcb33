"""What a map product holds: its variables, CF-1.8 attributes and JSON summary, per quantity.

One place for every executor and sink: the products computed in memory, lazily or streamed to
a file (:mod:`fieldmap.products.engine`, :mod:`fieldmap.products.sinks`) build their Datasets
from the templates here (:func:`disturbance_template`, :func:`quantity_template`), so that the
files agree attribute for attribute. Attributes follow the CF conventions 1.8 (``units``,
``standard_name``, ``long_name``) as harmonica's grids do. :func:`summary` is the one
JSON-ready summary of every product (``fieldmap map|sweep|truncation`` write it).

Heights: the ``height`` coordinate is in metres (CF); ``height_km`` rides along on the same
dimension (in the unit the heights are given in), so that ``sweep.sel(height_km=20)`` works.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import threading
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr

from fieldmap import __version__
from fieldmap.errors import InputError
from fieldmap.products.quantities import MAP_QUANTITIES, Variable, vector_variables
from fieldmap.products.quantities import quantity as get_quantity
from fieldmap.products.statistics import threshold_key
from fieldmap.units import MG, get_unit

if TYPE_CHECKING:
    from xarray.indexes import PandasIndex

    from fieldmap.field.ellipsoid import Ellipsoid
    from fieldmap.grids.spec import GridSpec
    from fieldmap.models.shmodel import SHModel
    from fieldmap.units import Unit

REFERENCE = (
    "Chen K., Zeng C.-Z., Pei S.-S., Liang W.-C. (2022), Normal gravity model for inertial "
    "navigation of a hypersonic boost-glide vehicle, J. Zhejiang Univ. Sci. A, "
    "doi:10.1631/jzus.A2100133, Section 4"
)
#: CF names of the east, north, up components.
COMPONENTS = {"east": "eastward", "north": "northward", "up": "upward"}
#: Variables of a disturbance product (and of each of its blocks), in the order of
#: :func:`vector_vars`.
DISTURBANCE_VARIABLES = ("east", "north", "up", "modulus", "modulus_mg")
#: milli-g in UDUNITS terms. UDUNITS (and so every CF tool) reads "mg" as milligram, a mass;
#: a scaled SI unit converts correctly to m s-2 and mGal.
MG_UNITS = "0.00980665 m s-2"
MG_COMMENT = (
    "values in mg (milli-g): 1 mg = 1e-3 g_n = 9.80665e-3 m s-2 = 980.665 mGal; the units "
    "attribute spells it as a scaled SI unit because UDUNITS reads 'mg' as milligram"
)


def cf_units(units: str) -> str:
    """Return the ``units`` attribute (UDUNITS spelling) of a :data:`fieldmap.units.UNITS` unit."""
    return get_unit(units).udunits


def units_scale(units_attr: str) -> float:
    """Size in m/s² of a unit given by name (:data:`UNITS`) or by its ``units`` attribute."""
    try:
        return get_unit(units_attr).si
    except InputError:
        raise KeyError(units_attr) from None


def mg_attrs(long_name: str) -> dict:
    """Attributes of a variable in mg: UDUNITS-readable units, a comment naming milli-g."""
    return {"units": MG_UNITS, "long_name": long_name, "comment": MG_COMMENT}


def attr_name(key: str) -> str:
    """Return a legal CF attribute name for a statistics key: "p99.9_mg" -> "p99p9_mg".

    CF attribute names are letters, digits and underscores (CF 1.8 §2.3): "." becomes "p"
    (point) and "-" becomes "m" (minus), as in "0p05".
    """
    return key.replace(".", "p").replace("-", "m").replace("+", "")


def fraction_attr(threshold_mg: float) -> str:
    """Global attribute of the area fraction above a threshold: 0.05 -> area_fraction_above_0p05_mg.

    The JSON summaries keep the threshold as written ("0.05"); see
    :func:`fieldmap.products.statistics.threshold_key`.
    """
    return attr_name(f"area_fraction_above_{threshold_key(threshold_mg)}_mg")


def coords(grid: GridSpec, stacked_heights: bool) -> dict[str, xr.Variable]:
    """Latitude, longitude and height coordinates of ``grid`` (height a dimension if stacked)."""
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
    kmattrs = {"units": "km", "long_name": "height above the ellipsoid in km"}
    if stacked_heights:
        height = xr.Variable("height", grid.heights, hattrs)
        km = xr.Variable("height", grid.heights / 1e3, kmattrs)
    else:
        height = xr.Variable((), grid.heights[0], hattrs)
        km = xr.Variable((), grid.heights[0] / 1e3, kmattrs)
    return {"latitude": lat, "longitude": lon, "height": height, "height_km": km}


def index_height_km(ds: xr.Dataset) -> xr.Dataset:
    """Give a stack of heights an index on ``height_km`` too, so ``ds.sel(height_km=20)`` works.

    ``height`` (metres, CF) stays the dimension coordinate; ``height_km`` is the same heights
    in the unit the API and the CLI take them in.
    """
    if "height_km" in ds.coords and ds["height_km"].dims == ("height",):
        ds = ds.set_xindex("height_km")
    return ds


def global_attrs(
    title: str, model: SHModel | None, ellipsoid: Ellipsoid, grid: GridSpec, source: str
) -> dict[str, Any]:
    """Global attributes: conventions, provenance, grid, and the model's when ``model`` is given."""
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
                **_tide_conversion(model, str(attrs["history"])),
                "model_gm": float(model.gm),
                "model_radius": float(model.radius),
            }
        )
    if grid.heights.size == 1:
        attrs["height_m"] = float(grid.heights[0])
    return attrs


def _tide_conversion(model: SHModel, history: str) -> dict[str, Any]:
    """Return the file's tide system and a history line of a model converted to another."""
    if not (isinstance(model.header, dict) and "tide_origin" in model.header):
        return {}  # read as it is (and fieldmap.models.tide not imported)
    from fieldmap.models.tide import conversion_note

    note = conversion_note(model)
    if not note:
        return {}
    system = model.header["tide_origin"]["system"]
    return {"model_tide_system_of_file": system, "history": f"{history}; {model.name} {note}"}


def converted_tide_system(attrs: Mapping[str, Any]) -> str | None:
    """Return the tide system of a product's model converted from its file's, else None.

    Read from the global attributes :func:`global_attrs` writes (``model_tide_system`` and
    ``model_tide_system_of_file``): file names and figure titles name it (``--tide-system``).
    """
    of_file = attrs.get("model_tide_system_of_file")
    system = attrs.get("model_tide_system")
    return str(system) if of_file is not None and of_file != system else None


def disturbance_attrs(mod: SHModel, grid: GridSpec, ell: Ellipsoid) -> dict[str, Any]:
    """Global attributes of a gravity-disturbance product (in-memory or block by block)."""
    heights = ", ".join(f"{x / 1e3:g}" for x in grid.heights)
    return global_attrs(
        f"Gravity disturbance at {heights} km, {mod.name} degree {mod.lmax}",
        mod,
        ell,
        grid,
        f"fieldmap {__version__}: {mod.name} degree {mod.lmax} gravitation minus exact "
        f"normal gravitation of {ell.name}",
    )


def convert_rows(
    comps: np.ndarray,
    dst: np.ndarray,
    mods: np.ndarray,
    scale: float,
    a: int | None = None,
    b: int | None = None,
) -> None:
    """Convert m/s² components to a unit of size ``scale`` and take the moduli, on rows [a, b).

    ``comps`` (3, rows, ...) and ``dst`` (3, rows, ...; ``comps`` itself converts in place)
    hold the components, ``mods`` (2, rows, ...) receives the modulus in the unit and in mg;
    element by element, on the rows ``[a, b)`` of the second axis (default: everything). The
    one conversion of :func:`vector_vars` and of the blocks of the maps
    (:func:`fieldmap.products.layouts.disturbance_partial`): the same bits.
    """
    ix = (slice(None),) if a is None else (slice(None), slice(a, b))
    c, d, m = comps[ix], dst[ix], mods[ix]
    np.divide(c, scale, out=d)
    np.einsum("k...,k...->...", d, d, out=m[0])  # one pass, no temporaries
    np.sqrt(m[0], out=m[0])  # in ``units``
    np.multiply(m[0], scale / MG, out=m[1])


def vector_vars(
    vec: np.ndarray, dims: tuple[str, ...], units: str | Unit, what: str, overwrite: bool = False
) -> dict[str, Any]:
    """east/north/up/modulus variables (in ``units``) plus modulus_mg, from m/s² ``vec``.

    ``vec`` has the components last (any leading shape, views welcome). With ``overwrite``
    the components are converted in place and become the east/north/up variables (views of
    ``vec``), so that a map allocates only its two moduli: on a fine grid, fresh memory costs
    more than the arithmetic (the public map call is meant to cost little more than its
    synthesis).
    ``units`` is any spelling :func:`fieldmap.units.get_unit` accepts.
    """
    from fieldmap.grids.longitude import map_rows

    unit = get_unit(units)
    scale, units = unit.si, unit.name
    comps = np.moveaxis(vec, -1, 0)
    if overwrite:
        buf = np.empty((2, *comps.shape[1:]))
        dst = comps
    else:
        buf = np.empty((5, *comps.shape[1:]))
        dst = buf[:3]
    mods = buf[-2:]
    if overwrite and comps.ndim > 2:  # rows of the grid: parts on the CPU threads
        map_rows(lambda a, b: convert_rows(comps, dst, mods, scale, a, b), comps.shape[1], 32)
    else:
        convert_rows(comps, dst, mods, scale)
    attrs = vector_attrs(units, what)
    values = dict(zip(attrs, (*dst, *mods)))
    return {name: (dims, values[name], a) for name, a in attrs.items()}


def vector_attrs(units: str, what: str) -> dict:
    """Attributes of east, north, up, modulus (in ``units``) and modulus_mg, by name, in order."""
    return variable_attrs(vector_variables(what), units)


def stats_attrs(stats: dict) -> dict:
    """Flatten :func:`fieldmap.products.statistics.map_statistics` into CF global attributes."""
    attrs = {attr_name(k): v for k, v in stats.items() if k != "area_fraction_above"}
    for key, frac in stats["area_fraction_above"].items():
        attrs[fraction_attr(float(key))] = frac
    return attrs


#: Long names of the statistics (``<statistic>_mg``).
STATISTIC_NAMES = {
    "max": "maximum",
    "min": "minimum",
    "mean": "area-weighted mean",
    "rms": "area-weighted root mean square",
}


def statistic_name(key: str) -> str:
    """Long name of a statistic from its key: ``"p99_mg"`` -> "area-weighted 99th percentile"."""
    stat = key.rsplit("_", 1)[0]
    if stat in STATISTIC_NAMES:
        return STATISTIC_NAMES[stat]
    q = stat[1:]
    suffix = (
        {"1": "st", "2": "nd", "3": "rd"}.get(q[-1:], "th")
        if not q.endswith(("11", "12", "13"))
        else "th"
    )
    return "area-weighted median" if q == "50" else f"area-weighted {q}{suffix} percentile"


def sweep_statistics(stats: list[dict[str, Any]], thresholds: Sequence[float]) -> dict[str, Any]:
    """Return the statistics variables of a sweep, {name: (dims, values, attrs)}.

    ``stats``: one :func:`fieldmap.products.statistics.map_statistics` dict per height.
    """
    out: dict[str, tuple] = {}
    for key in stats[0]:
        if key != "area_fraction_above":
            out[key] = (
                "height",
                np.array([s[key] for s in stats]),
                mg_attrs(f"{statistic_name(key)} of the disturbance modulus"),
            )
    frac = np.array(
        [[s["area_fraction_above"][threshold_key(t)] for t in thresholds] for s in stats]
    )
    out["area_fraction_above"] = (
        ("height", "threshold_mg"),
        frac,
        {
            "units": "1",
            "long_name": "fraction of the map area where the modulus exceeds the threshold",
        },
    )
    return out


#: The quantities of :func:`fieldmap.quantity_map` (:mod:`fieldmap.products.quantities`).
QUANTITIES = MAP_QUANTITIES


@dataclasses.dataclass(frozen=True)
class Template:
    """A product without its data: what the engine and the sinks build it from.

    Attributes
    ----------
    coords : dict
        {name: xarray.Variable}: latitude, longitude, height, height_km (and ``order`` or
        ``threshold_mg`` where the product has them).
    attrs : dict
        Global attributes (CF-1.8, provenance, grid, model).
    variables : dict
        {name: attributes} of the product's variables, in order.
    dims : tuple of str
        Dimensions of every variable.
    """

    coords: dict[str, xr.Variable]
    attrs: dict[str, Any]
    variables: dict[str, dict[str, Any]]
    dims: tuple[str, ...]

    @property
    def stacked(self) -> bool:
        """Whether the variables have a ``height`` dimension (a sweep)."""
        return "height" in self.dims

    def skeleton(self) -> xr.Dataset:
        """Return the product's coordinates and global attributes, without variables."""
        return xr.Dataset(coords=self.coords, attrs=dict(self.attrs))


def variable_attrs(
    variables: Sequence[Variable],
    units: str | None = None,
    model: SHModel | None = None,
    ell: Ellipsoid | None = None,
) -> dict[str, dict[str, Any]]:
    """{name: CF attributes} of registry variables (:class:`fieldmap.products.quantities.Variable`).

    ``units``: the units of the variables whose units are the request's (the disturbance
    vector); ``model`` and ``ell`` fill in the long names that name them.
    """
    names = {"model": getattr(model, "name", None), "ellipsoid": getattr(ell, "name", None)}
    out = {}
    for v in variables:
        if v.units is None:
            if units is None:
                raise ValueError(f"variable {v.name} takes the request's units: give units")
            unit = cf_units(get_unit(units).name)
        else:
            unit = v.units
        long_name = v.long_name.format(**names) if "{" in v.long_name else v.long_name
        va: dict[str, Any] = {"units": unit, "long_name": long_name}
        if v.standard_name:
            va["standard_name"] = v.standard_name
        if v.comment:
            va["comment"] = v.comment
        out[v.name] = va
    return out


def quantity_template(
    quantity: str,
    mod: SHModel,
    grid: GridSpec,
    ell: Ellipsoid,
    degree0: bool,
    extra_attrs: dict[str, Any] | None = None,
) -> Template:
    """Coordinates and attributes of a quantity map (the ``fields`` layout), without data.

    Everything comes from the quantity's entry (:mod:`fieldmap.products.quantities`): the
    variables, the definition, source and frame attributes; ``extra_attrs`` are added to the
    global attributes.
    """
    q = get_quantity(quantity)
    stacked = grid.heights.size > 1
    heights_txt = ", ".join(f"{x / 1e3:g}" for x in grid.heights)
    # no model enters the exact normal gravity: the product names none
    model = mod if q.uses_model else None
    what = q.variables[0].long_name.split(",")[0].split(" (")[0]
    title = f"{what} at {heights_txt} km, " + (
        f"{mod.name} degree {mod.lmax}" if model is not None else f"{ell.name} normal field"
    )
    source = q.source.format(model=mod.name, lmax=mod.lmax, ellipsoid=ell.name)
    attrs = global_attrs(title, model, ell, grid, f"fieldmap {__version__}: {source}")
    assert q.definition is not None  # every quantity of the fields layout has one
    attrs.update({"quantity": quantity, "definition": q.definition(degree0)})
    attrs["frame"] = q.frame
    attrs.update(extra_attrs or {})
    dims = ("height", "latitude", "longitude") if stacked else ("latitude", "longitude")
    return Template(coords(grid, stacked), attrs, variable_attrs(q.variables), dims)


def quantity_statistics_fields(tmpl: Template, stats: dict) -> tuple[dict, dict]:
    """Statistics of each variable in the product's form: (attributes per variable, variables).

    ``stats``: {name: [{"min", "max", "mean", "rms"} per height]}. One height: ``actual_range``,
    ``area_weighted_mean``, ``area_weighted_rms`` in the variable's attributes; several: the
    variables ``<name>_min`` ... on ``height``.
    """
    per_var: dict[str, dict] = {}
    extra: dict[str, tuple] = {}
    for name, va in tmpl.variables.items():
        per_h = stats[name]
        if tmpl.stacked:
            for key in ("min", "max", "mean", "rms"):
                extra[f"{name}_{key}"] = (
                    "height",
                    np.array([s[key] for s in per_h]),
                    {"units": va["units"], "long_name": f"area-weighted {key} of {name}"},
                )
            per_var[name] = {}
        else:
            # CF attribute names: letters, digits, underscores (CF 1.8 §2.3)
            s0 = per_h[0]
            per_var[name] = {
                "actual_range": np.array([s0["min"], s0["max"]]),
                "area_weighted_mean": s0["mean"],
                "area_weighted_rms": s0["rms"],
            }
    return per_var, extra


def assemble_quantity(tmpl: Template, vals: dict, stats: dict) -> xr.Dataset:
    """Build the product Dataset from its template, arrays ``(nh, nlat, nlon)`` and statistics."""
    per_var, extra = quantity_statistics_fields(tmpl, stats)
    data = {}
    for name, va in tmpl.variables.items():
        v = vals[name]
        data[name] = (tmpl.dims, v if tmpl.stacked else v[0], {**va, **per_var[name]})
    return xr.Dataset({**data, **extra}, coords=tmpl.coords, attrs=dict(tmpl.attrs))


def disturbance_template(
    mod: SHModel,
    grid: GridSpec,
    ell: Ellipsoid,
    units: str,
    thresholds: Sequence[float],
    stacked: bool,
) -> Template:
    """Coordinates, global and variable attributes of a disturbance product, without data.

    The attributes are those of :func:`fieldmap.products.maps.disturbance_map`; a product
    returned in memory is built from them in one ``xarray.Dataset`` (:func:`dataset`).
    """
    dims = ("height", "latitude", "longitude") if stacked else ("latitude", "longitude")
    c = coords(grid, stacked)
    if stacked:
        c["threshold_mg"] = xr.Variable(
            "threshold_mg",
            np.array(thresholds, dtype=np.float64),
            mg_attrs("threshold of the disturbance modulus"),
        )
    variables = variable_attrs(get_quantity("disturbance").variables, units)
    return Template(c, disturbance_attrs(mod, grid, ell), variables, dims)


def percentile_method_text(method: str = "histogram") -> str:
    """Return the ``percentile_method`` attribute of a product (``histogram`` or ``exact``)."""
    from fieldmap.products.statistics import PERCENTILE_RTOL

    if method == "exact":
        return "exact area-weighted percentiles of the whole map (inverted CDF)"
    return (
        f"mergeable area-weighted histogram of the modulus, relative accuracy {PERCENTILE_RTOL:.1e}"
    )


def map_attrs(
    stats: dict[str, Any], thresholds: Sequence[float], method: str = "histogram"
) -> dict[str, Any]:
    """Global statistics attributes of a one-height map (as disturbance_map's)."""
    attrs = stats_attrs(stats)
    attrs["thresholds_mg"] = np.array(thresholds)
    attrs["percentile_method"] = percentile_method_text(method)
    return attrs


#: pandas indexes of recent coordinates (:func:`dataset`), oldest first, and their lock
_INDEXES: dict = {}
_INDEX_LOCK = threading.Lock()


def _shared_index(name: str, var: xr.Variable) -> PandasIndex | None:
    """Return the default pandas index of coordinate ``var``, made once per values and shared.

    Its values are made read-only, so that no map can change the coordinates of another.
    Returns None where that is not possible (then each map gets its own index).
    """
    from xarray.indexes import PandasIndex

    key = (name, var.dtype.str, var.values.tobytes())
    with _INDEX_LOCK:
        index = _INDEXES.get(key)
    if index is not None:
        return index
    index = PandasIndex.from_variables({name: var}, options={})
    values = np.asarray(index.index)
    if values.dtype != var.dtype or values.tobytes() != key[2]:
        return None
    values.setflags(write=False)
    if np.asarray(index.index).flags.writeable:  # pandas handed out a copy: not shareable
        return None
    with _INDEX_LOCK:
        while len(_INDEXES) >= 16:  # the oldest goes
            _INDEXES.pop(next(iter(_INDEXES)))
        _INDEXES[key] = index
    return index


def dataset(data: dict, coords: dict, attrs: dict) -> xr.Dataset:
    """Return ``xarray.Dataset(data, coords=coords, attrs=attrs)``, built without its merge.

    ``data`` maps names to ``xarray.Variable`` or ``(dims, values, attrs)`` tuples, ``coords``
    to ``xarray.Variable`` (a dimension's own coordinate gets its default pandas index, as in
    the constructor). The parts of a product are consistent by construction (one grid), so the
    constructor's alignment and checks, ~0.3 ms a map, are skipped; the Dataset is the same
    (tests/test_block_partial.py compares it with the constructor's). Unlike the constructor,
    it takes ``attrs`` and the Variables as they are (no copies): callers pass fresh ones. The
    index of a dimension coordinate is shared between maps of the same grid, read-only
    (:func:`_shared_index`).
    """
    from xarray.indexes import PandasIndex

    direct = getattr(xr.Dataset, "_construct_direct", None)
    if direct is None:  # not in this xarray: the public constructor
        return xr.Dataset(data, coords=coords, attrs=attrs)
    variables = {k: v if isinstance(v, xr.Variable) else xr.Variable(*v) for k, v in data.items()}
    indexes = {}
    for name, var in coords.items():
        if var.dims == (name,):
            # a grid's latitudes and longitudes come back call after call: their pandas
            # indexes are made once (~0.12 ms each) and shared, as Dataset.copy does
            index = _shared_index(name, var)
            if index is None:
                index = PandasIndex.from_variables({name: var}, options={})
            indexes[name] = index
            variables.update(index.create_variables({name: var}))
        else:
            variables[name] = var
    try:
        return direct(variables, set(coords), None, attrs, indexes)
    except (TypeError, ValueError):  # a private API that changed: the public constructor
        return xr.Dataset(data, coords=coords, attrs=attrs)


def _header(ds: xr.Dataset, product: str) -> dict[str, Any]:
    a = ds.attrs
    out = {
        "product": product,
        "model": a.get("model"),
        "lmax": a.get("model_lmax"),
        "ellipsoid": a.get("ellipsoid"),
        "grid_step_deg": a.get("grid_step_deg"),
        "region_deg": [float(x) for x in a["region_west_east_south_north_deg"]],
    }
    h = ds["height"].values
    out["height_m"] = [float(x) for x in h] if "height" in ds.dims else float(h)
    out["tide_system"] = a.get("model_tide_system")
    return out


def _stack_statistics(ds: xr.Dataset, dim: str) -> list[str]:
    """Names of the statistics variables on ``dim`` (``<statistic>_mg``), in their order."""
    names = [str(k) for k, v in ds.data_vars.items() if v.dims == (dim,)]
    return [k for k in names if k.endswith("_mg")]


def summary(ds: xr.Dataset) -> dict:
    """JSON-ready statistics of any map product: disturbance map or sweep, truncation, quantity.

    Every summary starts with the same header: ``product``, ``model``, ``lmax``, ``ellipsoid``,
    ``grid_step_deg``, ``region_deg``, ``height_m`` (a list for a sweep), ``tide_system`` (the
    model's permanent-tide system; None without a model). Then, for a
    disturbance map, its statistics (``max_mg``, ``mean_mg``, ``rms_mg``, percentiles) and
    ``area_fraction_above`` {threshold in mg: fraction 0..1}; for a sweep the same as lists per
    height; for a truncation map each statistic as {"j2": ..., ...}; for a quantity map
    (``attrs["quantity"]``), ``definition`` and per variable its ``units``, ``min``, ``max``,
    ``mean``, ``rms`` (lists per height for a sweep).
    """
    a = ds.attrs
    if "quantity" in a:
        return _quantity_summary(ds)
    if "max_mg" not in a and "max_mg" not in ds:
        raise InputError(
            "this Dataset carries no statistics (a lazy product, chunks=): compute the map "
            "without chunks=, or stream it with fieldmap.products.engine.write_product"
        )
    if "order" in ds.dims:
        out = _header(ds, "truncation")
        orders = [f"j{int(o)}" for o in ds["order"].values]
        for k in _stack_statistics(ds, "order"):
            out[k] = {o: float(v) for o, v in zip(orders, ds[k].values)}
        return out
    if "percentile_method" in a:
        method = {"percentile_method": a["percentile_method"]}
    else:
        method = {}
    if "height" in ds.dims:
        out = {**_header(ds, "sweep"), **method}
        thr = [threshold_key(t) for t in ds["threshold_mg"].values]
        for k in _stack_statistics(ds, "height"):
            out[k] = [float(x) for x in ds[k].values]
        out["area_fraction_above"] = {
            k: [float(x) for x in ds["area_fraction_above"].values[:, j]] for j, k in enumerate(thr)
        }
        return out
    out = {**_header(ds, "disturbance"), **method}
    for k, v in a.items():
        if k.endswith("_mg") and not k.startswith("area_fraction_above") and k != "thresholds_mg":
            out[k] = float(v)
    out["area_fraction_above"] = {
        threshold_key(t): float(a[fraction_attr(t)]) for t in a["thresholds_mg"]
    }
    return out


def _quantity_summary(ds: xr.Dataset) -> dict:
    a = ds.attrs
    out = _header(ds, a["quantity"])
    out["definition"] = a.get("definition")
    stacked = "height" in ds.dims
    for var in get_quantity(a["quantity"]).variables:
        name, units = var.name, var.units
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


def truncation_template(
    grid: GridSpec, ell: Ellipsoid, orders: Sequence[int], units: str
) -> Template:
    """Template of a truncation map: the J2n normal gravitation minus the exact one, per order.

    Variables east, north, up, modulus (in ``units``), modulus_mg on (order, latitude,
    longitude); ``grid`` holds the one height.
    """
    h = float(grid.heights[0])
    c = coords(grid, False)
    c["order"] = xr.Variable(
        "order", np.array(orders), {"long_name": "highest zonal J2n term kept", "units": "1"}
    )
    attrs = global_attrs(
        f"J-series truncation error at {h / 1e3:g} km ({ell.name})",
        None,
        ell,
        grid,
        f"fieldmap {__version__}: J{'/J'.join(map(str, orders))} normal gravitation minus "
        f"exact normal gravitation of {ell.name}",
    )
    variables = variable_attrs(get_quantity("truncation").variables, units)
    return Template(c, attrs, variables, ("order", "latitude", "longitude"))


def components_template(mod: SHModel, grid: GridSpec, ell: Ellipsoid) -> Template:
    """Template of the component maps: model and normal gravity, east, north, up (m s-2)."""
    h = float(grid.heights[0])
    attrs = global_attrs(
        f"Gravity components at {h / 1e3:g} km, {mod.name} degree {mod.lmax} and {ell.name}",
        mod,
        ell,
        grid,
        f"fieldmap {__version__}: {mod.name} degree {mod.lmax} gravity and exact "
        f"normal gravity of {ell.name}, both with centrifugal acceleration",
    )
    variables = variable_attrs(get_quantity("components").variables, None, mod, ell)
    return Template(coords(grid, False), attrs, variables, ("latitude", "longitude"))

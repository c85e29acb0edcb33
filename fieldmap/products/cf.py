"""CF-1.8 metadata of the map Datasets: coordinates, global attributes, vector variables.

Shared by the products of :mod:`fieldmap.products.maps`; attributes follow the CF conventions 1.8
(``units``, ``standard_name``, ``long_name``) as harmonica's grids do.
"""

from __future__ import annotations

import datetime as _dt

import numpy as np
import xarray as xr

from fieldmap import __version__
from fieldmap.errors import InputError
from fieldmap.products.stats import threshold_key
from fieldmap.units import MG, MGAL, get_unit  # noqa: F401 - re-exported for 0.1 callers
from fieldmap.units import UNITS as UNITS  # noqa: F401 - the one table of units, re-exported

REFERENCE = (
    "Chen K., Zeng C.-Z., Pei S.-S., Liang W.-C. (2022), Normal gravity model for inertial "
    "navigation of a hypersonic boost-glide vehicle, J. Zhejiang Univ. Sci. A, "
    "doi:10.1631/jzus.A2100133, Section 4"
)
#: CF names of the east, north, up components.
COMPONENTS = {"east": "eastward", "north": "northward", "up": "upward"}
#: milli-g in UDUNITS terms. UDUNITS (and so every CF tool) reads "mg" as milligram, a mass;
#: a scaled SI unit converts correctly to m s-2 and mGal.
MG_UNITS = "0.00980665 m s-2"
MG_COMMENT = (
    "values in mg (milli-g): 1 mg = 1e-3 g_n = 9.80665e-3 m s-2 = 980.665 mGal; the units "
    "attribute spells it as a scaled SI unit because UDUNITS reads 'mg' as milligram"
)


def cf_units(units: str) -> str:
    """Return the ``units`` attribute (UDUNITS spelling) of an output unit of :data:`UNITS`."""
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
    :func:`fieldmap.products.stats.threshold_key`.
    """
    return attr_name(f"area_fraction_above_{threshold_key(threshold_mg)}_mg")


def coords(grid, stacked_heights: bool) -> dict:
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
    if stacked_heights:
        height = xr.Variable("height", grid.heights, hattrs)
    else:
        height = xr.Variable((), grid.heights[0], hattrs)
    return {"latitude": lat, "longitude": lon, "height": height}


def global_attrs(title, model, ellipsoid, grid, source) -> dict:
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
                "model_gm": float(model.gm),
                "model_radius": float(model.radius),
            }
        )
    if grid.heights.size == 1:
        attrs["height_m"] = float(grid.heights[0])
    return attrs


def disturbance_attrs(mod, grid, ell) -> dict:
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


def convert_rows(comps, dst, mods, scale: float, a=None, b=None) -> None:
    """Convert m/s² components to a unit of size ``scale`` and take the moduli, on rows [a, b).

    ``comps`` (3, rows, ...) and ``dst`` (3, rows, ...; ``comps`` itself converts in place)
    hold the components, ``mods`` (2, rows, ...) receives the modulus in the unit and in mg;
    element by element, on the rows ``[a, b)`` of the second axis (default: everything). The
    one conversion of :func:`vector_vars` and of the blocks of the maps
    (:func:`fieldmap.products.blockstats.disturbance_partial`): the same bits.
    """
    ix = (slice(None),) if a is None else (slice(None), slice(a, b))
    c, d, m = comps[ix], dst[ix], mods[ix]
    np.divide(c, scale, out=d)
    np.einsum("k...,k...->...", d, d, out=m[0])  # one pass, no temporaries
    np.sqrt(m[0], out=m[0])  # in ``units``
    np.multiply(m[0], scale / MG, out=m[1])


def vector_vars(vec, dims, units, what, overwrite: bool = False) -> dict:
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
    unit = cf_units(units)
    out = {
        name: {"units": unit, "long_name": f"{cf} component of the {what}"}
        for name, cf in COMPONENTS.items()
    }
    out["modulus"] = {"units": unit, "long_name": f"modulus of the {what}"}
    out["modulus_mg"] = mg_attrs(f"modulus of the {what} in mg")
    return out


def stats_attrs(stats: dict) -> dict:
    """Flatten :func:`fieldmap.products.stats.map_statistics` into legal CF global attributes."""
    attrs = {attr_name(k): v for k, v in stats.items() if k != "area_fraction_above"}
    for key, frac in stats["area_fraction_above"].items():
        attrs[fraction_attr(float(key))] = frac
    return attrs


def sweep_statistics(stats: list[dict], thresholds) -> dict:
    """Return the statistics variables of a sweep, {name: (dims, values, attrs)}.

    ``stats``: one :func:`fieldmap.products.stats.map_statistics` dict per height.
    """
    out: dict[str, tuple] = {}
    for key, long in (
        ("max_mg", "maximum"),
        ("mean_mg", "area-weighted mean"),
        ("p50_mg", "area-weighted median"),
        ("p99_mg", "area-weighted 99th percentile"),
    ):
        out[key] = (
            "height",
            np.array([s[key] for s in stats]),
            mg_attrs(f"{long} of the disturbance modulus"),
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

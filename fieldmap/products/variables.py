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

import datetime as _dt
import threading
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr

from fieldmap import __version__
from fieldmap.errors import InputError
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
    (:func:`fieldmap.products.engine.disturbance_partial`): the same bits.
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
    unit = cf_units(units)
    out = {
        name: {"units": unit, "long_name": f"{cf} component of the {what}"}
        for name, cf in COMPONENTS.items()
    }
    out["modulus"] = {"units": unit, "long_name": f"modulus of the {what}"}
    out["modulus_mg"] = mg_attrs(f"modulus of the {what} in mg")
    return out


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
for _q, _what in (
    ("gradient", "gravity"),
    ("gradient-disturbance", "gravity disturbance"),
    ("gradient-normal", "exact normal gravity"),
):
    VARIABLES[_q] = [
        (
            name,
            "1e-9 s-2",
            f"gradient tensor of {_what}, d g_{name[2]} / d {name[3]} (ENU), Eotvos",
            None,
        )
        for name in ("T_ee", "T_en", "T_eu", "T_nn", "T_nu", "T_uu")
    ]
VARIABLES["gradient-invariants"] = [
    ("I1", "1e-18 s-4", "second invariant of the gravitation gradient tensor, E^2", None),
    ("I2", "1e-27 s-6", "third invariant (determinant) of the gravitation gradient tensor, E^3",
     None),
    *[
        (f"eig_{k}", "1e-9 s-2", f"{o} eigenvalue of the gravitation gradient tensor, Eotvos",
         None)
        for k, o in ((1, "largest"), (2, "middle"), (3, "smallest"))
    ],
]  # fmt: skip
#: quantities of the tensor (no disturbing potential involved: degree0 does not apply)
GRADIENT_QUANTITIES = ("gradient", "gradient-disturbance", "gradient-normal", "gradient-invariants")
_SIGMA = "standard deviation (commission error, diagonal propagation of the coefficient sigma)"
VARIABLES["disturbance-sigma"] = [
    (f"sigma_{c}", "mGal", f"{_SIGMA} of the {c} component of the gravity disturbance", None)
    for c in ("east", "north", "up")
]
VARIABLES["anomaly-sigma"] = [("anomaly_sigma", "mGal", f"{_SIGMA} of the gravity anomaly", None)]
VARIABLES["geoid-sigma"] = [("geoid_sigma", "m", f"{_SIGMA} of the geoid height", None)]
_OMISSION = (
    "standard deviation (omission error: the degrees above the model's, from a degree-variance "
    "model)"
)
VARIABLES["omission-sigma"] = [
    (
        f"omission_sigma_{c}",
        "mGal",
        f"{_OMISSION} of the {c} component of the gravity disturbance",
        None,
    )
    for c in ("north", "east", "down")
]
VARIABLES["omission-sigma"].append(
    (
        "omission_sigma_modulus",
        "mGal",
        f"{_OMISSION} of the gravity disturbance vector (root of the three variances summed)",
        None,
    )
)
VARIABLES.update(
    {
        "height-anomaly": [
            (
                "height_anomaly",
                "m",
                "height anomaly on the ellipsoid (Bruns: T(h=0)/gamma0), ICGEM height_anomaly_ell",
                None,
            )
        ],
        "anomaly-classical": [
            (
                "anomaly_classical",
                "mGal",
                "classical gravity anomaly, |grad W(h)| - |grad U(h - zeta)|, ICGEM "
                "gravity_anomaly_cl",
                None,
            )
        ],
        "disturbance-sa": [
            (
                "disturbance_sa",
                "mGal",
                "gravity disturbance in spherical approximation, -dT/dr, ICGEM "
                "gravity_disturbance_sa",
                None,
            )
        ],
        "trr": [
            (
                "trr",
                "1e-9 s-2",
                "second radial derivative of the disturbing potential, d2T/dr2, Eotvos, ICGEM "
                "second_r_derivative",
                None,
            )
        ],
        "ewh": [
            (
                "ewh",
                "m",
                "equivalent water height of the difference of two fields (load Love numbers), "
                "ICGEM water_column",
                "lwe_thickness",
            )
        ],
    }
)  # ICGEM's functionals (Barthelmes 2013; fieldmap.field.geodesy, fieldmap.field.water)
#: commission-error quantities (fieldmap.field.commission_grid)
SIGMA_QUANTITIES = ("disturbance-sigma", "anomaly-sigma", "geoid-sigma")
#: quantities that live on the ellipsoid (h = 0)
SURFACE_QUANTITIES = ("geoid", "geoid-sigma", "height-anomaly", "ewh")
QUANTITIES = ("disturbance", *VARIABLES)


def _definition(degree0: bool, quantity: str = "potential") -> str:
    if quantity == "omission-sigma":
        return (
            "standard deviation of the gravity disturbance of the degrees above the model's "
            "degree L, an isotropic random field with the degree variances of the "
            "degree-variance model named in omission_model (fieldmap.field.omission: "
            "Tscherning & Rapp 1974 model 4, Kaula's rule, or a power law fitted to the model's "
            "degrees L/2..L); spherical approximation r = R + h, so the same at every node of a "
            "height; degrees L+1..omission_max_degree"
        )
    if quantity in SIGMA_QUANTITIES:
        return (
            "standard deviation of the quantity propagated from the model's coefficient "
            "standard deviations sigma C, sigma S, assumed uncorrelated (diagonal propagation: "
            "the full covariance is not used); the degrees above the model's degree are not "
            "counted (omission error); geoid at h = 0"
        )
    if quantity in GRADIENT_QUANTITIES:
        what = {
            "gradient": "g",
            "gradient-disturbance": "g - gamma_exact (gravitation)",
            "gradient-normal": "gamma_exact (with centrifugal)",
            "gradient-invariants": "model gravitation",
        }[quantity]
        text = (
            f"second derivatives of the potential: d({what})_i / dx_j in the local geodetic "
            "east-north-up frame at each node (1 E = 1e-9 s-2); g is model gravitation plus "
            "centrifugal; synthesised from the second derivatives of the series (one Legendre "
            "pass per row, FFT in longitude), the normal field as its zonal J2n series, the "
            "centrifugal tensor in closed form; the tensor is symmetric, so six components"
        )
        if quantity == "gradient-invariants":
            text += (
                "; invariants I1 = sum of the principal 2x2 minors, I2 = determinant "
                "(Pedersen & Rasmussen 1990), eigenvalues in decreasing order"
            )
        return text
    if quantity == "ewh":
        from fieldmap.field.water import DEFINITION

        return DEFINITION
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
        + _FUNCTIONALS.get(quantity, "")
    )


#: the definitions of ICGEM's functionals (Barthelmes 2013), appended to T's
_FUNCTIONALS = {
    "height-anomaly": "; height anomaly on the ellipsoid zeta = T(h=0)/gamma0 (Barthelmes 2013 "
    "sections 2.2, 4.3: Bruns' formula; the geoid without a GeographicLib model's N - zeta terms)",
    "anomaly-classical": "; classical gravity anomaly |grad W(P)| - |grad U(Q)|, Q on the "
    "ellipsoidal normal of P at height h - zeta with U(Q) = W(P) (Barthelmes 2013 sections "
    "2.4.1, 4.5), zeta solved by Newton's method on the closed-form normal potential",
    "disturbance-sa": "; gravity disturbance in spherical approximation -dT/dr, geocentric "
    "radial derivative (Barthelmes 2013 sections 3.4, 4.4)",
    "trr": "; second radial derivative d2T/dr2 = r^-2 sum_n (n+1)(n+2) T_n (geocentric r; "
    "Barthelmes 2013 section 4.1), 1 E = 1e-9 s-2",
}


def quantity_template(
    quantity: str, mod: SHModel, grid: GridSpec, ell: Ellipsoid, degree0: bool
) -> xr.Dataset:
    """Coordinates and attributes of a quantity map, without data.

    ``attrs["variables"]`` maps each variable to its attributes and ``attrs["dims"]`` holds
    the dimensions of the variables (shared with the block engine of
    :mod:`fieldmap.products.engine`).
    """
    stacked = grid.heights.size > 1
    heights_txt = ", ".join(f"{x / 1e3:g}" for x in grid.heights)
    # no model enters the exact normal gravity: the product names none
    model = None if quantity == "gradient-normal" else mod
    title = f"{VARIABLES[quantity][0][2].split(',')[0].split(' (')[0]} at {heights_txt} km, " + (
        f"{mod.name} degree {mod.lmax}" if model is not None else f"{ell.name} normal field"
    )
    attrs = global_attrs(
        title,
        model,
        ell,
        grid,
        f"fieldmap {__version__}: "
        + {
            "gradient": f"{mod.name} degree {mod.lmax}",
            "gradient-invariants": f"{mod.name} degree {mod.lmax}",
            "gradient-normal": f"the exact normal gravity of {ell.name}",
            "ewh": f"{mod.name} degree {mod.lmax}",
        }.get(quantity, f"{mod.name} degree {mod.lmax} minus the {ell.name} normal field"),
    )
    attrs.update({"quantity": quantity, "definition": _definition(degree0, quantity)})
    attrs["frame"] = (
        "local geodetic east-north-up at each node"
        if quantity in GRADIENT_QUANTITIES
        else "geocentric spherical (deflection components), values are scalars otherwise"
    )
    var_attrs = {}
    for name, units, long_name, std in VARIABLES[quantity]:
        va: dict[str, Any] = {"units": units, "long_name": long_name}
        if std:
            va["standard_name"] = std
        var_attrs[name] = va
    ds = xr.Dataset(coords=coords(grid, stacked), attrs=attrs)
    ds.attrs["variables"] = var_attrs
    ds.attrs["dims"] = ("height", "latitude", "longitude") if stacked else ("latitude", "longitude")
    return ds


def quantity_statistics_fields(tmpl: xr.Dataset, stats: dict) -> tuple[dict, dict]:
    """Statistics of each variable in the product's form: (attributes per variable, variables).

    ``stats``: {name: [{"min", "max", "mean", "rms"} per height]}. One height: ``actual_range``,
    ``area_weighted_mean``, ``area_weighted_rms`` in the variable's attributes; several: the
    variables ``<name>_min`` ... on ``height``.
    """
    stacked = "height" in tmpl.attrs["dims"]
    per_var: dict[str, dict] = {}
    extra: dict[str, tuple] = {}
    for name, va in tmpl.attrs["variables"].items():
        per_h = stats[name]
        if stacked:
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


def assemble_quantity(tmpl: xr.Dataset, vals: dict, stats: dict) -> xr.Dataset:
    """Build the product Dataset from its template, arrays ``(nh, nlat, nlon)`` and statistics."""
    ds = tmpl.copy()
    var_attrs = ds.attrs.pop("variables")
    dims = ds.attrs.pop("dims")
    stacked = "height" in dims
    per_var, extra = quantity_statistics_fields(tmpl, stats)
    data = {}
    for name, va in var_attrs.items():
        v = vals[name]
        data[name] = (dims, v if stacked else v[0], {**va, **per_var[name]})
    return xr.Dataset({**data, **extra}, coords=ds.coords, attrs=ds.attrs)


def disturbance_template_parts(
    mod: SHModel,
    grid: GridSpec,
    ell: Ellipsoid,
    units: str,
    thresholds: Sequence[float],
    stacked: bool,
) -> dict[str, Any]:
    """Return the parts of :func:`disturbance_template`: coords, attrs, variables, dims.

    ``coords`` maps names to ``xarray.Variable``; ``variables`` maps each variable name to its
    attributes. A product returned in memory is built from them in one ``xarray.Dataset``.
    """
    dims = ("height", "latitude", "longitude") if stacked else ("latitude", "longitude")
    attrs = vector_attrs(get_unit(units).name, "gravity disturbance")
    c = coords(grid, stacked)
    if stacked:
        c["threshold_mg"] = xr.Variable(
            "threshold_mg",
            np.array(thresholds, dtype=np.float64),
            mg_attrs("threshold of the disturbance modulus"),
        )
    return {
        "coords": c,
        "attrs": disturbance_attrs(mod, grid, ell),
        "variables": {name: attrs[name] for name in DISTURBANCE_VARIABLES},
        "dims": dims,
    }


def disturbance_template(
    mod: SHModel,
    grid: GridSpec,
    ell: Ellipsoid,
    units: str,
    thresholds: Sequence[float],
    stacked: bool,
) -> xr.Dataset:
    """Coordinates, global and variable attributes of a disturbance product, without data.

    The attributes are those of :func:`fieldmap.products.maps.disturbance_map` (taken from the
    same helpers); ``attrs["variables"]`` maps each variable name
    to its attributes.
    """
    parts = disturbance_template_parts(mod, grid, ell, units, thresholds, stacked)
    ds = xr.Dataset(coords=parts["coords"], attrs=parts["attrs"])
    ds.attrs["variables"] = parts["variables"]
    ds.attrs["dims"] = parts["dims"]
    return ds


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


def truncation_template(
    grid: GridSpec, ell: Ellipsoid, orders: Sequence[int], units: str
) -> xr.Dataset:
    """Template of a truncation map: the J2n normal gravitation minus the exact one, per order.

    Variables east, north, up, modulus (in ``units``), modulus_mg on (order, latitude,
    longitude); ``grid`` holds the one height.
    """
    h = float(grid.heights[0])
    c = coords(grid, False)
    c["order"] = xr.Variable(
        "order", np.array(orders), {"long_name": "highest zonal J2n term kept", "units": "1"}
    )
    ds = xr.Dataset(
        coords=c,
        attrs=global_attrs(
            f"J-series truncation error at {h / 1e3:g} km ({ell.name})",
            None,
            ell,
            grid,
            f"fieldmap {__version__}: J{'/J'.join(map(str, orders))} normal gravitation minus "
            f"exact normal gravitation of {ell.name}",
        ),
    )
    ds.attrs["variables"] = vector_attrs(
        get_unit(units).name, "normal gravitation truncation error"
    )
    ds.attrs["dims"] = ("order", "latitude", "longitude")
    return ds


def components_template(mod: SHModel, grid: GridSpec, ell: Ellipsoid) -> xr.Dataset:
    """Template of the component maps: model and normal gravity, east, north, up (m s-2)."""
    h = float(grid.heights[0])
    ds = xr.Dataset(
        coords=coords(grid, False),
        attrs=global_attrs(
            f"Gravity components at {h / 1e3:g} km, {mod.name} degree {mod.lmax} and {ell.name}",
            mod,
            ell,
            grid,
            f"fieldmap {__version__}: {mod.name} degree {mod.lmax} gravity and exact "
            f"normal gravity of {ell.name}, both with centrifugal acceleration",
        ),
    )
    var_attrs = {}
    for c, cf_name in COMPONENTS.items():
        var_attrs[f"model_{c}"] = {
            "units": "m s-2",
            "long_name": f"{cf_name} component of gravity from {mod.name}",
        }
        var_attrs[f"normal_{c}"] = {
            "units": "m s-2",
            "long_name": f"{cf_name} component of normal gravity ({ell.name})",
        }
    ds.attrs["variables"] = var_attrs
    ds.attrs["dims"] = ("latitude", "longitude")
    return ds

"""Variables, attributes and statistics of the quantity maps (one place for every executor).

:func:`fieldmap.products.quantity_maps.quantity_map` (the whole map in memory) and the block
engine of :mod:`fieldmap.products.distributed` (in memory, NetCDF-4 or zarr) build their
Datasets from :func:`template`, :func:`statistics_fields` and :func:`assemble`, so that the
files agree attribute for attribute.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from fieldmap import __version__

__all__ = [
    "GRADIENT_QUANTITIES",
    "QUANTITIES",
    "SIGMA_QUANTITIES",
    "SURFACE_QUANTITIES",
    "VARIABLES",
    "assemble",
    "statistics_fields",
    "template",
]

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
#: quantities of the tensor (no disturbing potential involved: degree0 does not apply)
GRADIENT_QUANTITIES = ("gradient", "gradient-disturbance", "gradient-normal")
_SIGMA = "standard deviation (commission error, diagonal propagation of the coefficient sigma)"
VARIABLES["disturbance-sigma"] = [
    (f"sigma_{c}", "mGal", f"{_SIGMA} of the {c} component of the gravity disturbance", None)
    for c in ("east", "north", "up")
]
VARIABLES["anomaly-sigma"] = [("anomaly_sigma", "mGal", f"{_SIGMA} of the gravity anomaly", None)]
VARIABLES["geoid-sigma"] = [("geoid_sigma", "m", f"{_SIGMA} of the geoid height", None)]
#: commission-error quantities (fieldmap.field.commission_grid)
SIGMA_QUANTITIES = ("disturbance-sigma", "anomaly-sigma", "geoid-sigma")
#: quantities that live on the ellipsoid (h = 0)
SURFACE_QUANTITIES = ("geoid", "geoid-sigma")
QUANTITIES = ("disturbance", *VARIABLES)


def _definition(degree0: bool, quantity: str = "potential") -> str:
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
        }[quantity]
        return (
            f"second derivatives of the potential: d({what})_i / dx_j in the local geodetic "
            "east-north-up frame at each node (1 E = 1e-9 s-2); g is model gravitation plus "
            "centrifugal; central differences of the float64 gravity vector (steps 1 m and 2 m, "
            "one Richardson step), symmetrised; the tensor is symmetric, so six components"
        )
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


def template(quantity: str, mod, grid, ell, degree0: bool) -> xr.Dataset:
    """Coordinates and attributes of a quantity map, without data.

    ``attrs["variables"]`` maps each variable to its attributes and ``attrs["dims"]`` holds
    the dimensions of the variables (shared with the block engine of
    :mod:`fieldmap.products.distributed`).
    """
    from fieldmap.products.cf import coords, global_attrs

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
            "gradient-normal": f"the exact normal gravity of {ell.name}",
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


def statistics_fields(tmpl: xr.Dataset, stats: dict) -> tuple[dict, dict]:
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


def assemble(tmpl: xr.Dataset, vals: dict, stats: dict) -> xr.Dataset:
    """Build the product Dataset from its template, arrays ``(nh, nlat, nlon)`` and statistics."""
    ds = tmpl.copy()
    var_attrs = ds.attrs.pop("variables")
    dims = ds.attrs.pop("dims")
    stacked = "height" in dims
    per_var, extra = statistics_fields(tmpl, stats)
    data = {}
    for name, va in var_attrs.items():
        v = vals[name]
        data[name] = (dims, v if stacked else v[0], {**va, **per_var[name]})
    return xr.Dataset({**data, **extra}, coords=ds.coords, attrs=ds.attrs)

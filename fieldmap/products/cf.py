"""CF-1.8 metadata of the map Datasets: coordinates, global attributes, vector variables.

Shared by the products of :mod:`fieldmap.products.maps`; attributes follow the CF conventions 1.8
(``units``, ``standard_name``, ``long_name``) as harmonica's grids do.
"""

from __future__ import annotations

import datetime as _dt

import numpy as np
import xarray as xr

from fieldmap import __version__
from fieldmap.products.stats import MG
from fieldmap.units import UNITS as UNITS  # noqa: F401 - the one table of units, re-exported
from fieldmap.units import get_unit

REFERENCE = (
    "Chen K., Zeng C.-Z., Pei S.-S., Liang W.-C. (2022), Normal gravity model for inertial "
    "navigation of a hypersonic boost-glide vehicle, J. Zhejiang Univ. Sci. A, "
    "doi:10.1631/jzus.A2100133, Section 4"
)
#: CF names of the east, north, up components.
COMPONENTS = {"east": "eastward", "north": "northward", "up": "upward"}


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


def vector_vars(vec, dims, units, what) -> dict:
    """east/north/up/modulus variables (in ``units``) plus modulus_mg, from m/s² ``vec``.

    ``units`` is any spelling :func:`fieldmap.units.get_unit` accepts.
    """
    unit = get_unit(units)
    scale, units = unit.si, unit.udunits
    out = {}
    for k, name in enumerate(("east", "north", "up")):
        out[name] = (
            dims,
            vec[..., k] / scale,
            {"units": units, "long_name": f"{COMPONENTS[name]} component of the {what}"},
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


def stats_attrs(stats: dict) -> dict:
    """Flatten :func:`fieldmap.products.stats.map_statistics` into scalar attributes."""
    attrs = {k: v for k, v in stats.items() if k != "area_fraction_above"}
    for key, frac in stats["area_fraction_above"].items():
        attrs[f"area_fraction_above_{key}_mg"] = frac
    return attrs

"""Metadata of a product built block by block: its template Dataset and statistics attributes.

The attributes are those of the products computed at once (:mod:`fieldmap.products.maps`), made
by the same :mod:`fieldmap.products.cf` helpers, so that a product streamed to a store by
:mod:`fieldmap.products.blockio` carries the same metadata.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from fieldmap.products.blocks import VARIABLES
from fieldmap.units import get_unit


def template_parts(mod, grid, ell, units: str, thresholds, stacked: bool) -> dict:
    """Return the parts of :func:`template`: ``coords``, ``attrs``, ``variables``, ``dims``.

    ``coords`` maps names to ``xarray.Variable``; ``variables`` maps each variable name to its
    attributes. A product returned in memory is built from them in one ``xarray.Dataset``.
    """
    from fieldmap.products.cf import coords, disturbance_attrs, mg_attrs, vector_attrs

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
        "variables": {name: attrs[name] for name in VARIABLES},
        "dims": dims,
    }


def template(mod, grid, ell, units: str, thresholds, stacked: bool) -> xr.Dataset:
    """Coordinates, global and variable attributes of a disturbance product, without data.

    The attributes are those of :func:`fieldmap.products.maps.disturbance_map` (taken from the
    same :mod:`fieldmap.products.cf` helpers); ``attrs["variables"]`` maps each variable name
    to its attributes.
    """
    parts = template_parts(mod, grid, ell, units, thresholds, stacked)
    ds = xr.Dataset(coords=parts["coords"], attrs=parts["attrs"])
    ds.attrs["variables"] = parts["variables"]
    ds.attrs["dims"] = parts["dims"]
    return ds


def percentile_method_text(method: str = "histogram") -> str:
    """Return the ``percentile_method`` attribute of a product (``histogram`` or ``exact``)."""
    from fieldmap.products.blockstats import PERCENTILE_RTOL

    if method == "exact":
        return "exact area-weighted percentiles of the whole map (inverted CDF)"
    return (
        f"mergeable area-weighted histogram of the modulus, relative accuracy {PERCENTILE_RTOL:.1e}"
    )


def map_attrs(stats: dict, thresholds, method: str = "histogram") -> dict:
    """Global statistics attributes of a one-height map (as disturbance_map's)."""
    from fieldmap.products.cf import stats_attrs

    attrs = stats_attrs(stats)
    attrs["thresholds_mg"] = np.array(thresholds)
    attrs["percentile_method"] = percentile_method_text(method)
    return attrs

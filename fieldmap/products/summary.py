"""JSON-ready statistics of the disturbance products (maps, sweeps, truncation maps).

:func:`summary` is what ``fieldmap map|sweep|truncation`` write as JSON; it is re-exported by
:mod:`fieldmap.products.maps`.
"""

from __future__ import annotations

import xarray as xr

from fieldmap.errors import InputError
from fieldmap.products.cf import fraction_attr
from fieldmap.products.stats import threshold_key

__all__ = ["summary"]


def summary(ds: xr.Dataset) -> dict:
    """JSON-ready statistics of a disturbance map, sweep or truncation Dataset.

    Keys: ``model``, ``lmax``, ``height_m``, ``max_mg``, ``mean_mg``, percentiles and
    ``area_fraction_above`` {threshold in mg: fraction 0..1}; for a sweep, lists per height
    (``height_m`` is a list); for a truncation map, ``max_mg``, ``mean_mg`` and ``rms_mg``
    = {"j2": ..., ...} (area-weighted, as every product's).
    """
    a = ds.attrs
    if "max_mg" not in a and "max_mg" not in ds:
        raise InputError(
            "this Dataset carries no statistics (a lazy product, chunks=): compute the map "
            "without chunks=, or stream it with fieldmap.products.distributed.write_disturbance"
        )
    out = {
        "product": None,
        "model": a.get("model"),
        "lmax": a.get("model_lmax"),
        "ellipsoid": a.get("ellipsoid"),
        "grid_step_deg": a.get("grid_step_deg"),
        "region_deg": [float(x) for x in a["region_west_east_south_north_deg"]],
    }
    if "percentile_method" in a:
        out["percentile_method"] = a["percentile_method"]
    if "order" in ds.dims:
        out.update(
            product="truncation",
            height_m=float(ds["height"].values),
            max_mg={
                f"j{int(o)}": float(v) for o, v in zip(ds["order"].values, ds["max_mg"].values)
            },
            mean_mg={
                f"j{int(o)}": float(v) for o, v in zip(ds["order"].values, ds["mean_mg"].values)
            },
            rms_mg={
                f"j{int(o)}": float(v) for o, v in zip(ds["order"].values, ds["rms_mg"].values)
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
        threshold_key(t): float(a[fraction_attr(t)]) for t in a["thresholds_mg"]
    }
    return out

"""Metadata of a product built block by block: its template Dataset and statistics attributes.

The attributes are those of the products computed at once (:mod:`fieldmap.products.maps`), made
by the same :mod:`fieldmap.products.cf` helpers, so that a product streamed to a store by
:mod:`fieldmap.products.blockio` carries the same metadata.
"""

from __future__ import annotations

import threading

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


#: pandas indexes of recent coordinates (:func:`dataset`), oldest first, and their lock
_INDEXES: dict = {}
_INDEX_LOCK = threading.Lock()


def _shared_index(name: str, var: xr.Variable):
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

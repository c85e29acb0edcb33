"""The CF form of a navigation result's Dataset: string labels and the flown path.

A CF coordinate variable (one named as its dimension) must be numeric and monotonic (CF 1.8
§5), so the labels of the dimensions of a study's Dataset (``run``, ``model``, ``axis``,
``gravity_term``, ``source``...) are string auxiliary coordinates of their own name,
``<dim>_label`` (:func:`labels`), that the data variables name in their ``coordinates``
attribute and that select (:func:`indexed_labels`: ``ds.sel(model_label="j4")``); the truth's
path is the latitude, longitude and height of every output time (:func:`flown_path`), with
their standard names. Used by :func:`fieldmap.nav.study.flight_dataset`,
:meth:`fieldmap.nav.covariance.CovarianceStudyResult.to_dataset` and
:func:`fieldmap.nav.aiding.add_to_dataset`; ``cfchecks`` finds no error and no warning in the
files (``tests/test_cf.py``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import xarray as xr

#: suffix of the string label coordinates of a study's Dataset (:func:`labels`)
LABEL = "_label"


def labels(**dims: tuple[Any, str]) -> dict[str, tuple[str, np.ndarray, dict[str, str]]]:
    """Return the string labels of dimensions as CF auxiliary coordinates: ``<dim>_label``.

    ``dims``: dimension -> (labels, long name). A CF coordinate variable (one named as its
    dimension) must be numeric and monotonic (CF 1.8 §5), so the labels of the dimensions
    ``run``, ``model``, ``axis``… are string auxiliary coordinates of their own name
    (``model_label(model)``); the data variables name them in their ``coordinates`` attribute.
    :func:`indexed_labels` makes them selectable (``ds.sel(model_label="j4")``).
    """
    return {
        f"{dim}{LABEL}": (dim, np.array(list(values), dtype=str), {"long_name": long_name})
        for dim, (values, long_name) in dims.items()
    }


def indexed_labels(ds: xr.Dataset) -> xr.Dataset:
    """Return ``ds`` with an index on each label coordinate of :func:`labels` (for ``sel``)."""
    for name in list(ds.coords):
        coord = ds.coords[name]
        if str(name).endswith(LABEL) and coord.ndim == 1 and name not in ds.xindexes:
            ds = ds.set_xindex(str(name))
    return ds


def flown_path(track: np.ndarray) -> dict[str, tuple[str, np.ndarray, dict[str, str]]]:
    """Return the true path's latitude, longitude and height over time, with CF attributes.

    ``track`` (n, 3): geodetic latitude and longitude (degrees) and height above the ellipsoid
    (m) of the truth at the output times. A study's Dataset holds them as auxiliary coordinates
    of ``time`` (a CF trajectory: every curve over time names where it was flown).
    """
    return {
        "latitude": ("time", track[:, 0], {
            "standard_name": "latitude", "long_name": "geodetic latitude of the flown path",
            "units": "degrees_north"}),
        "longitude": ("time", track[:, 1], {
            "standard_name": "longitude", "long_name": "longitude of the flown path",
            "units": "degrees_east"}),
        "height": ("time", track[:, 2], {
            "standard_name": "height_above_reference_ellipsoid",
            "long_name": "ellipsoidal height of the flown path", "units": "m"}),
    }  # fmt: skip

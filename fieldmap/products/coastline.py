"""Coastlines for map plots, shipped with the package (Natural Earth 1:50m, public domain).

The data file ``fieldmap/data/coastline_ne50m.npz`` and its provenance are described in
``fieldmap/data/README_coastline.md``; nothing is downloaded at run time.
"""

from __future__ import annotations

from functools import lru_cache
from importlib import resources
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from matplotlib.axes import Axes

DATA_FILE = "coastline_ne50m.npz"


@lru_cache(maxsize=1)
def coastlines() -> tuple[np.ndarray, np.ndarray]:
    """Return ``(lon, lat)`` float64 arrays of all coast polylines, separated by NaN.

    Units: degrees, longitudes in -180..180.
    """
    with resources.files("fieldmap").joinpath("data").joinpath(DATA_FILE).open("rb") as fh:
        with np.load(fh) as npz:
            lon = npz["lon"].astype(np.float64)
            lat = npz["lat"].astype(np.float64)
    lon.setflags(write=False)
    lat.setflags(write=False)
    return lon, lat


def shifted(lon_min: float) -> tuple[np.ndarray, np.ndarray]:
    """Coastlines with longitudes wrapped into ``[lon_min, lon_min + 360)``.

    A segment that crosses the wrap longitude is broken there (NaN inserted) so that no line
    runs across the whole map.
    """
    lon, lat = coastlines()
    w = (lon - lon_min) % 360.0 + lon_min
    jump = np.abs(np.diff(w)) > 180.0
    if not np.any(jump):
        return w, lat.copy()
    idx = np.nonzero(jump)[0] + 1
    return np.insert(w, idx, np.nan), np.insert(lat, idx, np.nan)


def draw(ax: Axes, lon_min: float = -180.0, **kwargs: Any) -> None:
    """Draw the coastlines on a plate-carrée matplotlib axis without changing its limits.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    lon_min : float
        Western edge of the longitude window used by the map. Units: degrees.
    **kwargs
        Line properties (default: thin dark grey).
    """
    style: dict[str, Any] = {"color": "0.15", "linewidth": 0.5, "zorder": 5}
    style.update(kwargs)
    lon, lat = shifted(lon_min)
    xlim, ylim = ax.get_xlim(), ax.get_ylim()
    ax.plot(lon, lat, **style)
    ax.set_xlim(xlim)
    ax.set_ylim(ylim)

"""Map panels shared by the figures of :mod:`fieldmap.products.plots` and :mod:`.studyplots`.

Maps are plate carrée in degrees, with the shipped Natural Earth coastlines (thin and grey,
under the isolines), a labelled graticule (landmarks inland, where there is no coast) and a
colour bar whose bands are as long as their share of the scale.

Resolution: a map figure is made large enough that each grid node gets at least one pixel at
the 130 dpi of :func:`fieldmap.products.io.write_png`, with unchanged fonts and line widths, up
to :data:`MAX_MAP_PIXELS` across, beyond which nodes share pixels. (Raising the dpi instead
would thicken every line in pixels and hide the detail it was meant to show.)
"""

from __future__ import annotations

import numpy as np
from matplotlib.ticker import FixedLocator, FuncFormatter, MaxNLocator

from fieldmap.products import coastline
from fieldmap.products.io import PNG_DPI

_COAST = {"color": "0.42", "linewidth": 0.35, "zorder": 4}
#: Widest map drawn, in pixels; finer grids than this share pixels between nodes.
MAX_MAP_PIXELS = 4000
DPI = PNG_DPI


def _regional(ds) -> bool:
    return ds.attrs.get("grid_kind", "global") != "global"


def _deg_label(value: float, pos: str, neg: str) -> str:
    v = float(value)
    if abs(v) < 1e-9:
        return "0°"
    return f"{abs(v):g}°{pos if v > 0 else neg}"


def _lon_label(x, _=None) -> str:
    """120 -> 120°E, -60 or 300 -> 60°W, 180 -> 180°."""
    x = (float(x) + 180.0) % 360.0 - 180.0
    if abs(abs(x) - 180.0) < 1e-9:
        return "180°"
    return _deg_label(x, "E", "W")


def _lat_label(y, _=None) -> str:
    return _deg_label(y, "N", "S")


def node_step(ds) -> float:
    """Spacing of the nodes drawn: the grid step, times the decimation of a figure's view."""
    return float(ds.attrs.get("grid_step_deg", 1.0)) * int(ds.attrs.get("figure_decimation", 1))


def _map_axes(ax, ds, **coast):
    lon = ds["longitude"].values
    lat = ds["latitude"].values
    step = node_step(ds)
    ax.set_xlim(lon[0] - step / 2, lon[-1] + step / 2)
    ax.set_ylim(lat[0] - step / 2, lat[-1] + step / 2)
    ax.set_aspect("equal")
    coastline.draw(ax, lon_min=lon[0] - step / 2 - 1e-9, **{**_COAST, **coast})
    if not _regional(ds):
        ax.set_xticks(np.arange(-180, 181, 60) if lon[0] < 0 else np.arange(0, 361, 60))
        ax.set_yticks(np.arange(-80, 81, 20))
    else:  # round degrees, a graticule line every few degrees
        nice = MaxNLocator(nbins=7, steps=[1, 2, 2.5, 5, 10])
        for axis, lim in ((ax.xaxis, ax.get_xlim()), (ax.yaxis, ax.get_ylim())):
            axis.set_major_locator(FixedLocator(nice.tick_values(*lim)))
    ax.xaxis.set_major_formatter(FuncFormatter(_lon_label))
    ax.yaxis.set_major_formatter(FuncFormatter(_lat_label))
    # the graticule: landmarks inland, above the colours, under coastlines and isolines
    ax.grid(True, color="0.3", linewidth=0.3, linestyle=(0, (4, 4)), alpha=0.5, zorder=3)
    ax.set_axisbelow(False)
    ax.set_xlabel("longitude")
    ax.set_ylabel("latitude")
    ax.tick_params(labelsize=8)


def _spacing(x: np.ndarray) -> float | None:
    """Return the step of evenly spaced values (to 1e-9 of it), else None."""
    if x.size < 2:
        return None
    d = np.diff(x)
    return float(d.mean()) if np.allclose(d, d.mean(), rtol=1e-9, atol=0) else None


def _mesh(ax, ds, values, **style):
    """Colour every node's cell: an image on an evenly spaced grid, else a quad mesh.

    The image is the same picture as ``pcolormesh(shading="nearest")``, drawn an order of
    magnitude faster on fine grids (a 0.1° global map: 0.1 s instead of 8 s).
    """
    lon = ds["longitude"].values
    lat = ds["latitude"].values
    dx, dy = _spacing(lon), _spacing(lat)
    if dx is None or dy is None:
        return ax.pcolormesh(lon, lat, values, shading="nearest", rasterized=True, **style)
    extent = (lon[0] - dx / 2, lon[-1] + dx / 2, lat[0] - dy / 2, lat[-1] + dy / 2)
    return ax.imshow(
        values, origin="lower", extent=extent, interpolation="nearest", aspect="auto", **style
    )


def _colorbar(fig, mesh, axes, label, extend="neither", ticks=None):
    # proportional: a band is as long as its share of the scale, even where edges are uneven
    cb = fig.colorbar(
        mesh,
        ax=axes,
        shrink=0.9,
        pad=0.015,
        aspect=25,
        fraction=0.04,
        extend=extend,
        ticks=ticks,
        spacing="proportional",
    )
    cb.set_label(label, fontsize=9)
    cb.ax.yaxis.set_major_formatter(FuncFormatter(lambda x, _: f"{x:g}"))
    cb.ax.tick_params(labelsize=8)
    return cb


def _field(ax, ds, values, cmap, label, vmin=None, vmax=None, fig=None, norm=None, extend=None):
    if norm is not None:
        vmin = vmax = None
    mesh = _mesh(ax, ds, values, cmap=cmap, norm=norm, vmin=vmin, vmax=vmax)
    _map_axes(ax, ds)
    if extend is None:
        top = vmax if norm is None else norm.vmax
        extend = "max" if top is not None and np.nanmax(values) > top else "neither"
    _colorbar(fig or ax.figure, mesh, ax, label, extend=extend)
    return mesh


def _figsize(ds, nrows=1, map_width=8.0, max_map_height=6.5, extra_width=1.3, scale=True):
    """Figure size in inches for ``nrows`` map panels plus a colourbar column.

    A map is 8 inches wide (at most 6.5 high) when that gives each grid node a pixel at
    :data:`DPI`; a finer grid gets a larger figure, with the same fonts and line widths, so
    that its detail is drawn (up to :data:`MAX_MAP_PIXELS` across).
    """
    lon = ds["longitude"].values
    lat = ds["latitude"].values
    aspect = max(0.25, (lat[-1] - lat[0] + 1e-9) / max(lon[-1] - lon[0], 1e-9))
    w = min(map_width, max_map_height / aspect)
    f = map_scale(lon.size, lat.size, w, w * aspect) if scale else 1.0
    w *= f
    return (w + extra_width, min(22.0 * f, nrows * (w * aspect + 0.8) + 0.3))


def map_scale(nlon: int, nlat: int, width_in: float, height_in: float) -> float:
    """Factor by which to enlarge a map of ``width_in`` x ``height_in`` inches (≥ 1).

    Enough for one pixel per node at :data:`DPI` across and up (the tick labels take about
    0.6 inch of the width), but no more than :data:`MAX_MAP_PIXELS` across.
    """
    need = max(nlon / ((width_in - 0.6) * DPI), nlat / ((height_in - 0.3) * DPI), 1.0)
    return float(min(need, max(1.0, MAX_MAP_PIXELS / (width_in * DPI))))

"""Figures of the map products (Chen et al. 2022 Figs. 2-8 and 10), with coastlines.

Every function takes a Dataset from :mod:`fieldmap.products.maps` and returns a matplotlib Figure
(Agg backend, no display needed);
:func:`fieldmap.products.io.write_png` saves it atomically. Maps are
plate carrée in degrees, with the shipped Natural Earth coastlines, a colourbar with units and a
title naming the model, its degree and the height.

Disturbance maps use colour bands whose edges include the isoline levels, so that colour and
isolines tell the same story, and a colour bar whose bands are as long as their share of the
scale (uneven edges are not drawn evenly). Isolines are coloured (none black) with a white halo;
coastlines are thin and grey, under them, so that the two are not confused. Isolines below the
area median of the map, which would wind through most of it, are drawn faint and dotted.
Every map has a labelled graticule (landmarks inland, where there is no coast).
Maps of several heights of one sweep share one colour scale (the largest value of the sweep),
so that they can be compared by eye.

Sweeps and the truncation study (Figs. 7, 8) are :func:`plot_sweep` and
:func:`plot_truncation`. Every other quantity is drawn in one map style, its entry's
(:mod:`fieldmap.products.quantities`): :func:`plot_quantity` (one variable) or
:func:`plot_panels` (all of them, the gradient tensor's six components in one figure), with a
colour scale chosen from the values (:func:`colours`: symmetric about zero and clipped at the
99th percentile of |x| for signed fields, the clip shown by the colour bar's arrows);
:func:`quantity_figures` lists them. :func:`plot_omission` draws the SH omission maps in the
same style. The map panel (plate carrée, coastlines, degree ticks, equal aspect, size and
resolution of a figure) is shared by all; titles name the model, its degree, the height and a
tide system other than the model file's (:func:`source_text`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, Literal

import matplotlib

matplotlib.use("Agg")

import matplotlib.patheffects as pe  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402
from matplotlib.colors import BoundaryNorm, ListedColormap  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402
from matplotlib.ticker import FixedLocator, FuncFormatter, MaxNLocator  # noqa: E402
from numpy.typing import ArrayLike  # noqa: E402

from fieldmap.products import coastline  # noqa: E402
from fieldmap.products.io import PNG_DPI  # noqa: E402
from fieldmap.products.quantities import Style  # noqa: E402
from fieldmap.products.variables import fraction_attr  # noqa: E402

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.cm import ScalarMappable
    from matplotlib.collections import QuadMesh
    from matplotlib.colorbar import Colorbar
    from matplotlib.colors import Colormap, Normalize
    from matplotlib.figure import Figure, SubFigure
    from matplotlib.image import AxesImage
    from matplotlib.patheffects import AbstractPathEffect

MG_NOTE = "1 mg = 9.80665×10⁻³ m/s²"
# isoline styles by rank of the level (lowest first): colour, width. None is black or grey, the
# colours of the coastlines and the graticule.
_ISO = [
    ("#1565c0", 1.0),
    ("#6a1b9a", 1.4),
    ("#0b6623", 1.8),
    ("#00838f", 2.1),
]
_FAINT = ("#5b9bd5", 0.5, ":")  # isolines below the area median of the map


def _halo(lw: float) -> list[AbstractPathEffect]:
    return [pe.withStroke(linewidth=lw + 1.3, foreground="white", alpha=0.85)]


def describe(ds: xr.Dataset, height_m: float | None = None) -> str:
    """'EIGEN-6S degree 240, h = 20 km' from a Dataset's attributes (with a converted tide)."""
    h = float(ds["height"].values) if height_m is None else float(height_m)
    parts = []
    if ds.attrs.get("model"):
        parts.append(source_text(ds))
    parts.append(f"h = {h / 1e3:g} km")
    return ", ".join(parts)


def _bands(top: float, levels: Sequence[float]) -> np.ndarray:
    """Colour-band edges from 0 to ``top``: round steps plus every isoline level.

    A round edge closer than 0.3 step to an isoline level is dropped so that no band is a
    sliver.
    """
    nice = np.asarray(MaxNLocator(nbins=12, steps=[1, 2, 2.5, 5, 10]).tick_values(0.0, top))
    nice = np.round(nice[(nice >= 0) & (nice < top * (1 - 1e-9))], 12)
    step = nice[1] - nice[0] if nice.size > 1 else top
    lev = np.array([x for x in levels if 0 < x < top])
    keep = [e for e in nice if lev.size == 0 or np.min(np.abs(lev - e)) > 0.3 * step or e in lev]
    return np.union1d(np.union1d(keep, lev), [0.0, top])


def _levels(ds: xr.Dataset, levels_mg: Iterable[float] | None) -> list[float]:
    """Isoline levels: those given, else the thresholds of the map or sweep, else Fig. 4's."""
    if levels_mg is None and "threshold_mg" in ds.coords:
        levels_mg = ds["threshold_mg"].values
    if levels_mg is None:
        levels_mg = ds.attrs.get("thresholds_mg", [0.02, 0.06, 0.1])
    return sorted(float(x) for x in levels_mg)


def _modulus_top(v: np.ndarray, levels: Sequence[float]) -> float:
    """Upper end of the colour scale: a round value at or above the maximum of the data.

    At least 1.2 x the top isoline. The colour bar covers every value of the map (a scale
    ending at a percentile left the largest disturbances, the ones a reader looks for, off the
    bar).
    """
    raw = max(float(np.nanmax(v)), max(levels) * 1.2)
    return float(MaxNLocator(nbins=12, steps=[1, 2, 2.5, 5, 10]).tick_values(0.0, raw)[-1])


def _area_median(sub: xr.Dataset, v: np.ndarray) -> float:
    """Area-weighted median of the modulus map ``v`` (mg): from the Dataset when it has it."""
    if "p50_mg" in sub.data_vars and sub["p50_mg"].ndim == 0:
        return float(sub["p50_mg"])
    if "p50_mg" in sub.attrs:
        return float(sub.attrs["p50_mg"])
    from fieldmap.products.statistics import area_weights, weighted_percentile

    return weighted_percentile(v, area_weights(sub["latitude"].values)[:, None], 50.0)


def _isolines(
    ax: Axes, ds: xr.Dataset, v: np.ndarray, levels: Sequence[float], labels: bool
) -> list[Line2D]:
    """Draw one isoline per level; return legend handles.

    A level below the area median of the map encloses most of it in scattered loops (the
    0.02 mg isoline at 20 km winds through every ocean): it is drawn faint and dotted, not
    labelled, so that the levels that mark out the map stay readable.
    """
    lon = ds["longitude"].values
    lat = ds["latitude"].values
    if v.shape[0] < 2 or v.shape[1] < 2:
        return []
    median = _area_median(ds, v)
    handles = []
    strong = [lev for lev in sorted(levels) if lev >= median]
    for lev in sorted(levels):
        if lev < median:
            color, lw, ls = _FAINT
            halo, alpha, label = [], 0.8, f"{lev:g} mg (below the median)"
        else:
            color, lw = _ISO[min(strong.index(lev), len(_ISO) - 1)]
            ls, halo, alpha, label = "-", _halo(lw), 1.0, f"{lev:g} mg"
        cs = ax.contour(
            lon,
            lat,
            v,
            levels=[lev],
            colors=[color],
            linewidths=lw,
            linestyles=[ls],
            alpha=alpha,
            zorder=6,
        )
        cs.set(path_effects=halo)
        if labels and lev >= median:
            txt = ax.clabel(cs, fmt=lambda x: f"{x:g}", fontsize=8, inline=True, inline_spacing=3)
            for t in txt:
                t.set(path_effects=[pe.withStroke(linewidth=2.5, foreground="white")])
        handles.append(
            Line2D([], [], color=color, lw=lw, ls=ls, alpha=alpha, label=label, path_effects=halo)
        )
    return handles


def plot_components(ds: xr.Dataset, which: str = "model") -> Figure:
    """Three panels (east, north, up) of model or normal gravity (Figs. 2 and 3).

    Horizontal components are in mGal on a symmetric scale clipped at the 99.5th percentile of
    their magnitude (arrows on the colourbar mark values beyond it); the up component is in m/s².

    Parameters
    ----------
    ds : xarray.Dataset
        From :func:`fieldmap.products.maps.component_maps`.
    which : {"model", "normal"}
    """
    fig, axes = plt.subplots(3, 1, figsize=_figsize(ds, 3), constrained_layout=True)
    what = (
        f"gravity from {source_text(ds)}"
        if which == "model"
        else f"normal gravity of {ds.attrs['ellipsoid']} (exact)"
    )
    h = float(ds["height"].values) / 1e3
    for ax, (k, c) in zip(axes, enumerate(("east", "north", "up"))):
        v = ds[f"{which}_{c}"].values
        if c != "up":
            v = v * 1e5
            big = float(np.max(np.abs(v)))
            lim = float(np.percentile(np.abs(v), 99.5))
            if big < 1e-6:
                lim = 1.0
                ax.text(
                    0.5,
                    0.5,
                    "identically 0 (rotationally symmetric field)",
                    transform=ax.transAxes,
                    ha="center",
                    va="center",
                    fontsize=9,
                    bbox=dict(fc="white", ec="0.6", alpha=0.9),
                    zorder=7,
                )
            _field(
                ax,
                ds,
                v,
                "RdBu_r",
                f"g {c} (mGal)",
                -lim,
                lim,
                extend="both" if big > lim * 1.0001 else "neither",
            )
        else:
            _field(ax, ds, v, "viridis", "g up (m/s²)")
        ax.set_title(f"({'abc'[k]}) {c} component of {what}, h = {h:g} km", fontsize=10)
    return fig


def plot_isolines(
    ds: xr.Dataset,
    levels_mg: Iterable[float] | None = None,
    title: str | None = None,
    height_index: int | None = None,
    vmax: float | None = None,
) -> Figure:
    """Modulus of the disturbance (mg) in colour with isolines at ``levels_mg`` (Figs. 4, 7, 10).

    With ``height_index`` (one height of an altitude sweep) the colour scale is common to all
    heights of the sweep unless ``vmax`` is given. Global maps list the isolines in a legend;
    regional maps label them in place.
    """
    levels = _levels(ds, levels_mg)
    sub = ds if height_index is None else ds.isel(height=height_index)
    if vmax is None:
        vmax = _modulus_top(ds["modulus_mg"].values, levels)
    fig, ax = plt.subplots(figsize=_figsize(sub), constrained_layout=True)
    _isoline_panel(fig, ax, sub, levels, vmax)
    common = " (colour scale common to all heights)" if height_index is not None else ""
    ax.set_title(
        title
        or f"Gravity disturbance |δg| with isolines {', '.join(f'{x:g}' for x in levels)} mg\n"
        f"{describe(sub)}, {sub.attrs.get('ellipsoid', 'WGS84')} normal field{common}",
        fontsize=10,
    )
    return fig


def _isoline_panel(
    fig: Figure,
    ax: Axes,
    sub: xr.Dataset,
    levels: Sequence[float],
    vmax: float,
    colorbar: bool = True,
    legend: bool = True,
) -> QuadMesh | AxesImage:
    v = sub["modulus_mg"].values
    edges = _bands(vmax, levels)
    cmap = plt.get_cmap("YlOrRd", len(edges) - 1)
    norm = BoundaryNorm(edges, cmap.N)
    mesh = _mesh(ax, sub, v, cmap=cmap, norm=norm)
    _map_axes(ax, sub)
    handles = _isolines(ax, sub, v, levels, labels=_regional(sub))
    if handles and legend:
        lead = Line2D([], [], color="none", label="isolines:")
        ax.legend(
            handles=[lead, *handles],
            fontsize=8,
            loc="upper center",
            bbox_to_anchor=(0.5, -0.1 if not _regional(sub) else -0.06),
            ncol=len(handles) + 1 if not _regional(sub) else 3,
            frameon=False,
            handlelength=2.2,
            columnspacing=1.2,
        )
    if colorbar:
        ticks = edges if len(edges) <= 16 else None
        _colorbar(
            fig,
            mesh,
            ax,
            f"|δg| (mg)   [{MG_NOTE}]",
            extend="max" if np.nanmax(v) > vmax else "neither",
            ticks=ticks,
        )
    return mesh


def plot_isolines_panels(
    ds: xr.Dataset, height_indices: Sequence[int], levels_mg: Iterable[float] | None = None
) -> Figure:
    """Stacked disturbance maps at several heights of a sweep with ONE colour scale (Fig. 7)."""
    levels = _levels(ds, levels_mg)
    idx = list(height_indices)
    vmax = _modulus_top(ds["modulus_mg"].values[idx], levels)
    w, h = _figsize(ds.isel(height=0), nrows=len(idx))
    fig, axes = plt.subplots(len(idx), 1, figsize=(w, h), constrained_layout=True, squeeze=False)
    for k, (ax, i) in enumerate(zip(axes[:, 0], idx)):
        sub = ds.isel(height=i)
        mesh = _isoline_panel(fig, ax, sub, levels, vmax, colorbar=False, legend=k == len(idx) - 1)
        f = zip(ds["threshold_mg"].values, ds["area_fraction_above"].values[i])
        extra = "; ".join(f"> {t:g} mg: {100 * x:.2f}%" for t, x in f if t >= 0.05)
        ax.set_title(
            f"({'abcdefgh'[k]}) h = {float(sub['height']) / 1e3:g} km — max "
            f"{float(np.nanmax(sub['modulus_mg'].values)):.3f} mg"
            + (f"; area {extra}" if extra else ""),
            fontsize=9,
        )
    edges = _bands(vmax, levels)
    _colorbar(
        fig,
        mesh,
        axes[:, 0],
        f"|δg| (mg)   [{MG_NOTE}]",
        extend="max" if np.nanmax(ds["modulus_mg"].values[idx]) > vmax else "neither",
        ticks=edges if len(edges) <= 16 else None,
    )
    fig.suptitle(
        f"Gravity disturbance |δg|, {source_text(ds)}"
        f" minus exact {ds.attrs.get('ellipsoid', 'WGS84')} normal gravity "
        "(one colour scale)",
        fontsize=10,
    )
    return fig


def plot_threshold(ds: xr.Dataset, threshold_mg: float, title: str | None = None) -> Figure:
    """Area where the modulus exceeds ``threshold_mg`` in black (Figs. 5 and 6)."""
    v = ds["modulus_mg"].values
    key = fraction_attr(threshold_mg)
    if key in ds.attrs:
        frac = float(ds.attrs[key])
    else:
        from fieldmap.products.statistics import weights_2d

        frac = float(np.sum(weights_2d(ds["latitude"].values, v.shape[1])[v > threshold_mg]))
    fig, ax = plt.subplots(figsize=_figsize(ds, extra_width=0.4), constrained_layout=True)
    cmap = ListedColormap(["#f2f2f2", "black"])
    _mesh(ax, ds, (v > threshold_mg).astype(float), cmap=cmap, vmin=0, vmax=1)
    _map_axes(ax, ds, color="#e66100", linewidth=0.5)
    ax.legend(
        handles=[
            Patch(fc="black", label=f"|δg| > {threshold_mg:g} mg ({100 * frac:.2f}% of area)"),
            Patch(fc="#f2f2f2", ec="0.5", label=f"|δg| ≤ {threshold_mg:g} mg"),
            Line2D([], [], color="#e66100", lw=1, label="coastline"),
        ],
        loc="upper center",
        bbox_to_anchor=(0.5, -0.1 if not _regional(ds) else -0.06),
        ncol=3 if not _regional(ds) else 1,
        fontsize=8,
        frameon=False,
    )
    ax.set_title(
        title
        or f"Area with |δg| > {threshold_mg:g} mg: {100 * frac:.2f}% (area-weighted)\n"
        f"{describe(ds)}, {ds.attrs.get('ellipsoid', 'WGS84')} normal field",
        fontsize=10,
    )
    return fig


_COAST = {"color": "0.42", "linewidth": 0.35, "zorder": 4}
#: Widest map drawn, in pixels; finer grids than this share pixels between nodes.
MAX_MAP_PIXELS = 4000
DPI = PNG_DPI


def _regional(ds: xr.Dataset) -> bool:
    return ds.attrs.get("grid_kind", "global") != "global"


def _deg_label(value: float, pos: str, neg: str) -> str:
    v = float(value)
    if abs(v) < 1e-9:
        return "0°"
    return f"{abs(v):g}°{pos if v > 0 else neg}"


def _lon_label(x: float, _: object = None) -> str:
    """120 -> 120°E, -60 or 300 -> 60°W, 180 -> 180°."""
    x = (float(x) + 180.0) % 360.0 - 180.0
    if abs(abs(x) - 180.0) < 1e-9:
        return "180°"
    return _deg_label(x, "E", "W")


def _lat_label(y: float, _: object = None) -> str:
    return _deg_label(y, "N", "S")


def node_step(ds: xr.Dataset) -> float:
    """Spacing of the nodes drawn: the grid step, times the decimation of a figure's view."""
    return float(ds.attrs.get("grid_step_deg", 1.0)) * int(ds.attrs.get("figure_decimation", 1))


def _map_axes(ax: Axes, ds: xr.Dataset, **coast: Any) -> None:
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


def _mesh(ax: Axes, ds: xr.Dataset, values: np.ndarray, **style: Any) -> QuadMesh | AxesImage:
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


def _colorbar(
    fig: Figure | SubFigure,
    mesh: ScalarMappable,
    axes: Axes | Sequence[Axes] | np.ndarray,
    label: str,
    extend: Literal["neither", "both", "min", "max"] = "neither",
    ticks: ArrayLike | None = None,
) -> Colorbar:
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


def _field(
    ax: Axes,
    ds: xr.Dataset,
    values: np.ndarray,
    cmap: str | Colormap,
    label: str,
    vmin: float | None = None,
    vmax: float | None = None,
    fig: Figure | None = None,
    norm: Normalize | None = None,
    extend: Literal["neither", "both", "min", "max"] | None = None,
) -> QuadMesh | AxesImage:
    if norm is not None:
        vmin = vmax = None
    mesh = _mesh(ax, ds, values, cmap=cmap, norm=norm, vmin=vmin, vmax=vmax)
    _map_axes(ax, ds)
    if extend is None:
        top = vmax if norm is None else norm.vmax
        extend = "max" if top is not None and np.nanmax(values) > top else "neither"
    _colorbar(fig or ax.figure, mesh, ax, label, extend=extend)
    return mesh


def _figsize(
    ds: xr.Dataset,
    nrows: int = 1,
    map_width: float = 8.0,
    max_map_height: float = 6.5,
    extra_width: float = 1.3,
    scale: bool = True,
) -> tuple[float, float]:
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


def plot_sweep(
    ds: xr.Dataset, reference: Mapping[float, tuple[float, float]] | None = None
) -> Figure:
    """Area fraction above each threshold, and max / mean modulus, versus height (Fig. 7 study).

    Parameters
    ----------
    reference : dict, optional
        ``{threshold_mg: (height_km, percent)}`` values of another study (e.g. the paper's
        §4.1 fractions at 20 km) drawn as open markers. Units: mg, km, %.
    """
    h = ds["height"].values / 1e3
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    frac = 100 * ds["area_fraction_above"].values
    a1.set_yscale(
        "log" if np.all(frac > 0) else "symlog", **({} if np.all(frac > 0) else {"linthresh": 0.01})
    )
    for j, t in enumerate(ds["threshold_mg"].values):
        (line,) = a1.plot(h, frac[:, j], "o-", label=f"> {t:g} mg")
        if reference and float(t) in reference:
            rh, rp = reference[float(t)]
            a1.plot([rh], [rp], "D", color=line.get_color(), mfc="none", ms=9, mew=1.5)
    if reference:
        a1.plot([], [], "D", color="0.3", mfc="none", label="paper (EIGEN-6C4 d2190)")
    a1.set_xlabel("height above the ellipsoid (km)")
    a1.set_ylabel("area fraction (%)")
    a1.grid(True, which="major", alpha=0.3)
    a1.grid(True, which="minor", alpha=0.1)
    a1.legend(fontsize=8)
    a1.set_title("Area (area-weighted) with |δg| above thresholds", fontsize=10)
    a2.plot(h, ds["max_mg"].values, "o-", label="maximum")
    if "p99_mg" in ds:
        a2.plot(h, ds["p99_mg"].values, "^-", label="99th percentile")
    a2.plot(h, ds["mean_mg"].values, "s-", label="area-weighted mean")
    a2.set_xlabel("height above the ellipsoid (km)")
    a2.set_ylabel("|δg| (mg)")
    a2.set_ylim(bottom=0)
    a2.grid(True, alpha=0.3)
    a2.legend(fontsize=8)
    a2.set_title("Disturbance modulus versus height", fontsize=10)
    fig.suptitle(
        f"Altitude sweep — {source_text(ds)} minus exact "
        f"{ds.attrs.get('ellipsoid', 'WGS84')} normal gravity",
        fontsize=11,
    )
    return fig


def plot_truncation(ds: xr.Dataset) -> Figure:
    """Modulus of the J2n truncation error per order (Fig. 8), with a latitude profile."""
    orders = [int(o) for o in ds["order"].values]
    n = len(orders)
    w, _ = _figsize(ds, extra_width=0.0, scale=False)  # axisymmetric: no detail to resolve
    fig, axes = plt.subplots(
        n,
        2,
        figsize=(w + 4.2, 3.0 * n + 0.4),
        squeeze=False,
        gridspec_kw={"width_ratios": [3, 1]},
        constrained_layout=True,
    )
    h = float(ds["height"].values) / 1e3
    lat = ds["latitude"].values
    for k, o in enumerate(orders):
        sub = ds.isel(order=k)
        v = sub["modulus_mg"].values
        exp = int(np.floor(np.log10(max(float(v.max()), 1e-300))))
        scale = 10.0**exp
        _field(axes[k, 0], sub, v / scale, "magma_r", f"|δg| ($10^{{{exp}}}$ mg)", 0.0)
        axes[k, 0].set_title(
            f"({'abcdef'[k]}) J{o} minus exact normal gravitation, h = {h:g} km "
            f"({ds.attrs['ellipsoid']}); max {float(v.max()):.3g} mg",
            fontsize=10,
        )
        prof = axes[k, 1]
        for c in ("north", "up"):
            prof.plot(sub[c].values[:, 0] * _to_mg(sub[c].attrs["units"]) / scale, lat, label=c)
        prof.axvline(0, color="0.5", lw=0.6)
        prof.set_xlabel(f"δg ($10^{{{exp}}}$ mg)")
        prof.set_ylabel("latitude (°N)")
        prof.set_yticks(np.arange(-80, 81, 20) if not _regional(ds) else prof.get_yticks())
        prof.set_ylim(lat[0], lat[-1])
        prof.grid(True, alpha=0.3)
        east0 = float(np.max(np.abs(sub["east"].values))) == 0.0
        prof.legend(fontsize=8, title="east ≡ 0" if east0 else None, title_fontsize=7)
        prof.set_title("zonal profile of the components", fontsize=9)
    return fig


def _to_mg(units: str) -> float:
    from fieldmap.units import MG, get_unit

    return get_unit(units).si / MG


#: Colour-bar spellings of the UDUNITS units of the quantities.
_UNIT_LABELS = {
    "1e-9 s-2": "E",
    "1e-18 s-4": "E²",
    "1e-27 s-6": "E³",
    "m2 s-2": "m²/s²",
    "m s-2": "m/s²",
}
#: Default colour maps of the scales (:class:`fieldmap.products.quantities.Style`).
_CMAPS = {"signed": "RdBu_r", "magnitude": "magma_r", "level": "viridis"}


@dataclasses.dataclass(frozen=True)
class Colours:
    """A colour scale chosen from a map's values (:func:`colours`).

    Attributes
    ----------
    vmin, vmax : float
        Ends of the scale (``vmin == -vmax`` for a signed scale).
    cmap : str
    extend : {"neither", "min", "max", "both"}
        The colour bar's arrows: values beyond the scale's ends, drawn in the end colours.
    kind : {"signed", "magnitude", "level", "constant"}
        The scale chosen (an ``auto`` style's choice made; ``constant``: every value the same,
        drawn mid-scale).
    note : str
        How the ends were chosen, for the colour bar's label ("" when nothing is clipped).
    """

    vmin: float
    vmax: float
    cmap: str
    extend: Literal["neither", "both", "min", "max"]
    kind: str
    note: str


def colours(values: np.ndarray, lat: np.ndarray, style: Style) -> Colours:
    """Choose the colour scale of a map from its values (area-weighted percentiles).

    ``signed``: symmetric about zero, to the ``style.clip`` percentile of |x| (a field of both
    signs: anomaly, geoid, deflection); ``magnitude``: 0 to the percentile (standard
    deviations; from the ``100 - clip`` percentile where that is above half the top, a field
    far from zero everywhere); ``level``: between the ``100 - clip`` and ``clip`` percentiles
    (a field far from zero); ``auto``: ``signed`` if those percentiles have opposite signs,
    else ``level``. A few extreme nodes (mountains, trenches) then take the end colours and the
    colour bar's arrows instead of leaving the rest of the map pale. A constant field gets a
    scale around its value.

    Parameters
    ----------
    values : numpy.ndarray
        (nlat, nlon); NaNs are ignored.
    lat : numpy.ndarray
        Latitudes of the rows (area weights). Units: degrees.
    style : fieldmap.products.quantities.Style

    Examples
    --------
    >>> import numpy as np
    >>> from fieldmap.products.plots import colours
    >>> from fieldmap.products.quantities import Style
    >>> x = np.linspace(-1.0, 3.0, 200).reshape(10, 20)
    >>> c = colours(x, np.linspace(-45.0, 45.0, 10), Style(scale="signed"))
    >>> c.vmin == -c.vmax, c.extend
    (True, 'max')
    """
    from fieldmap.products.statistics import area_weights, weighted_percentiles

    w = np.broadcast_to(area_weights(lat)[:, None], values.shape)
    ok = np.isfinite(values)
    v, w = values[ok], w[ok]
    if v.size == 0:
        return Colours(-1.0, 1.0, _CMAPS["signed"], "neither", "signed", "")
    q = float(style.clip)
    kind = style.scale
    if float(np.min(v)) == float(np.max(v)):  # a constant field: its value mid-scale
        x = float(v[0])
        pad = abs(x) * 0.5 or 1.0
        cmap = style.cmap or _CMAPS["magnitude" if kind == "magnitude" else "level"]
        return Colours(x - pad, x + pad, cmap, "neither", "constant", "")
    if kind == "auto":
        lo, hi = weighted_percentiles(v, w, [100.0 - q, q])
        kind = "signed" if lo < 0.0 < hi else "level"
    if kind == "signed":
        top = float(weighted_percentiles(np.abs(v), w, [q])[0]) or float(np.max(np.abs(v)))
        top = top or 1.0
        vmin, vmax = -top, top
        note = f"±{_ordinal(q)} percentile of |x|"
    elif kind == "magnitude":
        lo, top = (float(x) for x in weighted_percentiles(v, w, [100.0 - q, q]))
        top = top if top > 0 else float(np.max(v)) or 1.0
        if lo < 0.5 * top:  # from zero, as a size is read
            vmin, note = min(0.0, float(np.min(v))), f"0 to the {_ordinal(q)} percentile"
        else:  # a field far from zero everywhere (a sigma of 0.1 to 0.18 m): its own range
            vmin, note = lo, f"{_ordinal(100 - q)} to {_ordinal(q)} percentile"
        vmax = top
    else:
        vmin, vmax = (float(x) for x in weighted_percentiles(v, w, [100.0 - q, q]))
        note = f"{_ordinal(100 - q)} to {_ordinal(q)} percentile"
        if vmax <= vmin:  # all but a few nodes alike
            pad = abs(vmin) * 1e-3 or 1.0
            vmin, vmax = vmin - pad, vmax + pad
    low, high = bool(np.min(v) < vmin), bool(np.max(v) > vmax)
    extend: Literal["neither", "both", "min", "max"] = (
        "both" if low and high else "min" if low else "max" if high else "neither"
    )
    cmap = style.cmap or _CMAPS[kind]
    return Colours(vmin, vmax, cmap, extend, kind, note if extend != "neither" else "")


def source_text(ds: xr.Dataset) -> str:
    """Name the source of a product: model and degree (and the tide system where converted)."""
    from fieldmap.products.variables import converted_tide_system

    a = ds.attrs
    if not a.get("model"):
        return f"{a.get('ellipsoid', 'WGS84')} normal field"
    system = converted_tide_system(a)
    return f"{a['model']} degree {a.get('model_lmax')}" + (f" ({system})" if system else "")


def _unit_label(units: str) -> str:
    return _UNIT_LABELS.get(units, units)


def _ordinal(q: float) -> str:
    """1 -> '1st', 99 -> '99th', 99.5 -> '99.5th'."""
    text = f"{q:g}"
    if "." in text or text.endswith(("11", "12", "13")):
        return f"{text}th"
    return text + {"1": "st", "2": "nd", "3": "rd"}.get(text[-1], "th")


def _wrapped(text: str, fig: Figure | SubFigure, fontsize: float) -> str:
    """``text`` broken into lines that fit the figure's width (a title inside the canvas)."""
    import textwrap

    # a title is centred on its map, left of the figure's centre (the colour bar is right):
    # lines of 0.8 of the figure's width, a character being ~0.55 em wide
    width = fig.get_figure(root=True).get_figwidth()
    chars = max(30, int(0.8 * width * 72 / (0.55 * fontsize)))
    return "\n".join(textwrap.fill(line, chars) for line in text.split("\n"))


def _layer(ds: xr.Dataset, height_index: int | None) -> tuple[xr.Dataset, float]:
    """Return the map at one height of a product (the first by default) and that height (m)."""
    if "height" in ds.dims:
        sub = ds.isel(height=0 if height_index is None else int(height_index))
    else:
        sub = ds
    return sub, float(sub["height"].values)


def _where(ds: xr.Dataset, height: float) -> str:
    from fieldmap.products.quantities import quantity

    surface = quantity(ds.attrs["quantity"]).surface
    return "h = 0" if surface else f"h = {height / 1e3:g} km"


def _quantity_panel(
    fig: Figure | SubFigure, ax: Axes, sub: xr.Dataset, name: str, style: Style
) -> Colours:
    """Draw one variable of a quantity map in the map style on ``ax``, with its colour bar."""
    var = sub[name]
    values = np.asarray(var.values)
    c = colours(values, sub["latitude"].values, style)
    mesh = _mesh(ax, sub, values, cmap=c.cmap, vmin=c.vmin, vmax=c.vmax)
    _map_axes(ax, sub)
    units = _unit_label(str(var.attrs.get("units", "")))
    _colorbar(
        fig,
        mesh,
        ax,
        f"{name} ({units})" + (f"; colours {c.note}" if c.note else ""),
        extend=c.extend,
    )
    if c.kind == "constant":
        ax.text(
            0.5,
            0.5,
            f"the same at every node: {float(np.nanmax(values)):.4g} {units}",
            transform=ax.transAxes,
            ha="center",
            va="center",
            fontsize=9,
            bbox=dict(fc="white", ec="0.6", alpha=0.9),
            zorder=7,
        )
    return c


def plot_quantity(ds: xr.Dataset, name: str, height_index: int | None = None) -> Figure:
    """Map of one variable of a quantity map, in the map style of every quantity.

    Plate carrée in degrees with coastlines, a labelled graticule and equal aspect (as the
    disturbance maps); the colour scale is chosen from the values in the quantity's style
    (:func:`colours`): symmetric about zero for a signed field, clipped at a high percentile,
    the clip shown by the colour bar's arrows.

    Parameters
    ----------
    ds : xarray.Dataset
        From :func:`fieldmap.quantity_map`.
    name : str
        A variable of it (``anomaly``, ``xi``, ``geoid``, ``T_uu``...).
    height_index : int, optional
        Height of a sweep (default: the first).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from fieldmap.products.quantities import quantity

    sub, height = _layer(ds, height_index)
    style = quantity(ds.attrs["quantity"]).style
    fig, ax = plt.subplots(figsize=_figsize(sub), constrained_layout=True)
    _quantity_panel(fig, ax, sub, name, style)
    title = f"{sub[name].attrs['long_name']}\n{source_text(ds)}, {_where(ds, height)}"
    ax.set_title(_wrapped(title, fig, 9), fontsize=9)
    return fig


def plot_panels(ds: xr.Dataset, height_index: int | None = None) -> Figure:
    """Every variable of a quantity map in one figure (the gradient tensor's six components).

    Two columns of maps in the style of :func:`plot_quantity`, each with its own colour scale
    chosen from its values; one title for the figure.
    """
    from fieldmap.products.quantities import quantity

    q = quantity(ds.attrs["quantity"])
    sub, height = _layer(ds, height_index)
    names = q.names
    ncols = 2 if len(names) > 1 else 1
    nrows = -(-len(names) // ncols)
    w, h = _figsize(sub, map_width=6.0, max_map_height=4.5, extra_width=1.4)
    fig, axes = plt.subplots(
        nrows, ncols, figsize=(ncols * w, nrows * (h - 0.3) + 0.7), constrained_layout=True
    )
    flat = np.atleast_1d(axes).ravel()
    for ax, name in zip(flat, names):
        _quantity_panel(fig, ax, sub, name, q.style)
        ax.set_title(name, fontsize=9)
    for ax in flat[len(names) :]:
        ax.set_visible(False)
    what = sub[names[0]].attrs["long_name"].split(",")[0]
    title = f"{what}\n{source_text(ds)}, {_where(ds, height)}"
    fig.suptitle(_wrapped(title, fig, 10), fontsize=10)
    return fig


def quantity_figures(ds: xr.Dataset, quantity: str) -> list[tuple[str, Callable[[], Figure]]]:
    """Return the figures of a quantity map or sweep, as ``(file suffix, maker)`` pairs.

    In the quantity's style (:mod:`fieldmap.products.quantities`): one map per variable and
    height (suffix: the variable, ``<variable>_h<h>km`` in a sweep), or one figure of all
    variables per height (``panels``: the tensor's, suffix ``tensor``).
    """
    from functools import partial

    from fieldmap.products.quantities import quantity as entry

    q = entry(quantity)
    heights = np.atleast_1d(ds["height"].values)
    sweep = heights.size > 1

    def at(k: int) -> str:
        return f"_h{heights[k] / 1e3:g}km" if sweep else ""

    if q.style.figure == "panels":
        return [(q.style.suffix + at(k), partial(plot_panels, ds, k)) for k in range(heights.size)]
    return [
        (name + at(k), partial(plot_quantity, ds, name, k))
        for name in q.names
        for k in range(heights.size)
    ]


def plot_omission(ds: xr.Dataset, variable: str = "modulus") -> Figure:
    """Spherical-harmonic omission maps, one per degree d, at the product's first height.

    ``ds`` from :func:`fieldmap.products.degree.omission_map`: the disturbance of the model's
    degrees d+1..L. In the map style of every quantity: coastlines, graticule, equal aspect,
    a colour scale from 0 to the 99th percentile of each map (arrows beyond).
    """
    degs = [int(d) for d in ds["degree"].values]
    first = ds.isel(degree=0, height=0)
    w, h = _figsize(first)
    fig, axes = plt.subplots(
        len(degs),
        1,
        figsize=(w, len(degs) * (h - 0.3) + 0.6),
        constrained_layout=True,
        squeeze=False,
    )
    style = Style(scale="magnitude")
    height = float(ds["height"].values[0])
    units = _unit_label(str(ds[variable].attrs.get("units", "")))
    for k, d in enumerate(degs):
        sub = ds.isel(degree=k, height=0)
        ax = axes[k, 0]
        v = np.asarray(sub[variable].values)
        c = colours(v, sub["latitude"].values, style)
        mesh = _mesh(ax, sub, v, cmap=c.cmap, vmin=c.vmin, vmax=c.vmax)
        _map_axes(ax, sub)
        label = f"|δg_full − δg_{d}| ({units})" + (f"; colours {c.note}" if c.note else "")
        _colorbar(fig, mesh, ax, label, extend=c.extend)
        ax.set_title(
            f"omission of degree {d} (the model's degrees {d + 1}..{ds.attrs['model_lmax']}); "
            f"max {float(np.nanmax(v)):.3g} {units}",
            fontsize=9,
        )
    fig.suptitle(
        f"Spherical-harmonic omission, {source_text(ds)}, h = {height / 1e3:g} km", fontsize=10
    )
    return fig


#: Thresholds from which ``fieldmap map`` draws a map of the area above (below, the area is most
#: of the map and the figure says little).
THRESHOLD_FIGURES_FROM_MG = 0.05


def disturbance_figures(
    ds: xr.Dataset, thresholds: Sequence[float]
) -> list[tuple[str, Callable[[], Figure]]]:
    """Return the figures of a disturbance map or sweep, as ``(file suffix, maker)`` pairs.

    A map: its isolines and, for each threshold from :data:`THRESHOLD_FIGURES_FROM_MG`, the
    area above it (``above_<t>mg``); a sweep: its table and the isolines at each height
    (``isolines_h<h>km``), one colour scale for all. The one list of ``fieldmap map|sweep``,
    whether the map is held in memory or streamed to a store.
    """
    from functools import partial

    if "height" in ds.dims:
        figs: list[tuple[str, Callable[[], Figure]]] = [("table", partial(plot_sweep, ds))]
        for k, h in enumerate(ds["height"].values):
            figs.append(
                (f"isolines_h{h / 1e3:g}km", partial(plot_isolines, ds, thresholds, height_index=k))
            )
        return figs
    figs = [("isolines", partial(plot_isolines, ds, thresholds))]
    for t in thresholds:
        if t >= THRESHOLD_FIGURES_FROM_MG:
            figs.append((f"above_{t:g}mg", partial(plot_threshold, ds, t)))
    return figs

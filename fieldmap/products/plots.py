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

This module holds the map figures (components, isolines, threshold areas). The map panel they
share (axes, coastlines, graticule, colour bar, figure size and resolution) is
:mod:`fieldmap.products.mapaxes`; the figures of an altitude sweep and of the truncation study,
:func:`plot_sweep` and :func:`plot_truncation`, are in :mod:`fieldmap.products.studyplots` and
importable from here too.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.patheffects as pe  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import BoundaryNorm, ListedColormap  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402

from fieldmap.products.cf import fraction_attr  # noqa: E402
from fieldmap.products.mapaxes import (  # noqa: E402, F401 - DPI, MAX_MAP_PIXELS, map_scale: API
    DPI,
    MAX_MAP_PIXELS,
    _colorbar,
    _field,
    _figsize,
    _map_axes,
    _mesh,
    _regional,
    map_scale,
)
from fieldmap.products.studyplots import plot_sweep, plot_truncation  # noqa: E402, F401

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


def _halo(lw):
    return [pe.withStroke(linewidth=lw + 1.3, foreground="white", alpha=0.85)]


def describe(ds, height_m=None) -> str:
    """'EIGEN-6S degree 240, h = 20 km' from a Dataset's attributes."""
    h = float(ds["height"].values) if height_m is None else float(height_m)
    parts = []
    if ds.attrs.get("model"):
        parts.append(f"{ds.attrs['model']} degree {ds.attrs['model_lmax']}")
    parts.append(f"h = {h / 1e3:g} km")
    return ", ".join(parts)


def _bands(top: float, levels) -> np.ndarray:
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


def _levels(ds, levels_mg):
    """Isoline levels: those given, else the thresholds of the map or sweep, else Fig. 4's."""
    if levels_mg is None and "threshold_mg" in ds.coords:
        levels_mg = ds["threshold_mg"].values
    if levels_mg is None:
        levels_mg = ds.attrs.get("thresholds_mg", [0.02, 0.06, 0.1])
    return sorted(float(x) for x in levels_mg)


def _modulus_top(v, levels) -> float:
    """Upper end of the colour scale: the 99.9th percentile, at least 1.2 x the top isoline."""
    raw = max(float(np.nanpercentile(v, 99.9)), max(levels) * 1.2)
    return float(MaxNLocator(nbins=12, steps=[1, 2, 2.5, 5, 10]).tick_values(0.0, raw)[-1])


def _area_median(sub, v) -> float:
    """Area-weighted median of the modulus map ``v`` (mg): from the Dataset when it has it."""
    if "p50_mg" in sub.data_vars and sub["p50_mg"].ndim == 0:
        return float(sub["p50_mg"])
    if "p50_mg" in sub.attrs:
        return float(sub.attrs["p50_mg"])
    from fieldmap.products.stats import area_weights, weighted_percentile

    return weighted_percentile(v, area_weights(sub["latitude"].values)[:, None], 50.0)


def _isolines(ax, ds, v, levels, labels: bool):
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


def plot_components(ds, which: str = "model"):
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
        f"gravity from {ds.attrs['model']} degree {ds.attrs['model_lmax']}"
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


def plot_isolines(ds, levels_mg=None, title: str | None = None, height_index=None, vmax=None):
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


def _isoline_panel(fig, ax, sub, levels, vmax, colorbar=True, legend=True):
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


def plot_isolines_panels(ds, height_indices, levels_mg=None):
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
        f"Gravity disturbance |δg|, {ds.attrs['model']} degree {ds.attrs['model_lmax']}"
        f" minus exact {ds.attrs.get('ellipsoid', 'WGS84')} normal gravity "
        "(one colour scale)",
        fontsize=10,
    )
    return fig


def plot_threshold(ds, threshold_mg: float, title: str | None = None):
    """Area where the modulus exceeds ``threshold_mg`` in black (Figs. 5 and 6)."""
    v = ds["modulus_mg"].values
    key = fraction_attr(threshold_mg)
    if key in ds.attrs:
        frac = float(ds.attrs[key])
    else:
        from fieldmap.products.stats import weights_2d

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

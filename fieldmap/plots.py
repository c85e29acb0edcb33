"""Figures of the map products (Chen et al. 2022 Figs. 2-8 and 10), with coastlines.

Every function takes a Dataset from :mod:`fieldmap.maps` and returns a matplotlib Figure
(Agg backend, no display needed); :func:`fieldmap.io.write_png` saves it atomically. Maps are
plate carrée in degrees, with the shipped Natural Earth coastlines, a colourbar with units and a
title naming the model, its degree and the height.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import ListedColormap  # noqa: E402

from . import coastline  # noqa: E402
from .stats import threshold_key  # noqa: E402

_COMP_NAME = {"east": "east", "north": "north", "up": "up"}


def describe(ds, height_m=None) -> str:
    """'EIGEN-6S degree 240, h = 20 km' from a Dataset's attributes."""
    h = float(ds["height"].values) if height_m is None else float(height_m)
    parts = []
    if ds.attrs.get("model"):
        parts.append(f"{ds.attrs['model']} degree {ds.attrs['model_lmax']}")
    parts.append(f"h = {h / 1e3:g} km")
    return ", ".join(parts)


def _map_axes(ax, ds, **coast):
    lon = ds["longitude"].values
    lat = ds["latitude"].values
    step = float(ds.attrs.get("grid_step_deg", 1.0))
    ax.set_xlim(lon[0] - step / 2, lon[-1] + step / 2)
    ax.set_ylim(lat[0] - step / 2, lat[-1] + step / 2)
    ax.set_aspect("equal")
    coastline.draw(ax, lon_min=lon[0] - step / 2 - 1e-9, **coast)
    ax.set_xlabel("longitude (°)")
    ax.set_ylabel("latitude (°)")


def _field(ax, ds, values, cmap, label, vmin=None, vmax=None, fig=None):
    lon = ds["longitude"].values
    lat = ds["latitude"].values
    mesh = ax.pcolormesh(
        lon, lat, values, cmap=cmap, shading="nearest", vmin=vmin, vmax=vmax, rasterized=True
    )
    _map_axes(ax, ds)
    cb = (fig or ax.figure).colorbar(mesh, ax=ax, shrink=0.85, pad=0.02)
    cb.set_label(label)
    return mesh


def _figsize(ds, nrows=1, width=9.0):
    lon = ds["longitude"].values
    lat = ds["latitude"].values
    aspect = max(0.25, (lat[-1] - lat[0] + 1e-9) / max(lon[-1] - lon[0], 1e-9))
    return (width, min(22.0, nrows * (width * 0.8 * aspect + 0.9)))


def plot_components(ds, which: str = "model"):
    """Three panels (east, north, up) of model or normal gravity (Figs. 2 and 3).

    Parameters
    ----------
    ds : xarray.Dataset
        From :func:`fieldmap.maps.component_maps`.
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
        unit = "m/s²"
        if c != "up":
            v, unit = v * 1e5, "mGal"
        cmap = "RdBu_r" if c != "up" else "viridis"
        if c != "up":
            lim = float(np.max(np.abs(v))) or 1.0
            _field(ax, ds, v, cmap, f"g {c} ({unit})", -lim, lim)
        else:
            _field(ax, ds, v, cmap, f"g {c} ({unit})")
        ax.set_title(f"({'abc'[k]}) {c} component of {what}, h = {h:g} km", fontsize=10)
    return fig


def plot_isolines(ds, levels_mg=None, title: str | None = None, height_index=None, vmax=None):
    """Modulus of the disturbance (mg) in colour with isolines at ``levels_mg`` (Figs. 4, 7, 10)."""
    levels = sorted(
        levels_mg if levels_mg is not None else ds.attrs.get("thresholds_mg", [0.02, 0.06, 0.1])
    )
    sub = ds if height_index is None else ds.isel(height=height_index)
    v = sub["modulus_mg"].values
    fig, ax = plt.subplots(figsize=_figsize(sub), constrained_layout=True)
    top = vmax if vmax is not None else max(float(np.percentile(v, 99.9)), max(levels) * 1.2)
    _field(ax, sub, v, "YlOrRd", "|δg| (mg)   [1 mg = 9.80665e-3 m/s²]", 0.0, top)
    lon = sub["longitude"].values
    lat = sub["latitude"].values
    if v.shape[0] > 1 and v.shape[1] > 1:
        styles = ["-", "--", "-.", ":"]
        colors = ["tab:blue", "k", "tab:purple", "tab:green", "tab:cyan"]
        cs = ax.contour(
            lon,
            lat,
            v,
            levels=levels,
            colors=colors[: len(levels)],
            linestyles=[styles[i % 4] for i in range(len(levels))],
            linewidths=0.9,
            zorder=6,
        )
        ax.clabel(cs, fmt=lambda x: f"{x:g} mg", fontsize=7, inline=True)
    ax.set_title(
        title
        or f"Disturbance modulus with isolines {', '.join(f'{x:g}' for x in levels)} mg"
        f" — {describe(sub)}",
        fontsize=10,
    )
    return fig


def plot_threshold(ds, threshold_mg: float, title: str | None = None):
    """Area where the modulus exceeds ``threshold_mg`` in black (Figs. 5 and 6)."""
    v = ds["modulus_mg"].values
    key = f"area_fraction_above_{threshold_key(threshold_mg)}_mg"
    if key in ds.attrs:
        frac = float(ds.attrs[key])
    else:
        from .stats import weights_2d

        frac = float(np.sum(weights_2d(ds["latitude"].values, v.shape[1])[v > threshold_mg]))
    fig, ax = plt.subplots(figsize=_figsize(ds), constrained_layout=True)
    cmap = ListedColormap(["#f4f4f4", "black"])
    mesh = ax.pcolormesh(
        ds["longitude"].values,
        ds["latitude"].values,
        (v > threshold_mg).astype(float),
        cmap=cmap,
        vmin=0,
        vmax=1,
        shading="nearest",
        rasterized=True,
    )
    _map_axes(ax, ds, color="tab:orange", linewidth=0.6)
    cb = fig.colorbar(mesh, ax=ax, ticks=[0.25, 0.75], shrink=0.6, pad=0.02)
    cb.ax.set_yticklabels([f"≤ {threshold_mg:g} mg", f"> {threshold_mg:g} mg"])
    ax.set_title(
        title or f"|δg| > {threshold_mg:g} mg on {100 * frac:.2f}% of the area — {describe(ds)}",
        fontsize=10,
    )
    return fig


def plot_sweep(ds):
    """Area fraction above each threshold, and max / mean modulus, versus height (Fig. 7 study)."""
    h = ds["height"].values / 1e3
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    for j, t in enumerate(ds["threshold_mg"].values):
        a1.plot(h, 100 * ds["area_fraction_above"].values[:, j], "o-", label=f"> {t:g} mg")
    a1.set_xlabel("height above the ellipsoid (km)")
    a1.set_ylabel("area fraction (%)")
    a1.set_yscale("symlog", linthresh=0.1)
    a1.grid(True, alpha=0.3)
    a1.legend()
    a1.set_title("Area with |δg| above thresholds", fontsize=10)
    a2.plot(h, ds["max_mg"].values, "o-", label="maximum")
    a2.plot(h, ds["mean_mg"].values, "s-", label="area-weighted mean")
    a2.set_xlabel("height above the ellipsoid (km)")
    a2.set_ylabel("|δg| (mg)")
    a2.grid(True, alpha=0.3)
    a2.legend()
    a2.set_title("Disturbance modulus versus height", fontsize=10)
    fig.suptitle(f"Altitude sweep — {ds.attrs['model']} degree {ds.attrs['model_lmax']}")
    return fig


def plot_truncation(ds):
    """Modulus of the J2n truncation error per order (Fig. 8), with a latitude profile."""
    orders = [int(o) for o in ds["order"].values]
    n = len(orders)
    fig, axes = plt.subplots(
        n,
        2,
        figsize=(13, 3.2 * n + 0.5),
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
        _field(axes[k, 0], sub, v / scale, "magma_r", f"|δg| (10^{exp} mg)", 0.0)
        axes[k, 0].set_title(
            f"({'abc'[k]}) J{o} minus exact normal gravitation, h = {h:g} km "
            f"({ds.attrs['ellipsoid']}); max {float(v.max()):.3g} mg",
            fontsize=10,
        )
        prof = axes[k, 1]
        for c in ("north", "up"):
            prof.plot(sub[c].values[:, 0] * _to_mg(sub[c].attrs["units"]), lat, label=c)
        prof.set_xlabel("δg (mg)")
        prof.set_ylabel("latitude (°)")
        prof.grid(True, alpha=0.3)
        prof.legend(fontsize=8)
        prof.set_title("components", fontsize=9)
    return fig


def _to_mg(units: str) -> float:
    from .maps import UNITS
    from .stats import MG

    return UNITS[units] / MG

"""Figures of an altitude sweep and of the truncation study (Chen et al. 2022 Figs. 7 and 8).

Like :mod:`fieldmap.products.plots` (whose map panel they share, :mod:`.mapaxes`), every
function takes a Dataset of :mod:`fieldmap.products.maps` and returns a matplotlib Figure (Agg
backend, no display needed); :func:`fieldmap.products.io.write_png` saves it atomically.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from fieldmap.products.mapaxes import _field, _figsize, _regional  # noqa: E402


def plot_sweep(ds, reference=None):
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
        f"Altitude sweep — {ds.attrs['model']} degree {ds.attrs['model_lmax']} minus exact "
        f"{ds.attrs.get('ellipsoid', 'WGS84')} normal gravity",
        fontsize=11,
    )
    return fig


def plot_truncation(ds):
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

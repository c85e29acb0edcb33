"""Figures of the flight study: errors over time, gravity error and its prediction, ground track.

No paper values are drawn here: a user's flight is not the paper's boost-glide path.
"""

from __future__ import annotations

import numpy as np


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _median_band(x):
    return np.median(x, 0), np.percentile(x, 5, 0), np.percentile(x, 95, 0)


def errors_figure(res):
    """Horizontal and vertical error per model (median, 5–95 % band), δg and its prediction."""
    plt = _plt()
    t = res.t / 60.0
    models = np.array(res.models)
    rows = list(dict.fromkeys(res.models))
    fig, axes = plt.subplots(2, 2, figsize=(12, 8), layout="constrained")
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, row in enumerate(rows):
        sel = models == row
        c = colors[k % len(colors)]
        for ax, val in (
            (axes[0, 0], np.hypot(res.dpos[sel, :, 0], res.dpos[sel, :, 1])),
            (axes[0, 1], np.abs(res.dpos[sel, :, 2])),
        ):
            with np.errstate(invalid="ignore"):
                med, lo, hi = _median_band(np.where(np.isfinite(val), val, np.nan))
            ax.plot(t, med, color=c, label=row, lw=1.5 if row != "imu_only" else 2.5)
            if sel.sum() > 1:
                ax.fill_between(t, lo, hi, color=c, alpha=0.15, lw=0)
    for ax, what in ((axes[0, 0], "horizontal"), (axes[0, 1], "vertical")):
        ax.set_yscale("log")
        ax.set_xlabel("time (min)")
        ax.set_ylabel(f"{what} position error (m)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0, 0].legend(fontsize=8, title="navigation gravity")
    ax = axes[1, 0]
    for k, m in enumerate(res.dg):
        c = colors[(k + 1) % len(colors)]
        for j, ls in ((0, "-"), (1, "--"), (2, ":")):
            ax.plot(t, res.dg[m][:, j] * 1e5, ls, color=c, lw=1, label=m if j == 0 else None)
    ax.set_xlabel("time (min)")
    ax.set_ylabel("δg = model − truth (mGal); N solid, E dashed, D dotted")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax = axes[1, 1]
    ref = models == "imu_only"
    for k, m in enumerate(res.dg):
        c = colors[(k + 1) % len(colors)]
        sel = models == m
        d = res.dpos[sel, :, :2] - res.dpos[ref, :, :2]
        ax.plot(t, np.median(np.hypot(d[..., 0], d[..., 1]), 0), color=c, label=f"{m} simulated")
        p = res.predicted[m]
        ax.plot(t, np.hypot(p[:, 0], p[:, 1]), "--", color=c, label=f"{m} ∬δg dt²")
    ax.set_yscale("log")
    ax.set_xlabel("time (min)")
    ax.set_ylabel("horizontal error added by the model (m)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    m = res.summary["meta"]
    fig.suptitle(
        f"Flight {m['trajectory']}: IMU {m['imu']}, {m['draws']} draw(s), frame {m['frame']}, "
        f"altitude aiding {m['altitude_aiding']}, truth {m['truth_model']} {m['truth_degree']}\n"
        f"{res.summary['recommendation']}",
        fontsize=10,
    )
    return fig


def track_figure(res, disturbance=None):
    """Ground track over the gravity disturbance (mGal) of the truth model, if given."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7, 6), layout="constrained")
    if disturbance is not None:
        lat, lon, dg = disturbance
        lim = np.nanmax(np.abs(dg))
        pc = ax.pcolormesh(lon, lat, dg, cmap="RdBu_r", vmin=-lim, vmax=lim, shading="auto")
        fig.colorbar(pc, ax=ax, label="gravity disturbance δg_D at flight height (mGal)")
    ax.plot(res.track[:, 1], res.track[:, 0], "k-", lw=2)
    ax.plot(res.track[0, 1], res.track[0, 0], "go", label="start")
    ax.plot(res.track[-1, 1], res.track[-1, 0], "rs", label="end")
    ax.set_xlabel("longitude (°)")
    ax.set_ylabel("latitude (°)")
    ax.set_aspect(1.0 / np.cos(np.radians(np.mean(res.track[:, 0]))))
    ax.legend()
    ax.set_title("ground track over the truth model's disturbance")
    return fig


def disturbance_grid(res, model, n: int = 60, device=None):
    """Down component of g_truth − γ_normal (mGal) on a grid around the track at mean height."""
    from fieldmap.field.frames import C_e_to_enu, geodetic_to_ecef
    from fieldmap.nav.imu import Gravitation

    la, lo = res.track[:, 0], res.track[:, 1]
    pad = max(0.5, 0.1 * max(np.ptp(la), np.ptp(lo)))
    lat = np.linspace(max(la.min() - pad, -89.0), min(la.max() + pad, 89.0), n)
    lon = np.linspace(lo.min() - pad, lo.max() + pad, n)
    LA, LO = np.meshgrid(lat, lon, indexing="ij")
    h = np.full(LA.size, float(np.mean(res.track[:, 2])))
    r = np.stack(geodetic_to_ecef(LA.ravel(), LO.ravel(), h), -1)
    d = Gravitation("sh", model=model, device=device)(r) - Gravitation("exact", device=device)(r)
    up = np.einsum("nj,nj->n", C_e_to_enu(LA.ravel(), LO.ravel())[:, 2], d)
    return lat, lon, (-up * 1e5).reshape(LA.shape)

"""Fig. 10: the region of the trajectory.
======================================

Fig. 10 of Chen et al. (2022).

Disturbance at 20 km around the simulated trajectory (100-112E, 18-37N) with isolines at 0.025,
0.05, 0.075 and 0.10 mg, the paper's trajectory box (103-109E, 20-35N) and the ground track of
our own boost-glide path (fieldmap.nav.trajectory.BoostGlide, 800 s).

Run: ``python examples/fig10_region.py``.
"""

import os

import numpy as np
from matplotlib.patches import Rectangle

import fieldmap
from fieldmap.nav.trajectory import BoostGlide
from fieldmap.products import plots
from fieldmap.products.io import prepare_out_dir, write_png

# full size by default (the paper's); the tests run it small with these variables
step_deg = float(os.environ.get("FIELDMAP_EXAMPLE_STEP", "0.025"))  # grid step (degrees)
lmax = int(os.environ.get("FIELDMAP_EXAMPLE_LMAX", "0")) or None  # None: full degree
out = prepare_out_dir(os.environ.get("FIELDMAP_EXAMPLE_OUT", "outputs/examples"))

levels = (0.025, 0.05, 0.075, 0.10)
ds = fieldmap.disturbance_map(
    model="eigen-6s",
    lmax=lmax,
    height_km=20,
    step_deg=min(step_deg, 0.5),
    region=(100, 112, 18, 37),
    thresholds_mg=levels,
)
fig = plots.plot_isolines(ds, levels)
ax = fig.axes[0]
ax.add_patch(Rectangle((103, 20), 6, 15, fill=False, ec="0.1", lw=1.0, ls=(0, (5, 3)), zorder=7))
box = dict(fc="white", ec="none", alpha=0.8, pad=1.5)
ax.text(
    103.15,
    34.85,
    "paper's trajectory area\n103–109°E, 20–35°N",
    fontsize=7,
    zorder=9,
    bbox=box,
    va="top",
)
lat, lon, h = BoostGlide().geodetic(np.linspace(0.0, 800.0, 401))
ax.plot(lon, lat, color="#00a6d6", lw=2.0, zorder=8, label="our boost-glide ground track")
ax.plot(lon[0], lat[0], "^", color="#00a6d6", mec="k", ms=7, zorder=9)
ax.plot(lon[-1], lat[-1], "o", color="#00a6d6", mec="k", ms=6, zorder=9)
ax.text(
    lon[0] + 0.25, lat[0], "our boost-glide:\nlaunch", fontsize=7, zorder=9, va="center", bbox=box
)
ax.text(lon[-1] + 0.25, lat[-1], "end (800 s)", fontsize=7, zorder=9, va="center", bbox=box)
write_png(fig, out / "fig10_region_20km.png")
sub = ds.sel(longitude=slice(103, 109), latitude=slice(20, 35))
print(
    f"{ds.attrs['model']} degree {ds.attrs['model_lmax']}, 100-112E 18-37N at 20 km: "
    f"max {ds.attrs['max_mg']:.4f} mg; along the trajectory area (103-109E, 20-35N) "
    f"max {float(sub.modulus_mg.max()):.4f} mg (paper: between 0.05 and 0.10 mg)"
)
on_track = ds.modulus_mg.interp(
    latitude=("p", lat), longitude=("p", lon)
)  # the 20-km field under our ground track
print(
    f"  under our ground track (20-km field): max {float(on_track.max()):.4f} mg, "
    f"mean {float(on_track.mean()):.4f} mg"
)

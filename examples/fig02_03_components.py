"""Figs. 2 and 3: gravity components at 20 km.
===========================================

Figs. 2 and 3 of Chen et al. (2022).

Gravity components at 20 km from the model and from the exact normal (ellipsoidal) gravity of WGS84,
80S-80N on a 1-degree grid.

Run: ``python examples/fig02_03_components.py`` (figures in outputs/examples/).
"""

import os

from fieldmap.products import maps, plots
from fieldmap.products.io import prepare_out_dir, write_png

# full size by default (the paper's); the tests run it small with these variables
step_deg = float(os.environ.get("FIELDMAP_EXAMPLE_STEP", "1"))  # grid step (degrees)
lmax = int(os.environ.get("FIELDMAP_EXAMPLE_LMAX", "0")) or None  # None: full degree
out = prepare_out_dir(os.environ.get("FIELDMAP_EXAMPLE_OUT", "outputs/examples"))

ds = maps.component_maps(model="eigen-6s", lmax=lmax, height_km=20, step_deg=step_deg, lat_max=80)
write_png(plots.plot_components(ds, "model"), out / "fig02_model_gravity_20km.png")
write_png(plots.plot_components(ds, "normal"), out / "fig03_normal_gravity_20km.png")
up = ds["model_up"]
print(
    f"{ds.attrs['model']} degree {ds.attrs['model_lmax']}, h = 20 km: g_up from "
    f"{float(up.min()):.5f} to {float(up.max()):.5f} m/s² (stronger at the poles than at the "
    "equator, as the paper notes); model minus normal up: "
    f"{float(abs(ds.model_up - ds.normal_up).max()) * 1e5:.1f} mGal at most"
)
print(f"figures: {out}/fig02_model_gravity_20km.png, {out}/fig03_normal_gravity_20km.png")

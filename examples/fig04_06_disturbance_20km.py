"""Figs. 4, 5 and 6: the disturbance at 20 km.
===========================================

Figs. 4, 5 and 6 of Chen et al. (2022).

Disturbance modulus at 20 km with isolines at 0.02, 0.06 and 0.10 mg, and the areas above 0.06 mg
and 0.10 mg (in black), 80S-80N, 1-degree grid.

Run: ``python examples/fig04_06_disturbance_20km.py``.
"""

import os

import fieldmap
from fieldmap.products import plots
from fieldmap.products.io import prepare_out_dir, write_png
from fieldmap.products.variables import summary

# full size by default (the paper's); the tests run it small with these variables
step_deg = float(os.environ.get("FIELDMAP_EXAMPLE_STEP", "1"))  # grid step (degrees)
lmax = int(os.environ.get("FIELDMAP_EXAMPLE_LMAX", "0")) or None  # None: full degree
out = prepare_out_dir(os.environ.get("FIELDMAP_EXAMPLE_OUT", "outputs/examples"))

ds = fieldmap.disturbance_map(
    model="eigen-6s",
    lmax=lmax,
    height_km=20,
    step_deg=step_deg,
    lat_max=80,
    thresholds_mg=(0.02, 0.05, 0.06, 0.10),
)
write_png(plots.plot_isolines(ds, [0.02, 0.06, 0.10]), out / "fig04_isolines_20km.png")
write_png(plots.plot_threshold(ds, 0.06), out / "fig05_above_0.06mg_20km.png")
write_png(plots.plot_threshold(ds, 0.10), out / "fig06_above_0.10mg_20km.png")
a = ds.attrs
print(
    f"{a['model']} degree {a['model_lmax']}, h = 20 km, {ds.sizes['latitude']} x "
    f"{ds.sizes['longitude']} nodes"
)
print("  area above    ours     paper (EIGEN-6C4, degree 2190)")
frac = summary(ds)["area_fraction_above"]
for key, paper in (("0.05", 16.67), ("0.06", 9.45), ("0.1", 1.68)):
    print(f"  {key:>5} mg   {100 * frac[key]:6.2f} %   {paper:6.2f} %")
print(f"  max {a['max_mg']:.4f} mg, area-weighted mean {a['mean_mg']:.4f} mg")

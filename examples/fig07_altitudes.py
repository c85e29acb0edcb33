"""Fig. 7: the disturbance from 20 to 100 km.
==========================================

Fig. 7 of Chen et al. (2022).

Disturbance isolines at 50 and 100 km (one colour scale for all heights, and a two-panel figure
like the paper's), with the altitude sweep 20-100 km (area above thresholds and maximum versus
height; the paper's 20-km area fractions as open diamonds).

Run: ``python examples/fig07_altitudes.py``.
"""

import os

import fieldmap
from fieldmap.products import plots
from fieldmap.products.io import prepare_out_dir, write_png

# full size by default (the paper's); the tests run it small with these variables
step_deg = float(os.environ.get("FIELDMAP_EXAMPLE_STEP", "1"))  # grid step (degrees)
lmax = int(os.environ.get("FIELDMAP_EXAMPLE_LMAX", "0")) or None  # None: full degree
out = prepare_out_dir(os.environ.get("FIELDMAP_EXAMPLE_OUT", "outputs/examples"))

heights = [20, 30, 50, 70, 100]
sw = fieldmap.altitude_sweep(
    model="eigen-6s",
    lmax=lmax,
    height_km=heights,
    step_deg=step_deg,
    lat_max=80,
    thresholds_mg=(0.02, 0.05, 0.06, 0.10),
)
for k, h in enumerate(heights):
    if h in (50, 100):
        write_png(
            plots.plot_isolines(sw, [0.02, 0.06, 0.10], height_index=k),
            out / f"fig07_isolines_{h}km.png",
        )
write_png(
    plots.plot_isolines_panels(sw, [heights.index(50), heights.index(100)], [0.02, 0.06, 0.10]),
    out / "fig07_isolines_50_100km.png",
)
# Chen et al. (2022) §4.1: area fractions at 20 km (EIGEN-6C4 degree 2190)
paper = {0.05: (20, 16.67), 0.06: (20, 9.45), 0.10: (20, 1.68)}
write_png(plots.plot_sweep(sw, reference=paper), out / "fig07_sweep.png")
print(f"{sw.attrs['model']} degree {sw.attrs['model_lmax']}")
print("  h (km)  max (mg)  mean (mg)  >0.05 mg  >0.06 mg  >0.10 mg")
for k, h in enumerate(heights):
    f = 100 * sw["area_fraction_above"].values[k]
    print(
        f"  {h:6d}  {sw.max_mg.values[k]:8.4f}  {sw.mean_mg.values[k]:9.4f}  {f[1]:7.2f}%  "
        f"{f[2]:7.2f}%  {f[3]:7.2f}%"
    )
print(
    "Paper: at 50 and 100 km the areas above 0.10 mg and inside the 0.06-mg isoline shrink, "
    "but areas above 0.06 mg still exist at 100 km."
)

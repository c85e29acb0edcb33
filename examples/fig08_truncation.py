"""Fig. 8: J2, J4 and J6 truncation errors.
========================================

Fig. 8 of Chen et al. (2022).

J2 and J4 (and J6) normal gravitation minus the exact level-ellipsoid gravitation at 20 km (WGS84).

Run: ``python examples/fig08_truncation.py``.
"""

import os

import fieldmap
from fieldmap.products import plots
from fieldmap.products.io import prepare_out_dir, write_png

# full size by default (the paper's); the tests run it small with these variables
step_deg = float(os.environ.get("FIELDMAP_EXAMPLE_STEP", "1"))  # grid step (degrees)
out = prepare_out_dir(os.environ.get("FIELDMAP_EXAMPLE_OUT", "outputs/examples"))

tr = fieldmap.truncation_map(height_km=20, orders=(2, 4, 6), step_deg=step_deg, lat_max=80)
write_png(plots.plot_truncation(tr), out / "fig08_truncation_20km.png")
print("  model   max error (mg)   paper")
for o, mx, paper in zip(tr.order.values, tr.max_mg.values, ("~1e-2", "~1e-5", "-")):
    print(f"  J{int(o)}      {mx:11.3e}      {paper}")

"""Fig. 8: J2, J4 and J6 truncation errors.
========================================

Fig. 8 of Chen et al. (2022).

J2 and J4 (and J6) normal gravitation minus the exact level-ellipsoid gravitation at 20 km (WGS84).

Run: ``python examples/fig08_truncation.py``.
"""

from _settings import out_dir, step

import fieldmap
from fieldmap.products import plots
from fieldmap.products.io import write_png

tr = fieldmap.truncation_map(height_km=20, orders=(2, 4, 6), step_deg=step(), lat_max=80)
write_png(plots.plot_truncation(tr), out_dir() / "fig08_truncation_20km.png")
print("  model   max error (mg)   paper")
for o, mx, paper in zip(tr.order.values, tr.max_mg.values, ("~1e-2", "~1e-5", "-")):
    print(f"  J{int(o)}      {mx:11.3e}      {paper}")

"""Fig. 10 of Chen et al. (2022).

Disturbance at 20 km around the simulated trajectory (100-112E, 18-37N) with isolines at 0.025,
0.05, 0.075 and 0.10 mg.

Run: ``python examples/fig10_region.py``.
"""

from _settings import lmax, out_dir, step

import fieldmap
from fieldmap import plots
from fieldmap.io import write_png

levels = (0.025, 0.05, 0.075, 0.10)
ds = fieldmap.disturbance_map(
    model="eigen-6s",
    lmax=lmax(),
    height_km=20,
    step_deg=min(step(0.025), 0.5),
    region=(100, 112, 18, 37),
    thresholds_mg=levels,
)
write_png(plots.plot_isolines(ds, levels), out_dir() / "fig10_region_20km.png")
sub = ds.sel(longitude=slice(103, 109), latitude=slice(20, 35))
print(
    f"{ds.attrs['model']} degree {ds.attrs['model_lmax']}, 100-112E 18-37N at 20 km: "
    f"max {ds.attrs['max_mg']:.4f} mg; along the trajectory area (103-109E, 20-35N) "
    f"max {float(sub.modulus_mg.max()):.4f} mg (paper: between 0.05 and 0.10 mg)"
)

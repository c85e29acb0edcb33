"""Section 4.1: the statistics, ours next to the paper's.
======================================================

Statistics of §4.1-4.2 of Chen et al. (2022), ours next to the paper's.

Paper: EIGEN-6C4 at degree 2190, WGS84, 80S-80N on 1 degree. Ours: the bundled EIGEN-6S at its
full degree 240 on the same grid (or the model/degree given in FIELDMAP_EXAMPLE_LMAX).

Run: ``python examples/section41_statistics.py``.
"""

import os

import matplotlib.pyplot as plt

import fieldmap
from fieldmap.products.io import prepare_out_dir, write_png

# full size by default (the paper's); the tests run it small with these variables
step_deg = float(os.environ.get("FIELDMAP_EXAMPLE_STEP", "1"))  # grid step (degrees)
lmax = int(os.environ.get("FIELDMAP_EXAMPLE_LMAX", "0")) or None  # None: full degree
out = prepare_out_dir(os.environ.get("FIELDMAP_EXAMPLE_OUT", "outputs/examples"))

sw = fieldmap.altitude_sweep(
    model="eigen-6s",
    lmax=lmax,
    height_km=[20, 50, 100],
    step_deg=step_deg,
    lat_max=80,
    thresholds_mg=(0.05, 0.06, 0.10),
)
tr = fieldmap.truncation_map(height_km=20, orders=(2, 4), step_deg=step_deg, lat_max=80)
frac = 100 * sw["area_fraction_above"].values
rows = [
    ("area > 0.05 mg at 20 km", f"{frac[0, 0]:.2f} %", "16.67 %"),
    ("area > 0.06 mg at 20 km", f"{frac[0, 1]:.2f} %", "9.45 %"),
    ("area > 0.10 mg at 20 km", f"{frac[0, 2]:.2f} %", "1.68 %"),
    ("max |dg| at 20 km", f"{sw.max_mg.values[0]:.3f} mg", "> 0.10 mg (Fig. 4)"),
    ("max |dg| at 50 km", f"{sw.max_mg.values[1]:.3f} mg", "> 0.10 mg (Fig. 7a)"),
    ("max |dg| at 100 km", f"{sw.max_mg.values[2]:.3f} mg", "> 0.06 mg (Fig. 7b)"),
    ("area > 0.06 mg at 100 km", f"{frac[2, 1]:.2f} %", '> 0 ("still exist")'),
    ("J2 truncation max at 20 km", f"{tr.max_mg.values[0]:.2e} mg", "~1e-2 mg"),
    ("J4 truncation max at 20 km", f"{tr.max_mg.values[1]:.2e} mg", "~1e-5 mg"),
]
print(
    f"ours: {sw.attrs['model']} degree {sw.attrs['model_lmax']}, step {step_deg:g} deg; "
    "paper: EIGEN-6C4 degree 2190, 1 deg"
)
w = max(len(r[0]) for r in rows)
print(f"{'quantity':<{w}}  {'ours':>12}  paper")
for name, ours, paper in rows:
    print(f"{name:<{w}}  {ours:>12}  {paper}")

# the area fractions at 20 km, ours beside the paper's
fig, ax = plt.subplots(figsize=(6.5, 3.8), constrained_layout=True)
x = range(3)
ax.bar([k - 0.2 for k in x], frac[0], width=0.4, label=f"ours: {sw.attrs['model']} degree "
       f"{sw.attrs['model_lmax']}")  # fmt: skip
ax.bar([k + 0.2 for k in x], [16.67, 9.45, 1.68], width=0.4, label="paper: EIGEN-6C4 degree 2190")
ax.set_xticks(list(x), ["> 0.05 mg", "> 0.06 mg", "> 0.10 mg"])
ax.set(ylabel="area of the globe (±80°) (%)", title="Area above each threshold at 20 km (§4.1)")
ax.legend()
write_png(fig, out / "section41_area_fractions.png")

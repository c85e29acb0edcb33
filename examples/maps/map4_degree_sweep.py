"""A degree sweep: what the field above each degree is worth at 20 km.
====================================================================

The spherical-harmonic omission of degree d, δg_full − δg_d (the disturbance of EIGEN-6S's
degrees d+1..240), 20 km above WGS84, for degrees from 2 to 220
(:func:`fieldmap.products.degree.omission_map`): its largest value and its area-weighted RMS
over the globe, and maps of it at three degrees.

What a geodesist or INS engineer learns: which degree a gravity model needs for a given
tolerance at flight height (the curve of the maximum against degree; ``fieldmap degree
--tolerance-mgal`` finds that degree by bisection, :func:`fieldmap.products.degree.degree_needed`),
and that the omission is anything but uniform: it sits over the trenches and mountain belts.
Above degree 240 EIGEN-6S itself says nothing; the flight studies model that part by degree
variances (the "omission" term of their error budgets).

Run: ``python examples/maps/map4_degree_sweep.py`` (figures in ``outputs/examples/``).
"""

import os

import matplotlib.pyplot as plt

import fieldmap
from fieldmap.products import plots
from fieldmap.products.degree import omission_map
from fieldmap.products.io import prepare_out_dir, write_png

# full size by default; the tests run it small with these variables
step_deg = float(os.environ.get("FIELDMAP_EXAMPLE_STEP", "1"))  # grid step (degrees)
lmax = int(os.environ.get("FIELDMAP_EXAMPLE_LMAX", "0")) or None  # None: full degree
out = prepare_out_dir(os.environ.get("FIELDMAP_EXAMPLE_OUT", "outputs/examples"))

# %%
# The omission of each degree, at every node of the grid.
model = fieldmap.load_model("eigen-6s", lmax=lmax)
degrees = [d for d in (2, 4, 8, 12, 18, 24, 36, 48, 60, 90, 120, 150, 180, 220) if d < model.lmax]
om = omission_map(model, degrees=degrees, height_km=20, step_deg=step_deg)
mx, rms = om["max_mgal"].isel(height=0), om["rms_mgal"].isel(height=0)
print(f"{om.attrs['model']} degree {model.lmax}, h = 20 km: omission of degree d (mGal)")
print("     d      max      RMS")
for d in degrees:
    print(f"  {d:4d}  {float(mx.sel(degree=d)):7.2f}  {float(rms.sel(degree=d)):7.3f}")

# %%
# The curves against degree.
fig, ax = plt.subplots(figsize=(7.0, 4.2), constrained_layout=True)
ax.semilogy(degrees, mx, "o-", label="largest over the globe")
ax.semilogy(degrees, rms, "s--", label="area-weighted RMS")
ax.set(
    xlabel="degree d of the truncated model",
    ylabel="omission |δg_full − δg_d| (mGal)",
    title=f"Omission at 20 km, {om.attrs['model']} degree {model.lmax}",
)
ax.grid(which="both", alpha=0.35)
ax.legend()
write_png(fig, out / "map4_omission_by_degree.png")

# %%
# Where the omission is, at three degrees.
shown = [d for d in (18, 90, 180) if d in degrees] or degrees[-1:]
write_png(plots.plot_omission(om.sel(degree=shown)), out / "map4_omission_maps.png")

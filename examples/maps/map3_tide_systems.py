"""Tide systems: the zero-tide minus the tide-free geoid.
======================================================

The same model, EIGEN-6S, in two permanent-tide systems: tide-free (its file's) and zero-tide
(:func:`fieldmap.load_model` with ``tide_system="zero_tide"``, IERS Conventions 2010 §6.2.2).
Only C̄20 differs, by k₂₀·A₀H₀ = −4.2·10⁻⁹, so the geoids differ by a zonal degree-2 surface
N_zero − N_free = R·ΔC̄20·P̄20(sin φ), with P̄20 = √5 (3 sin²φ − 1)/2.

What a geodesist learns: mixing tide systems moves the geoid by +3 cm at the equator and −6 cm
at the poles, a 9-cm pole-to-equator tilt, larger than the centimetre asked of a modern geoid.
The first figure is the map of the difference (``geoid`` of each system from
:func:`fieldmap.quantity_map`), the second its profile in latitude against the closed form
above, which it meets to half a millimetre (the closed form takes normal gravity as GM/R² on a
sphere of radius R).

Run: ``python examples/maps/map3_tide_systems.py`` (figures in ``outputs/examples/``).
"""

import os

import matplotlib.pyplot as plt
import numpy as np

import fieldmap
from fieldmap.products import plots
from fieldmap.products.io import prepare_out_dir, write_png

# full size by default; the tests run it small with these variables
step_deg = float(os.environ.get("FIELDMAP_EXAMPLE_STEP", "1"))  # grid step (degrees)
lmax = int(os.environ.get("FIELDMAP_EXAMPLE_LMAX", "0")) or None  # None: full degree
out = prepare_out_dir(os.environ.get("FIELDMAP_EXAMPLE_OUT", "outputs/examples"))

# %%
# The model in each system, and the geoid of each (everything else the same).
models = {
    s: fieldmap.load_model("eigen-6s", lmax=lmax, tide_system=s) for s in ("tide_free", "zero_tide")
}
geoid = {
    s: fieldmap.quantity_map("geoid", model=m, step_deg=step_deg, lat_max=89)
    for s, m in models.items()
}
dC20 = float(models["zero_tide"].C[2, 0] - models["tide_free"].C[2, 0])
print(f"C20: tide-free {models['tide_free'].C[2, 0]:.12e}, zero-tide minus tide-free {dC20:.4e}")

# %%
# The difference map, drawn in the style of every geoid map.
diff = geoid["zero_tide"].copy()
diff["geoid"] = geoid["zero_tide"]["geoid"] - geoid["tide_free"]["geoid"]
diff["geoid"].attrs.update(units="m", long_name="zero-tide minus tide-free geoid height")
dN = diff["geoid"]
print(f"N_zero − N_free: {100 * float(dN.min()):+.2f} .. {100 * float(dN.max()):+.2f} cm")
write_png(plots.plot_quantity(diff, "geoid"), out / "map3_tide_difference.png")

# %%
# Its profile in latitude (zonal: the same at every longitude) against R·ΔC̄20·P̄20(sin φ).
lat = dN["latitude"].values
s = np.sin(np.radians(lat))
closed = models["tide_free"].radius * dC20 * np.sqrt(5.0) * (3.0 * s**2 - 1.0) / 2.0
fig, ax = plt.subplots(figsize=(7.0, 4.0), constrained_layout=True)
ax.plot(lat, 100 * dN.mean("longitude"), lw=2.5, label="fieldmap: quantity_map, zonal mean")
ax.plot(lat, 100 * closed, "k--", label="R·ΔC̄20·P̄20(sin φ)")
ax.set(
    xlabel="latitude (°)", ylabel="N_zero − N_free (cm)", title="Zero-tide minus tide-free geoid"
)
ax.grid(alpha=0.4)
ax.legend()
spread = float((dN.max("longitude") - dN.min("longitude")).max())
print(f"largest spread along a parallel: {spread:.1e} m (zonal)")
departure = float(np.abs(dN.mean("longitude") - closed).max())
print(f"largest departure from the closed form: {departure:.1e} m")
write_png(fig, out / "map3_tide_profile.png")

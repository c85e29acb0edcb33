"""The geoid: EIGEN-6S's geoid heights above WGS84.
================================================

The geoid height N of the bundled satellite-only model EIGEN-6S (degree 240) above the WGS84
ellipsoid, by Bruns' formula N = T/γ₀ from the disturbing potential T on the ellipsoid
(``fieldmap.quantity_map("geoid")``; the degree-0 term of T left out, as GeographicLib does).

What a geodesist learns: the geoid's long wavelengths, from about −106 m south of India to
+85 m over New Guinea, with an area-weighted RMS of about 31 m; and what a height in a flight
log "above mean sea level" is off from the ellipsoidal height an INS works in (the log readers
add N of the truth model, see :func:`fieldmap.load_flight`).

Run: ``python examples/maps/map1_geoid.py`` (figure in ``outputs/examples/``).
"""

import os

import fieldmap
from fieldmap.products import plots
from fieldmap.products.io import prepare_out_dir, write_png

# full size by default; the tests run it small with these variables
step_deg = float(os.environ.get("FIELDMAP_EXAMPLE_STEP", "1"))  # grid step (degrees)
lmax = int(os.environ.get("FIELDMAP_EXAMPLE_LMAX", "0")) or None  # None: full degree
out = prepare_out_dir(os.environ.get("FIELDMAP_EXAMPLE_OUT", "outputs/examples"))

ds = fieldmap.quantity_map("geoid", model="eigen-6s", lmax=lmax, step_deg=step_deg, lat_max=89)
N = ds["geoid"]
low = N.where(N == N.min(), drop=True)
high = N.where(N == N.max(), drop=True)
print(f"{ds.attrs['model']} degree {ds.attrs['model_lmax']}, {step_deg:g}° grid to ±89°:")
print(
    f"  lowest  {float(N.min()):7.1f} m at {float(low.latitude[0]):6.1f}°N "
    f"{float(low.longitude[0]):6.1f}°E"
)
print(
    f"  highest {float(N.max()):7.1f} m at {float(high.latitude[0]):6.1f}°N "
    f"{float(high.longitude[0]):6.1f}°E"
)
print(f"  area-weighted RMS {N.attrs['area_weighted_rms']:.1f} m")
write_png(plots.plot_quantity(ds, "geoid"), out / "map1_geoid.png")

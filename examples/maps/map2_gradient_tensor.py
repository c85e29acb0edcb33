"""The gravity gradient tensor of the disturbance at 20 km.
========================================================

The six components of the gradient tensor of the gravity disturbance, ∂²T/∂x∂y in the local
east-north-up frame (T_ee, T_en, T_eu, T_nn, T_nu, T_uu), 20 km above WGS84 from EIGEN-6S to
degree 240 (``fieldmap.quantity_map("gradient-disturbance")``), in Eötvös (1 E = 10⁻⁹ s⁻²).

What a geodesist or gradiometer engineer learns: the size of the anomalous gradients at
aircraft height (an RMS of 2–3 E and peaks of some 30 E at degree 240, against the ~3000 E of
normal gravity's vertical gradient), where the signal is (along the trenches and mountain belts:
the Andes, the Himalaya, Indonesia; T_uu the strongest), and that the tensor is traceless in
free space (Laplace's equation: the sum of the three diagonal components is zero to rounding,
printed below).

Run: ``python examples/maps/map2_gradient_tensor.py`` (figure in ``outputs/examples/``).
"""

import os

import numpy as np

import fieldmap
from fieldmap.products import plots
from fieldmap.products.io import prepare_out_dir, write_png

# full size by default; the tests run it small with these variables
step_deg = float(os.environ.get("FIELDMAP_EXAMPLE_STEP", "1"))  # grid step (degrees)
lmax = int(os.environ.get("FIELDMAP_EXAMPLE_LMAX", "0")) or None  # None: full degree
out = prepare_out_dir(os.environ.get("FIELDMAP_EXAMPLE_OUT", "outputs/examples"))

ds = fieldmap.quantity_map(
    "gradient-disturbance", model="eigen-6s", lmax=lmax, height_km=20, step_deg=step_deg
)
print(f"{ds.attrs['model']} degree {ds.attrs['model_lmax']}, h = 20 km (Eötvös):")
for name in ("T_ee", "T_en", "T_eu", "T_nn", "T_nu", "T_uu"):
    v = ds[name]
    rms = v.attrs["area_weighted_rms"]
    print(f"  {name}: {float(v.min()):7.2f} .. {float(v.max()):6.2f}, RMS {rms:.2f}")
trace = ds["T_ee"] + ds["T_nn"] + ds["T_uu"]
print(f"  largest |trace| (Laplace: 0): {float(np.abs(trace).max()):.1e}")
write_png(plots.plot_panels(ds), out / "map2_gradient_tensor.png")

"""A flight log: conditioned, then flown with three gravity models.
==================================================================

A real ADS-B log (DLH4TR, descent and landing at Zurich, 11 Nov 2019: 848 fixes at 1 Hz, with
frozen positions, velocity outliers and a 10-km height spike) read and conditioned by
:func:`fieldmap.load_flight`, then flown by a navigation-grade strapdown INS through the
EIGEN-6S field while navigating with J2, J4 and EIGEN-6S to degree 200.

What an INS engineer learns: a raw log is not a trajectory. The conditioning rejects the faults,
fits a smooth path whose noise level and vehicle class it estimates, and says so line by line;
the first figure shows every fix against the flown path. The second: the navigator's own error
(black) against what each gravity model adds to it (panel d), and the gravity error each model
makes along the track (panel c).

Run: ``python examples/flights/flight1_log.py`` from the repository's root (figures in
``outputs/examples/``); ``FIELDMAP_EXAMPLE_SMALL=1`` flies the first 5 minutes only.
"""

# sphinx_gallery_thumbnail_number = 2

import os
from pathlib import Path

import fieldmap
from fieldmap.nav.logs.report import plot_conditioning
from fieldmap.products.io import prepare_out_dir, write_png

# full size by default; the tests and the docs build run it small with these variables
small = os.environ.get("FIELDMAP_EXAMPLE_SMALL", "0") != "0"
logs = Path(os.environ.get("FIELDMAP_EXAMPLE_LOGS", "tests/data/flights"))  # the sample logs
out = prepare_out_dir(os.environ.get("FIELDMAP_EXAMPLE_OUT", "outputs/examples"))

# %%
# Read and condition the log. Its heights are geometric altitudes above mean sea level: the
# truth model's geoid makes them ellipsoidal.
truth = fieldmap.load_model("eigen-6s")
flight, conditioned = fieldmap.load_flight(
    logs / "adsb_dlh4tr_zurich_landing_20191111.csv.gz", model=truth
)
print(conditioned.format_report())
write_png(plot_conditioning(conditioned), out / "flight1_conditioning.png")

# %%
# Fly it: a navigation-grade IMU (Monte Carlo draws of its errors), three navigation gravity
# models against the truth EIGEN-6S at degree 240, and the IMU-only runs as the reference.
study = fieldmap.FlightStudy(
    flight,
    imu="navigation",
    models="j2,j4,sh200",
    truth=truth,
    draws=4 if small else 20,
    rate_hz=50.0 if small else 200.0,  # IMU rate (Hz)
    duration="5min" if small else None,  # None: the whole flight
)
res = fieldmap.run_flight(study)
models = res.summary["models"]
print(f"IMU alone: {res.summary['imu_only_horizontal_error_m']:.1f} m horizontal error at the end")
for name in study.models:
    print(f"  {name:>6} adds {models[name]['added_horizontal_error_m']:7.1f} m")
print(res.summary["recommendation"])
write_png(res.plot(), out / "flight1_errors.png")

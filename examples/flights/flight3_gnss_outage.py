"""A GNSS outage: how far the navigator coasts, and what gravity adds to it.
=========================================================================

The Porto flight (ADS-B, 77 min) flown with GNSS aiding: a loosely coupled Kalman filter takes a
position and velocity fix every second and feeds its estimates back to the strapdown, except
during outages of 5 minutes every 20 minutes (``GnssSpec(outages="every 20min:5min")``). While
GNSS is out the navigator coasts on its IMU; the gravity model's error shows in how fast its
error grows, and is wiped out again at the first fix after the outage.

What an INS engineer learns: the coasting error at the end of each outage, the IMU's own and
what each navigation gravity model (J2, EIGEN-6S to degree 200) adds to it, by Monte Carlo
over the IMU's errors and the GNSS noise. The first figure shows the errors over time with the
outages shaded; the second the error budget at the end of the worst outage.

Run: ``python examples/flights/flight3_gnss_outage.py`` from the repository's root (about
80 s on two cores); ``FIELDMAP_EXAMPLE_SMALL=1`` flies the first 30 minutes (one outage),
with 2 draws at 50 Hz.
"""

import os
from pathlib import Path

import fieldmap
from fieldmap.products.io import prepare_out_dir, write_png

# full size by default; the tests and the docs build run it small with these variables
small = os.environ.get("FIELDMAP_EXAMPLE_SMALL", "0") != "0"
logs = Path(os.environ.get("FIELDMAP_EXAMPLE_LOGS", "tests/data/flights"))  # the sample logs
out = prepare_out_dir(os.environ.get("FIELDMAP_EXAMPLE_OUT", "outputs/examples"))

# %%
# GNSS fixes at 1 Hz (2 m position and 0.05 m/s velocity noise, 1σ per axis), out for 5 min
# every 20 min; a navigation-grade IMU; two navigation gravity models.
gnss = fieldmap.GnssSpec(
    rate_hz=1.0, sigma_m=2.0, velocity_sigma_mps=0.05, outages="every 20min:5min"
)
study = fieldmap.FlightStudy(
    logs / "adsb_4b1815_porto_20220713.csv.gz",
    imu="navigation",
    models="j2,sh200",
    gnss=gnss,
    draws=2 if small else 20,
    rate_hz=50.0 if small else 200.0,  # IMU rate (Hz)
    duration="30min" if small else None,  # None: the whole flight
)
res = fieldmap.run_flight(study)
print("coasting error at the end of each outage (horizontal, m):")
print("  outage (min)     IMU alone  " + "  ".join(f"{m:>12}" for m in study.models))
for outage in res.summary["gnss"]["outages"]:
    start, end = outage["start_s"] / 60, outage["end_s"] / 60
    models = outage["models"]
    print(
        f"  {start:5.0f}–{end:<5.0f}   {outage['imu_only_horizontal_error_m']:10.2f}  "
        + "  ".join(f"{models[m]['horizontal_error_m']:12.2f}" for m in study.models)
    )
print(res.summary["recommendation"])
write_png(res.plot(), out / "flight3_errors.png")
write_png(res.plot("budget"), out / "flight3_budget.png")

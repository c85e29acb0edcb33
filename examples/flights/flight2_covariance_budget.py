"""An error budget: every error source of a 77-minute flight, by covariance analysis.
===================================================================================

A real ADS-B log (ICAO 4b1815: take-off from Porto, climb to FL360–380 and cruise north-east
over Spain and France, 77 min) flown by linear covariance analysis (``method="covariance"``):
one pass gives σ(t) of the position error for each error source alone, the navigation-grade
IMU's (biases, bias instabilities, scale factors, misalignments, random walks), the baro loop's,
and the three gravity terms of each navigation model: (a) its difference from the truth model,
(b) the omission (the field above the truth's degree 240, from Tscherning & Rapp's degree
variances) and (c) the commission (the truth's coefficient errors).

What an INS engineer learns: which sources dominate at the flight's end, and whether a gravity
model is good enough for this IMU. The bar chart sorts every source; the dashed line is 10 % of
the IMU-only error, the limit the recommendation holds each model's gravity terms to. The second
figure shows σ(t) of each source over the flight.

Run: ``python examples/flights/flight2_covariance_budget.py`` from the repository's root;
``FIELDMAP_EXAMPLE_SMALL=1`` analyses the first 10 minutes only.
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
# The study: the log's path (conditioned as ``load_flight`` does), a navigation-grade IMU and
# four navigation gravity models, by covariance analysis (no Monte Carlo draws).
study = fieldmap.FlightStudy(
    logs / "adsb_4b1815_porto_20220713.csv.gz",
    imu="navigation",
    models="j2,j4,exact,sh200",
    method="covariance",
    duration="10min" if small else None,  # None: the whole flight
)
res = fieldmap.run_flight(study)
print(f"{study.duration_s / 60:.0f} min flown, altitude aiding: {study.aiding}")
print(f"IMU alone: {res.summary['imu_only_horizontal_error_m']:.1f} m horizontal σ at the end")
for name, row in res.summary["models"].items():
    if name == "imu_only":
        continue
    terms = row["gravity"]["horizontal_terms_m"]
    print(
        f"  {name:>6}: gravity {row['gravity']['horizontal_m']:7.1f} m = "
        + ", ".join(f"{term} {v:.1f} m" for term, v in terms.items())
    )
print(res.summary["recommendation"])
write_png(res.plot("budget"), out / "flight2_budget.png")
write_png(res.plot(), out / "flight2_sigma.png")

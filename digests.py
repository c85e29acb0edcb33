"""sha256 of every data variable of small runs of each map product (before/after check).

Run: .venv/bin/python digests.py OUT.json  (uses only the public API and the CLI).
"""

import dataclasses
import hashlib
import json
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np
import xarray as xr

warnings.simplefilter("ignore", DeprecationWarning)
import fieldmap  # noqa: E402
from fieldmap.models.registry import kaula_model  # noqa: E402

OUT = {}


def digest(name, ds):
    """Record the sha256 of every data variable of ``ds``."""
    for k, v in ds.data_vars.items():
        a = np.ascontiguousarray(np.asarray(v.values))
        OUT[f"{name}/{k}"] = hashlib.sha256(a.tobytes()).hexdigest() + f" {a.dtype}{a.shape}"


def sig_model():
    """Return a small Kaula model with coefficient standard deviations."""
    m = kaula_model(36, seed=5)
    rng = np.random.default_rng(3)
    tri = np.tril(np.ones_like(m.C))
    sc = rng.uniform(1e-12, 1e-11, m.C.shape) * tri
    ss = rng.uniform(1e-12, 1e-11, m.C.shape) * tri
    ss[:, 0] = 0.0
    return dataclasses.replace(m, sigma_c=sc, sigma_s=ss)


S = dict(step_deg=5.0)
digest("map240", fieldmap.disturbance_map(height_km=20.0, **S))
digest("map36", fieldmap.disturbance_map(lmax=36, height_km=10.0, **S))
digest("map36_region", fieldmap.disturbance_map(lmax=36, region=(-20, 40, 10, 60), step_deg=2.0))
digest("map36_mg_grs80", fieldmap.disturbance_map(lmax=36, units="mg", ellipsoid="GRS80", **S))
digest("sweep36", fieldmap.altitude_sweep(lmax=36, height_km=(10.0, 20.0, 50.0), **S))
digest("trunc", fieldmap.truncation_map(height_km=20.0, **S))
digest("trunc_pos", fieldmap.truncation_map(30.0, (2, 6), 5.0))
digest("comp36", fieldmap.component_maps("eigen-6s", 36, 20.0, 5.0))
from fieldmap.products.degree import omission_map  # noqa: E402

digest("omission", omission_map(degrees=(18, 36), height_km=(20.0, 50.0), **S))
for q in ("geoid", "anomaly", "gradient", "deflection", "potential", "gradient-normal"):
    digest(f"q_{q}", fieldmap.quantity_map(q, lmax=36, height_km=20.0, **S))
digest("q_anomaly_sweep", fieldmap.quantity_map("anomaly", lmax=36, height_km=(10.0, 30.0), **S))
sm = sig_model()
for q in ("disturbance-sigma", "anomaly-sigma", "geoid-sigma"):
    digest(f"q_{q}", fieldmap.quantity_map(q, model=sm, height_km=20.0, **S))

fm = str(Path(sys.executable).parent / "fieldmap")
with tempfile.TemporaryDirectory() as tmp:
    runs = {
        "cli_map": ["map", "--step-deg", "5", "--lmax", "36", "--no-plots"],
        "cli_map_threads": [
            "map",
            "--step-deg",
            "5",
            "--lmax",
            "36",
            "--no-plots",
            "--scheduler",
            "threads",
            "--height-km",
            "30",
        ],
        "cli_sweep": [
            "sweep",
            "--step-deg",
            "5",
            "--lmax",
            "36",
            "--no-plots",
            "--height-km",
            "10,20",
        ],
        "cli_trunc": ["truncation", "--step-deg", "5", "--no-plots", "--orders", "2,4"],
        "cli_degrees": [
            "truncation",
            "--step-deg",
            "5",
            "--no-plots",
            "--degrees",
            "18,36",
            "--lmax",
            "90",
        ],
        "cli_geoid": [
            "map",
            "--step-deg",
            "5",
            "--lmax",
            "36",
            "--no-plots",
            "--quantity",
            "geoid",
        ],
        "cli_gradient": [
            "map",
            "--step-deg",
            "5",
            "--lmax",
            "36",
            "--no-plots",
            "--quantity",
            "gradient",
        ],
        "cli_table": [
            "table",
            "--region",
            "0",
            "4",
            "40",
            "44",
            "--heights-km",
            "5,10",
            "--max-error-mgal",
            "2",
            "--lmax",
            "36",
        ],
    }
    for name, argv in runs.items():
        out = Path(tmp) / name
        r = subprocess.run([fm, *argv, "--out", str(out)], capture_output=True, text=True)
        if r.returncode:
            print(name, r.stderr, file=sys.stderr)
            raise SystemExit(1)
        for f in sorted(out.rglob("*")):
            if f.suffix == ".nc":
                with xr.open_dataset(f) as ds:
                    digest(f"{name}/{f.name}", ds.load())
            elif f.suffix == ".bin":
                OUT[f"{name}/{f.name}"] = hashlib.sha256(f.read_bytes()).hexdigest()

Path(sys.argv[1]).write_text(json.dumps(OUT, indent=1, sort_keys=True))
print(len(OUT), "digests")

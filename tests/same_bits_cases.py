"""The products whose numbers must not change when code moves (tests/test_same_bits.py).

Each case is one ``fieldmap`` command line, small enough to run in seconds; its NetCDF outputs
are read back and every data variable and coordinate is kept. ``tests/data/same_bits/
make_reference.py`` recorded them on the commit named in ``reference.json`` (before the
regrouping of issue 25); the test runs the same commands on the code of today.
"""

from __future__ import annotations

import pathlib

import numpy as np

#: name -> the fieldmap command line (without the leading ``fieldmap`` and ``--out``).
CASES: dict[str, list[str]] = {
    "map": ["map", "--height-km", "20", "--step-deg", "5", "--no-plots"],
    "map_region": [
        "map",
        "--region",
        "100",
        "112",
        "18",
        "37",
        "--step-deg",
        "1",
        "--height-km",
        "30",
        "--thresholds-mg",
        "0.025",
        "0.05",
        "--no-plots",
    ],
    "sweep": ["sweep", "--height-km", "20,50,100", "--step-deg", "10", "--no-plots"],
    "truncation_orders": [
        "truncation",
        "--orders",
        "2,4,6",
        "--height-km",
        "20",
        "--step-deg",
        "10",
        "--no-plots",
    ],
    "truncation_degrees": [
        "truncation",
        "--degrees",
        "18,36",
        "--height-km",
        "20",
        "--step-deg",
        "10",
        "--tolerance-mgal",
        "20",
        "--no-plots",
    ],
    "geoid": ["map", "--quantity", "geoid", "--step-deg", "10", "--no-plots"],
    "anomaly": ["map", "--quantity", "anomaly", "--step-deg", "10", "--no-plots"],
    "gradient": [
        "map",
        "--quantity",
        "gradient",
        "--region",
        "100",
        "112",
        "18",
        "37",
        "--step-deg",
        "2",
        "--no-plots",
    ],
    "geoid_sigma": ["map", "--quantity", "geoid-sigma", "--step-deg", "10", "--no-plots"],
    "table": [
        "table",
        "--region",
        "100",
        "104",
        "30",
        "33",
        "--height-km",
        "0,10",
        "--max-error-mgal",
        "5",
        "--lmax",
        "60",
    ],
    "table1": ["navsim", "--study", "table1", "--no-timing", "--duration", "100"],
    "table3": ["navsim", "--study", "table3", "--draws", "3", "--duration", "100"],
    "flight": [
        "navsim",
        "--route",
        "47,8,500;47.5,9,3000",
        "--speed-mps",
        "200",
        "--imu",
        "tactical",
        "--draws",
        "2",
        "--models",
        "j4,sh60",
        "--lmax",
        "60",
        "--seed",
        "7",
        "--no-timing",
    ],
}


def run_case(name: str, out: pathlib.Path) -> dict[str, np.ndarray]:
    """Run one case into ``out`` and return its numbers: ``file:variable`` -> array."""
    import xarray as xr

    from fieldmap.cli import main

    out.mkdir(parents=True, exist_ok=True)
    status = main([*CASES[name], "--out", str(out)])
    if status not in (0, None):
        raise RuntimeError(f"fieldmap {' '.join(CASES[name])} exited {status}")
    arrays: dict[str, np.ndarray] = {}
    for path in sorted(out.rglob("*.nc")):
        with xr.open_dataset(path, decode_times=False) as ds:
            for key in sorted(set(ds.data_vars) | set(ds.coords)):
                values = np.asarray(ds[key].values)
                if values.dtype.kind in "fiub":
                    arrays[f"{path.relative_to(out)}:{key}"] = values
    if not arrays:
        raise RuntimeError(f"case {name}: no NetCDF numbers written")
    return arrays


def machine() -> dict[str, str]:
    """Return what the bits depend on besides the code: the CPU kind, Warp and NumPy.

    The CPU kind is its model name, family and model numbers and the vector instruction sets
    it offers: two machines that both call themselves "AMD EPYC" (one AVX2, one AVX-512) round
    the last bit of the same code differently (Warp's CPU kernels are compiled for the host,
    NumPy dispatches its loops by instruction set).
    """
    import platform

    import numpy
    import warp

    cpu = platform.processor() or platform.machine()
    fields: dict[str, str] = {}
    flags: set[str] = set()
    try:
        for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
            key, _, value = line.partition(":")
            key, value = key.strip(), value.strip()
            if key in ("model name", "cpu family", "model") and key not in fields:
                fields[key] = value
            elif key == "flags" and not flags:
                flags = set(value.split())
    except OSError:
        pass
    cpu = fields.get("model name", cpu)
    kind = f"family {fields.get('cpu family', '?')} model {fields.get('model', '?')}"
    isa = " ".join(f for f in ("sse4_2", "avx", "avx2", "fma", "avx512f") if f in flags)
    return {
        "cpu": cpu,
        "cpu_kind": kind,
        "isa": isa,
        "warp": warp.config.version,
        "numpy": numpy.__version__,
    }

"""Benchmark: grids above degree 2700 (issue 17), time and memory, against ducc0 on the sphere.

A Kaula-rule model of degree ``--degree`` (default 5540, XGM2019e's) on a global grid of
``--step`` degrees (default 0.25°: 721 x 1440 nodes, poles included) at h = 20 km:

- fieldmap's synthesis (ellipsoidal heights, the extended-range Legendre pass of
  ``kernels/grid_xrange.py``) and its public call ``fieldmap.disturbance_map``;
- fieldmap on the sphere r = a + h and ducc0's ``sht.synthesis_2d`` + ``synthesis_2d_deriv1``
  on the same sphere (the same three components; ducc0 takes one radius for all rings), with
  their agreement in mGal; ducc0 is optional (``pip install '.[bench]'``);
- peak memory of one synthesis in a fresh process (``ru_maxrss``), next to the sizes of the
  model's C and S and of the packed tables (64 bytes per (n, m)): the synthesis adds the tables
  and row blocks of bounded size (``fieldmap.grids.synthesis.BLOCK_BYTES``), nothing that grows
  with the grid.

Medians of ``--repeat`` rounds run in turn. Usage:
``python benchmarks/bench_grid_xrange.py [--degree 5540] [--step 0.25] [--repeat 3]
[--threads 2] [--device cpu]``.
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import time

import numpy as np
from bench_grid import ducc_sphere

import fieldmap
from fieldmap import _warp
from fieldmap.field.ellipsoid import WGS84, Ellipsoid
from fieldmap.grids import synthesis as G
from fieldmap.models.registry import kaula_model


def child(degree: int, step: float, device: str) -> None:
    """One synthesis in this process; print JSON with the peak RSS before and after (bytes)."""
    model = kaula_model(degree, seed=7)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    grid = G.make_grid(step, 90.0, heights_m=[20e3])
    t0 = time.perf_counter()
    out = G.synthesize(model, grid, quantity="gravitation", device=device)
    wall = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    print(json.dumps({"model": before, "peak": peak, "wall": wall, "out": out.nbytes}))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--degree", type=int, default=5540)
    ap.add_argument("--step", type=float, default=0.25)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--device", default=None)
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    dev = _warp.resolve_device(args.device)
    if args.child:
        child(args.degree, args.step, dev)
        return
    L, step, h = args.degree, args.step, 20e3
    res = subprocess.run(
        [sys.executable, __file__, "--child", "--degree", str(L), "--step", str(step)]
        + ["--device", dev],
        capture_output=True,
        text=True,
        check=True,
    )
    mem = json.loads(res.stdout.strip().splitlines()[-1])
    ntri = (L + 1) * (L + 2) // 2
    gb = 1e9
    print(f"degree {L}, global {step} deg grid, h = 20 km, {dev}, {args.threads} threads")
    print(
        f"  memory (fresh process): peak {mem['peak'] / gb:.2f} GB; after building the model "
        f"{mem['model'] / gb:.2f} GB (C and S: {2 * (L + 1) ** 2 * 8 / gb:.2f} GB); packed "
        f"tables {ntri * 64 / gb:.2f} GB; result {mem['out'] / gb:.3f} GB; first call "
        f"{mem['wall']:.1f} s (with the tables)"
    )
    t0 = time.perf_counter()
    model = kaula_model(L, seed=7)
    print(f"  Kaula model built in {time.perf_counter() - t0:.1f} s")
    grid = G.make_grid(step, 90.0, heights_m=[h])
    gsph = G.make_grid(step, 90.0, heights_m=[0.0])
    sphere = Ellipsoid("sphere", WGS84.a + h, 1e-15, WGS84.GM, 0.0)
    with _warp.threads(args.threads):
        G.synthesize(model, G.make_grid(30.0, heights_m=[h]), device=dev)  # compile, tables
        fns = {
            "fieldmap synthesis (ellipsoidal h)": lambda: G.synthesize(
                model, grid, quantity="gravitation", device=dev
            ),
            "fieldmap public disturbance_map": lambda: fieldmap.disturbance_map(
                model, height_km=h / 1e3, step_deg=step, lat_max=90.0, device=dev
            ),
            "fieldmap sphere r = a + h": lambda: G.synthesize(
                model, gsph, sphere, quantity="gravitation", device=dev
            )[0],
        }
        try:
            import ducc0  # noqa: F401

            fns["ducc0 sphere (3 components)"] = lambda: ducc_sphere(
                model, WGS84.a + h, grid.lat, grid.lon, args.threads
            )
        except ImportError:
            print("  ducc0 not installed (pip install '.[bench]'): skipped")
        times: dict[str, list[float]] = {k: [] for k in fns}
        vals = {}
        for _ in range(args.repeat):
            for k, fn in fns.items():
                t0 = time.perf_counter()
                v = fn()
                times[k].append(time.perf_counter() - t0)
                vals[k] = v
    med = {k: statistics.median(v) for k, v in times.items()}
    for k, v in med.items():
        print(f"  {k:40s} {v:8.2f} s")
    duc = "ducc0 sphere (3 components)"
    if duc in med:
        ours = vals["fieldmap sphere r = a + h"]
        diff = np.max(np.abs(ours - vals[duc])) * 1e5
        print(f"  agreement fieldmap vs ducc0 on the sphere: {diff:.1e} mGal")
        for k in ("fieldmap synthesis (ellipsoidal h)", "fieldmap public disturbance_map"):
            print(f"  ratio {k} / ducc0 sphere: {med[k] / med[duc]:.2f}")


if __name__ == "__main__":
    main()

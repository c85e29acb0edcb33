"""Dask block engine: overhead against the thread pool, per-block cost, memory of a huge map.

Default run (a few minutes on 2 cores): a 0.1 deg degree-240 map (EIGEN-6S) and a 0.5 deg
degree-2190 map (Kaula synthetic model) at 20 km, each made

- by ``disturbance_map`` (today's path: the whole map in memory, the Warp thread pool),
- by the block engine here (blocks one after the other, same thread pool),
- on ``local:1`` and ``local:2`` (LocalCluster worker processes; cluster start not timed),

(a) returned in memory to the caller, (b) written to a file as ``fieldmap map`` does (today:
the map in memory, then NetCDF-4; the engine: streamed block by block to NetCDF-4 or zarr);
medians of ``--repeat`` runs, with the ratios to today's path, and a projection of a 1'
degree-2190 global map at 5 heights on N workers from the measured per-row costs.

``--big``: a global 0.02 deg degree-240 map (9,001 x 18,000 nodes) on ``local:2`` written to a
zarr store by the workers, with the peak RSS of the client and of every worker process.

Usage::

    python benchmarks/bench_dask.py [--repeat 3] [--quick]
    python benchmarks/bench_dask.py --big [--out /tmp] [--format zarr|netcdf]
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import threading
import time

from timing import median_time


class PeakRSS:
    """Sample the RSS of this process and its descendants every ``dt`` s; keep the peaks."""

    def __init__(self, dt: float = 0.25):
        import psutil

        self.me = psutil.Process()
        self.dt = dt
        self.peak: dict[int, tuple[str, int]] = {}
        self._stop = threading.Event()
        self._t = threading.Thread(target=self._run, daemon=True)

    def _run(self):
        import psutil

        while not self._stop.is_set():
            procs = [self.me, *self.me.children(recursive=True)]
            for p in procs:
                try:
                    rss = p.memory_info().rss
                    name = " ".join(p.cmdline()[-2:])[-60:] if p is not self.me else "client"
                except (psutil.NoSuchProcess, psutil.AccessDenied):
                    continue
                old = self.peak.get(p.pid, (name, 0))
                self.peak[p.pid] = (name, max(old[1], rss))
            time.sleep(self.dt)

    def __enter__(self):
        self._t.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._t.join()
        return False


def overhead(repeat: int, quick: bool) -> None:
    """Two tables: the map returned in memory, and the map written to a file (the CLI's job)."""
    from fieldmap import cluster
    from fieldmap.models.registry import kaula_model, load_model
    from fieldmap.products import engine
    from fieldmap.products.io import write_netcdf
    from fieldmap.products.maps import disturbance_map
    from fieldmap.products.request import MapRequest

    cases = [("0.1 deg, EIGEN-6S deg 240", load_model("eigen-6s"), 0.1)]
    if not quick:
        cases.append(("0.5 deg, Kaula deg 2190", kaula_model(2190), 0.5))
    else:
        cases = [("0.5 deg, EIGEN-6S deg 240", load_model("eigen-6s"), 0.5)]
    results = {}
    for label, mod, step in cases:
        request = MapRequest.build(model=mod, heights_m=[20000.0], step_deg=step)
        grid = request.grid
        plan = engine.plan_blocks(grid, mod.lmax)
        kw = dict(model=mod, height_km=20.0, step_deg=step, progress=False)
        disturbance_map(**kw)  # warm the kernel cache
        tmp = tempfile.mkdtemp(prefix="bench-dask-")

        def today_file():  # what `fieldmap map` does: the map in memory, then the NetCDF
            write_netcdf(disturbance_map(**kw), f"{tmp}/today.nc")

        def engine_file(fmt, client=None):
            ext = "zarr" if fmt == "zarr" else "nc"
            engine.write_product(request.executing(executor=client), f"{tmp}/m.{ext}", fmt)

        row = {
            "nlat": grid.lat.size,
            "nlon": grid.lon.size,
            "nblocks": len(plan),
            "lmax": mod.lmax,
            "pool": median_time(lambda: disturbance_map(**kw), repeat),
            "blocks": median_time(lambda: disturbance_map(**kw, scheduler="threads"), repeat),
            "file:today": median_time(today_file, repeat),
            "file:here": median_time(lambda: engine_file("netcdf"), repeat),
            "zarr": median_time(lambda: engine_file("zarr"), repeat),
        }
        for n in (1, 2):
            with cluster.open_client(("local", n)) as client:
                disturbance_map(**kw, client=client)  # workers load kernels and the model
                row[f"local:{n}"] = median_time(
                    lambda: disturbance_map(**kw, client=client), repeat
                )
                row[f"file:local:{n}"] = median_time(lambda: engine_file("netcdf", client), repeat)
                if n == 2:
                    row["zarr:2"] = median_time(lambda: engine_file("zarr", client), repeat)
        shutil.rmtree(tmp, ignore_errors=True)
        results[label] = row
    load = os.getloadavg()[0]
    print(
        f"\nDask overhead, medians of {repeat} (2-core machine, 1-min load average {load:.1f}; "
        "cluster start not timed; the model already on the workers)"
    )
    print(
        "\n(a) The map returned to the client in memory (pool: today's disturbance_map; "
        "engine: the same blocks here, one after the other)"
    )
    print(
        f"{'map':28s} {'blocks':>6s} {'pool':>7s} {'engine':>7s} {'local:1':>7s} "
        f"{'local:2':>7s} {'l2/engine':>9s} {'l2/pool':>7s}"
    )
    for label, r in results.items():
        print(
            f"{label:28s} {r['nblocks']:6d} {r['pool']:7.3f} {r['blocks']:7.3f} "
            f"{r['local:1']:7.3f} {r['local:2']:7.3f} {r['local:2'] / r['blocks']:9.2f} "
            f"{r['local:2'] / r['pool']:7.2f}"
        )
    print(
        "\n(b) The map written to a file, as `fieldmap map` does (today: the map in memory "
        "then NetCDF-4; engine: streamed block by block)"
    )
    print(
        f"{'map':28s} {'today':>7s} | NetCDF: {'here':>7s} {'local:1':>7s} {'local:2':>7s} "
        f"{'l2/today':>8s} | zarr: {'here':>7s} {'local:2':>7s} {'l2/today':>8s}"
    )
    for label, r in results.items():
        t = r["file:today"]
        print(
            f"{label:28s} {t:7.3f} |         {r['file:here']:7.3f} {r['file:local:1']:7.3f} "
            f"{r['file:local:2']:7.3f} {r['file:local:2'] / t:8.2f} |       {r['zarr']:7.3f} "
            f"{r['zarr:2']:7.3f} {r['zarr:2'] / t:8.2f}"
        )
    projection(results)


def projection(results: dict) -> None:
    """1' degree-2190 global map at 5 heights on N workers, from the measured costs.

    Time per height = nlat * (c_leg * nm**2 / 2 + c_fft * nlon) on one 2-core worker: c_leg
    from the degree-2190 map (Legendre recursion, shared by mirrored rows: nm**2 / 2 per row),
    c_fft per node from the degree-240 map once its Legendre part is removed.
    """
    from fieldmap.grids.spec import make_grid
    from fieldmap.products import engine

    big = [r for r in results.values() if r["lmax"] == 2190]
    small = [r for r in results.values() if r["lmax"] == 240]
    if not big or not small:
        return
    b, s = big[0], small[0]
    nm_b, nm_s = 2191, 241
    # two unknowns, two runs (engine here, both cores): t = nlat*(a*nm^2/2 + c*nlon)
    A = [
        [b["nlat"] * nm_b**2 / 2, b["nlat"] * b["nlon"]],
        [s["nlat"] * nm_s**2 / 2, s["nlat"] * s["nlon"]],
    ]
    y = [b["blocks"], s["blocks"]]  # the sum of the per-block costs on this machine's 2 cores
    det = A[0][0] * A[1][1] - A[0][1] * A[1][0]
    a = (y[0] * A[1][1] - A[0][1] * y[1]) / det
    c = (A[0][0] * y[1] - y[0] * A[1][0]) / det
    nlat, nlon, nh = 10801, 21600, 5
    t1 = nh * nlat * (a * nm_b**2 / 2 + c * nlon)  # one worker of 2 cores
    grid = make_grid(1 / 60, 90.0, None, [2e4], whole_in_memory=False)
    plan_rows = max(b.rows.size for b in engine.plan_blocks(grid, 2190))
    # interpreter R0 = 0.21 GiB (measured by --big); model: C, S on the host, C, S and three
    # recursion tables on the device = 7 * 8 * nm^2 bytes
    mem = engine.block_bytes(plan_rows, 2190, nlon) + 56 * nm_b**2 + 0.21 * 2**30
    size = nh * nlat * nlon * 5 * 8
    print("\nProjection: 1' (10,801 x 21,600) degree-2190 global map at 5 heights")
    print(
        f"  fitted costs: Legendre {a * 1e9:.3f} ns per (row, nm^2/2) term, "
        f"longitudes {c * 1e9:.2f} ns per node (2 cores)"
    )
    print("  T = nh * nlat * (a * nm^2 / 2 + c * nlon) / N  (+ ~1 s to ship the model)")
    print(
        f"  T(N workers of 2 cores) = {t1 / 3600:.2f} h / N  (N=1: {t1 / 3600:.2f} h, "
        f"N=8: {t1 / 8 / 60:.1f} min, N=32: {t1 / 32 / 60:.1f} min)"
    )
    print(
        f"  memory per worker: {plan_rows} rows per block -> {mem / 2**20:.0f} MiB "
        "(block + model + interpreter)"
    )
    print(f"  output: {size / 1e9:.1f} GB uncompressed (5 variables, float64)")
    # zarr write rate of one process: (zarr store here - engine in memory) for the 0.1 deg map
    rate = s["nlat"] * s["nlon"] * 40 / max(1e-9, s["zarr"] - s["blocks"])
    tw = size / rate
    print(
        f"  writing at {rate / 1e6:.0f} MB/s per worker (measured here): {tw / 60:.0f} min / N; "
        f"total {(t1 + tw) / 60:.0f} min / N on N workers with their own storage bandwidth"
    )


def big(out: str, fmt: str, workers: int) -> None:
    from fieldmap import cluster
    from fieldmap.products import engine
    from fieldmap.products.request import MapRequest

    path = os.path.join(out, f"bench_big_0.02deg.{'zarr' if fmt == 'zarr' else 'nc'}")
    t0 = time.perf_counter()
    with PeakRSS() as mon, cluster.open_client(("local", workers)) as client:
        t1 = time.perf_counter()
        request = MapRequest.build(
            heights_m=[20000.0], step_deg=0.02, lat_max=90.0, client=client, progress=True
        )
        info = engine.write_product(request, path, fmt)
        t2 = time.perf_counter()
    grid = info["grid"]
    s = info["stats"][0]
    print(
        f"\n0.02 deg degree-240 global map: {grid.lat.size} x {grid.lon.size} nodes, "
        f"format {fmt}, local:{workers}"
    )
    print(f"  cluster start {t1 - t0:.1f} s, map {t2 - t1:.1f} s")
    print(f"  max {s['max_mg']:.4f} mg, mean {s['mean_mg']:.5f} mg, p99 {s['p99_mg']:.4f} mg")
    du = (
        sum(os.path.getsize(os.path.join(d, f)) for d, _, fs in os.walk(path) for f in fs)
        if os.path.isdir(path)
        else os.path.getsize(path)
    )
    print(
        f"  product {du / 1e9:.2f} GB on disk "
        f"({grid.lat.size * grid.lon.size * 5 * 8 / 1e9:.2f} GB uncompressed)"
    )
    print("  peak RSS per process:")
    for pid, (name, rss) in sorted(mon.peak.items(), key=lambda kv: -kv[1][1]):
        if rss > 50 * 2**20:
            print(f"    {rss / 2**30:6.2f} GiB  pid {pid}  {name}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--quick", action="store_true", help="small maps only (a smoke test)")
    p.add_argument("--big", action="store_true", help="the 0.02 deg memory benchmark")
    p.add_argument("--out", default=None, help="folder of the --big product (default: a temp)")
    p.add_argument("--format", default="zarr", choices=("zarr", "netcdf"))
    p.add_argument("--workers", type=int, default=2)
    args = p.parse_args()
    if args.big:
        with tempfile.TemporaryDirectory(dir=args.out) as tmp:
            big(tmp, args.format, args.workers)
    else:
        overhead(args.repeat, args.quick)


if __name__ == "__main__":
    main()

"""Scattered-point gravity at degree 240: fieldmap's Warp kernel vs GeographicLib and pyshtools.

Run: ``python benchmarks/bench_points.py [--points 20000] [--repeats 5]``

Prints µs per point (medians of ``--repeats`` runs) and ratios, all measured in this run:

* fieldmap ``sh_gravitation`` (ECEF gravitation, the kernel alone; CPU: chunks on every core)
  and ``gravity.disturbance`` (the whole public call: geodetic→ECEF, SH, exact normal field,
  ENU), warm (kernel compiled and model tables cached);
* GeographicLib's ``Gravity -G`` point mode (one process, one core): N points piped in, minus the
  time of the same command with 1 point (start-up and model loading);
* pyshtools ``SHGravCoeffs.expand(lat=, lon=, r=)`` point mode;
* the paper's 4.4 ms per point at degree 200 (Chen et al. 2022), a printed constant;
* ``fieldmap point`` for one point as a user runs it: warm (kernel cache filled) and cold (a fresh
  empty ``FIELDMAP_KERNEL_CACHE``: Warp compiles the kernels);
* one point from a degree-2190 model (a Kaula model the size of EGM2008, written once to
  ``--folder`` as ``.gfc`` and GeographicLib ``.egm``): the wall time of a fresh ``fieldmap
  point`` process (warm model and kernel caches) beside GeographicLib's ``Gravity -D`` on the
  same model and point (skipped, with the reason, where ``Gravity`` is not installed).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
from timing import median_time

from fieldmap import _warp
from fieldmap.field.frames import geodetic_to_ecef
from fieldmap.models.geographiclib import gravity_tool, write_egm
from fieldmap.models.registry import load_model

PAPER_US_PER_POINT_DEG200 = 4400.0  # Chen et al. (2022), degree 200, per point


def _points(n, seed=0):
    rng = np.random.default_rng(seed)
    lat = np.degrees(np.arcsin(rng.uniform(-1, 1, n)))
    lon = rng.uniform(-180, 180, n)
    h = rng.uniform(0, 100e3, n)
    return lat, lon, h


def bench_fieldmap(model, n, repeats, device):
    """Return µs/point of the kernel alone, the public disturbance call, the kernel on 1 core."""
    from fieldmap.field import gravity as fg
    from fieldmap.field.sh import sh_gravitation

    lat, lon, h = _points(n)
    x, y, z = geodetic_to_ecef(lat, lon, h)
    sh_gravitation(model, x, y, z, device=device)  # warm: compile/load, tables
    fg.disturbance(lat, lon, h, model=model, device=device)
    t_k = median_time(lambda: sh_gravitation(model, x, y, z, device=device), repeats)
    t_api = median_time(lambda: fg.disturbance(lat, lon, h, model=model, device=device), repeats)
    with _warp.threads(1):  # one chunk, one core
        t_1 = median_time(lambda: sh_gravitation(model, x, y, z, device=device), repeats)
    return 1e6 * t_k / n, 1e6 * t_api / n, 1e6 * t_1 / n


def bench_geographiclib(model, n, repeats):
    """Return µs/point of ``Gravity -G`` (N points minus 1 point, one process), or None."""
    exe = gravity_tool()
    if exe is None:
        return None
    folder = tempfile.mkdtemp(prefix="bench_egm_")
    name = write_egm(model, folder)
    lat, lon, h = _points(n, seed=1)
    many = "".join(f"{a!r} {b!r} {c!r}\n" for a, b, c in zip(*(v.tolist() for v in (lat, lon, h))))
    one = f"{float(lat[0])!r} {float(lon[0])!r} {float(h[0])!r}\n"
    cmd = [exe, "-n", name, "-d", folder, "-G", "-p", "12"]

    def run(text):
        subprocess.run(cmd, input=text, capture_output=True, text=True, check=True)

    t_many = median_time(lambda: run(many), repeats)
    t_one = median_time(lambda: run(one), repeats)
    return 1e6 * (t_many - t_one) / (n - 1)


def bench_pyshtools(model, n, repeats):
    """Return µs/point of pyshtools' point mode (geocentric lat, lon, r), or None."""
    try:
        import pyshtools
    except ImportError:
        return None
    L = model.lmax
    cilm = np.zeros((2, L + 1, L + 1))
    cilm[0], cilm[1] = model.C, model.S
    coeffs = pyshtools.SHGravCoeffs.from_array(
        cilm, gm=model.gm, r0=model.radius, omega=7.292115e-5
    )
    lat, lon, h = _points(n, seed=2)
    x, y, z = geodetic_to_ecef(lat, lon, h)
    r = np.sqrt(x * x + y * y + z * z)
    lat_gc = np.degrees(np.arcsin(z / r))
    coeffs.expand(lat=lat_gc[:2], lon=lon[:2], r=r[:2])  # warm-up
    t = median_time(lambda: coeffs.expand(lat=lat_gc, lon=lon, r=r), repeats)
    return 1e6 * t / n


def bench_cli(repeats):
    """Wall time of ``fieldmap point`` with one point: warm and cold kernel cache."""
    cmd = [sys.executable, "-m", "fieldmap", "point"]

    def run(env):
        out = subprocess.run(cmd, input="45 10 1000\n", capture_output=True, text=True, env=env)
        if out.returncode != 0:
            raise RuntimeError(out.stderr)

    env = dict(os.environ)
    run(env)  # make sure the user's cache is warm
    warm = median_time(lambda: run(env), repeats)
    colds = []
    for _ in range(2):
        with tempfile.TemporaryDirectory(prefix="fm_cold_cache_") as cache:
            cold_env = {**env, "FIELDMAP_KERNEL_CACHE": cache}
            t0 = time.perf_counter()
            run(cold_env)
            colds.append(time.perf_counter() - t0)
    return warm, statistics.median(colds)


POINT_2190 = "30 105 20000\n"


def _model_2190(folder: str, lmax: int = 2190) -> tuple[str, str]:
    """Paths of the Kaula model of degree ``lmax`` in ``folder``: (.gfc file, .egm name)."""
    from fieldmap.models.icgem import write_icgem
    from fieldmap.models.registry import kaula_model

    os.makedirs(folder, exist_ok=True)
    gfc, name = os.path.join(folder, f"k{lmax}.gfc"), f"k{lmax}"
    if not (os.path.exists(gfc) and os.path.exists(os.path.join(folder, name + ".egm.cof"))):
        print(f"writing a Kaula model of degree {lmax} to {folder} ...", flush=True)
        model = kaula_model(lmax, seed=7)
        write_icgem(gfc, model)
        write_egm(model, folder, name=name)
    return gfc, name


def _wall(cmd, repeats: int) -> tuple[float, float, str]:
    """Median and min wall time of ``repeats`` fresh runs of ``cmd`` on one point; its output."""
    times, out = [], ""
    for _ in range(repeats):
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, input=POINT_2190, capture_output=True, text=True, timeout=900)
        times.append(time.perf_counter() - t0)
        if proc.returncode != 0:
            raise RuntimeError(f"{cmd[0]} failed: {proc.stderr.strip()[-300:]}")
        out = proc.stdout.strip()
    return statistics.median(times), min(times), out


def bench_point_2190(repeats: int, folder: str) -> None:
    """Print the fresh-process wall time of one point at degree 2190: fieldmap beside Gravity."""
    gfc, name = _model_2190(folder)
    script = os.path.join(os.path.dirname(sys.executable), "fieldmap")  # the user's command
    cmd = [script] if os.path.exists(script) else [sys.executable, "-m", "fieldmap"]
    cmd += ["point", "--model", gfc]
    subprocess.run(cmd, input=POINT_2190, capture_output=True, text=True, check=True)  # warm caches
    med, low, out = _wall(cmd, repeats)
    print(
        f"\none point, degree 2190, fresh process (medians of {repeats}, warm caches):\n"
        f"  fieldmap point        {med:6.3f} s wall (min {low:.3f})  -> {out}"
    )
    if os.environ.get("PYTHONDONTWRITEBYTECODE"):
        print("  (PYTHONDONTWRITEBYTECODE is set: fieldmap's modules are compiled at each start)")
    exe = gravity_tool()
    if exe is None:
        print(
            "  GeographicLib Gravity  skipped: not installed (apt-get install geographiclib-tools)"
        )
        return
    g_med, g_low, g_out = _wall([exe, "-n", name, "-d", folder, "-D"], repeats)
    print(
        f"  GeographicLib Gravity {g_med:6.3f} s wall (min {g_low:.3f})  -> {g_out}\n"
        f"  fieldmap / Gravity    {med / g_med:6.1f} x"
    )


def main(argv=None) -> int:
    """Run the benchmark and print the table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=20000, help="points for fieldmap")
    ap.add_argument("--tool-points", type=int, default=2000, help="points for Gravity")
    ap.add_argument("--pyshtools-points", type=int, default=200, help="points for pyshtools")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--skip-cli", action="store_true", help="skip the fieldmap point timings")
    ap.add_argument(
        "--folder",
        default=os.path.join(tempfile.gettempdir(), "fieldmap-bench-2190"),
        help="where the degree-2190 model files are kept between runs",
    )
    args = ap.parse_args(argv)

    _warp.init()
    device = _warp.resolve_device(args.device)
    model = load_model("eigen-6s")
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(
        f"EIGEN-6S degree {model.lmax}, device {device} ({_warp.cpu_workers()} CPU threads), "
        f"medians of {args.repeats}; 1-min load average before the run: {load:.2f}"
    )
    k_us, api_us, one_us = bench_fieldmap(model, args.points, args.repeats, device)
    tool_us = bench_geographiclib(model, args.tool_points, args.repeats)
    pysh_us = bench_pyshtools(model, args.pyshtools_points, max(1, min(args.repeats, 3)))

    rows = [
        (f"fieldmap kernel sh_gravitation ({args.points} pts)", k_us),
        (f"fieldmap gravity.disturbance ({args.points} pts)", api_us),
        (f"fieldmap kernel sh_gravitation, 1 thread ({args.points} pts)", one_us),
        (f"GeographicLib Gravity -G, 1 process ({args.tool_points} pts)", tool_us),
        (f"pyshtools expand(lat, lon, r) ({args.pyshtools_points} pts)", pysh_us),
        ("Chen et al. 2022, degree 200 (printed)", PAPER_US_PER_POINT_DEG200),
    ]
    print(f"\n{'method':58s} {'us/point':>10s} {'vs kernel':>10s} {'vs API':>8s}")
    for name, us in rows:
        if us is None:
            print(f"{name:58s} {'n/a':>10s}")
            continue
        print(f"{name:58s} {us:10.2f} {us / k_us:9.1f}x {us / api_us:7.1f}x")
    if not args.skip_cli:
        warm, cold = bench_cli(args.repeats)
        print(
            f"\nfieldmap point, 1 point, wall: warm cache {warm:.2f} s (median of "
            f"{args.repeats}), cold cache {cold:.2f} s (median of 2)"
        )
        bench_point_2190(args.repeats, args.folder)
    return 0


if __name__ == "__main__":
    sys.exit(main())

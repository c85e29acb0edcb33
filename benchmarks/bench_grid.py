"""Benchmark: grid synthesis against GeographicLib's circle mode and pyshtools.

Prints medians and ratios measured in the same run:

1. Global 0.5° grid 80S-80N (321 x 720), EIGEN-6S degree 240, h = 20 km, disturbance vector:
   ours vs GeographicLib's in-process circle mode (``GravityModel::Circle`` +
   ``GravityCircle::Disturbance``, a small C++ program compiled here with g++ against Debian's
   libgeographiclib-dev), for the synthesis alone (``synthesize``) and for the public call
   ``fieldmap.disturbance_map`` (synthesis + Dataset with CF attributes + area-weighted
   statistics), the three run in turn. Targets: both <= 0.1x, and the public call <= 1.3x the
   synthesis. The two grids are also compared value by value.
2. pyshtools' Driscoll-Healy grid (lmax 240, 483 x 965), gravity vector on the WGS84 ellipsoid
   inflated by h = 20 km (``SHGravCoeffs.expand(normal_gravity=False)``) vs ours on a grid of the
   same 483 x 965 nodes at h = 20 km (gravity incl. centrifugal). Target: ours <= 0.5x.
3. Degree 2190 synthetic Kaula-rule model, 1° grid 80S-80N at 20 km: ours vs GeographicLib's
   circle mode. Target: ours <= 0.5x.

4. Peers (issue 17), EIGEN-6S degree 240 on a global 0.5° grid (361 x 720, poles included) at
   h = 20 km: fieldmap (ellipsoidal heights: synthesis, and the public ``disturbance_map``; and
   the sphere r = a + h) against ducc0's ``sht.synthesis_2d`` + ``synthesis_2d_deriv1`` on that
   sphere (ducc0 takes one radius for all rings: it covers the sphere case only) and CHarm's
   ``pyharm.shs.point_grad1`` on the same nodes as ours (geocentric latitudes, one radius per
   row: the ellipsoidal case). Times (medians of rounds run in turn), ratios from the same run,
   agreement in mGal, the Legendre pass's flop count, GFLOP/s and fraction of the cores' peak.
   Targets: fieldmap's public call <= ducc0's sphere time.
5. The same for a Kaula-rule model of degree 2190 on a global 0.1° grid (1801 x 3600).
6. The gradient tensor by synthesis (issue 28), EIGEN-6S degree 240: the public
   ``quantity_map("gradient-disturbance")`` against ``disturbance_map`` on the same global 1°
   grid with the poles (181 x 360, h = 20 km), target <= 3x (and the syntheses alone); the
   gravitation tensor on pyshtools' own Driscoll-Healy grid (lmax 240, 483 x 965, the sphere
   r = R + 20 km) against ``SHGravCoeffs.tensor`` there, target <= 1x (same node count: the
   time ratio is the per-node ratio); and a global 0.1° tensor map of a degree-2190
   Kaula-rule model (720 with ``--quick``): time and the growth of the peak resident memory
   (rows in blocks: the six output arrays, 311 MB, and the packed tables, 230 MB, dominate).

ducc0 and pyharm are optional (``pip install '.[bench]'``); a missing one is skipped with a
line saying so. ``--threads`` (default 2) applies to all codes in cases 4 and 5.

Usage: ``python benchmarks/bench_grid.py [--repeat 5] [--quick] [--device cpu] [--cases 1 2 3 4 5]
[--threads 2]`` (``--quick``: degree 720 instead of 2190 in cases 3 and 5, fewer repeats).
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import tempfile
import time

import numpy as np
from timing import median_time

import fieldmap
from fieldmap import _warp
from fieldmap.field.ellipsoid import WGS84, Ellipsoid
from fieldmap.grids import synthesis as G
from fieldmap.models.geographiclib import write_egm
from fieldmap.models.registry import kaula_model, load_model

CIRCLE_CPP = r"""
// Times a full lat-lon grid of gravity disturbances with GeographicLib's circle mode.
#include <GeographicLib/GravityCircle.hpp>
#include <GeographicLib/GravityModel.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <vector>
using namespace GeographicLib;
int main(int argc, char** argv) {
  if (argc < 10) { std::fprintf(stderr, "usage\n"); return 2; }
  GravityModel model(argv[1], argv[2]);
  double h = std::atof(argv[3]), lat0 = std::atof(argv[4]), dlat = std::atof(argv[5]);
  int nlat = std::atoi(argv[6]);
  double lon0 = std::atof(argv[7]), dlon = std::atof(argv[8]);
  int nlon = std::atoi(argv[9]);
  int repeat = argc > 10 ? std::atoi(argv[10]) : 3;
  const char* out = argc > 11 ? argv[11] : nullptr;
  std::vector<double> buf(3 * (size_t)nlat * nlon);
  for (int k = 0; k < repeat; ++k) {
    auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < nlat; ++i) {
      GravityCircle c = model.Circle(lat0 + i * dlat, h, GravityModel::DISTURBANCE);
      for (int j = 0; j < nlon; ++j) {
        double dx, dy, dz;
        c.Disturbance(lon0 + j * dlon, dx, dy, dz);
        size_t p = 3 * ((size_t)i * nlon + j);
        buf[p] = dx; buf[p + 1] = dy; buf[p + 2] = dz;
      }
    }
    auto t1 = std::chrono::steady_clock::now();
    std::printf("%.6f\n", std::chrono::duration<double>(t1 - t0).count());
  }
  if (out) {
    FILE* f = std::fopen(out, "wb");
    std::fwrite(buf.data(), 8, buf.size(), f);
    std::fclose(f);
  }
  return 0;
}
"""


def build_circle(tmp: str) -> str | None:
    """Compile the circle-mode program; None if g++ or GeographicLib is missing."""
    if not shutil.which("g++") or not os.path.exists(
        "/usr/include/GeographicLib/GravityCircle.hpp"
    ):
        return None
    src = os.path.join(tmp, "circle.cpp")
    exe = os.path.join(tmp, "circle")
    with open(src, "w") as f:
        f.write(CIRCLE_CPP)
    r = subprocess.run(
        ["g++", "-O3", "-march=native", "-o", exe, src, "-lGeographicLib"],
        capture_output=True,
        text=True,
    )
    if r.returncode != 0:
        print("g++ failed:", r.stderr.strip()[:500])
        return None
    return exe


def run_circle(exe, name, folder, grid: G.GridSpec, repeat: int, out=None):
    """Median seconds of one full grid in circle mode (one core), and the grid if ``out``."""
    lat, lon = grid.lat, grid.lon
    args = [
        exe,
        name,
        folder,
        repr(float(grid.heights[0])),
        repr(float(lat[0])),
        repr(float(lat[1] - lat[0])),
        str(lat.size),
        repr(float(lon[0])),
        repr(float(lon[1] - lon[0])),
        str(lon.size),
        str(repeat),
    ]
    if out:
        args.append(out)
    r = subprocess.run(args, capture_output=True, text=True, check=True)
    times = [float(x) for x in r.stdout.split()]
    vals = None
    if out:
        vals = np.fromfile(out, dtype="<f8").reshape(lat.size, lon.size, 3)
    return statistics.median(times), vals


def paired_medians(fn_a, fn_b, repeat: int) -> tuple[float, float]:
    """Median times of two functions run alternately (the machine's load hits both alike)."""
    ta, tb = [], []
    for _ in range(repeat):
        ta.append(median_time(fn_a, 1))
        tb.append(median_time(fn_b, 1))
    return statistics.median(ta), statistics.median(tb)


def line(label, ours, peer, target):
    ratio = ours / peer
    ok = "meets" if ratio <= target else "MISSES"
    print(
        f"  {label:<44} ours {ours:8.4f} s   peer {peer:8.4f} s   ratio {ratio:5.3f}  "
        f"({ok} target <= {target})"
    )
    return ratio


def case1(eigen, exe, tmp, dev, rep) -> None:
    """Time EIGEN-6S degree 240 on the 0.5° grid: synthesis and public call vs GeographicLib.

    The three are run in turn, ``rep`` rounds, so that a change of the machine's load during
    the run hits all of them alike; each time is the median of its rounds.
    """
    grid = G.make_grid(0.5, 80.0, heights_m=[20e3])
    G.synthesize(eigen, G.make_grid(30.0, heights_m=[20e3]), device=dev)  # compile, warm

    def synthesis():
        return G.synthesize(eigen, grid, device=dev)

    def public():
        return fieldmap.disturbance_map(eigen, height_km=20.0, step_deg=0.5, device=dev)

    public()
    name = write_egm(eigen, tmp, "eigen6s") if exe else None
    t_syn, t_pub, t_gl, vals = [], [], [], None
    for _ in range(rep):
        t_syn.append(median_time(synthesis, 1))
        t_pub.append(median_time(public, 1))
        if exe:  # the program times its grid loop alone (not its start or model loading)
            t, vals = run_circle(exe, name, tmp, grid, 1, os.path.join(tmp, "g1.bin"))
            t_gl.append(t)
    t_syn, t_pub = statistics.median(t_syn), statistics.median(t_pub)
    print("1. EIGEN-6S degree 240, 0.5 deg grid 80S-80N (321 x 720), h = 20 km, disturbance")
    line("public disturbance_map vs synthesis alone", t_pub, t_syn, 1.3)
    if not exe:
        print("  GeographicLib circle program unavailable")
        return
    t_gl = statistics.median(t_gl)
    line("synthesis vs GeographicLib circle mode", t_syn, t_gl, 0.1)
    line("public disturbance_map vs GeographicLib circle", t_pub, t_gl, 0.1)
    mine = synthesis()[0]
    print(
        f"     max |ours - GeographicLib| = {np.max(np.abs(mine - vals)) / 1e-5:.2e} mGal "
        f"(max |dg| {np.max(np.abs(vals)) / 1e-5:.1f} mGal)"
    )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--device", default="cpu")
    ap.add_argument(
        "--cases",
        type=int,
        nargs="+",
        default=[1, 2, 3, 4, 5, 6],
        choices=[1, 2, 3, 4, 5, 6],
    )
    ap.add_argument("--tensor", action="store_true", help="case 6 only (the gradient tensor)")
    ap.add_argument("--threads", type=int, default=2, help="threads of each code in cases 4, 5")
    args = ap.parse_args()
    rep = 3 if args.quick else args.repeat
    if args.tensor:
        args.cases = [6]
    # CHarm (OpenMP) reads this when it is loaded; ducc0 and fieldmap take it per call
    os.environ["OMP_NUM_THREADS"] = str(args.threads)
    _warp.init()
    dev = args.device
    print(f"device {dev}, {_warp.cpu_workers()} CPU worker threads; medians of {rep} runs")
    tmp = tempfile.mkdtemp(prefix="fieldmap-bench-")
    try:
        exe = build_circle(tmp)
        eigen = load_model("eigen-6s")
        if 1 in args.cases:
            case1(eigen, exe, tmp, dev, rep)
        if 2 in args.cases:
            case2(eigen, dev, rep)
        if 3 in args.cases:
            case3(exe, tmp, dev, rep, args.quick)
        if 4 in args.cases:
            case_peers(4, 240, 0.5, dev, rep, args.threads)
        if 5 in args.cases:
            L5 = 720 if args.quick else 2190
            case_peers(5, L5, 0.1, dev, max(3, rep // 2), args.threads)
        if 6 in args.cases:
            case_tensor(eigen, dev, rep, args.quick)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


def case2(eigen, dev, rep) -> None:
    """Time ours against pyshtools' Driscoll-Healy grid on the same nodes."""
    print("2. Driscoll-Healy grid lmax 240 (483 x 965), gravity vector at h = 20 km")
    try:
        import pyshtools as pysh
    except ImportError:
        print("  pyshtools not installed")
        return
    L = 240
    coeffs = np.stack([eigen.C, eigen.S])
    clm = pysh.SHGravCoeffs.from_array(coeffs, gm=eigen.gm, r0=eigen.radius, omega=WGS84.omega)
    h = 20e3
    f_infl = 1.0 - (WGS84.b + h) / (WGS84.a + h)

    def peer():
        return clm.expand(a=WGS84.a + h, f=f_infl, lmax=L, normal_gravity=False, extend=True)

    g_dh = peer()
    nlat, nlon = g_dh.rad.data.shape
    lat = 90.0 - 180.0 * np.arange(nlat) / (nlat - 1)
    lon = 360.0 * np.arange(nlon) / (nlon - 1)
    dh = G.GridSpec(lat[::-1].copy(), lon, np.array([h]), 180.0 / (nlat - 1))
    t_us, t_sh = paired_medians(
        lambda: G.synthesize(eigen, dh, quantity="gravity", device=dev), peer, 2 * rep
    )
    line(f"vs pyshtools SHGravCoeffs.expand {nlat}x{nlon}", t_us, t_sh, 0.5)


def case3(exe, tmp, dev, rep, quick: bool) -> None:
    """Time a degree-2190 (or 720) Kaula-rule model on a 1° grid against GeographicLib."""
    L3 = 720 if quick else 2190
    kau = kaula_model(L3, seed=7)
    grid3 = G.make_grid(1.0, 80.0, heights_m=[20e3])
    print(
        f"3. Kaula-rule model degree {L3}, 1 deg grid 80S-80N (161 x 360), h = 20 km, disturbance"
    )
    G.synthesize(kau, G.make_grid(60.0, heights_m=[20e3]), device=dev)
    t_us = median_time(lambda: G.synthesize(kau, grid3, device=dev), max(3, rep // 2))
    if not exe:
        print(f"  ours {t_us:.4f} s; GeographicLib circle program unavailable")
        return
    name = write_egm(kau, tmp, "kaula")
    t_gl, vals = run_circle(exe, name, tmp, grid3, max(3, rep // 2), os.path.join(tmp, "g3.bin"))
    line("vs GeographicLib circle mode", t_us, t_gl, 0.5)
    mine = G.synthesize(kau, grid3, device=dev)[0]
    print(f"     max |ours - GeographicLib| = {np.max(np.abs(mine - vals)) / 1e-5:.2e} mGal")


# ----------------------------------------------------------------------------- peers (issue 17)
def cpu_peak(threads: int) -> tuple[float, str]:
    """Peak double-precision GFLOP/s of ``threads`` cores from lscpu flags, and the assumption.

    FMA vector width (AVX-512: 8 doubles, AVX2+FMA: 4, else SSE2: 2 without FMA) x 2 flops per
    FMA x one vector FMA per cycle (Zen 4 and most client cores: two 256-bit pipes = one 512-bit
    FMA per cycle; Intel server cores with two 512-bit units reach twice this) x clock x cores.
    """
    flags, mhz = set(), 0.0
    try:
        with open("/proc/cpuinfo") as f:
            for ln in f:
                if ln.startswith("flags") and not flags:
                    flags = set(ln.split(":", 1)[1].split())
                elif ln.startswith("cpu MHz") and not mhz:
                    mhz = float(ln.split(":", 1)[1])
    except OSError:
        pass
    lanes, fma = (8, 2) if "avx512f" in flags else (4, 2) if "fma" in flags else (2, 1)
    ghz = mhz / 1e3 if mhz else 2.0
    peak = lanes * fma * ghz * threads
    text = (
        f"{lanes} doubles x {fma} flops x 1 vector FMA/cycle x {ghz:.2f} GHz x {threads} cores "
        f"= {peak:.1f} GFLOP/s"
    )
    return peak, text


def legendre_flops(units: int, lmax: int) -> float:
    """Flops of fieldmap's Legendre pass (kernels.grid.column8_simd), counted per term.

    Per (row unit, n, m): recursion a*tq, b*qq, two products and a difference (5 flops), then
    six fused multiply-adds into the sums (12 flops): 17. The m = 0 thread adds the zonal north
    recursion along m = 1 (5 + 2 flops per degree). A unit is a row and its mirror row.
    """
    return units * ((lmax + 1) * (lmax + 2) / 2 * 17 + lmax * 7)


def _healpy_index(L: int):
    ms = np.repeat(np.arange(L + 1), L + 1 - np.arange(L + 1))
    ls = np.concatenate([np.arange(m, L + 1) for m in range(L + 1)])
    return ls, ms


def ducc_sphere(model, r, lat_deg, lon_deg, threads: int, up_only: bool = False):
    """Gravitation (east, north, up; m/s²) on the sphere of radius r with ducc0.sht, CC rings.

    Radial component: ``synthesis_2d`` of the (n+1)-weighted coefficients; horizontal ones:
    ``synthesis_2d_deriv1`` of the potential's coefficients. Rows are returned south to north
    like fieldmap's grid; fully normalised geodesy coefficients map onto ducc0's orthonormal
    harmonics as a_n0 = sqrt(4 pi) C_n0, a_nm = (-1)^m sqrt(2 pi) (C_nm - i S_nm).
    ``up_only``: the radial component alone (one scalar transform), shape (nlat, nlon).
    """
    import ducc0

    L = model.lmax
    ls, ms = _healpy_index(L)
    q = model.radius / r
    base = (model.C[ls, ms] - 1j * model.S[ls, ms]) * np.where(
        ms == 0, np.sqrt(4 * np.pi), np.sqrt(2 * np.pi) * (-1.0) ** ms
    )
    qn = q ** ls.astype(float)
    k = model.gm / r
    alm_v = (k * qn * base)[None, :]
    alm_r = (-(k / r) * (ls + 1.0) * qn * base)[None, :]
    nt, nphi = lat_deg.size, lon_deg.size
    kw = dict(lmax=L, geometry="CC", ntheta=nt, nphi=nphi, phi0=np.radians(lon_deg[0]))
    up = ducc0.sht.synthesis_2d(alm=alm_r, spin=0, nthreads=threads, **kw)[0]
    if up_only:
        return up[::-1]
    d = ducc0.sht.experimental.synthesis_2d_deriv1(alm=alm_v, nthreads=threads, **kw)
    north = -d[0] / r
    east = d[1] / r  # ducc0's phi derivative comes divided by sin(colatitude)
    return np.stack([east, north, up], axis=-1)[::-1]


def geocentric_rows(lat_deg: np.ndarray, h: float):
    """Geocentric latitude (rad), radius and (cos, sin) of geodetic minus geocentric latitude."""
    a, e2 = WGS84.a, WGS84.e2
    phi = np.radians(lat_deg)
    nrad = a / np.sqrt(1 - e2 * np.sin(phi) ** 2)
    rho = (nrad + h) * np.cos(phi)
    z = (nrad * (1 - e2) + h) * np.sin(phi)
    psi = np.arctan2(z, rho)
    return psi, np.hypot(rho, z), np.cos(phi - psi), np.sin(phi - psi)


def charm_rows(model, lat_deg: np.ndarray, lon_deg: np.ndarray, h: float):
    """Gravitation (geodetic east, north, up; m/s²) at ellipsoidal height h with CHarm.

    ``pyharm.shs.point_grad1`` on a point grid of geocentric latitudes with one radius per row
    (the same nodes as fieldmap's grid), its LNOF (x north, y west, z up) rotated into the
    geodetic frame. CHarm sums longitudes by FFT only on grids starting at 0 deg: it runs on
    those and the columns are rotated to ours. Threads: OMP_NUM_THREADS.
    """
    import pyharm as ph

    L = model.lmax
    ls, ms = _healpy_index(L)
    shcs = ph.shc.Shc.from_arrays(
        L,
        np.ascontiguousarray(model.C[ls, ms]),
        np.ascontiguousarray(model.S[ls, ms]),
        mu=model.gm,
        r=model.radius,
    )
    psi, r, cd, sd = geocentric_rows(lat_deg, h)
    nlon = lon_deg.size
    step = 360.0 / nlon
    pnt = ph.crd.PointGrid.from_arrays(psi, np.radians(step * np.arange(nlon)), r)
    fx, fy, fz = ph.shs.point_grad1(pnt, shcs, L)
    cols = (np.arange(nlon) + int(round((lon_deg[0] % 360.0) / step))) % nlon
    fx, fy, fz = fx[:, cols], fy[:, cols], fz[:, cols]
    cd, sd = cd[:, None], sd[:, None]
    return np.stack([-fy, cd * fx - sd * fz, cd * fz + sd * fx], axis=-1)


def case_peers(case: int, L: int, step: float, dev: str, rep: int, threads: int) -> None:
    """Time ours vs ducc0 (sphere) and CHarm (ellipsoidal heights) on a global grid, h = 20 km."""
    h = 20e3
    model = load_model("eigen-6s", lmax=L) if L <= 240 else kaula_model(L, seed=7)
    grid = G.make_grid(step, 90.0, heights_m=[h])
    nlat, nlon = grid.lat.size, grid.lon.size
    name = "EIGEN-6S" if L <= 240 else "Kaula-rule model"
    print(
        f"{case}. peers: {name} degree {L}, global {step} deg grid ({nlat} x {nlon}, poles "
        f"included), h = 20 km, {threads} threads each; medians of {rep} rounds"
    )
    sphere = Ellipsoid("sphere", WGS84.a + h, 1e-15, WGS84.GM, 0.0)  # f = 1e-15: a sphere
    # CHarm's gradient with one radius per row takes minutes at degree 2190: it runs on every
    # sub-th row (a symmetric subset) and its time is scaled to the whole grid
    sub = 1 if L <= 720 else 10
    gsph = G.make_grid(step, 90.0, heights_m=[0.0])
    with _warp.threads(threads):
        G.synthesize(model, G.make_grid(30.0, heights_m=[h]), device=dev)  # compile, tables

        def ours():
            return G.synthesize(model, grid, quantity="gravitation", device=dev)[0]

        def ours_public():
            return fieldmap.disturbance_map(
                model, height_km=h / 1e3, step_deg=step, lat_max=90.0, device=dev
            )

        def ours_sphere():
            return G.synthesize(model, gsph, sphere, quantity="gravitation", device=dev)[0]

        peers = {}
        try:
            import ducc0  # noqa: F401

            peers["ducc0 sht.synthesis_2d (sphere r = a + h)"] = lambda: ducc_sphere(
                model, WGS84.a + h, grid.lat, grid.lon, threads
            )
            peers["ducc0, up component only (sphere)"] = lambda: ducc_sphere(
                model, WGS84.a + h, grid.lat, grid.lon, threads, up_only=True
            )
        except ImportError:
            print("  ducc0 not installed (pip install '.[bench]'): skipped")
        try:
            import pyharm  # noqa: F401

            peers["CHarm shs.point_grad1 (ellipsoidal h)"] = lambda: charm_rows(
                model, grid.lat[::sub], grid.lon, h
            )
        except ImportError:
            print("  pyharm (CHarm) not installed (pip install '.[bench]'): skipped")
        fns = {"ours": ours, "ours_sphere": ours_sphere, "ours_public": ours_public, **peers}
        times: dict[str, list[float]] = {k: [] for k in fns}
        leg: list[float] = []
        vals: dict[str, np.ndarray] = {}
        for rnd in range(rep):
            for k, fn in fns.items():
                if k.startswith("CHarm") and sub > 1 and rnd > 0:
                    continue  # one round of CHarm on the subset
                t0 = time.perf_counter()
                v = fn()
                times[k].append(time.perf_counter() - t0)
                if k == "ours":
                    leg.append(G.last_timings["legendre"])
                if k != "ours_public":
                    vals[k] = v
                del v
    med = {k: statistics.median(v) for k, v in times.items()}
    nsub = grid.lat[::sub].size
    for k in med:
        if k.startswith("CHarm") and sub > 1:
            med[k] *= nlat / nsub
    t_leg = statistics.median(leg)
    units = (nlat + 1) // 2
    flops = legendre_flops(units, L)
    peak, ptxt = cpu_peak(threads)
    print(f"  fieldmap synthesize, ellipsoidal h         {med['ours']:8.3f} s")
    print(f"  fieldmap synthesize, sphere r = a + h      {med['ours_sphere']:8.3f} s")
    print(f"  fieldmap disturbance_map (public call)     {med['ours_public']:8.3f} s")
    print(
        f"  Legendre pass {t_leg:.3f} s: {flops / 1e9:.1f} GFLOP ({units} row units x 17 flops "
        f"per (n, m)) = {flops / t_leg / 1e9:.1f} GFLOP/s, {flops / t_leg / 1e9 / peak:.0%} of "
        f"peak ({ptxt})"
    )
    mask = np.abs(grid.lat) < 89.95  # on a pole "north" and "east" depend on the peer's choice
    for k in peers:
        ref = vals["ours_sphere"] if "sphere" in k else vals["ours"]
        if k.startswith("CHarm") and sub > 1:
            ref, mk = ref[::sub], mask[::sub]
            print(f"  (CHarm: {nsub} of {nlat} rows, one round, time scaled by {nlat / nsub:.2f})")
        else:
            mk = mask
        if "up component only" in k:
            ref = ref[..., 2]
        diff = np.max(np.abs(vals[k][mk] - ref[mk])) / 1e-5
        print(
            f"  {k:<42} {med[k]:8.3f} s   ours/peer: synthesis {med['ours'] / med[k]:5.2f}, "
            f"sphere {med['ours_sphere'] / med[k]:5.2f}, public {med['ours_public'] / med[k]:5.2f}"
            f"   max |ours - peer| {diff:.1e} mGal"
        )


def case_tensor(eigen, dev, rep, quick: bool) -> None:
    """Time the gradient tensor by synthesis (issue 28); see the module docstring, case 6."""
    import resource

    from fieldmap.field.gradient import synthesis_model
    from fieldmap.products.maps import quantity_map

    m240 = eigen.truncated(240)
    print("6. gradient tensor by synthesis, EIGEN-6S degree 240, h = 20 km")
    kw = dict(height_km=20.0, step_deg=1.0, lat_max=90.0, device=dev)

    def tensor_map():
        return quantity_map("gradient-disturbance", model=m240, **kw)

    def vector_map():
        return fieldmap.disturbance_map(m240, **kw)

    tensor_map(), vector_map()  # compile, warm, tables
    t_ten, t_vec = paired_medians(tensor_map, vector_map, 2 * rep)
    line("1 deg tensor map vs disturbance map (181x360)", t_ten, t_vec, 3.0)
    grid = G.make_grid(1.0, 90.0, heights_m=[20e3])
    dist = synthesis_model("disturbance", m240, "exact", WGS84)
    t_st, t_sv = paired_medians(
        lambda: G.synthesize_tensor(dist, grid, WGS84, dev),
        lambda: G.synthesize(m240, grid, WGS84, "disturbance", dev),
        2 * rep,
    )
    line("  syntheses alone: tensor vs vector", t_st, t_sv, 3.0)
    try:
        import pyshtools as pysh
    except ImportError:
        print("  pyshtools not installed")
    else:
        clm = pysh.SHGravCoeffs.from_array(np.stack([m240.C, m240.S]), m240.gm, m240.radius)
        a = m240.radius + 20e3

        def peer():
            return clm.tensor(a=a, f=0.0, degree0=True)

        ten = peer()
        nlat, nlon = ten.vxx.data.shape
        lat = np.asarray(ten.vxx.lats())[::-1].copy()
        lon = np.asarray(ten.vxx.lons())
        dh = G.GridSpec(lat, lon, np.array([20e3]), 180.0 / (nlat - 1))
        G.synthesize_tensor(m240, dh, WGS84, dev)
        t_us, t_sh = paired_medians(
            lambda: G.synthesize_tensor(m240, dh, WGS84, dev), peer, max(3, rep)
        )
        line(f"vs pyshtools SHGravCoeffs.tensor {nlat}x{nlon}", t_us, t_sh, 1.0)
    L = 720 if quick else 2190
    kaula = kaula_model(L, seed=1)
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    t0 = time.perf_counter()
    ds = quantity_map(
        "gradient-disturbance", model=kaula, height_km=20.0, step_deg=0.1, lat_max=90.0,
        device=dev,
    )  # fmt: skip
    t1 = time.perf_counter() - t0
    rss1 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    shape = "x".join(str(n) for n in ds["T_uu"].shape)
    print(
        f"  0.1 deg tensor map, Kaula degree {L} ({shape}): {t1:.1f} s, peak resident memory "
        f"+{rss1 - rss0:.0f} MB (to {rss1:.0f} MB)"
    )


if __name__ == "__main__":
    raise SystemExit(main())

"""Benchmark: batched strapdown propagation vs pyins' numba integrator and GeographicLib.

Prints medians and ratios measured in the same run:

1. J4 navigation gravity, 64 trajectories (and more): our LCI two-sample kernel and our NED
   kernel vs ``pyins._numba_integrate.integrate`` run over the same 64 trajectories from a
   ``numba.prange`` loop (both cores). Rates in trajectory-steps/s, where a step is one
   navigation update (LCI: 2 IMU samples; NED and pyins: 1 sample); IMU samples/s also printed.
2. SH degree-200 navigation gravity: per-step cost of the LCI kernel vs one GeographicLib
   point-mode gravitation evaluation at degree 200 (C++ ``GravityModel::Gravitation``, compiled
   here against libGeographicLib; falls back to the ``Gravity`` command line).

Usage: ``python benchmarks/bench_strapdown.py [--samples 20000] [--repeat 5] [--quick]``.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import tempfile

import numpy as np
from timing import median_time

from fieldmap import _warp
from fieldmap.nav.frames import LaunchFrame
from fieldmap.nav.mechanize import LciStart, NavConfig, NedStart, propagate_lci, propagate_ned

FRAME = LaunchFrame(105.3, 27.1, 63.0)


def _increments(ns, dt, seed=0):
    rng = np.random.default_rng(seed)
    dth = rng.normal(0.0, 0.01, (ns, 3)) * dt
    dv = (rng.normal(0.0, 0.5, (ns, 3)) + [0.0, 0.0, -9.8]) * dt
    return dth, dv


def bench_pyins(n_traj, ns, dt, repeat):
    """Time pyins' numba NED integrator over n_traj trajectories with numba.prange (all cores)."""
    import numba
    from pyins._numba_integrate import integrate

    @numba.njit(parallel=True, cache=False)
    def run_many(dt_array, lla, vel, mat, theta, dv):
        for j in numba.prange(lla.shape[0]):
            integrate(dt_array, lla[j], vel[j], mat[j], theta, dv, 0, True)

    dth, dv = _increments(ns, dt)
    dts = np.full(ns, dt)
    lla = np.zeros((n_traj, ns + 1, 3))
    lla[:, 0] = [27.1, 105.3, 1000.0]
    vel = np.zeros((n_traj, ns + 1, 3))
    vel[:, 0] = [100.0, 50.0, 0.0]
    mat = np.zeros((n_traj, ns + 1, 3, 3))
    mat[:, 0] = np.eye(3)
    small = [np.ascontiguousarray(x[:, :11]) for x in (lla, vel, mat)]
    run_many(dts[:10].copy(), *small, dth[:10].copy(), dv[:10].copy())  # compile
    sec = median_time(lambda: run_many(dts, lla, vel, mat, dth, dv), repeat)
    return sec, numba.get_num_threads()


#: Warp device of fieldmap's kernels (``--device``).
DEVICE = "cpu"


def bench_ours(n_traj, ns, dt, repeat, gravity="j4", sh_model=None, mech="lci"):
    """Median seconds of one batched propagation (LCI or NED kernel) of n_traj trajectories."""
    dth, dv = _increments(ns, dt)
    if mech == "lci":

        def fn(n=ns):
            return propagate_lci(
                dth[:n],
                dv[:n],
                dt,
                LciStart(np.zeros((n_traj, 3)), [0.0, 7000.0, 0.0], [1.0, 0, 0, 0], FRAME),
                NavConfig(gravity, sh_model=sh_model, output_every=max(1, n // 2)),
                device=DEVICE,
            )
    else:

        def fn(n=ns):
            return propagate_ned(
                dth[:n],
                dv[:n],
                dt,
                NedStart(np.full(n_traj, 27.1), 105.3, 1000.0, [100.0, 50.0, 0.0], [1.0, 0, 0, 0]),
                NavConfig(gravity, sh_model=sh_model, output_every=n),
                device=DEVICE,
            )

    fn(4)  # compile / load
    return median_time(fn, repeat)


_CPP = r"""
#include <GeographicLib/GravityModel.hpp>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <vector>
int main(int argc, char** argv) {
  GeographicLib::GravityModel g(argv[1], argv[2], atoi(argv[3]));
  int n = atoi(argv[4]);
  std::vector<double> X(n), Y(n), Z(n);
  for (int i = 0; i < n; ++i) {  // points 20-100 km up over the study area
    double lat = (20.0 + 15.0 * i / n) * M_PI / 180;
    double lon = (103.0 + 6.0 * ((i * 7919) % n) / n) * M_PI / 180;
    double r = 6378137.0 + 20000.0 + 80000.0 * ((i * 104729) % n) / n;
    X[i] = r * cos(lat) * cos(lon); Y[i] = r * cos(lat) * sin(lon); Z[i] = r * sin(lat);
  }
  double gx, gy, gz, acc = 0;
  auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < n; ++i) { acc += g.V(X[i], Y[i], Z[i], gx, gy, gz) + gx + gy + gz; }
  auto t1 = std::chrono::steady_clock::now();
  std::printf("%.9e %.3f\n", std::chrono::duration<double>(t1 - t0).count() / n, acc);
  return 0;
}
"""


def bench_geographiclib(model, degree, n_points, repeat):
    """Seconds per point of GeographicLib at ``degree``, one core: list of (seconds, how).

    C++ ``GravityModel::V`` (potential and ECEF gravitation, compiled here) and the ``Gravity``
    command line in point mode (``-G``, includes text I/O and the geodetic conversion).
    """
    from fieldmap.models.geographiclib import gravity_tool, run_gravity_tool, write_egm

    out = []
    tmp = tempfile.mkdtemp(prefix="bench_gl_")
    try:
        name = write_egm(model, tmp, name="benchmodel")
        cxx = shutil.which("g++") or shutil.which("c++")
        if cxx:
            src, exe = os.path.join(tmp, "gl.cpp"), os.path.join(tmp, "gl")
            with open(src, "w") as f:
                f.write(_CPP)
            cmd = [cxx, "-O2", src, "-o", exe, "-lGeographicLib"]
            if subprocess.run(cmd, capture_output=True).returncode == 0:
                run = [exe, name, tmp, str(degree), str(n_points)]
                runs = [
                    float(
                        subprocess.run(
                            run, capture_output=True, text=True, check=True
                        ).stdout.split()[0]
                    )
                    for _ in range(repeat)
                ]
                out.append((float(np.median(runs)), "C++ GravityModel::V"))
        if gravity_tool() is not None:
            m = max(200, n_points // 10)
            pts = np.column_stack(
                [np.linspace(20, 35, m), np.linspace(103, 109, m), np.full(m, 30e3)]
            )
            sec = median_time(
                lambda: run_gravity_tool(pts, tmp, name, "gravity", nmax=degree), repeat
            )
            out.append((sec / m, "Gravity command line -G, point mode"))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return out


def main(argv=None):
    """Run the benchmark and print rates and ratios."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=20000, help="IMU samples per trajectory (J4)")
    ap.add_argument("--dt", type=float, default=0.005)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--sh-steps", type=int, default=100, help="LCI steps per trajectory at SH200")
    ap.add_argument("--quick", action="store_true", help="small sizes (smoke test)")
    ap.add_argument("--device", default="cpu", help="Warp device of fieldmap's kernels")
    a = ap.parse_args(argv)
    global DEVICE
    DEVICE = _warp.resolve_device(a.device)
    if a.quick:
        a.samples, a.repeat, a.sh_steps = 2000, 2, 10
    _warp.init()
    ns, dt = a.samples, a.dt
    cores = _warp.cpu_workers()
    print(
        f"CPU workers: {cores}; {ns} IMU samples per trajectory, dt = {dt} s; medians of {a.repeat}"
    )

    print("\n== J4 navigation gravity ==")
    sec_py, nthreads = bench_pyins(64, ns, dt, a.repeat)
    rate_py = 64 * ns / sec_py
    print(
        f"pyins numba integrate, 64 traj, prange on {nthreads} threads: {sec_py:.3f} s, "
        f"{rate_py:.3e} traj-steps/s (1 step = 1 sample)"
    )
    for n in (64, 512):
        sec = bench_ours(n, ns, dt, a.repeat, "j4", mech="lci")
        rate_step, rate_sample = n * ns / 2 / sec, n * ns / sec
        print(
            f"LCI two-sample kernel, {n:4d} traj: {sec:.3f} s, {rate_step:.3e} traj-steps/s "
            f"({rate_sample:.3e} traj-samples/s)  ratio vs pyins: steps {rate_step / rate_py:.2f}x,"
            f" samples {rate_sample / rate_py:.2f}x"
        )
        sec = bench_ours(n, ns, dt, a.repeat, "j4", mech="ned")
        rate = n * ns / sec
        print(
            f"NED kernel,            {n:4d} traj: {sec:.3f} s, {rate:.3e} traj-steps/s"
            f"  ratio vs pyins: {rate / rate_py:.2f}x"
        )

    print("\n== SH degree-200 navigation gravity ==")
    from fieldmap.models.registry import load_model

    model = load_model("eigen-6s", lmax=200)
    n_traj, steps = 64, a.sh_steps
    sec = bench_ours(n_traj, 2 * steps, dt, a.repeat, "sh200", sh_model=model, mech="lci")
    per_step = sec / (n_traj * steps)
    gls = bench_geographiclib(model, 200, 2000 if a.quick else 20000, a.repeat)
    print(
        f"LCI kernel with SH200, {n_traj} traj x {steps} steps: {per_step * 1e6:.2f} us per "
        f"trajectory-step on {cores} cores ({per_step * cores * 1e6:.2f} us core-time)"
    )
    if not gls:
        print("GeographicLib not available")
    for gl, how in gls:
        print(f"GeographicLib {how}, degree 200, one core: {gl * 1e6:.2f} us per point")
        print(
            f"  ratio per-step cost / GeographicLib point: {per_step / gl:.3f} (wall, {cores} "
            f"cores), {per_step * cores / gl:.3f} (per core)"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

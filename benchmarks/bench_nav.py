"""Benchmark: the flight study (synthesis + batched NED propagation) vs pyins, same run.

Prints, all measured in this run (medians of ``--repeat``):

1. IMU synthesis per sample: :func:`fieldmap.nav.imu.synthesize` on an airliner-like route
   (J4 truth, 3 Gauss nodes) vs ``pyins.sim.generate_imu`` on the same path sampled at the IMU
   rate (its own normal gravity, increments).
2. Propagation per IMU sample and trajectory: our NED kernel (J4, ``--runs`` trajectories in one
   launch) vs pyins' numba NED integrator (``pyins._numba_integrate.integrate``, the loop of
   ``pyins.strapdown``) over the same trajectories from a ``numba.prange`` loop (all cores).
3. The whole study of the issue — ``--minutes`` of flight at ``--rate`` Hz, models j2 j4 j6
   exact sh18 sh200 + the IMU-only row, ``--draws`` tactical-IMU draws, NED, truth EIGEN-6S
   degree 200 — with its wall time split into synthesis, propagation and the gravity budget;
   then the same study by covariance analysis (``--method covariance``), its time and ratio;
   and GNSS-aided with a 5-minute outage every 30 minutes by covariance analysis (with
   ``--aided-mc`` also by Monte Carlo with the feedback filter, and the ratio).

Usage: ``python benchmarks/bench_nav.py [--minutes 120 --rate 200 --draws 20]``;
``--quick`` runs 2 minutes at 100 Hz with 3 draws (a CPU check of the script).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np
from timing import median_time

ROUTE = (
    "47.0,8.0,500;47.4,9.2,11000;48.5,12.0,11000;50.0,14.0,11000;51.0,17.0,9000;"
    "52.2,21.0,11000;53.0,23.5,600"
)


def bench_synthesis(traj, rate, seconds, repeat):
    """Seconds per IMU sample: ours (J4 truth) and pyins.sim.generate_imu on the same path."""
    from pyins import sim

    from fieldmap.nav.imu import Gravitation, ImuSampling, synthesize
    from fieldmap.nav.trajectory import geodetic_state

    g = Gravitation("j4")
    n = int(seconds * rate) // 2 * 2
    sampling = ImuSampling(rate, 3)
    synthesize(traj, sampling, g, duration=2.0)  # warm-up (kernels)
    ours = median_time(lambda: synthesize(traj, sampling, g, duration=n / rate), repeat) / n
    t = np.arange(n + 1) / rate
    lat, lon, h, v, C = geodetic_state(traj, t)
    from scipy.spatial.transform import Rotation

    ypr = Rotation.from_matrix(C).as_euler("ZYX", degrees=True)
    rph = np.stack([ypr[:, 2], ypr[:, 1], ypr[:, 0] % 360.0], -1)
    lla = np.stack([lat, lon, h], -1)
    theirs = (
        median_time(lambda: sim.generate_imu(t, lla, rph, v, sensor_type="increment"), repeat) / n
    )
    return ours, theirs


def bench_propagation(runs, ns, dt, repeat):
    """Seconds per IMU sample and trajectory: our NED kernel vs pyins' numba integrator."""
    sys.path.insert(0, os.path.dirname(__file__))
    from bench_strapdown import bench_ours, bench_pyins

    ours = bench_ours(runs, ns, dt, repeat, mech="ned") / (runs * ns)
    theirs, threads = bench_pyins(runs, ns, dt, repeat)
    return ours, theirs / (runs * ns), threads


#: Wall time of today's configuration (120 min, 200 Hz, 7 rows x 20 draws) before the truth
#: and navigation gravity paths of issue 16 (full SH at every node and step), on these 2 cores.
BASELINE_S = 1770.0


def bench_study(traj, minutes, rate, draws, device, **kw):
    """Wall time of the full flight study, split into synthesis and propagation."""
    from fieldmap.nav.sensors import PRESETS
    from fieldmap.nav.study import FlightStudy, run_flight

    t0 = time.perf_counter()
    res = run_flight(
        FlightStudy(
            traj,
            imu=PRESETS["tactical"],
            imu_name="tactical",
            models=["j2", "j4", "j6", "exact", "sh18", "sh200"],
            draws=draws,
            rate_hz=rate,
            truth_lmax=200,
            duration=60.0 * minutes,
            output_dt=10.0,
            **kw,
        ),
        device=device,
        progress=True,
    )
    wall = time.perf_counter() - t0
    return res, wall


def agreement(traj, minutes, rate, draws, device) -> float:
    """Return the largest relative difference of the final horizontal errors (per model).

    RMS over the draws, the fast paths (interpolated truth, gravity rate) against the full
    evaluation (SH truth at every node, SH navigation models at every step), same draws.
    """
    fast, _ = bench_study(traj, minutes, rate, draws, device)
    full, _ = bench_study(
        traj, minutes, rate, draws, device, truth_evaluation="full", gravity_rate_hz="full"
    )
    worst = 0.0
    for m, e in full.summary["models"].items():
        a = e["final_horizontal_error_m"]["rms"]
        b = fast.summary["models"][m]["final_horizontal_error_m"]["rms"]
        worst = max(worst, abs(b - a) / max(abs(a), 1e-12))
    return worst


def main(argv=None) -> int:
    """Run the three measurements and print the ratios."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=120.0)
    ap.add_argument("--rate", type=float, default=200.0)
    ap.add_argument("--draws", type=int, default=20)
    ap.add_argument("--runs", type=int, default=140, help="trajectories of the kernel benchmark")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--device", default=None)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--skip-study", action="store_true", help="only the per-sample ratios")
    ap.add_argument(
        "--aided-mc", action="store_true", help="also the GNSS-aided study by Monte Carlo"
    )
    ap.add_argument(
        "--check-minutes",
        type=float,
        default=2.0,
        help="minutes of the study also run with the full evaluation (agreement; 0: skip)",
    )
    args = ap.parse_args(argv)
    if args.quick:
        args.minutes, args.rate, args.draws, args.runs, args.repeat = 2.0, 100.0, 3, 16, 1
        args.check_minutes = min(args.check_minutes, 1.0)

    from fieldmap.nav.trajectory import FlightTrajectory, route_flight

    traj = FlightTrajectory(route_flight(ROUTE, 180.0))
    if traj.duration < 60.0 * args.minutes:  # a longer study: the same route, flown slower
        speed = 180.0 * traj.duration / (60.0 * args.minutes) * 0.999
        traj = FlightTrajectory(route_flight(ROUTE, speed))
        print(f"route flown at {speed:.1f} m/s to last {args.minutes:g} min")
    syn_o, syn_p = bench_synthesis(traj, args.rate, 20.0 if args.quick else 60.0, args.repeat)
    print(
        f"synthesis per IMU sample: ours {syn_o * 1e6:.2f} us, pyins generate_imu "
        f"{syn_p * 1e6:.2f} us -> ours {syn_p / syn_o:.2f}x faster"
    )
    ns = int((20.0 if args.quick else 60.0) * args.rate)
    pr_o, pr_p, thr = bench_propagation(args.runs, ns, 1.0 / args.rate, args.repeat)
    print(
        f"NED propagation per IMU sample and trajectory ({args.runs} trajectories, J4): ours "
        f"{pr_o * 1e9:.1f} ns, pyins numba ({thr} threads) {pr_p * 1e9:.1f} ns -> ours "
        f"{pr_p / pr_o:.2f}x faster"
    )
    if not args.skip_study:
        res, wall = bench_study(traj, args.minutes, args.rate, args.draws, args.device)
        m = res.summary["meta"]
        print(
            f"flight study {args.minutes:g} min at {args.rate:g} Hz, 7 rows x {m['draws']} draws, "
            f"NED, truth EIGEN-6S 200: wall {wall:.1f} s = synthesis {m['synthesis_seconds']:.1f} s"
            f" + propagation {m['propagation_seconds']:.1f} s + gravity budget "
            f"{m['gravity_budget_seconds']:.1f} s (omission and commission, "
            f"{m['gravity_terms']['draws']} draws, linear error model) (+ outputs/δg)"
        )
        print(res.summary["recommendation"])
        cres, cwall = bench_study(traj, args.minutes, args.rate, args.draws, args.device,
                                  method="covariance")  # fmt: skip
        cm = cres.summary["meta"]
        print(
            f"the same study by covariance analysis (--method covariance): wall {cwall:.1f} s "
            f"(covariance {cm['covariance_seconds']:.1f} s + gravity budget "
            f"{cm['gravity_budget_seconds']:.1f} s) -> {wall / cwall:.1f}x faster than the "
            f"Monte Carlo; IMU-only horizontal sigma "
            f"{cres.summary['imu_only_horizontal_error_m']:.1f} m vs Monte Carlo RMS "
            f"{res.summary['imu_only_horizontal_error_m']:.1f} m "
            f"({m['draws']} draws)"
        )
        from fieldmap.nav.aiding import GnssSpec

        q = 60.0 * args.minutes / 4.0  # a short study: one outage over its second quarter
        outages = "every 30min:5min" if args.minutes >= 35 else f"{q:g}:{q:g}"
        gnss = GnssSpec(rate_hz=0.1, outages=outages)  # a fix per stored state (10 s)
        ares, awall = bench_study(traj, args.minutes, args.rate, args.draws, args.device,
                                  method="covariance", gnss=gnss)  # fmt: skip
        am = ares.summary["meta"]
        g = ares.summary["gnss"]
        worst = max(g["outages"], key=lambda o: o["imu_only_horizontal_error_m"], default=None)
        print(
            f"GNSS-aided (fixes at 0.1 Hz, outages {outages}) by covariance "
            f"analysis: wall {awall:.1f} s (covariance and filter {am['covariance_seconds']:.1f} s"
            f" + gravity budget {am['gravity_budget_seconds']:.1f} s); largest coasting sigma "
            + ("-" if worst is None else f"{worst['imu_only_horizontal_error_m']:.1f} m")
        )
        if args.aided_mc:
            mres, mwall = bench_study(traj, args.minutes, args.rate, args.draws, args.device,
                                      gnss=gnss)  # fmt: skip
            mg = mres.summary["gnss"]
            mw = max(mg["outages"], key=lambda o: o["imu_only_horizontal_error_m"], default=None)
            print(
                f"  the same by Monte Carlo with the feedback filter: wall {mwall:.1f} s -> "
                f"covariance {mwall / awall:.1f}x faster; largest coasting RMS "
                + ("-" if mw is None else f"{mw['imu_only_horizontal_error_m']:.1f} m")
                + f" ({mres.summary['meta']['draws']} draws), NEES mean "
                f"{mg['nees'].get('mean', float('nan')):.2f} (6 expected)"
            )
        print(
            f"  truth disturbance every {m['truth_gravity'].split('every ')[-1].split(' +')[0]}"
            f" (interpolation error <= {m['truth_interpolation_max_error_mgal']:.1e} mGal), "
            f"SH navigation gravity at {m['gravity_rate_hz']:.3g} Hz"
        )
        if args.minutes == 120.0 and args.rate == 200.0 and args.draws == 20:
            print(f"  today's configuration: {BASELINE_S / wall:.1f}x faster than {BASELINE_S:g} s")
        if args.check_minutes > 0:
            worst = agreement(traj, args.check_minutes, args.rate, args.draws, args.device)
            print(
                f"agreement with the full evaluation ({args.check_minutes:g} min, same draws): "
                f"largest relative difference of the final horizontal errors {worst:.2e}"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())

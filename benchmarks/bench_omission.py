"""Issue 26's omission check at full size: Kaula degrees 241..2190 by the point engine vs Omission.

Run: ``python benchmarks/bench_omission.py [--tracks 1000] [--points 8] [--lo 240] [--hi 2190]``

A random spherical-harmonic model of Kaula's rule (fully normalised coefficients of σ = 1e-5/n²,
degrees lo+1..hi) is evaluated with fieldmap's point engine (``sh_gravitation``, the Warp
kernel) along ``--tracks`` random great-circle tracks of ``--points`` points at 0, 10 and 30 km
(on the sphere r = R + h); ``Omission(lo, kind="kaula", max_degree=hi).realise`` along ten times
as many tracks. For each height the script prints the along-track variance and the
half-correlation length of δg down and horizontal (north and east pooled) of both, their
ratios, and the values of the direct Legendre sums of the degree variances. The track spacing is
a third of the Legendre half-correlation length at each height: many short tracks sample the
long wavelengths of the field better than a few long ones for the same number of points (the
statistics of 100 tracks of 48 points scatter by 5-7 %, those of 800 tracks of 8 points by
2-4 %). ``tests/test_omission.py`` runs
the same check at degrees 61..548 (the point engine at degree 2190 costs ~10 ms a point on two
cores: 30,000 points take five minutes, too long for the test suite).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))

from omission_tracks import (  # noqa: E402
    kaula_model,
    kaula_potential_variances,
    legendre_stats,
    sh_ned,
    track_stats,
    tracks,
)

from fieldmap.field.omission import Omission  # noqa: E402


def compare(lo: int, hi: int, ntracks: int, npts: int, heights: list[float]) -> list[dict]:
    """Statistics of the point engine, of Omission and of the Legendre sums at each height."""
    n = np.arange(lo + 1, hi + 1, dtype=np.float64)
    c = kaula_potential_variances(n)
    model = kaula_model(lo + 1, hi, seed=26)
    om = Omission(lo, kind="kaula", max_degree=hi)
    rows = []
    for k, h in enumerate(heights):
        probe = legendre_stats(c, n, h, 100.0, 4000)
        spacing = probe["length_down"] / 3.0
        maxlag = npts - 1
        truth = legendre_stats(c, n, h, spacing, maxlag)
        lat, lon = tracks(ntracks, npts, spacing, seed=100 + k)
        t0 = time.perf_counter()
        sh = track_stats(sh_ned(model, lat, lon, h), spacing, maxlag)
        t_sh = time.perf_counter() - t0
        lat, lon = tracks(10 * ntracks, npts, spacing, seed=200 + k)
        t0 = time.perf_counter()
        real = om.realise(lat.ravel(), lon.ravel(), h, 1, 300 + k)[0].reshape(lat.shape + (3,))
        t_om = time.perf_counter() - t0
        rows.append(
            {
                "h": h,
                "spacing": spacing,
                "sh": sh,
                "omission": track_stats(real, spacing, maxlag),
                "legendre": truth,
                "t_sh": t_sh,
                "t_om": t_om,
                "n_sh": lat.size // 10,
                "n_om": lat.size,
            }
        )
    return rows


def main() -> None:
    """Print the table."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--tracks", type=int, default=1000)
    p.add_argument("--points", type=int, default=8)
    p.add_argument("--lo", type=int, default=240)
    p.add_argument("--hi", type=int, default=2190)
    a = p.parse_args()
    rows = compare(a.lo, a.hi, a.tracks, a.points, [0.0, 10e3, 30e3])
    print(
        f"Kaula degrees {a.lo + 1}..{a.hi}: point engine on {a.tracks} tracks, Omission on "
        f"{10 * a.tracks} tracks, {a.points} points each"
    )
    print(
        "h km  spacing km  quantity          point engine   Omission   ratio O/P   Legendre  "
        "ratio P/Leg"
    )
    for row in rows:
        for q in ("var_down", "var_horizontal", "length_down", "length_horizontal"):
            scale, unit = (1e10, "mGal²") if q.startswith("var") else (1e-3, "km")
            sh, om, lg = (row[k][q] * scale for k in ("sh", "omission", "legendre"))
            print(
                f"{row['h'] / 1e3:4.0f}  {row['spacing'] / 1e3:9.2f}  {q:17s} {sh:10.3f}  "
                f"{om:10.3f}   {om / sh:8.3f}  {lg:10.3f}   {sh / lg:8.3f}   {unit}"
            )
        print(
            f"      time: point engine {row['t_sh']:.1f} s for {row['n_sh']} points, "
            f"Omission {row['t_om']:.1f} s for {row['n_om']} points"
        )


if __name__ == "__main__":
    main()

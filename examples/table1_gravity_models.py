"""Table 1 / Fig. 11: navigation errors from the gravity model alone.
==================================================================

Reproduce Table 1 / Fig. 11 of Chen et al. (2022): navigation errors from gravity models only.

Truth: the bundled EIGEN-6S at full degree (240; the paper used EIGEN-6C4 to degree 2190). The
boost-glide path (fieldmap.nav.trajectory.BoostGlide) is flown with exact IMU increments and
navigated with J2, J4, J6, the exact normal field (``exact``), SH degree 18 and SH degree 200, all
in one Warp launch, plus the truth model itself (the numerical floor). Run::

    python examples/table1_gravity_models.py          # 800 s at 200 Hz (about 2 min, 2 cores)
    python examples/table1_gravity_models.py --small  # 60 s at 100 Hz (used by the tests)
"""

from __future__ import annotations

import argparse
import os
import sys


def main(argv=None) -> int:
    """Run the study, print the table next to the paper's and write outputs to ``--out``."""
    ap = argparse.ArgumentParser(description="Table 1 / Fig. 11 of Chen et al. (2022).")
    ap.add_argument("--small", action="store_true", help="short run for tests")
    ap.add_argument("--out", default="outputs", help="output folder")
    ap.add_argument("--device", default=None)
    args = ap.parse_args(argv)

    from fieldmap.nav import paper as navsim
    from fieldmap.nav import study
    from fieldmap.nav.imu import ImuSampling
    from fieldmap.nav.report import format_table, write_outputs

    duration, rate = (60.0, 100.0) if args.small else (800.0, 200.0)
    sc = study.build_scenario(
        duration=duration,
        sampling=ImuSampling(rate, 2),
        device=args.device,
        progress=not args.small,
    )
    res = navsim.table1(sc, navsim.TABLE1_MODELS, timing=not args.small)
    print(format_table(res))
    os.makedirs(args.out, exist_ok=True)
    write_outputs(res, args.out)
    return 0


if __name__ == "__main__":
    # exit only on failure: the docs gallery runs this file in its own process, where a
    # SystemExit (even with status 0) would stop the build
    if status := main():
        sys.exit(status)

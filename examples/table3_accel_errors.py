"""Table 3 / Fig. 12: J4 navigation with the Table 2 accelerometers.
=================================================================

Reproduce Table 3 / Fig. 12 of Chen et al. (2022): J4 navigation with Table 2 accelerometers.

Monte Carlo over the accelerometer bias and white noise of each group (Table 2; bias read as µg,
noise as µg/√Hz — see fieldmap.nav.sensors), every draw of every group in one Warp launch; the
table gives mean, RMS and 95th percentile of the final errors over the draws. Run::

    python examples/table3_accel_errors.py          # 800 s at 200 Hz, 50 draws per group
    python examples/table3_accel_errors.py --small  # 60 s at 100 Hz, 4 draws (used by the tests)
"""

from __future__ import annotations

import argparse
import os
import sys


def main(argv=None) -> int:
    """Run the study, print the table next to the paper's and write outputs to ``--out``."""
    ap = argparse.ArgumentParser(description="Table 3 / Fig. 12 of Chen et al. (2022).")
    ap.add_argument("--small", action="store_true", help="short run for tests")
    ap.add_argument("--draws", type=int, default=None, help="draws per group")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="outputs", help="output folder")
    ap.add_argument("--device", default=None)
    args = ap.parse_args(argv)

    from fieldmap.nav import paper as navsim
    from fieldmap.nav import study
    from fieldmap.nav.imu import ImuSampling
    from fieldmap.nav.report import format_table, write_outputs

    duration, rate, draws = (60.0, 100.0, 4) if args.small else (800.0, 200.0, 50)
    sc = study.build_scenario(
        duration=duration,
        sampling=ImuSampling(rate, 2),
        device=args.device,
        progress=not args.small,
    )
    res = navsim.table3(sc, draws=args.draws or draws, seed=args.seed, nav="j4")
    print(format_table(res))
    os.makedirs(args.out, exist_ok=True)
    write_outputs(res, args.out)
    return 0


if __name__ == "__main__":
    # exit only on failure: the docs gallery runs this file in its own process, where a
    # SystemExit (even with status 0) would stop the build
    if status := main():
        sys.exit(status)

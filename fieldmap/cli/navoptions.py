"""The options of ``fieldmap navsim`` and where each applies: the paper's studies, a flight, both.

:func:`add_options` defines them on the ``navsim`` parser; :data:`FLIGHT_ONLY`,
:data:`STUDIES_ONLY` and :data:`USED_BY` say which study uses which, and
:func:`refuse_in_studies` / :func:`refuse_in_flight` refuse, in one line, an option given where
it does nothing. The checks of the values and the runs are :mod:`fieldmap.cli.nav`'s.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from fieldmap.nav.sensors import ImuErrorSpec
    from fieldmap.nav.trajectory import Trajectory

from fieldmap.cli import navflight
from fieldmap.errors import InputError
from fieldmap.limits import MAX_DRAWS

STUDIES = ("table1", "table3", "table4")

#: most Monte Carlo draws per study (each draw propagates the whole flight; 10 000 draws of the
#: 800 s path take hours on a CPU)


def add_options(p: argparse.ArgumentParser) -> None:
    """Add the options of ``navsim`` (those of the flight study included) to ``p``."""
    p.add_argument(
        "--study", default="table1", choices=STUDIES + ("all",), help="study (default table1)"
    )
    p.add_argument(
        "--trajectory",
        default=None,
        nargs="+",
        metavar="FILE",
        help="your flight log(s), as they come: CSV (fieldmap's time_s, lat_deg, lon_deg, "
        "height_m [, roll_deg, pitch_deg, heading_deg]; ADS-B exports; any columns with "
        "--columns), GPX, NMEA 0183, IGC, or NetCDF; conditioned (outliers, gaps, smoothing) "
        "unless --no-smooth; several files: one study each, one summary",
    )
    p.add_argument(
        "--route",
        default=None,
        help='a study flight along geodesics: "lat,lon,h;lat,lon,h;..." (with --speed-mps)',
    )
    p.add_argument("--speed-mps", type=float, default=None, help="ground speed of --route (m/s)")
    p.add_argument(
        "--imu",
        default=None,
        help="flight study IMU: ideal consumer industrial tactical navigation strategic "
        "table2-groupN table4, or a TOML file (default ideal)",
    )
    p.add_argument(
        "--frame",
        default=None,
        choices=("ned", "lci"),
        help="mechanization of the flight study (default ned; the paper's studies use lci)",
    )
    p.add_argument(
        "--altitude-aiding",
        default="auto",
        choices=("auto", "none", "baro"),
        help="flight study vertical channel: third-order baro loop or free (auto: baro for "
        "flights over 15 min)",
    )
    p.add_argument(
        "--fraction",
        type=float,
        default=0.1,
        help="recommended model: the simplest whose gravity contribution (model difference, "
        "omission and commission through the linear error model) stays below this fraction of "
        "the IMU-only horizontal error (default 0.1)",
    )
    p.add_argument(
        "--method",
        default=None,
        choices=("monte-carlo", "covariance"),
        help="flight study: monte-carlo (default: strapdown runs of every model and IMU draw) "
        "or covariance (linear covariance analysis: sigma(t) of every error source in one "
        "pass, an error budget; --draws does not apply)",
    )
    p.add_argument(
        "--omission-model",
        default=None,
        metavar="tscherning-rapp|kaula|fitted|none",
        help="flight study: degree-variance model of the field above the truth's degree (the "
        "omission term of the gravity budget; default tscherning-rapp, Tscherning & Rapp 1974 "
        "model 4; fitted: a power law fitted to the truth's own degrees; none: left out)",
    )
    p.add_argument(
        "--commission",
        default=None,
        choices=("auto", "on", "off"),
        help="flight study: realise the truth model's coefficient errors (the commission term "
        "of the gravity budget; auto, the default: when the model carries coefficient sigma)",
    )
    p.add_argument(
        "--block-s",
        type=float,
        default=600.0,
        help="flight study time block in s (memory bound; default 600)",
    )
    p.add_argument(
        "--models",
        nargs="+",
        default=["j2,j4,j6,exact,sh18,sh200"],
        help="navigation gravity models, comma or space separated: j2 j4 j6 exact sh shN "
        "table:FILE auto (exact: the closed-form level-ellipsoid field, the --normal exact of "
        "the maps; 'normal' is its deprecated name; table:FILE: exact plus a compensation table "
        "of 'fieldmap table', flight studies only; auto: j2 j4 j6 exact and SH degrees "
        "12..the model's, the recommendation then names the simplest that meets --fraction) "
        "(table1 and flight; table4 adds the full IMU errors to the SH ones and to --nav)",
    )
    p.add_argument(
        "--nav",
        default="j4",
        help="normal model of table3 and of the table4 IMU-only reference (default j4)",
    )
    p.add_argument(
        "--draws",
        type=int,
        default=None,
        help=f"Monte Carlo draws, 1..{MAX_DRAWS} (default: table3 50, table4 20)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the error draws, >= 0 (default 0)")
    p.add_argument(
        "--bias-mode",
        default="gauss",
        choices=("gauss", "sign", "fixed"),
        help="how constant errors are drawn per run (see fieldmap.nav.sensors)",
    )
    p.add_argument("--rate", type=float, default=200.0, help="IMU sample rate in Hz (default 200)")
    p.add_argument(
        "--gauss",
        type=int,
        default=3,
        help="Gauss-Legendre nodes per IMU sample, 1..16 (default 3, as the API)",
    )
    p.add_argument(
        "--duration",
        type=float,
        default=None,
        help="flight time in s (paper's studies: at most 800, default 800; flight: default all)",
    )
    p.add_argument(
        "--model",
        default="eigen-6s",
        help="truth gravity model: bundled name or ICGEM .gfc[.gz] file (default eigen-6s)",
    )
    p.add_argument("--truth", dest="model", default=argparse.SUPPRESS, help=argparse.SUPPRESS)
    p.add_argument(
        "--lmax",
        type=int,
        default=None,
        help="truth degree (default: the model's full degree)",
    )
    p.add_argument(
        "--truth-degree", dest="lmax", type=int, default=argparse.SUPPRESS, help=argparse.SUPPRESS
    )
    p.add_argument(
        "--output-dt",
        type=float,
        default=None,
        help="interval of the error curves in s (paper's studies: default 1, dividing the run; "
        "flight: default about 3600 points)",
    )
    p.add_argument(
        "--no-timing",
        action="store_true",
        help="table1: skip the gravity CPU-time measurement; flight: leave the wall-clock "
        "seconds out of navsim_flight.json/.nc (null), so that two runs' files compare equal",
    )
    p.add_argument("--device", default=None, help="Warp device (cpu, cuda:0; default auto)")
    p.add_argument(
        "--scheduler",
        default=None,
        metavar="threads|local:N|ADDRESS",
        help="run the navigation launches (draws x models) on Dask: local:N starts a "
        "LocalCluster of N worker processes, ADDRESS connects to a running scheduler; the paper's "
        "studies and a flight study (--trajectory, --route: the IMU increments are synthesised "
        "here, block by block, the runs propagated on the workers) give the results of a local "
        "run, bit for bit (default: here)",
    )
    p.add_argument(
        "--out",
        default="outputs",
        help="output folder, created with its parents if missing (default outputs/)",
    )
    navflight.add_options(p)


#: options of the flight study (``--trajectory``/``--route``) only: dest -> option
FLIGHT_ONLY = {
    "imu": "--imu",
    "frame": "--frame",
    "altitude_aiding": "--altitude-aiding",
    "fraction": "--fraction",
    "block_s": "--block-s",
    "omission_model": "--omission-model",
    "commission": "--commission",
    "method": "--method",
    **navflight.LOG_ONLY,
    **navflight.FLIGHT_EXTRA,
}
#: options of the paper's studies only (the flight study's IMU-only reference is J4 and its
#: constant errors are Gaussian): dest -> option
STUDIES_ONLY = {"study": "--study", "nav": "--nav", "bias_mode": "--bias-mode"}
#: options that only some of the paper's studies use: dest -> (option, the studies using it)
USED_BY = {
    "models": ("--models", ("table1", "table4")),
    "no_timing": ("--no-timing", ("table1",)),
    "draws": ("--draws", ("table3", "table4")),
    "seed": ("--seed", ("table3", "table4")),
    "bias_mode": ("--bias-mode", ("table3", "table4")),
    "nav": ("--nav", ("table3", "table4")),
}
_FLIGHT = "flight studies (--trajectory/--route)"


def refuse_in_studies(
    args: argparse.Namespace, studies: Sequence[str], models: Sequence[str], nav: str
) -> None:
    """Refuse, in one line, an option given that the paper's chosen studies do not use."""
    from fieldmap.cli import given

    where = f"--study {args.study}"
    for dest, option in FLIGHT_ONLY.items():
        if given(args, dest):
            raise InputError(f"{option} applies to {_FLIGHT}, not to {where}")
    if given(args, "speed_mps"):
        raise InputError(f"--speed-mps applies to --route, not to {where}")
    for dest, (option, users) in USED_BY.items():
        if given(args, dest) and not set(users) & set(studies):
            raise InputError(
                f"{option} applies to --study {' or '.join(users)} (or all), not to {where}"
            )
    if tuple(studies) == ("table4",) and given(args, "models"):
        unused = [m for m in models if not (m.startswith("sh") or m == nav)]
        if unused:
            raise InputError(
                f"--models {' '.join(unused)}: --study table4 runs the SH models of --models and "
                f"--nav ({nav}) only"
            )


def refuse_in_flight(
    args: argparse.Namespace, imu: tuple[str, ImuErrorSpec], traj: Trajectory
) -> None:
    """Refuse, in one line, an option given that the flight study does not use."""
    from fieldmap.cli import given
    from fieldmap.nav.study import BARO_AFTER_S

    for dest, option in STUDIES_ONLY.items():
        if given(args, dest):
            studies = "the paper's studies" + ("" if option == "--study" else " (--study)")
            raise InputError(f"{option} applies to {studies}, not to {_FLIGHT}")
    if given(args, "speed_mps") and args.route is None:
        raise InputError("--speed-mps applies to --route, not to --trajectory")
    if args.method == "covariance":
        for dest, option in (("draws", "--draws"), ("scheduler", "--scheduler")):
            if given(args, dest):
                raise InputError(
                    f"{option} applies to --method monte-carlo: the covariance analysis draws "
                    "nothing and runs here"
                )
    label, spec = imu
    if spec.is_ideal:
        if given(args, "draws"):
            raise InputError(
                f"--draws needs IMU errors to draw: --imu {label} flies one run per model"
            )
        frame = args.frame or "ned"
        duration = traj.duration if args.duration is None else args.duration
        baro = args.altitude_aiding == "baro" or (
            args.altitude_aiding == "auto" and frame == "ned" and duration > BARO_AFTER_S
        )
        if given(args, "seed") and not baro:
            raise InputError(
                f"--seed: nothing is drawn with --imu {label} and no baro altitude aiding"
            )

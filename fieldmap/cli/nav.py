"""``fieldmap navsim``: navigation errors by gravity model and IMU, on the paper's or your flight.

``--study table1|table3|table4|all`` runs the studies of Chen et al. (2022) §5 on the boost-glide
path; ``--trajectory FILE`` or ``--route "lat,lon,h;..." --speed-mps V`` runs the flight study of
:mod:`fieldmap.nav.flightsim` (``navsim_flight.*``: see
:func:`fieldmap.nav.report.write_flight_outputs`).

Each option applies to the paper's studies, to the flight study or to both (the table of
:data:`FLIGHT_ONLY`, :data:`STUDIES_ONLY` and :data:`USED_BY`): one given where it does nothing
(``--block-s`` with ``--study table1``, ``--bias-mode`` with ``--route``, ``--draws`` with an
ideal IMU) is refused in one line, exit status 2, before any work.

Writes, for each study, ``navsim_<study>.csv`` / ``.json`` (table rows, truth model, floor, paper
values), ``navsim_<study>.nc`` (error curves over time, xarray/NetCDF, CF attributes) and
``navsim_<study>.png`` (Figs. 11-13 like curves) under ``--out`` (default ``outputs/``). Every
input is checked before any work starts; every file is written to a temporary name and renamed,
so a failed run leaves nothing half-written.
"""

from __future__ import annotations

import argparse
import sys
import warnings

import numpy as np

from fieldmap.cli import navflight
from fieldmap.errors import InputError

# the tables and files live in the library; re-exported for scripts written against 0.1
from fieldmap.nav.report import format_table, to_dataset, write_outputs  # noqa: F401

STUDIES = ("table1", "table3", "table4")


def register(subparsers) -> None:
    """Add the ``navsim`` sub-command."""
    p = subparsers.add_parser(
        "navsim",
        help="navigation errors by gravity model and IMU grade (Chen et al. 2022 Tables 1, 3, 4)",
        description="Boost-glide INS simulation in the launch-centred inertial frame: exact IMU "
        "increments under the truth gravity (bundled EIGEN-6S, full degree), propagated with "
        "each navigation gravity model and IMU error draw in one Warp launch. "
        "Bad input, or an option given where it does nothing (a flight option with --study, "
        "--bias-mode with --route): one line on stderr, exit status 2, nothing written.",
    )
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
        help="recommended model: added horizontal error below this fraction of the IMU-only "
        "error (default 0.1)",
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
        "(exact: the closed-form level-ellipsoid field, the --normal exact of the maps; "
        "'normal' is its deprecated name) (table1 and flight; table4 adds the full IMU errors "
        "to the SH ones and to --nav)",
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
        help="how constant errors are drawn per run (see fieldmap.nav.imu_errors)",
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
    p.set_defaults(func=run)


#: options of the flight study (``--trajectory``/``--route``) only: dest -> option
FLIGHT_ONLY = {
    "imu": "--imu",
    "frame": "--frame",
    "altitude_aiding": "--altitude-aiding",
    "fraction": "--fraction",
    "block_s": "--block-s",
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


def _refuse_in_studies(args, studies, models, nav) -> None:
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


def _refuse_in_flight(args, imu, traj) -> None:
    """Refuse, in one line, an option given that the flight study does not use."""
    from fieldmap.cli import given
    from fieldmap.nav.flightsim import BARO_AFTER_S

    for dest, option in STUDIES_ONLY.items():
        if given(args, dest):
            studies = "the paper's studies" + ("" if option == "--study" else " (--study)")
            raise InputError(f"{option} applies to {studies}, not to {_FLIGHT}")
    if given(args, "speed_mps") and args.route is None:
        raise InputError("--speed-mps applies to --route, not to --trajectory")
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


#: most Monte Carlo draws per study (each draw propagates the whole flight; 10 000 draws of the
#: 800 s path take hours on a CPU)
MAX_DRAWS = 10_000


def _model_names(args, names, model) -> list[str]:
    """:func:`~fieldmap.nav.studies.check_model_names`, its deprecation warnings on stderr.

    Python hides a ``DeprecationWarning`` outside ``__main__``; a CLI user gets it as one line
    (``"normal" is now "exact"``).
    """
    from fieldmap.nav.studies import check_model_names

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", DeprecationWarning)
        out = check_model_names(names, model)
    for w in caught:
        if issubclass(w.category, DeprecationWarning):
            print(
                f"fieldmap {getattr(args, 'command', 'navsim')}: warning: {w.message}",
                file=sys.stderr,
            )
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return out


def _check_args(args):
    """Validate every option (and the output folder) before any work; return the checked ones."""
    from fieldmap._warp import DeviceError, resolve_device
    from fieldmap.models.registry import load_model
    from fieldmap.nav.imu import sample_count
    from fieldmap.products.io import check_out_dir

    for name, v in (
        ("--rate", args.rate),
        ("--duration", args.duration),
        ("--output-dt", args.output_dt),
        ("--block-s", args.block_s),
        ("--speed-mps", args.speed_mps),
    ):
        if v is not None and (not np.isfinite(v) or v <= 0):
            raise InputError(f"{name} must be a positive number, got {v}")
    if not 0 < args.fraction < 1:
        raise InputError(f"--fraction must be in (0, 1), got {args.fraction}")
    model = load_model(args.model, lmax=args.lmax)
    models = _model_names(args, split_list(args.models), model)
    if is_flight(args):
        return _check_flight_args(args, model, models)
    args.duration = 800.0 if args.duration is None else args.duration
    args.output_dt = 1.0 if args.output_dt is None else args.output_dt
    if args.draws is not None and not 1 <= args.draws <= MAX_DRAWS:
        raise InputError(f"--draws must be within 1..{MAX_DRAWS}, got {args.draws}")
    if args.seed < 0:
        raise InputError(f"--seed must be >= 0, got {args.seed}")
    if not 1 <= args.gauss <= 16:
        raise InputError(f"--gauss must be in 1..16, got {args.gauss}")
    if args.duration * args.rate < 2:
        raise InputError("--duration × --rate gives fewer than 2 IMU samples")
    if args.duration > 800.0:
        raise InputError(
            f"--duration {args.duration} s is longer than the boost-glide path (800 s); fly "
            "longer with --trajectory FILE or --route"
        )
    if args.output_dt > args.duration:
        raise InputError(
            f"--output-dt {args.output_dt:g} s is longer than --duration {args.duration:g} s"
        )
    sample_count(args.duration, args.rate)
    nav = _model_names(args, [args.nav], model)[0]
    _refuse_in_studies(args, STUDIES if args.study == "all" else (args.study,), models, nav)
    check_out_dir(args.out)
    try:
        device = resolve_device(args.device)
    except DeviceError as exc:
        raise InputError(str(exc)) from None
    return device, models, nav


def split_list(values) -> list[str]:
    """``["j2,j4", "sh18"]`` or ``["j2 j4"]`` -> ``["j2", "j4", "sh18"]`` (commas or spaces)."""
    return [m for v in values for m in str(v).replace(",", " ").split() if m]


def is_flight(args) -> bool:
    """Tell whether ``--trajectory`` or ``--route`` asks for the flight study."""
    return args.trajectory is not None or args.route is not None


def _check_flight_args(args, model, models):
    """Validate the flight study's options; build the trajectory (its errors name the line)."""
    from fieldmap._warp import DeviceError, resolve_device
    from fieldmap.nav.imu_specs import load_imu
    from fieldmap.products.io import check_out_dir

    if args.trajectory is not None and args.route is not None:
        raise InputError("give --trajectory or --route, not both")
    if args.route is not None and args.speed_mps is None:
        raise InputError("--route needs --speed-mps")
    if args.draws is not None and not 1 <= args.draws <= MAX_DRAWS:
        raise InputError(f"--draws must be within 1..{MAX_DRAWS}, got {args.draws}")
    if args.seed < 0:
        raise InputError(f"--seed must be >= 0, got {args.seed}")
    if not 1 <= args.gauss <= 16:
        raise InputError(f"--gauss must be in 1..16, got {args.gauss}")
    imu = load_imu(args.imu or "ideal")
    if args.max_gap_s is not None and not (np.isfinite(args.max_gap_s) and args.max_gap_s > 0):
        raise InputError(f"--max-gap-s must be a positive number, got {args.max_gap_s}")
    from fieldmap.cli import given

    if given(args, "gravity_rate_hz") and not any(m.startswith("sh") for m in models):
        raise InputError(
            "--gravity-rate-hz sets the update rate of SH navigation models: --models has none"
        )
    flights = navflight.flights(args, model)
    for _, traj, _ in flights:
        _refuse_in_flight(args, imu, traj)
    check_out_dir(args.out)
    try:
        device = resolve_device(args.device)
    except DeviceError as exc:
        raise InputError(str(exc)) from None
    return device, models, (flights, imu, model)


def run(args) -> int:
    """Run the chosen study (or all) and write its outputs."""
    from fieldmap.products import cluster
    from fieldmap.products.io import output_batch

    device, models, nav = _check_args(args)
    scheduler = cluster.parse_scheduler(args.scheduler)
    studies = STUDIES if args.study == "all" else (args.study,)
    # connect (or start the LocalCluster) before the long work; None: here
    with cluster.open_client(scheduler) as client:
        if is_flight(args):
            flights, imu, model = nav
            return navflight.run(args, device, models, flights, imu, model, client=client)
        results = _scenario_and_studies(args, device, studies, models, nav, client)
    with output_batch(args.out) as batch:  # all files of all studies, or none
        for res in results:
            write_outputs(res, batch)
    for res in results:
        print(format_table(res))
    return 1 if any(res.meta.get("diverged") for res in results) else 0


def _scenario_and_studies(args, device, studies, models, nav, client=None) -> list:
    from tqdm import tqdm

    from fieldmap.nav import studies as navsim

    tqdm.write(
        f"navsim: synthesizing the IMU ({args.duration:g} s at {args.rate:g} Hz, "
        f"truth {args.model})"
    )
    sc = navsim.build_scenario(
        duration=args.duration,
        rate_hz=args.rate,
        truth=args.model,
        truth_lmax=args.lmax,
        n_gauss=args.gauss,
        output_dt=args.output_dt,
        device=device,
        progress=True,
    )
    return _run_studies(args, sc, studies, models, nav, client)


def _run_studies(args, sc, studies, models, nav, client=None) -> list:
    from tqdm import tqdm

    from fieldmap.nav import studies as navsim

    results = []
    for study in tqdm(studies, desc="navsim studies", unit="study"):
        if study == "table1":
            res = navsim.table1(sc, models, timing=not args.no_timing, progress=True, client=client)
        elif study == "table3":
            res = navsim.table3(
                sc,
                draws=args.draws or 50,
                seed=args.seed,
                nav=nav,
                mode=args.bias_mode,
                progress=True,
                client=client,
            )
        else:
            res = navsim.table4(
                sc,
                [m for m in models if m.startswith("sh") or m == nav] or [nav],
                draws=args.draws or 20,
                seed=args.seed,
                mode=args.bias_mode,
                reference=nav,
                progress=True,
                client=client,
            )
        results.append(res)
    return results

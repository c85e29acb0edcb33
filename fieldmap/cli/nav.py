"""``fieldmap navsim``: navigation errors by gravity model and IMU, on the paper's or your flight.

``--study table1|table3|table4|all`` runs the studies of Chen et al. (2022) §5 on the boost-glide
path; ``--trajectory FILE`` or ``--route "lat,lon,h;..." --speed-mps V`` runs the flight study of
:mod:`fieldmap.nav.study` (``navsim_flight.*``: see
:func:`fieldmap.nav.report.write_flight_outputs`).

Each option applies to the paper's studies, to the flight study or to both (the tables
:data:`FLIGHT_ONLY`, :data:`STUDIES_ONLY` and :data:`USED_BY`, beside :func:`add_options`, where
the options are defined): one given where it does nothing (``--block-s`` with
``--study table1``, ``--bias-mode`` with ``--route``, ``--draws`` with an ideal IMU) is refused
in one line, exit status 2, before any work.

Writes, for each study, ``navsim_<study>.csv`` / ``.json`` (table rows, truth model, floor, paper
values), ``navsim_<study>.nc`` (error curves over time, xarray/NetCDF, CF attributes) and
``navsim_<study>.png`` (Figs. 11-13 like curves) under ``--out`` (default ``outputs/``). Every
input is checked before any work starts; every file is written to a temporary name and renamed,
so a failed run leaves nothing half-written.

The flight study (``--trajectory FILE [FILE ...]`` / ``--route``, the section "your flight"):
flight logs are read as they come (:func:`fieldmap.nav.logs.load_flight`: CSV with any
column names, ADS-B exports, GPX, NMEA, IGC; MSL or pressure heights), conditioned (outliers,
gaps, ground, smoothing; ``--no-smooth`` for clean, simulated files) and flown: one summary table,
and per flight ``navsim_flight.{json,csv,nc,png}``, ``navsim_flight_track.png`` and the fit
figure ``navsim_flight_conditioning.png`` (prefixed ``navsim_flight_<name>`` when several flights
are flown in one launch). The JSON carries a ``conditioning`` block: what was done to the log and
the kinematics that were flown. Its notes, like the messages of the readers and the
conditioning, name the options here (:func:`fieldmap.cli.wording_of`).

The module reads top-down: your flight (its options and steps); all the options and where
each applies; the command.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import sys
import warnings
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from fieldmap import durations
from fieldmap.errors import InputError
from fieldmap.limits import MAX_DRAWS

# the tables and files live in the library; re-exported for scripts written against 0.1
from fieldmap.nav.report import format_table, write_outputs

if TYPE_CHECKING:
    from distributed import Client

    from fieldmap.models.shmodel import SHModel
    from fieldmap.nav.logs.report import ConditionedFlight
    from fieldmap.nav.paper import StudyResult
    from fieldmap.nav.sensors import ImuErrorSpec
    from fieldmap.nav.study import FlightStudy, Scenario
    from fieldmap.nav.trajectory import Trajectory

    #: ``(name, trajectory, conditioning or None)`` of a flight to fly
    Flight = tuple[str, Trajectory, ConditionedFlight | None]


# -------------------------------------------------------------------------------------- your flight
#: options of the flight logs (``--trajectory``) only: dest -> option
LOG_ONLY = {
    "columns": "--columns",
    "alt_units": "--alt-units",
    "height_ref": "--height-ref",
    "time_format": "--time-format",
    "position_noise_m": "--position-noise-m",
    "max_gap_s": "--max-gap-s",
    "keep_ground": "--keep-ground",
    "airborne_only": "--airborne-only",
    "no_smooth": "--no-smooth",
    "vehicle": "--vehicle",
    "ignore_log_velocities": "--ignore-log-velocities",
}
#: options of the conditioning: --no-smooth turns it off, and files flown as recorded (fieldmap
#: CSV with attitude columns, NetCDF) skip it: dest -> option
CONDITIONING = {
    k: LOG_ONLY[k]
    for k in (
        "position_noise_m",
        "max_gap_s",
        "keep_ground",
        "airborne_only",
        "vehicle",
        "ignore_log_velocities",
    )
}
#: options of the flight study, logs and routes alike: dest -> option
FLIGHT_EXTRA = {
    "gravity_rate_hz": "--gravity-rate-hz",
    "truth_evaluation": "--truth-evaluation",
    "gnss_rate": "--gnss-rate",
    "gnss_sigma": "--gnss-sigma",
    "gnss_velocity_sigma": "--gnss-velocity-sigma",
    "gnss_outage": "--gnss-outage",
    "gnss_bias": "--gnss-bias",
}
#: the GNSS options: any of them turns the aiding on
GNSS_OPTIONS = ("gnss_rate", "gnss_sigma", "gnss_velocity_sigma", "gnss_outage", "gnss_bias")


def _flight_options(p: argparse.ArgumentParser) -> None:
    """Add the flight-log and fast-path options of ``navsim``."""
    g = p.add_argument_group("flight logs (--trajectory)")
    g.add_argument(
        "--columns",
        default=None,
        help="CSV columns: time=NAME,lat=NAME,lon=NAME,alt=NAME (default: recognised from the "
        "header: fieldmap, OpenSky, traffic)",
    )
    g.add_argument("--alt-units", default=None, choices=("m", "ft"), help="altitude units")
    g.add_argument(
        "--height-ref",
        default=None,
        choices=("ellipsoid", "msl", "pressure"),
        help="what the heights are: above the ellipsoid, above mean sea level (the truth "
        "model's geoid is added), or pressure altitude (ISA, approximate)",
    )
    g.add_argument(
        "--time-format",
        default=None,
        help="s, epoch, epoch_ms, iso or a strptime pattern (default: recognised)",
    )
    g.add_argument(
        "--position-noise-m",
        default=None,
        help="position noise of the smoothing fit, horizontal[,vertical] in m (default: "
        "estimated from the log)",
    )
    g.add_argument(
        "--max-gap-s",
        type=float,
        default=60.0,
        help="gaps longer than this are listed in the report with the σ of the path the fit "
        "flies across them (every gap is bridged; default 60)",
    )
    g.add_argument(
        "--vehicle",
        default=None,
        help="vehicle class whose load factor, jerk and speed the conditioned path keeps "
        "within: airliner, light-aircraft, glider, helicopter, uav, fighter, car, ship, rocket "
        "(default: guessed from the log, and said in the report)",
    )
    g.add_argument(
        "--airborne-only",
        action="store_true",
        help="trim the ground movement (taxi, parking, the slow part of the take-off and "
        "landing rolls) at the ends of the log (default: flown, as the aircraft moved on the "
        "ground)",
    )
    g.add_argument(
        "--keep-ground",
        action="store_true",
        help="fly the ground movement at the ends of the log: the default now (a note says "
        "so); kept for old command lines, refused with --airborne-only",
    )
    g.add_argument(
        "--ignore-log-velocities",
        action="store_true",
        help="do not use the velocities the log carries (ground speed, track, vertical rate): "
        "the path is fitted to the positions alone (for velocity columns that are stale or "
        "from another source; default: used as observations and checked against the "
        "positions)",
    )
    g.add_argument(
        "--no-smooth",
        action="store_true",
        help="no conditioning: interpolate the samples exactly (clean, simulated flights)",
    )
    p.add_argument(
        "--gravity-rate-hz",
        default=None,
        help="flight study, SH navigation models: disturbance update rate in Hz, or 'full' for "
        "the whole model every step (default: from the degree and the speed, error < 0.1 %%)",
    )
    p.add_argument(
        "--truth-evaluation",
        default="interpolated",
        choices=("interpolated", "full"),
        help="flight study truth: disturbance interpolated along the path plus the exact "
        "normal field (default; error measured and reported), or the SH model at every node",
    )


def _noise(text: str | None) -> float | tuple[float, float] | None:
    if text is None:
        return None
    try:
        vals = [float(x) for x in str(text).replace(",", " ").split()]
    except ValueError:
        vals = []
    if len(vals) not in (1, 2) or not all(math.isfinite(v) and v > 0 for v in vals):
        raise InputError(
            f"--position-noise-m takes 1 or 2 positive numbers (m, horizontal[,vertical]), "
            f"got {text!r}"
        )
    return vals[0] if len(vals) == 1 else (vals[0], vals[1])


def _rate(text: str | None) -> float | str | None:
    if text is None or str(text).lower() == "full":
        return None if text is None else "full"
    try:
        return float(text)
    except ValueError:
        raise InputError(
            f"--gravity-rate-hz must be a number of Hz or 'full', got {text!r}"
        ) from None


def _flights(args: argparse.Namespace, model: SHModel) -> list[Flight]:
    """Return ``[(name, trajectory, conditioning or None), ...]`` of the flights to fly.

    The conditioning options are refused (one line) where no flight is conditioned: with
    ``--no-smooth``, and when every file is flown as recorded. The notes of the conditioning
    name the options here (:func:`fieldmap.cli.wording_of`; its errors are worded so where
    they are reported, :func:`fieldmap.cli.main`).
    """
    from fieldmap.cli import given, wording_of
    from fieldmap.errors import worded
    from fieldmap.nav.logs import load_flight
    from fieldmap.nav.logs.condition import Conditioning
    from fieldmap.nav.trajectory import FlightTrajectory, route_flight

    if args.route is not None:
        for dest, option in LOG_ONLY.items():
            if given(args, dest):
                raise InputError(f"{option} applies to flight logs (--trajectory), not to --route")
        return [("route", FlightTrajectory(route_flight(args.route, args.speed_mps)), None)]
    if given(args, "no_smooth"):
        for dest, option in CONDITIONING.items():
            if given(args, dest):
                raise InputError(
                    f"{option} applies to the conditioning of the log, which --no-smooth turns "
                    "off (the samples are flown as they are)"
                )
    if given(args, "keep_ground") and given(args, "airborne_only"):
        raise InputError(
            "--keep-ground flies the ground movement, --airborne-only trims it: give one"
        )
    conditioning = Conditioning(
        position_noise_m=_noise(args.position_noise_m),
        max_gap_s=args.max_gap_s,
        airborne_only=bool(args.airborne_only),
        smooth=not args.no_smooth,
        vehicle=args.vehicle,
        log_velocities=not args.ignore_log_velocities,
    )
    out: list[Flight] = []
    names: set[str] = set()
    for path in args.trajectory:
        traj, cf = load_flight(
            path,
            conditioning,
            columns=args.columns,
            alt_units=args.alt_units,
            height_ref=args.height_ref,
            time_format=args.time_format,
            model=model,
        )
        if cf is not None:
            navsim = wording_of("navsim")
            cf.report["notes"] = [worded(note, navsim) for note in cf.report["notes"]]
        name = Path(path).name.split(".")[0] or "flight"
        base, k = name, 2
        while name in names:
            name, k = f"{base}_{k}", k + 1
        names.add(name)
        out.append((name, traj, cf))
    _refuse_unconditioned(args, out)
    return out


def _refuse_unconditioned(args: argparse.Namespace, flights_: Sequence[Flight]) -> None:
    """Refuse the conditioning options when every flight is flown as recorded (not conditioned)."""
    from fieldmap.cli import given

    if any(cf is not None for _, _, cf in flights_):
        return
    for dest, option in {**CONDITIONING, "no_smooth": "--no-smooth"}.items():
        if given(args, dest):
            files = ", ".join(str(p) for p in args.trajectory)
            verb = "is" if len(args.trajectory) == 1 else "are"
            raise InputError(
                f"{option} applies to conditioned flight logs: {files} {verb} flown as recorded "
                "(a fieldmap flight file with attitude columns, or NetCDF), not conditioned"
            )


def _flight_study(
    args: argparse.Namespace,
    traj: Trajectory,
    imu: tuple[str, ImuErrorSpec],
    model: SHModel,
    names: list[str],
) -> FlightStudy:
    """Return the :class:`~fieldmap.nav.study.FlightStudy` of the options.

    Its refusals name the Python keywords and carry them (``param``): :func:`fieldmap.cli.main`
    names the options instead (:func:`fieldmap.cli.wording_of`).
    """
    from fieldmap.nav.study import FlightStudy

    return FlightStudy(
        traj,
        imu=imu[1],
        imu_name=imu[0],
        models=names,
        draws=20 if args.draws is None else args.draws,
        seed=args.seed,
        rate_hz=args.rate,
        frame=args.frame or "ned",
        altitude_aiding=args.altitude_aiding,
        truth=model,
        truth_evaluation=args.truth_evaluation,
        gravity_rate_hz=_rate(args.gravity_rate_hz),
        n_gauss=args.gauss,
        duration=args.duration,
        output_dt=args.output_dt,
        block_s=args.block_s,
        fraction=args.fraction,
        omission_model="tscherning-rapp" if args.omission_model is None else args.omission_model,
        commission={None: None, "auto": None, "on": True, "off": False}[args.commission],
        method=args.method or "monte-carlo",
        gnss=_gnss(args),
    )


def _gnss(args: argparse.Namespace) -> Any:
    """Return the :class:`~fieldmap.nav.aiding.GnssSpec` of the ``--gnss-*`` options (or None)."""
    from fieldmap.cli import given

    if not any(given(args, d) for d in GNSS_OPTIONS):
        return None
    from fieldmap.nav.aiding import GnssSpec

    vs = args.gnss_velocity_sigma
    if vs is not None and vs.strip().lower() == "none":
        vel = None
    else:
        try:
            vel = 0.05 if vs is None else float(vs)
        except ValueError:
            raise InputError(
                f"--gnss-velocity-sigma must be a number (m/s) or none, got {vs!r}"
            ) from None
    bias, tau = 0.0, 600.0
    if args.gnss_bias is not None:
        parts = args.gnss_bias.split(":")
        try:
            if len(parts) > 2:
                raise ValueError
            bias = float(parts[0])
            tau = durations.seconds(parts[1]) if len(parts) == 2 else tau
        except (ValueError, InputError):
            raise InputError(
                "--gnss-bias must be M[:TAU_S] (metres; the correlation time in s, or with a "
                f"unit s, min, h: 1:600, 1:10min), got {args.gnss_bias!r}"
            ) from None
    return GnssSpec(
        bias_m=bias,
        bias_tau_s=tau,
        rate_hz=1.0 if args.gnss_rate is None else args.gnss_rate,
        sigma_m=2.0 if args.gnss_sigma is None else args.gnss_sigma,
        velocity_sigma_mps=vel,
        outages=args.gnss_outage or "",
    )


def _run_flights(
    args: argparse.Namespace,
    studies: Sequence[tuple[str, FlightStudy, ConditionedFlight | None]],
    *,
    device: str | None = None,
    client: Client | None = None,
) -> int:
    """Fly every flight; write all outputs (or none); print the reports; exit 1 if one diverged.

    ``studies``: ``[(name, FlightStudy, conditioning or None), ...]``, validated.
    """
    import warnings

    from tqdm import tqdm

    from fieldmap.nav.plots import disturbance_grid
    from fieldmap.nav.report import format_flight, write_flight_outputs
    from fieldmap.nav.study import FlightResult, run_flight
    from fieldmap.products.io import output_batch

    if args.method == "covariance":  # imported for that method only
        from fieldmap.nav.report import format_covariance, write_covariance_outputs

    results = []
    for name, st, cf in studies:
        tqdm.write(
            f"navsim: flight {name} of {st.flight.duration:g} s, IMU {st.imu_name} at "
            f"{st.rate_hz:g} Hz, models {' '.join(st.models)}"
        )
        if cf is not None:
            print(cf.format_report())
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", RuntimeWarning)
            res = run_flight(st, device=device, client=client, progress=True)
        for w in caught:
            if issubclass(w.category, RuntimeWarning) and "diverged" in str(w.message):
                tqdm.write(f"warning: {w.message}")
        if args.no_timing:  # no wall-clock seconds in the files: two runs' results compare equal
            for key in (
                "synthesis_seconds", "propagation_seconds", "gravity_budget_seconds",
                "covariance_seconds",
            ):  # fmt: skip
                if key in res.summary["meta"]:
                    res.summary["meta"][key] = None
        if cf is not None:
            res.summary["conditioning"] = cf.report
        # the ground-track figure's map: drawn only with the figures
        grid = None if args.no_plots else disturbance_grid(res, st.truth, device=device)
        results.append((name, res, cf, grid))
    several = len(results) > 1
    with output_batch(args.out) as batch:  # every file of every flight, or none
        for name, res, cf, grid in results:
            prefix = f"navsim_flight_{name}" if several else "navsim_flight"
            figures = not args.no_plots
            if isinstance(res, FlightResult):
                write_flight_outputs(res, batch, grid, prefix=prefix, figures=figures)
            else:
                write_covariance_outputs(res, batch, prefix=prefix, figures=figures)
            if cf is not None and figures:
                from fieldmap.nav.logs.report import plot_conditioning

                batch.png(plot_conditioning(cf), f"{prefix}_conditioning.png")
    for name, res, _, _ in results:
        if several:
            print(f"== {name} ==")
        print(format_flight(res) if isinstance(res, FlightResult) else format_covariance(res))
    if several:
        print(f"{'flight':24s} {'duration s':>10s}  recommended")
        for name, res, _, _ in results:
            m = res.summary["meta"]
            print(f"{name:24s} {m['duration_s']:10.0f}  {res.summary['recommended_model']}")
    return 1 if any(res.diverged for _, res, _, _ in results) else 0


# --------------------------------------------------------------- the options and where each applies
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
    g = p.add_argument_group("GNSS aiding (flight study; any of these turns it on)")
    g.add_argument(
        "--gnss-rate",
        type=float,
        default=None,
        metavar="HZ",
        help="GNSS fix rate in Hz, at most the IMU's (default 1): a loosely coupled Kalman "
        "filter with feedback, fixes synthesised from the truth with white noise",
    )
    g.add_argument(
        "--gnss-sigma",
        type=float,
        default=None,
        metavar="M",
        help="GNSS position noise per axis (N, E, D), 1 sigma, in m (default 2)",
    )
    g.add_argument(
        "--gnss-velocity-sigma",
        default=None,
        metavar="MPS|none",
        help="GNSS velocity noise per axis, 1 sigma, in m/s (default 0.05; none: position "
        "fixes only)",
    )
    g.add_argument(
        "--gnss-bias",
        default=None,
        metavar="M[:TAU_S]",
        help="GNSS position bias per axis, first-order Gauss-Markov: 1 sigma in m and "
        "correlation time in s, or with a unit (2:10min) (default 0, none; time 600 s)",
    )
    g.add_argument(
        "--gnss-outage",
        default=None,
        metavar="START:DURATION[,...]|every PERIOD:DURATION",
        help="GNSS outages: START:DURATION in s (or with a unit s, min, h: 20min:5min), comma "
        "separated, inside the flight and not overlapping; or a pattern, 'every 30min:5min' (a "
        "5-minute outage every 30 minutes); the report gives the coasting error at the end of "
        "each outage per gravity model",
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
        "the maps; table:FILE: exact plus a compensation table "
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
        type=durations.argument,
        default=None,
        metavar="TIME",
        help="flight time in s, or with a unit s, min, h (5min, 1.5h) (paper's studies: at most "
        "800 s, default 800; flight: default all)",
    )
    p.add_argument(
        "--truth-model",
        default="eigen-6s",
        metavar="MODEL",
        help="truth gravity model, the field the vehicle flies through: bundled name or ICGEM "
        ".gfc[.gz] file (default eigen-6s); the navigation models are --models",
    )
    p.add_argument("--truth", dest="truth_model", default=argparse.SUPPRESS, help=argparse.SUPPRESS)
    p.add_argument("--model", action=_NoModelOption, help=argparse.SUPPRESS)
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
        "--tide-system",
        # fieldmap.models.tide.TIDE_SYSTEMS, spelt out (one module fewer at every start)
        choices=("tide_free", "zero_tide", "mean_tide"),
        default=None,
        help="convert the truth model to this permanent-tide system after loading (C̄20, IERS "
        "Conventions 2010 §6.2.2); recorded in the JSON meta (default: the model file's own)",
    )
    p.add_argument(
        "--output-dt",
        type=durations.argument,
        default=None,
        metavar="TIME",
        help="interval of the error curves in s, or with a unit (paper's studies: default 1, "
        "dividing the run; flight: default about 3600 points)",
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
    p.add_argument("--no-plots", action="store_true", help="write CSV, JSON and NetCDF only")
    _flight_options(p)


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
    **LOG_ONLY,
    **FLIGHT_EXTRA,
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


# -------------------------------------------------------------------------------------- the command
def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``navsim`` sub-command."""
    p = subparsers.add_parser(
        "navsim",
        help="which gravity model your flight's INS needs: navigation errors by gravity model "
        "and IMU grade (your flight log or a route; the paper's Tables 1, 3, 4)",
        description="Flight study: what each navigation gravity model (--models: J2, J4, J6, the "
        "exact normal field, SH degrees, compensation tables) adds to the position error of a "
        "strapdown INS of a given grade (--imu) on your flight (--trajectory FILE: CSV, ADS-B, "
        "GPX, NMEA, IGC; or --route with --speed-mps), against the truth gravity field "
        "(--truth-model, default the bundled EIGEN-6S at full degree), by Monte Carlo or "
        "covariance analysis, with or without GNSS aiding; it recommends the simplest model "
        "whose gravity error stays below --fraction of the IMU's own error. "
        "The paper's studies (--study table1|table3|table4|all, Chen et al. 2022) fly the "
        "boost-glide path in the launch-centred inertial frame. "
        "Bad input, or an option given where it does nothing (a flight option with --study, "
        "--bias-mode with --route): one line on stderr, exit status 2, nothing written.",
    )
    add_options(p)
    p.set_defaults(func=run)


@contextlib.contextmanager
def _deprecation_notes(args: argparse.Namespace, notes: list[str]) -> Iterator[None]:
    """Collect the deprecation warnings of the block (deprecated model names) in ``notes``.

    Python hides a ``DeprecationWarning`` outside ``__main__``; a CLI user gets it as one line
    on stderr (``"normal" is now "exact"``), printed by :func:`run` once every option passed
    its checks: a refused run prints its refusal alone.
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", DeprecationWarning)
        yield
    for w in caught:
        if issubclass(w.category, DeprecationWarning):
            note = f"fieldmap {getattr(args, 'command', 'navsim')}: warning: {w.message}"
            if note not in notes:
                notes.append(note)
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)


def _model_names(
    args: argparse.Namespace, names: list[str], model: SHModel, notes: list[str]
) -> list[str]:
    """:func:`~fieldmap.nav.study.check_model_names`, its deprecation warnings in ``notes``."""
    from fieldmap.nav.study import check_model_names

    with _deprecation_notes(args, notes):
        return check_model_names(names, model)


def _check_args(args: argparse.Namespace, notes: list[str]) -> tuple[str, list[str], Any]:
    """Validate every option (and the output folder) before any work; return the checked ones.

    ``(device, models, nav)``: the navigation model's name for the paper's studies, the
    ``(name, FlightStudy, conditioning)`` of each flight for the flight study.

    Warnings for the user (deprecated model names) go to ``notes``, printed once all passed.
    """
    from fieldmap._warp import resolve_device
    from fieldmap.models.registry import announce
    from fieldmap.nav.imu import sample_count
    from fieldmap.nav.study import output_steps
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
    model = _truth_model(args)
    if is_flight(args) and "table:" in str(args.models):  # truth and tables in one tide system
        from fieldmap.cli.model_options import in_tables_system

        model = in_tables_system(model, split_list(args.models), args.tide_system)
    announce(model)
    if is_flight(args):
        return _check_flight_args(args, model, notes)
    models = _model_names(args, split_list(args.models), model, notes)
    tables = [m for m in models if m.startswith("table:")]
    if tables:
        raise InputError(
            f"--models {tables[0]}: compensation tables navigate flight studies (--trajectory or "
            "--route), not the paper's boost-glide studies"
        )
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
    steps = sample_count(args.duration, args.rate) // 2
    # before the IMU synthesis: its progress bar would come before the refusal
    output_steps(args.output_dt, steps, 2.0 / args.rate)
    nav = _model_names(args, [args.nav], model, notes)[0]
    refuse_in_studies(args, STUDIES if args.study == "all" else (args.study,), models, nav)
    check_out_dir(args.out)
    device = resolve_device(args.device)
    return device, models, nav


class _NoModelOption(argparse.Action):
    """``navsim --model``: refused, naming the two options it could have meant.

    The truth model (``--truth-model``) and the navigation models (``--models``) are one letter
    apart as ``--model`` and ``--models``; the old spelling of the truth's option is refused
    rather than kept, so that ``--model j2`` (a navigation model) cannot fly as the truth.
    """

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        from fieldmap.nav.gravity import is_navigation_name

        if is_navigation_name(values):
            parser.error(
                f"--model {values}: navsim has no --model; navigation gravity models go to "
                f"--models {values} (the truth model is --truth-model)"
            )
        parser.error(
            f"--model {values}: navsim has no --model; the truth gravity model is "
            f"--truth-model {values} (the navigation models are --models)"
        )


def _truth_model(args: argparse.Namespace) -> SHModel:
    """Load the truth model of ``--truth-model``; a navigation model's name says ``--models``."""
    from fieldmap.models.registry import load_model
    from fieldmap.nav.gravity import is_navigation_name

    name = args.truth_model
    try:
        return load_model(name, lmax=args.lmax, tide_system=args.tide_system)
    except InputError as exc:
        if not is_navigation_name(name):
            raise
        raise InputError(
            f"--truth-model {name}: {name!r} is a navigation gravity model, not a truth model "
            "(a spherical-harmonic model: eigen-6s or an ICGEM file); navigation models go to "
            f"--models {name}"
        ) from exc


def split_list(values: Iterable[object]) -> list[str]:
    """``["j2,j4", "sh18"]`` or ``["j2 j4"]`` -> ``["j2", "j4", "sh18"]`` (commas or spaces)."""
    return [m for v in values for m in str(v).replace(",", " ").split() if m]


def is_flight(args: argparse.Namespace) -> bool:
    """Tell whether ``--trajectory`` or ``--route`` asks for the flight study."""
    return args.trajectory is not None or args.route is not None


def _check_flight_args(
    args: argparse.Namespace, model: SHModel, notes: list[str]
) -> tuple[str, list[str], list[tuple[str, FlightStudy, ConditionedFlight | None]]]:
    """Validate the flight study's options: one :class:`~fieldmap.nav.study.FlightStudy` a flight.

    The CLI checks what only it has (the choice of flight, the log options, options given
    where they do nothing); the study checks the rest, once, when it is built (its messages
    name the Python keywords, which :func:`fieldmap.cli.wording_of` names as options).
    """
    from fieldmap._warp import resolve_device
    from fieldmap.nav.sensors import PRESETS, load_imu
    from fieldmap.products.io import check_out_dir

    if args.trajectory is not None and args.route is not None:
        raise InputError("give --trajectory or --route, not both")
    if args.route is not None and args.speed_mps is None:
        raise InputError("--route needs --speed-mps")
    if args.imu is not None and not args.imu.strip():
        raise InputError(
            f"--imu is empty: give a preset ({', '.join(PRESETS)}) or an IMU .toml file"
        )
    imu = load_imu("ideal" if args.imu is None else args.imu)
    if args.max_gap_s is not None and not (np.isfinite(args.max_gap_s) and args.max_gap_s > 0):
        raise InputError(f"--max-gap-s must be a positive number, got {args.max_gap_s}")
    from fieldmap.cli import given

    names = split_list(args.models)
    if given(args, "gravity_rate_hz") and not any(m.startswith("sh") for m in names):
        raise InputError(
            "--gravity-rate-hz sets the update rate of SH navigation models: --models has none"
        )
    flights = _flights(args, model)
    if given(args, "keep_ground"):
        notes.append(
            f"fieldmap {getattr(args, 'command', 'navsim')}: note: --keep-ground is the "
            "default now: the ground movement is flown (--airborne-only trims it)"
        )
    studies = []
    for name, traj, cf in flights:
        refuse_in_flight(args, imu, traj)
        with _deprecation_notes(args, notes):
            studies.append((name, _flight_study(args, traj, imu, model, names), cf))
    check_out_dir(args.out)
    device = resolve_device(args.device)
    return device, list(studies[0][1].models), studies


def run(args: argparse.Namespace) -> int:
    """Run the chosen study (or all) and write its outputs."""
    from fieldmap.products.io import output_batch

    notes: list[str] = []
    device, models, nav = _check_args(args, notes)
    cluster: contextlib.AbstractContextManager[Any] = contextlib.nullcontext(None)  # here
    if args.scheduler is not None:
        from fieldmap.cluster import open_client, parse_scheduler

        cluster = open_client(parse_scheduler(args.scheduler))
    for note in notes:
        print(note, file=sys.stderr)
    studies = STUDIES if args.study == "all" else (args.study,)
    # connect (or start the LocalCluster) before the long work; None: here
    with cluster as opened:
        client = cast("Client | None", opened)  # open_client yields a Client, or None: here
        if is_flight(args):
            return _run_flights(args, nav, device=device, client=client)
        results = _scenario_and_studies(args, device, studies, models, nav, client)
    with output_batch(args.out) as batch:  # all files of all studies, or none
        for res in results:
            write_outputs(res, batch, figures=not args.no_plots)
    for res in results:
        print(format_table(res))
    return 1 if any(res.meta.get("diverged") for res in results) else 0


def _scenario_and_studies(
    args: argparse.Namespace,
    device: str,
    studies: Sequence[str],
    models: list[str],
    nav: str,
    client: Client | None = None,
) -> list[StudyResult]:
    from tqdm import tqdm

    from fieldmap.nav.imu import ImuSampling
    from fieldmap.nav.study import build_scenario

    tqdm.write(
        f"navsim: synthesizing the IMU ({args.duration:g} s at {args.rate:g} Hz, "
        f"truth {args.truth_model})"
    )
    sc = build_scenario(
        duration=args.duration,
        sampling=ImuSampling(args.rate, args.gauss),
        truth=_truth_model(args),
        output_dt=args.output_dt,
        device=device,
        progress=True,
    )
    return _run_studies(args, sc, studies, models, nav, client)


def _run_studies(
    args: argparse.Namespace,
    sc: Scenario,
    studies: Sequence[str],
    models: list[str],
    nav: str,
    client: Client | None = None,
) -> list[StudyResult]:
    from tqdm import tqdm

    from fieldmap.nav import paper as navsim

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
                navsim.MonteCarlo(args.draws or 20, args.seed, args.bias_mode),
                reference=nav,
                progress=True,
                client=client,
            )
        results.append(res)
    return results

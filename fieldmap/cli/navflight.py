"""``fieldmap navsim --trajectory FILE [FILE ...]`` / ``--route``: the flight study of your flight.

Flight logs are read as they come (:func:`fieldmap.nav.logs.load.load_flight`: CSV with any
column names, ADS-B exports, GPX, NMEA, IGC; MSL or pressure heights), conditioned (outliers,
gaps, ground, smoothing; ``--no-smooth`` for clean, simulated files) and flown: one summary table,
and per flight ``navsim_flight.{json,csv,nc,png}``, ``navsim_flight_track.png`` and the fit
figure ``navsim_flight_conditioning.png`` (prefixed ``navsim_flight_<name>`` when several flights
are flown in one launch). The JSON carries a ``conditioning`` block: what was done to the log and
the kinematics that were flown. Its notes, like the messages of the readers and the
conditioning, name the options here (:func:`fieldmap.cli.params.reword`).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from fieldmap.errors import InputError

if TYPE_CHECKING:
    from distributed import Client

    from fieldmap.models.shmodel import SHModel
    from fieldmap.nav.logs.report import ConditionedFlight
    from fieldmap.nav.sensors import ImuErrorSpec
    from fieldmap.nav.study import FlightStudy
    from fieldmap.nav.trajectory import Trajectory

    #: ``(name, trajectory, conditioning or None)`` of a flight to fly
    Flight = tuple[str, Trajectory, ConditionedFlight | None]

#: options of the flight logs (``--trajectory``) only: dest -> option
LOG_ONLY = {
    "columns": "--columns",
    "alt_units": "--alt-units",
    "height_ref": "--height-ref",
    "time_format": "--time-format",
    "position_noise_m": "--position-noise-m",
    "max_gap_s": "--max-gap-s",
    "keep_ground": "--keep-ground",
    "no_smooth": "--no-smooth",
    "vehicle": "--vehicle",
}
#: options of the conditioning: --no-smooth turns it off, and files flown as recorded (fieldmap
#: CSV with attitude columns, NetCDF) skip it: dest -> option
CONDITIONING = {k: LOG_ONLY[k] for k in ("position_noise_m", "max_gap_s", "keep_ground", "vehicle")}
#: options of the flight study, logs and routes alike: dest -> option
FLIGHT_EXTRA = {
    "gravity_rate_hz": "--gravity-rate-hz",
    "truth_evaluation": "--truth-evaluation",
}


def add_options(p: argparse.ArgumentParser) -> None:
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
        "--keep-ground",
        action="store_true",
        help="keep the taxi and ground segments at the ends (default: trimmed)",
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


def flights(args: argparse.Namespace, model: SHModel) -> list[Flight]:
    """Return ``[(name, trajectory, conditioning or None), ...]`` of the flights to fly.

    The conditioning options are refused (one line) where no flight is conditioned: with
    ``--no-smooth``, and when every file is flown as recorded. The notes of the conditioning
    name the options here (:func:`fieldmap.cli.params.reword`; its errors are reworded where
    they are reported, :func:`fieldmap.cli.main`).
    """
    from fieldmap.cli import given
    from fieldmap.cli.params import reword
    from fieldmap.nav.flight import FlightTrajectory, route_flight
    from fieldmap.nav.logs.condition import Conditioning
    from fieldmap.nav.logs.load import load_flight

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
    conditioning = Conditioning(
        position_noise_m=_noise(args.position_noise_m),
        max_gap_s=args.max_gap_s,
        airborne_only=not args.keep_ground,
        smooth=not args.no_smooth,
        vehicle=args.vehicle,
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
            cf.report["notes"] = [reword(note) for note in cf.report["notes"]]
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


def study(
    args: argparse.Namespace,
    traj: Trajectory,
    imu: tuple[str, ImuErrorSpec],
    model: SHModel,
    names: list[str],
) -> FlightStudy:
    """Return the :class:`~fieldmap.nav.study.FlightStudy` of the options.

    Its refusals name the Python keywords and carry them (``param``): :func:`fieldmap.cli.main`
    names the options instead (:func:`fieldmap.cli.params.reword`).
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
    )


def run(
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
    from fieldmap.nav.study import run_flight
    from fieldmap.products.io import output_batch

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
            res.summary["meta"].update(synthesis_seconds=None, propagation_seconds=None)
        if cf is not None:
            res.summary["conditioning"] = cf.report
        results.append((name, res, cf, disturbance_grid(res, st.truth, device=device)))
    several = len(results) > 1
    with output_batch(args.out) as batch:  # every file of every flight, or none
        for name, res, cf, grid in results:
            prefix = f"navsim_flight_{name}" if several else "navsim_flight"
            write_flight_outputs(res, batch, grid, prefix=prefix)
            if cf is not None:
                from fieldmap.nav.logs.report import plot_conditioning

                batch.png(plot_conditioning(cf), f"{prefix}_conditioning.png")
    for name, res, _, _ in results:
        if several:
            print(f"== {name} ==")
        print(format_flight(res))
    if several:
        print(f"{'flight':24s} {'duration s':>10s}  recommended")
        for name, res, _, _ in results:
            m = res.summary["meta"]
            print(f"{name:24s} {m['duration_s']:10.0f}  {res.summary['recommended_model']}")
    return 1 if any(res.diverged for _, res, _, _ in results) else 0

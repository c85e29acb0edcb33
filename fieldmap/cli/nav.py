"""``fieldmap navsim``: navigation errors by gravity model and IMU, on the paper's or your flight.

``--study table1|table3|table4|all`` runs the studies of Chen et al. (2022) §5 on the boost-glide
path; ``--trajectory FILE`` or ``--route "lat,lon,h;..." --speed-mps V`` runs the flight study of
:mod:`fieldmap.nav.study` (``navsim_flight.*``: see
:func:`fieldmap.nav.report.write_flight_outputs`).

Each option applies to the paper's studies, to the flight study or to both (the table of
:data:`~fieldmap.cli.navoptions.FLIGHT_ONLY`, :data:`~fieldmap.cli.navoptions.STUDIES_ONLY` and
:data:`~fieldmap.cli.navoptions.USED_BY` in :mod:`fieldmap.cli.navoptions`, where the options are
defined; their names are re-exported here): one given where it does nothing (``--block-s`` with
``--study table1``, ``--bias-mode`` with ``--route``, ``--draws`` with an ideal IMU) is refused
in one line, exit status 2, before any work.

Writes, for each study, ``navsim_<study>.csv`` / ``.json`` (table rows, truth model, floor, paper
values), ``navsim_<study>.nc`` (error curves over time, xarray/NetCDF, CF attributes) and
``navsim_<study>.png`` (Figs. 11-13 like curves) under ``--out`` (default ``outputs/``). Every
input is checked before any work starts; every file is written to a temporary name and renamed,
so a failed run leaves nothing half-written.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import warnings
from collections.abc import Iterable, Iterator, Sequence
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from fieldmap.cli import navflight, navoptions
from fieldmap.cli.navoptions import STUDIES
from fieldmap.errors import InputError
from fieldmap.limits import MAX_DRAWS

# the tables and files live in the library; re-exported for scripts written against 0.1
from fieldmap.nav.report import format_table, write_outputs

if TYPE_CHECKING:
    from distributed import Client

    from fieldmap.models.shmodel import SHModel
    from fieldmap.nav.logs.report import ConditionedFlight
    from fieldmap.nav.paper import StudyResult
    from fieldmap.nav.study import FlightStudy, Scenario


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
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
    navoptions.add_options(p)
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
    from fieldmap.models.registry import load_model
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
    model = load_model(args.model, lmax=args.lmax)
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
    navoptions.refuse_in_studies(
        args, STUDIES if args.study == "all" else (args.study,), models, nav
    )
    check_out_dir(args.out)
    device = resolve_device(args.device)
    return device, models, nav


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
    name the Python keywords, which :func:`fieldmap.cli.params.reword` names as options).
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
    flights = navflight.flights(args, model)
    studies = []
    for name, traj, cf in flights:
        navoptions.refuse_in_flight(args, imu, traj)
        with _deprecation_notes(args, notes):
            studies.append((name, navflight.study(args, traj, imu, model, names), cf))
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
            return navflight.run(args, nav, device=device, client=client)
        results = _scenario_and_studies(args, device, studies, models, nav, client)
    with output_batch(args.out) as batch:  # all files of all studies, or none
        for res in results:
            write_outputs(res, batch)
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
        f"truth {args.model})"
    )
    sc = build_scenario(
        duration=args.duration,
        sampling=ImuSampling(args.rate, args.gauss),
        truth=args.model,
        truth_lmax=args.lmax,
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

"""``fieldmap navsim``: the navigation-error studies of Chen et al. (2022) §5 (Tables 1, 3, 4).

Writes, for each study, ``navsim_<study>.csv`` / ``.json`` (table rows, truth model, floor, paper
values), ``navsim_<study>.nc`` (error curves over time, xarray/NetCDF, CF attributes) and
``navsim_<study>.png`` (Figs. 11-13 like curves) under ``--out`` (default ``outputs/``). Every
input is checked before any work starts; every file is written to a temporary name and renamed,
so a failed run leaves nothing half-written.
"""

from __future__ import annotations

import csv
import io
import json

import numpy as np

from fieldmap.errors import InputError

STUDIES = ("table1", "table3", "table4")


def register(subparsers) -> None:
    """Add the ``navsim`` sub-command."""
    p = subparsers.add_parser(
        "navsim",
        help="navigation errors by gravity model and IMU grade (Chen et al. 2022 Tables 1, 3, 4)",
        description="Boost-glide INS simulation in the launch-centred inertial frame: exact IMU "
        "increments under the truth gravity (bundled EIGEN-6S, full degree), propagated with "
        "each navigation gravity model and IMU error draw in one Warp launch. "
        "Bad input: one line on stderr, exit status 2, nothing written.",
    )
    p.add_argument(
        "--study", default="table1", choices=STUDIES + ("all",), help="study (default table1)"
    )
    p.add_argument(
        "--models",
        default="j2,j4,j6,normal,sh18,sh200",
        help="navigation gravity models, comma separated: j2 j4 j6 normal sh shN "
        "(table1; table4 adds the full IMU errors to the SH ones and to --nav)",
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
        default=2,
        help="Gauss-Legendre nodes per IMU sample, 1..16 (default 2)",
    )
    p.add_argument(
        "--duration", type=float, default=800.0, help="flight time in s, at most 800 (default 800)"
    )
    p.add_argument(
        "--truth",
        default="eigen-6s",
        help="truth gravity model: bundled name or ICGEM .gfc[.gz] file (default eigen-6s)",
    )
    p.add_argument(
        "--truth-degree",
        type=int,
        default=None,
        help="truth degree (default: the model's full degree)",
    )
    p.add_argument(
        "--output-dt",
        type=float,
        default=1.0,
        help="interval of the error curves in s, at most --duration (default 1)",
    )
    p.add_argument("--no-timing", action="store_true", help="skip the gravity CPU-time measurement")
    p.add_argument("--device", default=None, help="Warp device (cpu, cuda:0; default auto)")
    p.add_argument(
        "--out",
        default="outputs",
        help="output folder, created with its parents if missing (default outputs/)",
    )
    p.set_defaults(func=run)


#: most Monte Carlo draws per study (each draw propagates the whole flight; 10 000 draws of the
#: 800 s path take hours on a CPU)
MAX_DRAWS = 10_000


def _check_args(args):
    """Validate every option (and the output folder) before any work; return the checked ones."""
    from fieldmap._warp import DeviceError, resolve_device
    from fieldmap.models.registry import load_model
    from fieldmap.nav.imu import sample_count
    from fieldmap.nav.studies import check_model_names
    from fieldmap.products.io import check_out_dir

    for name, v in (
        ("--rate", args.rate),
        ("--duration", args.duration),
        ("--output-dt", args.output_dt),
    ):
        if not np.isfinite(v) or v <= 0:
            raise InputError(f"{name} must be a positive number, got {v}")
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
            f"--duration {args.duration} s is longer than the boost-glide path (800 s)"
        )
    if args.output_dt > args.duration:
        raise InputError(
            f"--output-dt {args.output_dt:g} s is longer than --duration {args.duration:g} s"
        )
    sample_count(args.duration, args.rate)
    model = load_model(args.truth, lmax=args.truth_degree)
    models = check_model_names([m for m in args.models.replace(" ", ",").split(",") if m], model)
    nav = check_model_names([args.nav], model)[0]
    check_out_dir(args.out)
    try:
        device = resolve_device(args.device)
    except DeviceError as exc:
        raise InputError(str(exc)) from None
    return device, models, nav


def run(args) -> int:
    """Run the chosen study (or all) and write its outputs."""
    from tqdm import tqdm

    from fieldmap.nav import studies as navsim
    from fieldmap.products.io import output_batch

    device, models, nav = _check_args(args)
    studies = STUDIES if args.study == "all" else (args.study,)
    tqdm.write(
        f"navsim: synthesizing the IMU ({args.duration:g} s at {args.rate:g} Hz, "
        f"truth {args.truth})"
    )
    sc = navsim.build_scenario(
        duration=args.duration,
        rate_hz=args.rate,
        truth=args.truth,
        truth_lmax=args.truth_degree,
        n_gauss=args.gauss,
        output_dt=args.output_dt,
        device=device,
        progress=True,
    )
    results = []
    for study in tqdm(studies, desc="navsim studies", unit="study"):
        if study == "table1":
            res = navsim.table1(sc, models, timing=not args.no_timing)
        elif study == "table3":
            res = navsim.table3(
                sc, draws=args.draws or 50, seed=args.seed, nav=nav, mode=args.bias_mode
            )
        else:
            res = navsim.table4(
                sc,
                [m for m in models if m.startswith("sh") or m == nav] or [nav],
                draws=args.draws or 20,
                seed=args.seed,
                mode=args.bias_mode,
                reference=nav,
            )
        results.append(res)
    with output_batch(args.out) as batch:  # all files of all studies, or none
        for res in results:
            write_outputs(res, batch)
    for res in results:
        print(format_table(res))
    return 0


def format_table(res) -> str:
    """Plain-text table of a study's rows (with the paper's values where they exist)."""
    from fieldmap.nav.studies import PAPER_TABLE1, PAPER_TABLE3

    lines = [
        f"== {res.study}: truth {res.meta['truth_model']} degree {res.meta['truth_degree']}, "
        f"{res.meta['duration_s']:g} s, IMU {res.meta['imu_rate_hz']:g} Hz =="
    ]
    if res.study == "table1":
        lines.append(
            f"{'model':8s} {'|dv| m/s':>10s} {'|dp| m':>10s} {'eval s':>10s}"
            "   paper: |dv| |dp| eval"
        )
        for r in res.rows:
            p = PAPER_TABLE1.get(r["model"], ("", "", ""))
            lines.append(
                f"{r['model']:8s} {r['final_velocity_error_m_s']:10.4f} "
                f"{r['final_position_error_m']:10.2f} "
                f"{r.get('gravity_eval_seconds', float('nan')):10.2e}   {p[0]} {p[1]} {p[2]}"
            )
        fl = res.meta["floor"]
        lines.append(
            f"floor ({fl['nav_gravity']} = truth): |dv| {fl['final_velocity_error_m_s']:.3e} m/s, "
            f"|dp| {fl['final_position_error_m']:.3e} m "
            f"(smallest effect / floor: {fl['margin_position']:.0f}x, {fl['margin_velocity']:.0f}x)"
        )
    else:
        key = "group" if res.study == "table3" else "case"
        lines.append(
            f"{key:14s} {'|dv| mean':>10s} {'rms':>8s} {'p95':>8s} {'|dp| mean':>10s} {'rms':>8s} "
            f"{'p95':>8s}" + ("   paper |dv| |dp|" if res.study == "table3" else "")
        )
        for r in res.rows:
            p = PAPER_TABLE3.get(r.get("group"), ("", "")) if res.study == "table3" else ("", "")
            lines.append(
                f"{str(r[key]):14s} {r['final_velocity_error_m_s_mean']:10.4f} "
                f"{r['final_velocity_error_m_s_rms']:8.4f} "
                f"{r['final_velocity_error_m_s_p95']:8.4f} "
                f"{r['final_position_error_m_mean']:10.2f} {r['final_position_error_m_rms']:8.2f} "
                f"{r['final_position_error_m_p95']:8.2f}   {p[0]} {p[1]}"
            )
    return "\n".join(lines)


def _json_doc(res) -> dict:
    from fieldmap.nav.studies import PAPER_TABLE1, PAPER_TABLE3

    doc = {
        "study": res.study,
        "truth_model": res.meta["truth_model"],
        "truth_degree": res.meta["truth_degree"],
        "meta": res.meta,
    }
    if res.study == "table1":
        doc["floor"] = res.meta["floor"]
        for r in res.rows:
            doc[r["model"]] = {k: v for k, v in r.items() if k != "model"}
        doc["paper"] = {
            k: dict(
                zip(
                    ("final_velocity_error_m_s", "final_position_error_m", "gravity_eval_seconds"),
                    v,
                )
            )
            for k, v in PAPER_TABLE1.items()
        }
    else:
        doc["rows"] = res.rows
        if res.study == "table3":
            doc["paper"] = {
                f"group{k}": dict(zip(("final_velocity_error_m_s", "final_position_error_m"), v))
                for k, v in PAPER_TABLE3.items()
            }
    return doc


def write_outputs(res, out) -> list[str]:
    """CSV, JSON, NetCDF and PNG of one study; return the paths.

    ``out`` is a folder (the four files are written as one
    :func:`fieldmap.products.io.output_batch`)
    or an open :class:`fieldmap.products.io.OutputBatch` (committed by its owner).
    """
    from fieldmap.products.io import OutputBatch, output_batch, signals_deferred

    if not isinstance(out, OutputBatch):
        with output_batch(out) as batch:
            paths = write_outputs(res, batch)
        return paths
    base = f"navsim_{res.study}"
    buf = io.StringIO()
    keys = list(dict.fromkeys(k for r in res.rows for k in r))
    w = csv.DictWriter(buf, fieldnames=keys)
    w.writeheader()
    w.writerows(res.rows)
    paths = [
        out.text(buf.getvalue(), base + ".csv"),
        out.text(json.dumps(_json_doc(res), indent=2, default=float) + "\n", base + ".json"),
        out.netcdf(to_dataset(res), base + ".nc"),
    ]
    with signals_deferred():  # see fieldmap.products.io.signals_deferred
        plot(res, str(out.path(base + ".png")))
    paths.append(out.folder / (base + ".png"))
    return [str(p) for p in paths]


def to_dataset(res):
    """Error curves of a study as an ``xarray.Dataset`` (dims run, time; CF-1.8 attributes)."""
    import xarray as xr

    ds = xr.Dataset(
        {
            "position_error": (
                ("run", "time"),
                res.pos,
                {"units": "m", "long_name": "norm of the a-frame position error"},
            ),
            "velocity_error": (
                ("run", "time"),
                res.vel,
                {"units": "m s-1", "long_name": "norm of the inertial velocity error"},
            ),
        },
        coords={
            # an auxiliary coordinate: CF coordinate variables are numeric (CF 1.8 §5)
            "label": ("run", np.array(res.labels, dtype=str), {"long_name": "run label"}),
            "time": ("time", res.t, {"units": "s", "long_name": "time since launch"}),
        },
        attrs={
            "Conventions": "CF-1.8",
            "title": f"fieldmap navsim {res.study}",
            "source": f"truth {res.meta['truth_model']} degree {res.meta['truth_degree']}",
            "meta": json.dumps(res.meta, default=float),
        },
    )
    return ds


def plot(res, path: str) -> None:
    """Write the study's figure (Figs. 11-13 like; see :mod:`fieldmap.nav.plots`) as PNG."""
    from fieldmap.nav.plots import plot as _plot

    _plot(res, path)

"""CLI sub-commands ``fieldmap map``, ``fieldmap sweep`` and ``fieldmap truncation``.

Each validates all input first (grid, model degree, thresholds, device, output folder), then
computes, then writes NetCDF (CF-1.8), PNG figures and a JSON summary atomically under
``--out`` (default ``outputs/``) and prints a short statistics table. Bad input writes nothing.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import xarray as xr

from fieldmap.cli.common import (
    api_call,
    heights_km,
    list_values,
    map_request,
    preflight,
    print_files,
    stem,
    streamed,
    streaming_options,
    thresholds_mg,
)

DEFAULT_THRESHOLDS = "0.02,0.05,0.06,0.10"


def _list_arg(p: argparse.ArgumentParser, name: str, default: str, help: str) -> None:
    p.add_argument(
        name,
        nargs="+",
        default=[default],
        help=help + "; separate arguments or comma-separated (default: " + default + ")",
    )


def _common(p: argparse.ArgumentParser, model: bool = True) -> None:
    if model:
        p.add_argument(
            "--model",
            default="eigen-6s",
            help="bundled model name or ICGEM .gfc[.gz] file (default: eigen-6s, degree 240)",
        )
        p.add_argument(
            "--lmax",
            type=int,
            default=None,
            help="truncation degree, 0..the model's (default: the model's full degree)",
        )
        p.add_argument(
            "--epoch",
            default=None,
            help="epoch of time-variable models: decimal year (1900..2200) or YYYY-MM-DD "
            "(refused for a model without time-variable terms)",
        )
        from fieldmap.cli.model_options import add_model_options

        add_model_options(p)
        from fieldmap.products.quantities import MAP_QUANTITIES, cli_help

        p.add_argument(
            "--quantity",
            # the registry of fieldmap.products.quantities (no xarray: a light import)
            choices=MAP_QUANTITIES,
            default="disturbance",
            help=cli_help(),
        )
        p.add_argument(
            "--minus",
            default=None,
            metavar="REFERENCE",
            help="--quantity ewh: the reference field subtracted from --model (a mean field, "
            "another month, or the same time-variable model: with --epoch T the change since "
            "its reference epoch); loaded with --lmax and the model-file options",
        )
        p.add_argument(
            "--omission-model",
            # fieldmap.field.omission.DEGREE_VARIANCE_MODELS, spelt out (start-up time)
            choices=("tscherning-rapp", "kaula", "fitted"),
            default=None,
            help="degree-variance model of --quantity omission-sigma: tscherning-rapp "
            "(Tscherning & Rapp 1974 model 4, default), kaula (Kaula's rule 1e-5/n^2) or fitted "
            "(a power law fitted to the model's own degrees L/2..L)",
        )
    p.add_argument(
        "--step-deg",
        type=float,
        default=1.0,
        help="grid step in degrees, > 0 and at most the region's size (default 1)",
    )
    p.add_argument(
        "--lat-max",
        type=float,
        default=80.0,
        help="global grid from -LAT_MAX to LAT_MAX degrees, 0 < LAT_MAX <= 90 "
        "(default 80, as the paper); rows symmetric about the equator: -LAT_MAX..LAT_MAX when "
        "2 LAT_MAX is a whole number of steps, else the multiples of the step within it",
    )
    p.add_argument(
        "--region",
        type=float,
        nargs=4,
        metavar=("W", "E", "S", "N"),
        default=None,
        help="regional grid instead of global: west east south north in degrees "
        "(longitudes -360..360, W > E crosses the antimeridian; -90 <= S < N <= 90)",
    )
    p.add_argument("--ellipsoid", default="WGS84", help="normal field: WGS84 (default) or GRS80")
    p.add_argument(
        "--device", default=None, help="Warp device: cpu, cuda, cuda:N (default: cuda if present)"
    )
    p.add_argument(
        "--out",
        default="outputs",
        help="output folder, created with its parents if missing (default: outputs/); "
        "nothing is written unless the whole run succeeds",
    )
    p.add_argument("--no-plots", action="store_true", help="write NetCDF and JSON only")
    p.add_argument(
        "--float32",
        action="store_true",
        help="store the maps of the NetCDF file in single precision (half the size; relative "
        "rounding error <= 6e-8, e.g. 2e-5 mGal on 300 mGal)",
    )


def register(
    subparsers: argparse._SubParsersAction[argparse.ArgumentParser],
    commands: tuple[str, ...] = ("map", "sweep", "truncation"),
) -> None:
    """Add the map, sweep and truncation sub-commands (or those of ``commands`` only).

    :func:`fieldmap.cli.build_parser` names the one run: ``fieldmap map`` then imports nothing
    of ``truncation``'s options (:mod:`fieldmap.cli.degree`).
    """
    for command in commands:
        _REGISTER[command](subparsers)


def _register_map(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``fieldmap map``."""
    p = subparsers.add_parser(
        "map",
        help="gravity-disturbance map at one height (the main job)",
        description=(
            "Global (80S-80N) or regional map of the gravity disturbance "
            "g_model - gamma_exact: east, north, up, modulus in mGal and mg, with area-weighted "
            "statistics. Writes NetCDF, JSON and PNG (isolines, threshold maps) to --out. "
            "Bad input: one line on stderr, exit status 2, nothing written."
        ),
    )
    _common(p)
    _list_arg(p, "--height-km", "20", "height above the ellipsoid in km, -10 to 1e5")
    _list_arg(
        p,
        "--thresholds-mg",
        DEFAULT_THRESHOLDS,
        "thresholds in mg (1 mg = 9.80665e-3 m/s²) for area fractions and isolines, "
        "positive and distinct",
    )
    streaming_options(p)
    _percentile_option(p)
    p.set_defaults(func=run_map)


def _register_sweep(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``fieldmap sweep``."""
    p = subparsers.add_parser(
        "sweep",
        help="disturbance statistics over several heights",
        description="Disturbance maps (east, north, up, modulus in mGal and mg) and their "
        "area-weighted statistics at several heights: table, plot, maps. Bad input: one line "
        "on stderr, exit status 2, nothing written.",
    )
    _common(p)
    _list_arg(
        p,
        "--height-km",
        "20,30,50,70,100",
        "heights above the ellipsoid in km, -10 to 1e5, distinct",
    )
    _list_arg(
        p,
        "--thresholds-mg",
        DEFAULT_THRESHOLDS,
        "thresholds in mg (1 mg = 9.80665e-3 m/s²), positive and distinct",
    )
    streaming_options(p)
    _percentile_option(p)
    p.set_defaults(func=run_sweep)


def _register_truncation(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``fieldmap truncation``."""
    p = subparsers.add_parser(
        "truncation",
        help="J2/J4/J6 normal gravitation truncation-error maps, or SH omission maps "
        "(--degrees) and the degree a tolerance needs (--tolerance-mgal)",
        description="Maps of the J2n normal gravitation minus the exact level-ellipsoid one "
        "(east, north, up, modulus in mGal and mg) for each order; with --degrees, of the "
        "spherical-harmonic omission of each degree d (the model's degrees d+1..L), with "
        "--tolerance-mgal the smallest degree whose omission stays within it. Bad input: one "
        "line on stderr, exit status 2, nothing written.",
    )
    _common(p, model=False)
    _list_arg(p, "--height-km", "20", "height above the ellipsoid in km, -10 to 1e5")
    _list_arg(p, "--orders", "2,4,6", "normal models j2, j4, j6 by name or order (2, 4, 6)")
    p.add_argument(
        "--scheduler",
        default=None,
        help="evaluate the rows on Dask: local:N (a cluster of N worker processes for this run), "
        "a scheduler address (tcp://host:port) or 'threads' (here); the same numbers "
        "(default: here)",
    )
    from fieldmap.cli import degree

    degree.add_options(p)
    p.set_defaults(func=run_truncation)


_REGISTER = {"map": _register_map, "sweep": _register_sweep, "truncation": _register_truncation}


def _percentile_option(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--percentile-method",
        choices=("histogram", "exact"),
        default="histogram",
        help="percentiles of the modulus: from per-block histograms (default; relative accuracy "
        "1.2e-4, the same bits on every executor and format) or exact (maps held in memory)",
    )


def _write(
    ds: xr.Dataset, stem: str, out: Path, figures: list, summary: dict, float32: bool = False
) -> list[Path]:
    """Write NetCDF, JSON and figures as one batch: all files appear, or none."""
    from tqdm.auto import tqdm

    from fieldmap.products.engine import show_progress
    from fieldmap.products.io import output_batch
    from fieldmap.products.variables import summary as _summary

    js = {**_summary(ds), **summary}
    nodes = ds.sizes["latitude"] * ds.sizes["longitude"] * ds.sizes.get("height", 1)
    # writing a fine map (NetCDF, figures) takes longer than computing it
    bar = tqdm(
        total=2 + len(figures),
        desc="writing",
        unit="file",
        leave=False,
        disable=not show_progress(nodes),
    )
    with bar, output_batch(out) as batch:
        batch.netcdf(ds, f"{stem}.nc", dtype="float32" if float32 else "float64")
        batch.json(js, f"{stem}.json")
        bar.update(2)
        for suffix, make in figures:
            batch.png(make(), f"{stem}_{suffix}.png")
            bar.update(1)
        return batch.commit()


def _check_omission_option(args: argparse.Namespace) -> None:
    """Refuse ``--omission-model`` with a quantity other than omission-sigma (one line).

    Likewise ``--minus`` with a quantity other than ewh, and ewh without ``--minus``.
    """
    from fieldmap.cli.common import check_minus
    from fieldmap.errors import InputError

    if args.omission_model is not None and args.quantity != "omission-sigma":
        raise InputError(
            f"--omission-model applies to --quantity omission-sigma, not to --quantity "
            f"{args.quantity}"
        )
    check_minus(args)


def _disturbance_figures(ds: xr.Dataset, thresholds: list[float]) -> list:
    """Return the figures of a disturbance map or sweep (matplotlib imported only for them)."""
    from fieldmap.products import plots

    return plots.disturbance_figures(ds, thresholds)


def run_map(args: argparse.Namespace) -> int:
    """``fieldmap map``: disturbance map at one height."""
    from fieldmap.products.engine import compute
    from fieldmap.products.variables import fraction_attr

    _check_omission_option(args)
    (height_km,) = heights_km(args, "map takes one height; use sweep for several")
    if args.quantity != "disturbance":
        from fieldmap.cli.quantity import run_quantity

        return run_quantity(args, [height_km])
    thresholds = thresholds_mg(args)
    if streamed(args):
        from fieldmap.cli import distributed

        return distributed.run(args, [height_km], thresholds, stacked=False)
    preflight(args, [height_km])
    t0 = time.perf_counter()
    ds = compute(
        map_request(
            args,
            [height_km],
            thresholds_mg=thresholds,
            percentile_method=args.percentile_method,
        )
    )
    elapsed = time.perf_counter() - t0
    a = ds.attrs
    print(
        f"{a['model']} degree {a['model_lmax']}, h = {height_km:g} km, "
        f"{ds.sizes['latitude']} x {ds.sizes['longitude']} nodes, {elapsed:.2f} s"
    )
    print(
        f"  max {a['max_mg']:.4f} mg   mean {a['mean_mg']:.4f} mg   "
        f"median {a['p50_mg']:.4f} mg   p99 {a['p99_mg']:.4f} mg"
    )
    print("  threshold (mg)   area above (%)")
    for t in thresholds:
        print(f"  {t:>14g}   {100 * a[fraction_attr(t)]:>14.2f}")
    figures = [] if args.no_plots else _disturbance_figures(ds, thresholds)
    print_files(_write(ds, stem(ds, "disturbance"), Path(args.out), figures, {}, args.float32))
    return 0


def run_sweep(args: argparse.Namespace) -> int:
    """``fieldmap sweep``: statistics over several heights."""
    from fieldmap.products.engine import compute

    _check_omission_option(args)
    thresholds = thresholds_mg(args)
    heights = heights_km(args)
    if args.quantity != "disturbance":
        from fieldmap.cli.quantity import run_quantity

        return run_quantity(args, heights)
    if streamed(args):
        from fieldmap.cli import distributed

        return distributed.run(args, heights, thresholds, stacked=True)
    preflight(args, heights)
    t0 = time.perf_counter()
    ds = compute(
        map_request(
            args,
            heights,
            stacked=True,
            thresholds_mg=thresholds,
            percentile_method=args.percentile_method,
        )
    )
    elapsed = time.perf_counter() - t0
    print(
        f"{ds.attrs['model']} degree {ds.attrs['model_lmax']}, {ds.sizes['latitude']} x "
        f"{ds.sizes['longitude']} nodes x {ds.sizes['height']} heights, {elapsed:.2f} s"
    )
    head = "  h (km)   max (mg)  mean (mg)" + "".join(f"  >{t:g} mg (%)" for t in thresholds)
    print(head)
    for k, h in enumerate(ds["height_km"].values):
        row = f"  {h:>6g}   {ds['max_mg'].values[k]:8.4f}   {ds['mean_mg'].values[k]:8.4f}"
        row += "".join(
            f"  {100 * f:>{len(f'>{t:g} mg (%)')}.2f}"
            for t, f in zip(thresholds, ds["area_fraction_above"].values[k])
        )
        print(row)
    figures = [] if args.no_plots else _disturbance_figures(ds, thresholds)
    print_files(_write(ds, stem(ds, "sweep"), Path(args.out), figures, {}, args.float32))
    return 0


def run_truncation(args: argparse.Namespace) -> int:
    """``fieldmap truncation``: J2n truncation-error maps, or SH omission (--degrees)."""
    from fieldmap.cli import degree

    if degree.wanted(args):
        return degree.run(args)
    from fieldmap.limits import check_orders
    from fieldmap.products import plots
    from fieldmap.products.engine import compute

    orders = api_call("--orders", check_orders, list_values(args.orders, "--orders"))
    (height_km,) = heights_km(args, "truncation takes one height")
    preflight(args, [height_km], layers=len(orders))
    # the request connects to (or starts) the scheduler first: an unreachable one writes nothing
    ds = compute(map_request(args, [height_km], quantity="truncation", orders=orders))
    print(f"J2n truncation error at h = {height_km:g} km ({ds.attrs['ellipsoid']})")
    print("  order   max (mg)      mean (mg)")
    for o, mx, mn in zip(ds["order"].values, ds["max_mg"].values, ds["mean_mg"].values):
        print(f"  J{int(o):<5d} {mx:11.4e}   {mn:11.4e}")
    figures = [] if args.no_plots else [("maps", lambda: plots.plot_truncation(ds))]
    print_files(_write(ds, stem(ds, "truncation"), Path(args.out), figures, {}, args.float32))
    return 0

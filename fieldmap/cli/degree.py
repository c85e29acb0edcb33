"""``fieldmap truncation --degrees`` / ``--tolerance-mgal``: the SH degree you need.

The spherical-harmonic form of ``fieldmap truncation`` (:mod:`fieldmap.cli.maps` runs the J2n
form): omission maps δg_full − δg_d for each ``--degrees`` d (:func:`fieldmap.products.degree.
omission_map`) and, with ``--tolerance-mgal T``, the smallest degree whose omission max over the
grid and heights is ≤ T (:func:`fieldmap.products.degree.degree_needed`). With ``--tolerance-mgal``
alone the maps are those of the degree found. ``--orders`` (J2n) and ``--degrees`` together, or
``--scheduler`` (J2n rows only) here, are refused; ``--model``/``--lmax`` only apply here.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fieldmap.cli.common import api_call, heights_km, list_values, preflight, print_files, region
from fieldmap.errors import InputError

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.figure import Figure


def add_options(p: argparse.ArgumentParser) -> None:
    """Add ``--degrees``, ``--tolerance-mgal``, ``--model`` and ``--lmax`` to ``truncation``."""
    p.add_argument(
        "--degrees",
        nargs="+",
        default=None,
        help="spherical-harmonic omission maps instead of J2n: for each degree d (2..L, distinct "
        "integers) the field of degrees d+1..L of --model (δg_full − δg_d); separate arguments "
        "or comma-separated, e.g. 18,36,90,180; not with --orders",
    )
    p.add_argument(
        "--tolerance-mgal",
        default=None,
        help="report the smallest degree whose omission max over the grid and all heights is "
        "<= this (mGal, > 0), by bisection; alone, the maps are those of that degree",
    )
    p.add_argument(
        "--model",
        default=None,
        help="model of --degrees/--tolerance-mgal: bundled name or ICGEM .gfc[.gz] file "
        "(default: eigen-6s)",
    )
    p.add_argument(
        "--lmax",
        type=int,
        default=None,
        help="truncate the model of --degrees/--tolerance-mgal to this degree first "
        "(the full model L; default: its own degree)",
    )
    from fieldmap.cli.model_options import add_tide_option

    add_tide_option(p)


def wanted(args: argparse.Namespace) -> bool:
    """Whether the run is the SH form; refuse mixed or stray options (one line each)."""
    from fieldmap.cli import given

    sh = args.degrees is not None or args.tolerance_mgal is not None
    if sh:
        if given(args, "orders"):
            other = "--degrees" if args.degrees is not None else "--tolerance-mgal"
            raise InputError(f"--orders and {other} together: J2n orders or SH degrees, not both")
        if args.scheduler is not None:
            raise InputError("--scheduler applies to the J2n maps (--orders), not to --degrees")
    else:
        for dest, opt in (
            ("model", "--model"),
            ("lmax", "--lmax"),
            ("tide_system", "--tide-system"),
        ):
            if given(args, dest) or getattr(args, dest) is not None:
                raise InputError(f"{opt} applies with --degrees or --tolerance-mgal")
    return sh


def run(args: argparse.Namespace) -> int:
    """Validate everything, compute, print, then write NetCDF, JSON (and PNG)."""
    from fieldmap.models.registry import announce, load_model
    from fieldmap.products import degree as deg

    heights = heights_km(args)
    tol = None
    if args.tolerance_mgal is not None:
        tol = api_call("--tolerance-mgal", deg.check_tolerance, args.tolerance_mgal)
    preflight(args, heights)
    model = load_model(args.model or "eigen-6s", lmax=args.lmax, tide_system=args.tide_system)
    announce(model)
    degrees = None
    if args.degrees is not None:
        degrees = api_call(
            "--degrees", deg.check_degrees, list_values(args.degrees, "--degrees"), model.lmax
        )
    preflight(args, heights, layers=len(degrees or (1,)))
    grid_kw = dict(
        height_km=heights,
        step_deg=args.step_deg,
        lat_max=args.lat_max,
        region=region(args),
        device=args.device,
        ellipsoid=args.ellipsoid,
    )
    found = None
    if tol is not None:
        found = deg.degree_needed(model, tolerance_mgal=tol, **grid_kw)
    ds = deg.omission_map(model, degrees=degrees or (found or {})["degree_needed"], **grid_kw)
    _print(ds, found)
    if found is not None:
        ds.attrs.update(
            degree_needed=found["degree_needed"],
            tolerance_mgal=found["tolerance_mgal"],
            omission_max_at_degree_needed_mgal=found["omission_max_mgal"],
            omission_max_below_degree_needed_mgal=found["omission_max_below_mgal"],
        )
    print_files(_write(ds, found, Path(args.out), args.no_plots, args.float32))
    return 0


def _print(ds: xr.Dataset, found: dict[str, Any] | None) -> None:
    a = ds.attrs
    print(
        f"SH omission of {a['model']} degree {a['model_lmax']} ({a['ellipsoid']}, "
        f"{a['model_tide_system']}), mGal"
    )
    print("  degree   h (km)    max         mean        rms         p99")
    for i, d in enumerate(ds["degree"].values):
        for k, h in enumerate(ds["height"].values):
            row = [float(ds[f"{s}_mgal"].values[i, k]) for s in ("max", "mean", "rms", "p99")]
            print(f"  {int(d):<6d} {h / 1e3:7g}  " + "  ".join(f"{v:10.4e}" for v in row))
    if found is not None:
        d = found["degree_needed"]
        print(
            f"degree needed for {found['tolerance_mgal']:g} mGal: {d} "
            f"(omission max {found['omission_max_mgal']:.4g} mGal; degree {d - 1}: "
            f"{found['omission_max_below_mgal']:.4g} mGal)"
        )


def summary(ds: xr.Dataset, found: dict[str, Any] | None) -> dict:
    """JSON-ready statistics of an omission map, with the degree found when there is one."""
    a = ds.attrs
    out: dict = {
        "product": "omission",
        "model": a["model"],
        "lmax": a["model_lmax"],
        "tide_system": a["model_tide_system"],
        "ellipsoid": a["ellipsoid"],
        "grid_step_deg": a["grid_step_deg"],
        "region_deg": [float(x) for x in a["region_west_east_south_north_deg"]],
        "height_m": [float(x) for x in ds["height"].values],
        "degrees": [int(d) for d in ds["degree"].values],
    }
    for s in ("max", "mean", "rms", "p99"):
        out[f"{s}_mgal"] = {
            str(int(d)): [float(v) for v in ds[f"{s}_mgal"].values[i]]
            for i, d in enumerate(ds["degree"].values)
        }
    if found is not None:
        out.update(
            degree_needed=found["degree_needed"],
            tolerance_mgal=found["tolerance_mgal"],
            omission_max_at_degree_needed_mgal=found["omission_max_mgal"],
            omission_max_below_degree_needed_mgal=found["omission_max_below_mgal"],
            omission_max_evaluated_mgal={str(k): v for k, v in found["evaluated"].items()},
        )
    return out


def _stem(ds: xr.Dataset) -> str:
    from fieldmap.cli.common import stem

    base = stem(ds, "omission")
    hs = "-".join(f"{h / 1e3:g}" for h in ds["height"].values)
    model = f"{ds.attrs['model'].lower()}_L{ds.attrs['model_lmax']}"
    return base.replace(model, f"{model}_h{hs}km".replace("/", "-").replace(" ", ""), 1)


def _write(
    ds: xr.Dataset, found: dict[str, Any] | None, out: Path, no_plots: bool, float32: bool
) -> list[Path]:
    from fieldmap.products.io import output_batch

    name = _stem(ds)
    with output_batch(out) as batch:
        batch.netcdf(ds, f"{name}.nc", dtype="float32" if float32 else "float64")
        batch.json(summary(ds, found), f"{name}.json")
        if not no_plots:
            batch.png(_plot(ds), f"{name}_maps.png")
        return batch.commit()


def _plot(ds: xr.Dataset) -> Figure:
    """Omission modulus per degree (rows) at the lowest height, in the map style."""
    from fieldmap.products.plots import plot_omission

    return plot_omission(ds)

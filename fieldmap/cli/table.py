"""Sub-command ``fieldmap table``: a gravity compensation table with a verified error bound.

``fieldmap table --region W E S N --height-km MIN,MAX --max-error-mgal B [--budget-mb M]
[--corridor FLIGHT --width-km W]`` writes ``table.nc`` (CF-1.8), ``table.bin`` (flat
little-endian), ``table.h`` (its C layout and interpolation) and ``table.json`` (the
verification report) into ``--out``: δg north, east, down (mGal) on a lattice whose spacings are
refined until the interpolation error, measured on a denser independent check set, is within B
(:mod:`fieldmap.products.tables.build`). Read it back with ``fieldmap point --model table:FILE``.

``--corridor`` alone: the track's bounding box widened by ``--width-km``; with ``--region``: the
intersection of both (refused when they do not overlap). The heights must hold the track's, with
the margin that ``navsim`` asks of a table (refused otherwise: navsim would refuse the table).
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy.typing as npt


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``table`` sub-command."""
    p = subparsers.add_parser(
        "table",
        help="gravity compensation table (δg north, east, down) with a verified error bound",
        description=(
            "Tabulate the gravity disturbance north, east, down (mGal; model gravity minus "
            "exact WGS84 normal gravity, the δg an INS adds to its normal gravity) on a "
            "latitude-longitude-height lattice whose spacings are refined until the "
            "Catmull-Rom (cubic) interpolation error, checked at cell centres, mid-heights "
            "and random points against direct evaluations, is within --max-error-mgal on "
            "every component. Writes table.nc, table.bin, table.h and table.json into --out; "
            "a bound the budget cannot meet is refused in one line (exit 2), nothing written. "
            "Check a table with 'fieldmap point --model table:FILE'."
        ),
    )
    p.add_argument(
        "--region",
        nargs=4,
        type=float,
        metavar=("W", "E", "S", "N"),
        default=None,
        help="valid domain west east south north, degrees (|lat| <= 89; W > E crosses the "
        "antimeridian)",
    )
    p.add_argument(
        "--height-km",
        default=None,
        help="MIN,MAX: lowest and highest height above the ellipsoid, km (MIN < MAX); "
        "required (the option of map and sweep)",
    )
    p.add_argument(
        "--heights-km",
        dest="heights_km_deprecated",
        default=None,
        help="deprecated spelling of --height-km (removed in fieldmap 0.3)",
    )
    p.add_argument(
        "--max-error-mgal",
        type=float,
        required=True,
        help="largest interpolation error accepted on each component, mGal",
    )
    p.add_argument(
        "--budget-mb",
        type=float,
        default=8.0,
        help="largest table.bin, MB (1e6 bytes; default 8)",
    )
    p.add_argument(
        "--corridor",
        default=None,
        metavar="FLIGHT",
        help="flight log (CSV, GPX, NMEA, IGC): the table covers its bounding box plus "
        "--width-km (intersected with --region when both are given)",
    )
    p.add_argument(
        "--width-km",
        type=float,
        default=None,
        help="margin around the --corridor track, km (default 50)",
    )
    p.add_argument(
        "--model",
        default="eigen-6s",
        help="gravity model: bundled name, model file or GeographicLib model (default eigen-6s)",
    )
    from fieldmap.cli.model_options import add_model_options

    add_model_options(p)
    p.add_argument("--lmax", type=int, default=None, help="truncation degree of the model")
    p.add_argument("--device", default=None, help="Warp device: cpu, cuda, cuda:N (default: auto)")
    p.add_argument("--out", default="outputs", help="output folder (default: outputs)")
    p.set_defaults(func=run_table)


def _height_option(args: argparse.Namespace) -> tuple[str, str]:
    """Return (the option given, its text): ``--height-km``, or the deprecated ``--heights-km``.

    The deprecated spelling works, with a note on stderr; both, or neither, is one line.
    """
    import sys

    from fieldmap.errors import InputError

    new, old = args.height_km, args.heights_km_deprecated
    if new is not None and old is not None:
        raise InputError("give --height-km once (--heights-km is its deprecated spelling)")
    if new is None and old is None:
        raise InputError("--height-km MIN,MAX is required (lowest and highest height, km)")
    if old is not None:
        print(
            "fieldmap table: --heights-km is deprecated (removed in fieldmap 0.3): use "
            "--height-km, as map and sweep do",
            file=sys.stderr,
        )
        return "--heights-km", old
    return "--height-km", new


def _heights(text: str, option: str = "--height-km") -> list[str]:
    from fieldmap.errors import InputError

    parts = [t for t in str(text).replace(",", " ").split()]
    if len(parts) != 2:
        raise InputError(f"{option} needs MIN,MAX (two numbers, km), got {text!r}")
    return parts


def _check_corridor_heights(
    flight: str, heights_m: npt.ArrayLike, option: str = "--height-km"
) -> None:
    """Refuse heights (``option``) that do not hold the ``--corridor`` flight as navsim flies it.

    ``navsim`` refuses a table that does not cover the conditioned path (outliers removed,
    ground segments trimmed) with :data:`~fieldmap.nav.study.TABLE_HEIGHT_MARGIN` above and
    below it, checked every second; the same path and margin are asked of the heights here,
    so a table made for its flight is one navsim accepts.
    """
    import math

    import numpy as np

    from fieldmap.errors import InputError
    from fieldmap.nav.logs import load_flight
    from fieldmap.nav.study import TABLE_HEIGHT_MARGIN as margin

    traj, _ = load_flight(flight)
    t = np.unique(np.r_[np.arange(0.0, traj.duration, 1.0), traj.duration])
    h = np.asarray(traj.geodetic(t)[2], dtype=np.float64)
    lo, hi = float(np.min(heights_m)), float(np.max(heights_m))
    out = np.flatnonzero((h - margin < lo) | (h + margin > hi))
    if out.size:
        i = int(out[0])
        # outward to 0.1 km, strictly beyond the margin
        need_lo = math.floor((h.min() - margin) / 100.0 - 1e-9) / 10.0
        need_hi = math.ceil((h.max() + margin) / 100.0 + 1e-9) / 10.0
        raise InputError(
            f"{option} {lo / 1e3:g},{hi / 1e3:g} do not hold the --corridor flight: at "
            f"t = {t[i]:g} s it is at {h[i]:.0f} m (its path as navsim flies it: "
            f"{h.min():.0f}..{h.max():.0f} m above the ellipsoid; navsim asks ±{margin:g} m "
            f"around it): give at least {option} {min(need_lo, lo / 1e3):g},"
            f"{max(need_hi, hi / 1e3):g}"
        )


def run_table(args: argparse.Namespace) -> int:
    """Run ``fieldmap table``; return the exit status."""
    import sys
    import time

    from fieldmap.cli import given
    from fieldmap.cli.common import api_call
    from fieldmap.errors import InputError
    from fieldmap.limits import heights_from_km
    from fieldmap.models.registry import announce, load_model, model_options
    from fieldmap.products.io import check_out_dir
    from fieldmap.products.tables.build import build_table, check_region, corridor_region
    from fieldmap.products.tables.files import write_table

    if args.corridor is None and given(args, "width_km"):
        raise InputError("--width-km applies to --corridor (the margin around a flight track)")
    if args.corridor is None and args.region is None:
        raise InputError("give --region W E S N, --corridor FLIGHT, or both")
    option, text = _height_option(args)
    heights = _heights(text, option)
    metres = api_call(option, heights_from_km, heights, distinct=False)
    if not metres[0] < metres[1]:
        raise InputError(f"{option} needs MIN,MAX with MIN < MAX, got {','.join(heights)}")
    if args.region is not None:
        api_call("--region", check_region, args.region)
    if args.lmax is not None and args.lmax < 0:
        raise InputError(f"--lmax must be >= 0, got {args.lmax}")
    opts = model_options(args)
    if args.corridor is not None:
        # the flight is read with the defaults: the readers' advice is left out where reported
        # (table has none of their options; fieldmap.cli.options_of)
        width = 50.0 if args.width_km is None else args.width_km
        region = corridor_region(args.corridor, width, args.region)
        _check_corridor_heights(args.corridor, metres, option)
    else:
        region = api_call("--region", check_region, args.region)
    check_out_dir(args.out)
    model = load_model(args.model, lmax=args.lmax, **opts)
    announce(model)
    t0 = time.perf_counter()
    tab, report = build_table(
        region,
        heights,
        args.max_error_mgal,
        budget_mb=args.budget_mb,
        model=model,
        device=args.device,
        log=lambda line: print(f"  {line}", file=sys.stderr),
    )
    files = write_table(tab, report, args.out)
    _print_report(report, time.perf_counter() - t0)
    print("written: " + ", ".join(str(f) for f in files))
    return 0


def _print_report(rep: dict, elapsed: float) -> None:
    lat = rep["lattice"]
    d = lat["valid_domain"]
    ver = rep["verification"]
    print(
        f"{rep['model']} degree {rep['lmax']}: latitude {d['south']:g}..{d['north']:g}, "
        f"longitude {d['west']:g}..{d['east']:g}, height {d['hmin']:g}..{d['hmax']:g} m"
    )
    print(
        f"  lattice {lat['nh']} x {lat['nlat']} x {lat['nlon']} (h x lat x lon, margin incl.): "
        f"dlat {lat['dlat_deg']:.6g} deg, dlon {lat['dlon_deg']:.6g} deg, dh {lat['dh_m']:.6g} "
        f"m; {rep['size_bytes'] / 1e6:.3f} MB ({elapsed:.1f} s)"
    )
    print(
        f"  verified on {ver['overall']['points']} check points: max {ver['max_mgal']:.4f} mGal "
        f"(bound {rep['max_error_mgal']:g}), rms {ver['rms_mgal']:.4f} mGal"
    )
    print("  height (m)   max dn     max de     max dd     rms dn     rms de     rms dd  (mGal)")
    for row in ver["per_height"]:
        mx, rm = row["max_mgal"], row["rms_mgal"]
        print(
            f"  {row['height_m']:10.1f} "
            + " ".join(f"{mx[c]:10.4f}" for c in ("dn", "de", "dd"))
            + " "
            + " ".join(f"{rm[c]:10.4f}" for c in ("dn", "de", "dd"))
        )

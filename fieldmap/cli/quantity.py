"""``fieldmap map|sweep --quantity anomaly|deflection|geoid|potential`` (geodetic quantity maps).

The disturbance stays with :mod:`fieldmap.cli.maps`; this module runs the other quantities of
:func:`fieldmap.products.maps.quantity_map` with the same grid options, checks and atomic outputs.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import xarray as xr
    from distributed import Client
    from matplotlib.figure import Figure


def run_quantity(args: argparse.Namespace, heights_km: list[float]) -> int:
    """Compute, print and write a quantity map (one height) or sweep (several)."""
    from fieldmap.cli.common import map_request, preflight, print_files, stem, streamed
    from fieldmap.errors import InputError
    from fieldmap.products.engine import compute
    from fieldmap.products.io import output_batch
    from fieldmap.products.variables import summary

    if getattr(args, "percentile_method", "histogram") != "histogram":
        raise InputError(
            f"--percentile-method applies to the disturbance modulus, not to --quantity "
            f"{args.quantity}"
        )
    from fieldmap.cli import given

    if given(args, "thresholds_mg"):
        raise InputError(
            f"--thresholds-mg applies to the disturbance modulus, not to --quantity {args.quantity}"
        )
    from fieldmap.products.quantities import quantity

    entry = quantity(args.quantity)
    if entry.surface and given(args, "height_km"):
        raise InputError(
            f"--height-km: --quantity {args.quantity} is a property of the ellipsoid's surface "
            "(h = 0); leave --height-km out"
        )
    if not entry.uses_model:
        from fieldmap.cli.model_options import MODEL_OPTIONS

        for dest, option in MODEL_OPTIONS.items():
            if given(args, dest):
                raise InputError(
                    f"{option}: no model enters --quantity {args.quantity} ({entry.help}); "
                    "leave the model options out"
                )
    if streamed(args):
        return _run_blocks(args, heights_km)
    preflight(args, heights_km)
    t0 = time.perf_counter()
    ds = compute(map_request(args, heights_km, quantity=args.quantity, stacked=True))
    elapsed = time.perf_counter() - t0
    summ = summary(ds)
    a = ds.attrs
    source = f"{a['model']} degree {a['model_lmax']}" if "model" in a else a["ellipsoid"]
    print(
        f"{source}, {args.quantity}, {ds.sizes['latitude']} x "
        f"{ds.sizes['longitude']} nodes"
        + (f" x {ds.sizes['height']} heights" if "height" in ds.dims else "")
        + f", {elapsed:.2f} s"
    )
    report(args.quantity, summ)
    base = stem(ds, args.quantity)
    with output_batch(Path(args.out)) as batch:
        batch.netcdf(ds, f"{base}.nc", dtype="float32" if args.float32 else "float64")
        batch.json(summ, f"{base}.json")
        if not args.no_plots:
            for suffix, make in figures(ds, args.quantity, summ):
                batch.png(make(), f"{base}_{suffix}.png")
        files = batch.commit()
    print_files(files)
    return 0


def report(quantity: str, summ: dict) -> None:
    """Print the statistics of a quantity map, a line per variable and height."""
    from fieldmap.products.quantities import quantity as entry

    heights = summ["height_m"] if isinstance(summ["height_m"], list) else [summ["height_m"]]
    for var in entry(quantity).variables:
        name, units = var.name, var.units
        s = summ[name]
        for k, h in enumerate(heights):
            pick = (lambda v: v[k]) if isinstance(s["max"], list) else (lambda v: v)
            shown = "E" if units == "1e-9 s-2" else units  # Eötvös
            print(
                f"  {name} ({shown}) h = {h / 1e3:g} km: min {pick(s['min']):.4f}  "
                f"max {pick(s['max']):.4f}  mean {pick(s['mean']):.4f}  rms {pick(s['rms']):.4f}"
            )


def figures(ds: xr.Dataset, quantity: str, summ: dict) -> list[tuple[str, Callable[..., Figure]]]:
    """(file suffix, figure maker) of a quantity map, in its style (``quantity_figures``)."""
    from fieldmap.products.plots import quantity_figures

    return quantity_figures(ds, quantity)


def _run_blocks(args: argparse.Namespace, heights_km: list[float]) -> int:
    """``fieldmap map|sweep --quantity Q --scheduler ...``: a quantity map streamed to a store."""
    from fieldmap.cli.common import map_request, stem
    from fieldmap.cli.distributed import stream
    from fieldmap.products.engine import template, write_product
    from fieldmap.products.variables import summary

    request = map_request(args, heights_km, quantity=args.quantity, stacked=True)
    grid, mod = request.grid, request.model

    def write(tmp: Path, client: Client | None) -> dict:
        return write_product(request.executing(executor=client), tmp, args.format, atomic=False)

    def publish(
        view: xr.Dataset, info: dict, elapsed: float
    ) -> tuple[dict, list[tuple[str, Callable[..., Figure]]]]:
        summ = summary(view)
        nh, nlat, nlon = grid.shape
        source = view.attrs["ellipsoid"] if "model" not in view.attrs else None
        print(
            f"{source or f'{mod.name} degree {mod.lmax}'}, {args.quantity}, {nlat} x {nlon} nodes"
            + (f" x {nh} heights" if nh > 1 else "")
            + f", {elapsed:.2f} s (block by block)"
        )
        report(args.quantity, summ)
        if view.attrs.get("figure_decimation"):
            print(f"  figures from one row and column in {view.attrs['figure_decimation']}")
        return summ, figures(view, args.quantity, summ)

    base = stem(template(request).skeleton(), args.quantity)
    return stream(args, request, base, write, publish)

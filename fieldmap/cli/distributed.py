"""``fieldmap map|sweep --scheduler ... --format ...``: products streamed block by block.

Used by :mod:`fieldmap.cli.maps` when ``--scheduler`` is given or ``--format zarr``
(:func:`fieldmap.cli.common.streamed`, options added by its ``streaming_options``): the blocks
of :mod:`fieldmap.products.engine` run here (``--scheduler threads``), on a LocalCluster
(``local:N``) or on a running Dask scheduler (an address), and go straight to the NetCDF file or
zarr store; figures are drawn from a decimated view of the store. Bad input and an unreachable
scheduler write nothing (one line, exit status 2).
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import xarray as xr
    from distributed import Client
    from matplotlib.figure import Figure

    from fieldmap.grids.spec import GridSpec
    from fieldmap.products.request import MapRequest

    #: ``(file suffix, maker)`` pairs of a product's figures
    Figures = list[tuple[str, Callable[..., Figure]]]
    #: ``publish(view, info, elapsed)``: the JSON summary and the figures
    Publish = Callable[[xr.Dataset, dict, float], tuple[dict, Figures]]


def run(
    args: argparse.Namespace, heights_km: list[float], thresholds: list[float], *, stacked: bool
) -> int:
    """Run ``fieldmap map`` (``stacked=False``) or ``fieldmap sweep`` on the block engine."""
    from fieldmap.cli.common import map_request, stem
    from fieldmap.products import plots
    from fieldmap.products.engine import template, write_product
    from fieldmap.products.variables import summary

    request = map_request(args, heights_km, stacked=stacked, thresholds_mg=thresholds)

    def write(tmp: Path, client: Client | None) -> dict:
        return write_product(request.executing(executor=client), tmp, args.format, atomic=False)

    def publish(view: xr.Dataset, info: dict, elapsed: float) -> tuple[dict, Figures]:
        _report(view, info, request.grid, heights_km, thresholds, elapsed)
        return summary(view), plots.disturbance_figures(view, thresholds)

    base = stem(template(request).skeleton(), "sweep" if stacked else "disturbance")
    return stream(args, request, base, write, publish)


def stream(
    args: argparse.Namespace,
    request: MapRequest,
    base: str,
    write: Callable[[Path, Client | None], dict],
    publish: Publish,
) -> int:
    """Write a product block by block under ``--out``, then its JSON and figures; all or none.

    Connects to the request's executor first (an unreachable scheduler writes nothing);
    ``write(tmp, client)`` streams the
    product to a temporary name and returns its information; ``publish(view, info, elapsed)``
    prints the report from a decimated view of the store and returns the JSON summary and the
    figures as ``(file suffix, maker)`` pairs (drawn unless ``--no-plots``).
    """
    from fieldmap.products.engine import executor_client
    from fieldmap.products.io import check_out_dir, output_batch, writing
    from fieldmap.products.sinks import atomic_store, decimated

    check_out_dir(args.out)
    out = Path(args.out)
    final = out / f"{base}.{'zarr' if args.format == 'zarr' else 'nc'}"
    t0 = time.perf_counter()
    with executor_client(request) as client, output_batch(out) as batch:
        with writing(final), atomic_store(final) as tmp:
            info = write(tmp, client)
            elapsed = time.perf_counter() - t0
            view = decimated(tmp, args.format)
            summ, figures = publish(view, info, elapsed)
            batch.json({**summ, "product_path": final.name}, f"{base}.json")
            for suffix, make in [] if args.no_plots else figures:
                batch.png(make(), f"{base}_{suffix}.png")
        files = batch.commit()
    print("written: " + ", ".join(str(f) for f in [final, *files]))
    return 0


def _report(
    view: xr.Dataset,
    info: dict,
    grid: GridSpec,
    heights_km: Sequence[float],
    thresholds: Sequence[float],
    elapsed: float,
) -> None:
    from fieldmap.products.statistics import threshold_key

    name, lmax = info["model"]
    nh, nlat, nlon = grid.shape
    print(
        f"{name} degree {lmax}, {nlat} x {nlon} nodes x {nh} height(s), {elapsed:.2f} s "
        f"(block by block)"
    )
    print(
        "  h (km)   max (mg)  mean (mg)   p50 (mg)   p99 (mg)"
        + "".join(f"  >{t:g} mg (%)" for t in thresholds)
    )
    for h, s in zip(heights_km, info["stats"]):
        row = f"  {h:>6g}   {s['max_mg']:8.4f}   {s['mean_mg']:8.4f}   {s['p50_mg']:8.4f}"
        row += f"   {s['p99_mg']:8.4f}"
        row += "".join(
            f"  {100 * s['area_fraction_above'][threshold_key(t)]:>{len(f'>{t:g} mg (%)')}.2f}"
            for t in thresholds
        )
        print(row)
    if view.attrs.get("figure_decimation"):
        print(f"  figures from one row and column in {view.attrs['figure_decimation']}")

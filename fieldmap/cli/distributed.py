"""``fieldmap map|sweep --scheduler ... --format ...``: products streamed block by block.

Used by :mod:`fieldmap.cli.maps` when ``--scheduler`` is given or ``--format zarr``: the blocks
of :mod:`fieldmap.products.blocks` run here (``--scheduler threads``), on a LocalCluster
(``local:N``) or on a running Dask scheduler (an address), and go straight to the NetCDF file or
zarr store; figures are drawn from a decimated view of the store. Bad input and an unreachable
scheduler write nothing (one line, exit status 2).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path


def add_options(p: argparse.ArgumentParser) -> None:
    """Add ``--scheduler``, ``--format`` and ``--rows-per-block`` to a map sub-command."""
    p.add_argument(
        "--scheduler",
        default=None,
        help="compute block by block on Dask: local:N (a cluster of N worker processes for this "
        "run), a scheduler address (tcp://host:port), or 'threads' (here, blocks one after the "
        "other); default: the whole map in memory here",
    )
    p.add_argument(
        "--format",
        choices=("netcdf", "zarr"),
        default="netcdf",
        help="product format: netcdf (NetCDF-4, zlib; default) or zarr (chunked, written by "
        "the workers in parallel; implies block-by-block computation)",
    )
    p.add_argument(
        "--rows-per-block",
        type=int,
        default=None,
        help="most latitude rows per block (default: from the memory budget and the grid)",
    )


def wanted(args) -> bool:
    """Tell whether the product is streamed to its file block by block (not held in memory).

    Options that need the whole map in memory are refused here with one line naming them.
    """
    from fieldmap.errors import InputError

    scheduler, fmt = getattr(args, "scheduler", None), getattr(args, "format", None)
    streamed = scheduler is not None or fmt == "zarr"
    if streamed:
        how = "--format zarr" if fmt == "zarr" else f"--scheduler {scheduler}"
        if getattr(args, "float32", False):
            raise InputError(
                f"--float32 is not available with {how}: streamed maps are stored in float64"
            )
        if getattr(args, "percentile_method", "histogram") != "histogram":
            raise InputError(
                f"--percentile-method {args.percentile_method} needs the whole map in memory: "
                f"not with {how}"
            )
    return streamed


def run(args, heights_km: list[float], thresholds, *, stacked: bool) -> int:
    """Run ``fieldmap map`` (``stacked=False``) or ``fieldmap sweep`` on the block engine."""
    from fieldmap.cli.common import load_cli_model, region, stem
    from fieldmap.products import blockmeta, cluster, distributed, plots
    from fieldmap.products.maps import summary

    scheduler = cluster.parse_scheduler(args.scheduler)
    prep = distributed.prepare(
        args.model,
        args.lmax,
        [1e3 * h for h in heights_km],
        args.step_deg,
        args.lat_max,
        region(args),
        args.ellipsoid,
        args.device,
        args.epoch,
        "mGal",
        load=lambda: load_cli_model(args),
    )
    grid, ell, mod = prep
    tmpl = blockmeta.template(mod, grid, ell, "mGal", thresholds, stacked)

    def write(tmp, client):
        return distributed.write_disturbance(
            tmp,
            args.format,
            thresholds_mg=thresholds,
            device=args.device,
            ellipsoid=args.ellipsoid,
            stacked=stacked,
            client=client,
            rows_per_block=args.rows_per_block,
            setup=prep,
            atomic=False,
        )

    def publish(view, info, elapsed):
        _report(view, info, grid, heights_km, thresholds, elapsed, stacked)
        return summary(view), _figures(view, thresholds, stacked, plots)

    return stream(
        args, scheduler, stem(tmpl, "sweep" if stacked else "disturbance"), write, publish
    )


def stream(args, scheduler, base: str, write, publish) -> int:
    """Write a product block by block under ``--out``, then its JSON and figures; all or none.

    Connects first (an unreachable scheduler writes nothing); ``write(tmp, client)`` streams the
    product to a temporary name and returns its information; ``publish(view, info, elapsed)``
    prints the report from a decimated view of the store and returns the JSON summary and the
    figures as ``(file suffix, maker)`` pairs (drawn unless ``--no-plots``).
    """
    from fieldmap.products import blockstore, cluster
    from fieldmap.products.io import check_out_dir, output_batch, writing

    check_out_dir(args.out)
    out = Path(args.out)
    final = out / f"{base}.{'zarr' if args.format == 'zarr' else 'nc'}"
    t0 = time.perf_counter()
    with cluster.open_client(scheduler) as client, output_batch(out) as batch:
        with writing(final), blockstore.atomic_store(final) as tmp:
            info = write(tmp, client)
            elapsed = time.perf_counter() - t0
            view = blockstore.decimated(tmp, args.format)
            summ, figures = publish(view, info, elapsed)
            batch.json({**summ, "product_path": final.name}, f"{base}.json")
            for suffix, make in [] if args.no_plots else figures:
                batch.png(make(), f"{base}_{suffix}.png")
        files = batch.commit()
    print("written: " + ", ".join(str(f) for f in [final, *files]))
    return 0


def _figures(view, thresholds, stacked, plots):
    if stacked:
        figs = [("table", lambda: plots.plot_sweep(view))]
        for k, h in enumerate(view["height"].values):
            figs.append(
                (
                    f"isolines_h{h / 1e3:g}km",
                    lambda k=k: plots.plot_isolines(view, thresholds, height_index=k),
                )
            )
        return figs
    figs = [("isolines", lambda: plots.plot_isolines(view, thresholds))]
    for t in thresholds:
        if t >= 0.05:
            figs.append((f"above_{t:g}mg", lambda t=t: plots.plot_threshold(view, t)))
    return figs


def _report(view, info, grid, heights_km, thresholds, elapsed, stacked) -> None:
    from fieldmap.products.stats import threshold_key

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

"""``fieldmap map|sweep --quantity anomaly|deflection|geoid|potential`` (geodetic quantity maps).

The disturbance stays with :mod:`fieldmap.cli.maps`; this module runs the other quantities of
:mod:`fieldmap.products.quantity_maps` with the same grid options, checks and atomic outputs.
"""

from __future__ import annotations

import time
from pathlib import Path


def load_cli_model(args):
    """Load the model of ``--model`` with ``--lmax``, ``--epoch`` and the model-file options."""
    from fieldmap.models.registry import announce, load_model, model_options

    model = load_model(args.model, lmax=args.lmax, epoch=args.epoch, **model_options(args))
    announce(model)
    return model


def run_quantity(args, heights_km: list[float]) -> int:
    """Compute, print and write a quantity map (one height) or sweep (several)."""
    from fieldmap.cli.common import preflight, print_files, region, stem
    from fieldmap.products import quantity_maps as qm
    from fieldmap.products.io import output_batch

    preflight(args, heights_km)
    t0 = time.perf_counter()
    ds = qm.quantity_map(
        args.quantity,
        model=load_cli_model(args),
        height_km=heights_km if len(heights_km) > 1 else heights_km[0],
        step_deg=args.step_deg,
        lat_max=args.lat_max,
        region=region(args),
        device=args.device,
        ellipsoid=args.ellipsoid,
    )
    elapsed = time.perf_counter() - t0
    summ = qm.summary(ds)
    a = ds.attrs
    print(
        f"{a['model']} degree {a['model_lmax']}, {args.quantity}, {ds.sizes['latitude']} x "
        f"{ds.sizes['longitude']} nodes"
        + (f" x {ds.sizes['height']} heights" if "height" in ds.dims else "")
        + f", {elapsed:.2f} s"
    )
    heights = summ["height_m"] if isinstance(summ["height_m"], list) else [summ["height_m"]]
    for name, units, _, _ in qm.VARIABLES[args.quantity]:
        s = summ[name]
        for k, h in enumerate(heights):
            pick = (lambda v: v[k]) if isinstance(s["max"], list) else (lambda v: v)
            print(
                f"  {name} ({units}) h = {h / 1e3:g} km: min {pick(s['min']):.4f}  "
                f"max {pick(s['max']):.4f}  mean {pick(s['mean']):.4f}  rms {pick(s['rms']):.4f}"
            )
    base = stem(ds, args.quantity)
    with output_batch(Path(args.out)) as batch:
        batch.netcdf(ds, f"{base}.nc")
        batch.json(summ, f"{base}.json")
        if not args.no_plots:
            for name, _, _, _ in qm.VARIABLES[args.quantity]:
                for k, h in enumerate(heights):
                    suffix = name if len(heights) == 1 else f"{name}_h{h / 1e3:g}km"
                    batch.png(qm.plot_quantity(ds, name, height_index=k), f"{base}_{suffix}.png")
        files = batch.commit()
    print_files(files)
    return 0

"""Helpers shared by the map sub-commands.

``map``, ``sweep``, ``truncation``, their ``--quantity`` and ``--scheduler`` forms: option lists,
the API's checks with the option named, file stems, pre-flight checks before anything is
computed or written, and the streaming options (:func:`streamed`: block by block to a file,
run by :mod:`fieldmap.cli.distributed`).
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from fieldmap.errors import InputError

if TYPE_CHECKING:
    import xarray as xr

    from fieldmap.models.shmodel import SHModel
    from fieldmap.products.request import MapRequest

_T = TypeVar("_T")


def check_minus(args: argparse.Namespace) -> None:
    """Refuse ``--minus`` with a quantity other than ewh, and ewh without ``--minus`` (one line)."""
    from fieldmap.errors import InputError

    minus = getattr(args, "minus", None)
    if minus is not None and args.quantity != "ewh":
        raise InputError(f"--minus applies to --quantity ewh, not to --quantity {args.quantity}")
    if minus is None and args.quantity == "ewh":
        raise InputError(
            f"--quantity ewh: equivalent water height is that of a change of the field, and "
            f"--model {args.model} is one field; give the reference with --minus (a mean "
            "field, or the same time-variable model with --epoch T for the change since its "
            "reference epoch)"
        )


def load_cli_model(args: argparse.Namespace) -> SHModel:
    """Load the model of ``--model`` with ``--lmax``, ``--epoch`` and the model-file options.

    With ``--minus`` (``--quantity ewh``), the difference of that model and the reference
    (:func:`fieldmap.field.water.field_difference`), the reference converted to the model's tide
    system first when they differ (said on stderr).
    """
    from fieldmap.models.registry import announce, load_model, model_options

    model = load_model(args.model, lmax=args.lmax, epoch=args.epoch, **model_options(args))
    announce(model)
    if getattr(args, "minus", None) is not None:  # --quantity ewh: the change of the field
        from fieldmap.field.water import field_difference

        reference = load_model(args.minus, lmax=args.lmax, **model_options(args))
        known = {model.tide_system, reference.tide_system} - {"unknown"}
        if len(known) > 1:  # one tide system for both (field_difference would convert too)
            from fieldmap.models.tide import convert_tide_system

            reference = convert_tide_system(reference, model.tide_system)
        announce(reference)
        model = field_difference(model, reference)
    return model


def list_values(values: object, option: str) -> list[str]:
    """Split a list option: separate arguments and/or comma-separated (``20 30`` or ``20,30``).

    The values stay text: the API converts and validates them, and its message is the one the
    user reads (prefixed with the option's name).
    """
    out = []
    for v in values if isinstance(values, (list, tuple)) else [values]:
        out.extend(str(v).replace(",", " ").split())
    if not out:
        raise InputError(f"{option}: no value given")
    return out


def api_call(option: str, check: Callable[..., _T], *args: Any, **kwargs: Any) -> _T:
    """Run an API validation ``check``; its InputError names the option the value came from."""
    try:
        return check(*args, **kwargs)
    except InputError as exc:
        raise InputError(f"{option}: {exc}") from None


def stem(ds: xr.Dataset, kind: str) -> str:
    """File stem of a product: kind, model, degree, tide system, height(s), region, step.

    The tide system is named when it is not the model file's own (``--tide-system``), so that
    the maps of two systems do not overwrite each other:
    ``disturbance_eigen-6s_L240_zero_tide_h20km_step1``.
    """
    a = ds.attrs
    parts = [kind]
    if a.get("model"):
        parts.append(f"{a['model'].lower()}_L{a['model_lmax']}")
        from fieldmap.products.variables import converted_tide_system

        system = converted_tide_system(a)
        if system is not None:
            parts.append(system)
    w, e, s, n = (float(x) for x in a["region_west_east_south_north_deg"])
    if "height" not in ds.dims:
        parts.append(f"h{float(ds['height'].values) / 1e3:g}km")
    if a.get("grid_kind") == "global":
        if n != 80.0:
            parts.append(f"latmax{n:g}")
    else:
        parts.append(f"region{w:g}_{e:g}_{s:g}_{n:g}")
    parts.append(f"step{float(a['grid_step_deg']):g}")
    return "_".join(p.replace("/", "-").replace(" ", "") for p in parts)


def thresholds_mg(args: argparse.Namespace) -> list[float]:
    """``--thresholds-mg`` as validated by the API."""
    from fieldmap.products.statistics import parse_thresholds

    return list(
        api_call(
            "--thresholds-mg", parse_thresholds, list_values(args.thresholds_mg, "--thresholds-mg")
        )
    )


def heights_km(args: argparse.Namespace, one: str | None = None) -> list[float]:
    """``--height-km`` as validated by the API (:func:`fieldmap.limits.heights_from_km`)."""
    from fieldmap.limits import heights_from_km

    tokens = list_values(args.height_km, "--height-km")
    return [h / 1e3 for h in api_call("--height-km", heights_from_km, tokens, one=one)]


def region(args: argparse.Namespace) -> tuple[float, float, float, float] | None:
    """``--region`` as a (west, east, south, north) tuple, or None.

    ``--lat-max`` (the extent of a global grid) given with ``--region`` is refused.
    """
    from fieldmap.cli import given

    if args.region is None:
        return None
    if given(args, "lat_max"):
        raise InputError("--lat-max applies to global grids, not with --region")
    return tuple(args.region)


def preflight(args: argparse.Namespace, heights_km: Sequence[float], layers: int = 1) -> None:
    """Validate the grid, its memory, device and output folder before any computation or writing.

    ``layers`` is the number of maps per height (orders of a truncation map), for the memory
    estimate. The rules are those of the API: :func:`fieldmap.grids.spec.make_grid` and
    :func:`fieldmap.grids.spec.check_memory`; the heights are already validated.
    """
    from fieldmap.grids.spec import check_memory, make_grid
    from fieldmap.grids.synthesis import resolve_device
    from fieldmap.products.io import check_out_dir

    grid = make_grid(args.step_deg, args.lat_max, region(args), [1e3 * h for h in heights_km])
    check_memory(grid, layers)
    if args.device is not None:
        resolve_device(args.device)
    check_out_dir(args.out)


def print_files(files: Iterable[str | Path]) -> None:
    """Print the paths written, on one line."""
    print("written: " + ", ".join(str(f) for f in files))


def map_request(args: argparse.Namespace, heights_km: list[float], **fixed: Any) -> MapRequest:
    """Build the :class:`~fieldmap.products.request.MapRequest` of a map sub-command.

    The model is loaded once, with ``--lmax``, ``--epoch`` and the model-file options
    (:func:`fieldmap.cli.common.load_cli_model`); ``fixed`` sets the product (``quantity``,
    ``stacked``, ``thresholds_mg``...).
    """
    from fieldmap.products.request import MapRequest

    if fixed.get("quantity") == "omission-sigma":
        fixed.setdefault("omission_model", getattr(args, "omission_model", None))
    return MapRequest.build(
        load=(lambda: load_cli_model(args)) if hasattr(args, "model") else None,
        height_km=heights_km,
        step_deg=args.step_deg,
        lat_max=args.lat_max,
        region=region(args),
        ellipsoid=args.ellipsoid,
        device=args.device,
        scheduler=getattr(args, "scheduler", None),
        rows_per_block=getattr(args, "rows_per_block", None),
        **fixed,
    )


def streaming_options(p: argparse.ArgumentParser) -> None:
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


def streamed(args: argparse.Namespace) -> bool:
    """Tell whether the product is streamed to its file block by block (not held in memory).

    Options that need the whole map in memory are refused here with one line naming them.
    A streamed product is run by :mod:`fieldmap.cli.distributed`.
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

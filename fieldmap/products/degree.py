"""The degree you need: spherical-harmonic omission maps and the smallest sufficient degree.

The omission of degree ``d`` is δg_full − δg_d, the gravitation of the model's degrees
d+1..L: both disturbances subtract the same normal field, so it cancels, and the omission is
the synthesis (:func:`fieldmap.grids.synthesis.synthesize`, quantity ``"gravitation"``) of the
model with every coefficient of degree ≤ d set to zero. :func:`omission_map` maps it for several
degrees and heights with area-weighted statistics (the J2/J4/J6 counterpart is
:func:`fieldmap.products.maps.truncation_map`); :func:`degree_needed` finds by bisection the
degree whose omission stays within a tolerance over a region and heights.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Sequence
from dataclasses import replace
from numbers import Integral
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import xarray as xr

from fieldmap import __version__
from fieldmap.errors import InputError
from fieldmap.grids.synthesis import check_memory, synthesize
from fieldmap.products.statistics import map_statistics
from fieldmap.products.variables import coords, global_attrs, index_height_km, mg_attrs, vector_vars
from fieldmap.units import MGAL

if TYPE_CHECKING:
    from fieldmap.field.ellipsoid import Ellipsoid
    from fieldmap.grids.spec import GridSpec
    from fieldmap.models.shmodel import SHModel

__all__ = ["MIN_DEGREE", "check_degrees", "check_tolerance", "degree_needed", "omission_map"]

#: The lowest degree mapped or searched (degrees 0 and 1 hold GM and the geocentre).
MIN_DEGREE = 2
#: Statistics of the omission modulus per degree and height (mGal).
STATS = (
    ("max", "maximum"),
    ("mean", "area-weighted mean"),
    ("rms", "area-weighted root mean square"),
    ("p99", "area-weighted 99th percentile"),
)


def _integer(v: object) -> int:
    if isinstance(v, bool):
        raise InputError(f"degree {v!r} is not an integer")
    if isinstance(v, Integral):
        return int(v)
    if isinstance(v, str):
        try:
            return int(v.strip())
        except ValueError:
            raise InputError(f"degree {v!r} is not an integer") from None
    raise InputError(f"degree {v!r} is not an integer")


def check_degrees(degrees: int | str | Iterable[int | str], lmax: int) -> tuple[int, ...]:
    """Return distinct integer degrees between :data:`MIN_DEGREE` and ``lmax``, ascending."""
    values = (
        [degrees]
        if isinstance(degrees, (str, Integral))
        else list(cast(Iterable[int | str], degrees))
    )
    if not values:
        raise InputError("no degree given")
    out = [_integer(v) for v in values]
    for d in out:
        if not MIN_DEGREE <= d <= lmax:
            raise InputError(
                f"degree {d} outside {MIN_DEGREE}..{lmax} (the model's degree is {lmax})"
            )
    dup = sorted({d for d in out if out.count(d) > 1})
    if dup:
        raise InputError(f"degree {dup[0]} given twice")
    return tuple(sorted(out))


def check_tolerance(tolerance_mgal: float | str) -> float:
    """Return a tolerance in mGal, refusing one that is not finite and > 0."""
    try:
        t = float(tolerance_mgal)
    except (TypeError, ValueError):
        raise InputError(f"tolerance {tolerance_mgal!r} is not a number") from None
    if not (math.isfinite(t) and t > 0):
        raise InputError(f"tolerance must be finite and > 0 mGal, got {tolerance_mgal!r}")
    return t


def omission_model(model: SHModel, degree: int) -> SHModel:
    """Return the model with every coefficient of degree ≤ ``degree`` zeroed (d+1..L kept)."""
    C, S = model.C.copy(), model.S.copy()
    C[: degree + 1] = 0.0
    S[: degree + 1] = 0.0
    return replace(model, C=C, S=S)


def _omission(
    mod: SHModel, degree: int, grid: GridSpec, ell: Ellipsoid, device: str | None
) -> np.ndarray:
    """Omission vector (nh, nlat, nlon, 3) in m/s²; exactly zero at the model's degree."""
    if degree >= mod.lmax:
        return np.zeros((*grid.shape, 3))
    return synthesize(omission_model(mod, degree), grid, ell, "gravitation", device)


def _max_mgal(vec: np.ndarray) -> float:
    return float(np.sqrt(np.einsum("...k,...k->...", vec, vec)).max() / MGAL)


def _setup(
    model: SHModel | str | os.PathLike[str],
    lmax: int | None,
    epoch: float | str | None,
    height_km: float | Sequence[float],
    step_deg: float,
    lat_max: float,
    region: Sequence[float] | None,
    ellipsoid: Ellipsoid | str,
    device: str | None,
) -> tuple[GridSpec, Ellipsoid, str | None, SHModel]:
    """Validate the grid, ellipsoid, device and model of an omission product (one request)."""
    from fieldmap.products.request import MapRequest

    req = MapRequest.build(
        model=model, lmax=lmax, epoch=epoch, height_km=height_km, step_deg=step_deg,
        lat_max=lat_max, region=region, ellipsoid=ellipsoid, device=device, stacked=True,
    )  # fmt: skip
    return req.grid, req.ellipsoid, req.execution.device, req.model


def omission_map(
    model: SHModel | str | os.PathLike[str] = "eigen-6s",
    *,
    degrees: int | str | Iterable[int | str] = (18, 36, 90, 180),
    lmax: int | None = None,
    epoch: float | str | None = None,
    height_km: float | Sequence[float] = 20.0,
    step_deg: float = 1.0,
    lat_max: float = 80.0,
    region: Sequence[float] | None = None,
    ellipsoid: Ellipsoid | str = "WGS84",
    device: str | None = None,
) -> xr.Dataset:
    """Map the SH omission δg_full − δg_d of each degree d (the field of degrees d+1..L).

    Parameters
    ----------
    model : str or SHModel
        As in :func:`fieldmap.products.maps.disturbance_map`; ``lmax`` truncates it first
        (the "full model" is then the truncated one), ``epoch`` as there.
    degrees : sequence of int
        Distinct integers between 2 and the model's degree L (L: omission zero).
    height_km : float or sequence of float
        One or several distinct heights above the ellipsoid, -10 ≤ h ≤ 1e5. Units: km.
    lmax, epoch, step_deg, lat_max, region, ellipsoid, device
        As in :func:`fieldmap.products.maps.disturbance_map`.

    Returns
    -------
    xarray.Dataset
        east, north, up, modulus (mGal) and modulus_mg on (degree, height, latitude,
        longitude); ``max_mg``, ``mean_mg``, ``rms_mg`` and ``p99_mg`` of the modulus
        (area-weighted but the max) on (degree, height), as every product's statistics, and
        the same in mGal (``max_mgal``...), the unit of the omission's tolerance.
    """
    grid, ell, device, mod = _setup(
        model, lmax, epoch, height_km, step_deg, lat_max, region, ellipsoid, device
    )
    degs = check_degrees(degrees, mod.lmax)
    check_memory(grid, layers=len(degs))
    vec = np.stack([_omission(mod, d, grid, ell, device) for d in degs])
    return _dataset(vec, degs, mod, grid, ell)


def _dataset(
    vec: np.ndarray, degs: tuple[int, ...], mod: SHModel, grid: GridSpec, ell: Ellipsoid
) -> xr.Dataset:
    dims = ("degree", "height", "latitude", "longitude")
    heights = ", ".join(f"{x / 1e3:g}" for x in grid.heights)
    ds = xr.Dataset(
        vector_vars(vec, dims, "mGal", "spherical-harmonic omission", overwrite=True),
        coords={
            **coords(grid, True),
            "degree": xr.Variable(
                "degree",
                np.array(degs),
                {"long_name": "highest spherical-harmonic degree kept", "units": "1"},
            ),
        },
        attrs=global_attrs(
            f"SH omission at {heights} km, {mod.name} degree {mod.lmax}",
            mod,
            ell,
            grid,
            f"fieldmap {__version__}: {mod.name} gravitation of degrees d+1..{mod.lmax} "
            "(disturbance of the full model minus that of degree d)",
        ),
    )
    st = [
        [map_statistics(m, grid.lat, thresholds_mg=(), percentiles=(99,)) for m in per_d]
        for per_d in ds["modulus"].values
    ]
    for key, long in STATS:
        ds[f"{key}_mgal"] = (
            ("degree", "height"),
            np.array([[s[f"{key}_mg"] for s in row] for row in st]),
            {"units": "mGal", "long_name": f"{long} of the omission modulus"},
        )
    # the statistics every product carries, of the modulus in mg (as the maps and sweeps)
    st_mg = [
        [map_statistics(m, grid.lat, thresholds_mg=(), percentiles=(99,)) for m in per_d]
        for per_d in ds["modulus_mg"].values
    ]
    for key, long in STATS:
        ds[f"{key}_mg"] = (
            ("degree", "height"),
            np.array([[s[f"{key}_mg"] for s in row] for row in st_mg]),
            mg_attrs(f"{long} of the omission modulus"),
        )
    return index_height_km(ds)


def degree_needed(
    model: SHModel | str | os.PathLike[str] = "eigen-6s",
    *,
    tolerance_mgal: float | str,
    lmax: int | None = None,
    epoch: float | str | None = None,
    height_km: float | Sequence[float] = 20.0,
    step_deg: float = 1.0,
    lat_max: float = 80.0,
    region: Sequence[float] | None = None,
    ellipsoid: Ellipsoid | str = "WGS84",
    device: str | None = None,
) -> dict[str, Any]:
    """Find the smallest degree d (2..L) whose omission max over grid and heights is ≤ tolerance.

    Bisection on d: the omission of L is zero (L always meets the tolerance); degree 2 is
    tried first. The answer d meets the tolerance and d − 1 does not (for d > 2), which the
    search checks by evaluating both. The omission max is nearly, not strictly, monotone in d
    (a higher degree may add a little locally): the answer is then a degree meeting the
    tolerance whose predecessor does not, the smallest one wherever the max is monotone.

    Parameters
    ----------
    model : str or SHModel
        As in :func:`omission_map`.
    tolerance_mgal : float
        Largest omission accepted (the modulus, over the grid and the heights). Units: mGal.
    lmax, epoch, height_km, step_deg, lat_max, region, ellipsoid, device
        As in :func:`omission_map`.

    Returns
    -------
    dict
        ``degree_needed``, ``tolerance_mgal``, ``model``, ``model_lmax``,
        ``model_tide_system``, ``height_m``, ``omission_max_mgal`` (at the degree),
        ``omission_max_below_mgal`` (at degree − 1, the degree 1 omission when the answer is
        2) and ``evaluated`` {degree: omission max}.
    """
    tol = check_tolerance(tolerance_mgal)
    grid, ell, device, mod = _setup(
        model, lmax, epoch, height_km, step_deg, lat_max, region, ellipsoid, device
    )
    if mod.lmax < MIN_DEGREE:
        raise InputError(f"model degree {mod.lmax} is below {MIN_DEGREE}")
    check_memory(grid)
    seen: dict[int, float] = {mod.lmax: 0.0}

    def omax(d: int) -> float:
        if d not in seen:
            seen[d] = _max_mgal(_omission(mod, d, grid, ell, device))
        return seen[d]

    lo, hi = MIN_DEGREE - 1, mod.lmax  # invariant: hi meets the tolerance, lo (if > 1) fails
    if omax(MIN_DEGREE) <= tol:
        hi = MIN_DEGREE
    else:
        lo = MIN_DEGREE
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if omax(mid) <= tol:
                hi = mid
            else:
                lo = mid
    below = omax(hi - 1)
    if hi > MIN_DEGREE and not below > tol:  # pragma: no cover - the invariant
        raise AssertionError("bisection invariant broken")
    return {
        "degree_needed": hi,
        "tolerance_mgal": tol,
        "model": mod.name,
        "model_lmax": int(mod.lmax),
        "model_tide_system": mod.tide_system,
        "height_m": [float(x) for x in grid.heights],
        "omission_max_mgal": omax(hi),
        "omission_max_below_mgal": below,
        "evaluated": {int(k): float(v) for k, v in sorted(seen.items())},
    }

"""Build a gravity compensation table whose interpolation error is verified below a bound.

:func:`build_table` computes δg north, east, down (mGal) on a lat-lon-height lattice
(:mod:`fieldmap.products.tables.model` describes the lattice and the interpolation scheme) with
fieldmap's grid engine (:func:`fieldmap.grids.synthesis.synthesize`, the engine of the map
products: model gravitation minus the exact normal gravitation, geodetic frame), then chooses
the spacings:

1. Start from the model's scales: horizontally half the shortest half-wavelength of the model,
   ``0.5 * max(π R / L, h_min)`` (L its degree, R its radius; the field at height h carries no
   shorter scales than about h), vertically ``R / L`` (the e-folding height of degree L), each
   cut to fit the region.
2. Evaluate the table against direct evaluations at an independent, denser check set (never at
   nodes): A) every horizontal cell centre at every node height (the horizontal error alone);
   B) every interior node at every mid-height (the vertical error alone); C) every cell centre
   at every mid-height (both); D) ``check_points`` random points uniform in the valid domain,
   evaluated by the point engine (:func:`fieldmap.field.gravity.disturbance`, another kernel).
   The errors are those of the stored float32 values (their rounding included).
3. While the largest error of any component on A-D exceeds the bound, halve the horizontal
   spacing (both latitude and longitude) and/or the vertical one: the one whose pure error (A
   or B) is the larger, both when each exceeds half the bound. A refinement that would pass
   ``budget_mb`` is refused (:class:`InputError`, one line naming the error reached, the size
   it had and the size the next refinement needs).

Longitude spacing: ``dlat / cos(φ)`` at the latitude φ of the region nearest the equator, so
that the east-west ground spacing never exceeds the north-south one. The spacings divide the
region exactly (the valid domain is the region), plus one margin node on each horizontal side.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fieldmap import limits
from fieldmap.errors import InputError
from fieldmap.products.tables.model import COMPONENTS, CompensationTable

if TYPE_CHECKING:
    from fieldmap.models.shmodel import SHModel

#: random check points of step D (reproducible: fixed seed)
CHECK_POINTS = 2000
#: most refinements tried (each halves a spacing)
MAX_REFINEMENTS = 14
#: highest |latitude| of a table region (the lattice, margin included, stays off the poles)
MAX_ABS_LAT = 89.0


def check_region(region: Iterable[float | str]) -> tuple[float, float, float, float]:
    """Validate (west, east, south, north); return it with east > west (east += 360 across ±180)."""
    try:
        w, e, s, n = (float(v) for v in region)
    except (TypeError, ValueError):
        raise InputError(f"region must be four numbers: west east south north, got {region!r}")
    if not all(math.isfinite(v) for v in (w, e, s, n)):
        raise InputError(f"region bounds must be finite, got {w:g} {e:g} {s:g} {n:g}")
    if not (-MAX_ABS_LAT <= s < n <= MAX_ABS_LAT):
        raise InputError(
            f"region needs -{MAX_ABS_LAT:g} <= south < north <= {MAX_ABS_LAT:g} deg, got south "
            f"{s:g} north {n:g}"
        )
    if not (-360.0 <= w <= 360.0 and -360.0 <= e <= 360.0):
        raise InputError(f"region longitudes must be within -360..360 deg, got {w:g}, {e:g}")
    if e < w:  # across the antimeridian
        e += 360.0
    if not 0.0 < e - w < 360.0:
        raise InputError(
            f"region longitudes {w:g}..{e:g} must span more than 0 and less than 360 deg"
        )
    return w, e, s, n


def corridor_region(
    flight: str | os.PathLike[str],
    width_km: float,
    region: Iterable[float | str] | None = None,
) -> tuple[float, float, float, float]:
    """(west, east, south, north) of a flight track's bounding box widened by ``width_km``.

    With ``region`` too, the intersection of both (refused when empty).
    """
    from fieldmap.nav.logs.read import read_track

    width = float(width_km)
    if not math.isfinite(width) or width < 0:
        raise InputError(f"--width-km must be a finite number >= 0, got {width_km!r}")
    track = read_track(flight)
    lat = np.asarray(track.lat, dtype=np.float64)
    lon = np.degrees(np.unwrap(np.radians(np.asarray(track.lon, dtype=np.float64))))
    dlat = math.degrees(width * 1e3 / 6_356_752.0)  # on the meridian (polar radius: generous)
    phi = min(max(abs(lat.min()), abs(lat.max())) + dlat, MAX_ABS_LAT)
    dlon = math.degrees(width * 1e3 / (6_378_137.0 * math.cos(math.radians(phi))))
    s, n = max(lat.min() - dlat, -MAX_ABS_LAT), min(lat.max() + dlat, MAX_ABS_LAT)
    w, e = lon.min() - dlon, lon.max() + dlon
    w0 = (w + 180.0) % 360.0 - 180.0
    w, e = w0, w0 + (e - w)
    if region is None:
        return check_region((w, e, s, n))
    rw, re, rs, rn = check_region(region)
    s, n = max(s, rs), min(n, rn)
    shift = round((rw - w) / 360.0) * 360.0  # the same longitude turn as the region
    w, e = max(w + shift, rw), min(e + shift, re)
    if not (s < n and w < e):
        raise InputError(
            f"--corridor {flight} ({width:g} km around the track) and --region do not overlap"
        )
    return w, e, s, n


def _synth(
    model: SHModel,
    lat: np.ndarray,
    lon: np.ndarray,
    heights: ArrayLike,
    device: str | None,
) -> np.ndarray:
    """δg north, east, down (mGal, float64) on a grid: (nh, nlat, nlon, 3)."""
    from fieldmap.grids.synthesis import GridSpec, check_memory, synthesize

    grid = GridSpec(lat=lat, lon=lon, heights=np.asarray(heights, float), step_deg=0.0)
    check_memory(grid)
    enu = synthesize(model, grid, None, "disturbance", device, progress=False) * 1e5
    return np.stack([enu[..., 1], enu[..., 0], -enu[..., 2]], axis=-1)


def _stats(err: np.ndarray) -> dict:
    e = err.reshape(-1, 3)
    return {
        "points": int(e.shape[0]),
        "max_mgal": {c: float(np.max(np.abs(e[:, k]))) for k, c in enumerate(COMPONENTS)},
        "rms_mgal": {c: float(np.sqrt(np.mean(e[:, k] ** 2))) for k, c in enumerate(COMPONENTS)},
    }


class _Lattice:
    """Spacings of one candidate: cells in latitude, longitude and height."""

    def __init__(
        self,
        region: tuple[float, float, float, float],
        hmin: float,
        hmax: float,
        ncl: int,
        ncn: int,
        nck: int,
    ) -> None:
        self.w, self.e, self.s, self.n = region
        self.hmin, self.hmax = hmin, hmax
        self.ncl, self.ncn, self.nck = ncl, ncn, nck
        self.dlat, self.dlon = (self.n - self.s) / ncl, (self.e - self.w) / ncn
        self.dh = (hmax - hmin) / nck

    @property
    def nbytes(self) -> int:
        from fieldmap.products.tables.model import HEADER_BYTES

        return HEADER_BYTES + (self.ncl + 3) * (self.ncn + 3) * (self.nck + 1) * 3 * 4

    def axes(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        lat = self.s + self.dlat * np.arange(-1, self.ncl + 2, dtype=np.float64)
        lon = self.w + self.dlon * np.arange(-1, self.ncn + 2, dtype=np.float64)
        h = self.hmin + self.dh * np.arange(self.nck + 1, dtype=np.float64)
        return lat, lon, h

    def spacing(self) -> dict:
        return {"dlat_deg": self.dlat, "dlon_deg": self.dlon, "dh_m": self.dh}


def _evaluate(
    lat_ax: np.ndarray,
    model: SHModel,
    lat_rng: np.random.Generator,
    tab: CompensationTable,
    device: str | None,
    check_points: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Errors of ``tab`` on the check sets A-D (see the module docstring)."""
    from fieldmap.field.gravity import disturbance

    lat, lon, h = tab.latitudes, tab.longitudes, tab.heights
    mlat, mlon = 0.5 * (lat[1:-2] + lat[2:-1]), 0.5 * (lon[1:-2] + lon[2:-1])
    mh = 0.5 * (h[:-1] + h[1:])

    def err(la: np.ndarray, lo: np.ndarray, hh: np.ndarray) -> np.ndarray:
        truth = _synth(model, la, lo, hh, device)
        g = np.meshgrid(hh, la, lo, indexing="ij")
        return tab.interpolate(g[1], g[2], g[0]).reshape(truth.shape) - truth

    a = err(mlat, mlon, h)
    b = err(lat[1:-1], lon[1:-1], mh)
    c = err(mlat, mlon, mh)
    w, e, s, n, h0, h1 = tab.domain
    rlat = np.degrees(
        np.arcsin(lat_rng.uniform(np.sin(np.radians(s)), np.sin(np.radians(n)), check_points))
    )
    rlon = lat_rng.uniform(w, e, check_points)
    rh = lat_rng.uniform(h0, h1, check_points)
    ref = disturbance(rlat, rlon, rh, model=model, frame="ned", device=device)
    d = tab.interpolate(rlat, rlon, rh) - ref
    return a, b, c, d


def build_table(
    region: Iterable[float | str],
    heights_km: Iterable[float | str],
    max_error_mgal: float,
    *,
    budget_mb: float = 8.0,
    model: SHModel | str | os.PathLike[str] = "eigen-6s",
    device: str | None = None,
    check_points: int = CHECK_POINTS,
    log: Callable[[str], object] | None = None,
) -> tuple[CompensationTable, dict[str, Any]]:
    """Build a compensation table whose verified interpolation error is within a bound.

    Parameters
    ----------
    region : (west, east, south, north)
        Valid domain; east < west crosses the antimeridian. Units: degrees (|lat| <= 89).
    heights_km : (min, max)
        Lowest and highest height above the ellipsoid, min < max (:mod:`fieldmap.limits`).
        Units: km.
    max_error_mgal : float
        Largest interpolation error accepted on each of north, east, down. Units: mGal.
    budget_mb : float
        Largest ``table.bin`` (header and float32 values). Units: MB (1e6 bytes).
    model : SHModel or str
        Gravity model: a model (its truncation degree applied by
        :func:`fieldmap.models.registry.load_model` ``lmax=``), a bundled name or a file.
    device : str, optional
        Warp device of the engine.
    check_points : int
        Random points of the check set D (drawn with seed 0: the same points every run).
    log : callable, optional
        Called with one line per refinement (progress).

    Returns
    -------
    (CompensationTable, dict)
        The table (float32 values) and its verification report (JSON-ready).

    Examples
    --------
    A table over a 1° square, 0 to 10 km, within 5 mGal of a degree-12 model:

    >>> import fieldmap
    >>> model = fieldmap.load_model("eigen-6s", lmax=12)
    >>> table, report = fieldmap.build_table(
    ...     (9.5, 10.5, 44.5, 45.5), (0, 10), 5.0, model=model, check_points=10
    ... )
    >>> report["verification"]["max_mgal"] < 5.0
    True
    """
    from fieldmap.grids.synthesis import resolve_device
    from fieldmap.models.registry import load_model

    bound = float(max_error_mgal)
    if not math.isfinite(bound) or bound <= 0:
        raise InputError(f"--max-error-mgal must be a positive number, got {max_error_mgal!r}")
    budget = float(budget_mb)
    if not math.isfinite(budget) or budget <= 0:
        raise InputError(f"--budget-mb must be a positive number, got {budget_mb!r}")
    w, e, s, n = check_region(region)
    hk = limits.heights_from_km(heights_km, distinct=False)
    if hk.size != 2 or not hk[0] < hk[1]:
        raise InputError(
            f"--height-km needs MIN,MAX with MIN < MAX, got {','.join(f'{v / 1e3:g}' for v in hk)}"
        )
    if int(check_points) < 1:
        raise InputError(f"check_points must be >= 1, got {check_points!r}")
    device = resolve_device(device)
    m = load_model(model)
    hmin, hmax = float(hk[0]), float(hk[1])
    L = max(int(m.lmax), 2)
    scale_m = 0.5 * max(math.pi * m.radius / L, hmin)
    d0 = math.degrees(scale_m / m.radius)
    phi = 0.0 if s <= 0.0 <= n else min(abs(s), abs(n))
    ncl = max(1, math.ceil((n - s) / d0))
    ncn = max(1, math.ceil((e - w) * math.cos(math.radians(phi)) / d0))
    nck = max(1, math.ceil((hmax - hmin) / (m.radius / L)))
    lat_cap = 90.0 - 1e-6
    while (s - (n - s) / ncl <= -lat_cap) or (n + (n - s) / ncl >= lat_cap):
        ncl, ncn = 2 * ncl, 2 * ncn  # the margin rows stay off the poles
    cand = _Lattice((w, e, s, n), hmin, hmax, ncl, ncn, nck)
    history: list[dict] = []
    for _ in range(MAX_REFINEMENTS + 1):
        if cand.nbytes > budget * 1e6:
            raise InputError(_over_budget(bound, budget, history, cand))
        lat, lon, h = cand.axes()
        values = _synth(m, lat, lon, h, device).astype(np.float32)
        tab = CompensationTable(lat[0], cand.dlat, lon[0], cand.dlon, h[0], cand.dh, values)
        rng = np.random.default_rng(0)
        a, b, c, d = _evaluate(lat, m, rng, tab, device, int(check_points))
        errs = {k: float(np.max(np.abs(v))) for k, v in zip("ABCD", (a, b, c, d))}
        step = {**cand.spacing(), "size_bytes": cand.nbytes, "max_error_mgal": errs}
        history.append(step)
        if log is not None:
            log(
                f"dlat {cand.dlat:.5g} deg, dlon {cand.dlon:.5g} deg, dh {cand.dh:.5g} m, "
                f"{cand.nbytes / 1e6:.3g} MB: max error {max(errs.values()):.3g} mGal"
            )
        if max(errs.values()) <= bound:
            break
        eh, ev = errs["A"], errs["B"]
        both = eh > 0.5 * bound and ev > 0.5 * bound
        refine_h = both or eh >= ev
        refine_v = both or ev > eh
        cand = _Lattice(
            (w, e, s, n),
            hmin,
            hmax,
            cand.ncl * (2 if refine_h else 1),
            cand.ncn * (2 if refine_h else 1),
            cand.nck * (2 if refine_v else 1),
        )
    else:
        raise InputError(
            f"no table within {bound:g} mGal after {MAX_REFINEMENTS} refinements "
            f"(reached {max(history[-1]['max_error_mgal'].values()):.3g} mGal)"
        )
    report = _report(tab, m, (w, e, s, n), (hmin, hmax), bound, budget, history, (a, b, c, d))
    tab.meta.update(
        model=m.name,
        lmax=int(m.lmax),
        tide_system=m.tide_system,
        ellipsoid="WGS84",
        max_error_mgal=bound,
        verified={
            "max_mgal": report["verification"]["max_mgal"],
            "rms_mgal": report["verification"]["rms_mgal"],
            "summary": {k: report[k] for k in ("lattice", "size_bytes")},
        },
    )
    return tab, report


def _over_budget(bound: float, budget: float, history: list[dict[str, Any]], cand: _Lattice) -> str:
    if not history:
        return (
            f"the coarsest table for this region already needs {cand.nbytes / 1e6:.3g} MB, more "
            f"than --budget-mb {budget:g}"
        )
    last = history[-1]
    return (
        f"cannot meet {bound:g} mGal within --budget-mb {budget:g}: the largest table within "
        f"the budget ({last['size_bytes'] / 1e6:.3g} MB, dlat {last['dlat_deg']:.4g} deg, dh "
        f"{last['dh_m']:.4g} m) reaches {max(last['max_error_mgal'].values()):.3g} mGal; the "
        f"next refinement needs {cand.nbytes / 1e6:.3g} MB (--budget-mb "
        f"{math.ceil(cand.nbytes / 1e6 * 10) / 10:g} or more)"
    )


def _report(
    tab: CompensationTable,
    m: SHModel,
    region: tuple[float, float, float, float],
    hrange: tuple[float, float],
    bound: float,
    budget: float,
    history: list[dict[str, Any]],
    errs: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
) -> dict[str, Any]:
    a, b, c, d = errs
    h = tab.heights
    mh = 0.5 * (h[:-1] + h[1:])
    per_height = [
        {"height_m": float(hh), "check": "cell centres at a node height", **_stats(a[k])}
        for k, hh in enumerate(h)
    ]
    per_height += [
        {
            "height_m": float(hh),
            "check": "cell centres and interior nodes at a mid-height",
            **_stats(np.concatenate([b[k].reshape(-1, 3), c[k].reshape(-1, 3)])),
        }
        for k, hh in enumerate(mh)
    ]
    per_height.sort(key=lambda r: r["height_m"])
    every = np.concatenate([x.reshape(-1, 3) for x in (a, b, c, d)])
    nh, nlat, nlon = tab.shape
    w, e, s, n, h0, h1 = tab.domain
    size = 168 + tab.data.size * 4
    return {
        "model": m.name,
        "lmax": int(m.lmax),
        "tide_system": m.tide_system,
        "normal_field": "exact normal gravity of the WGS84 level ellipsoid",
        "components": "dn, de, dd: gravity disturbance north, east, down (NED), mGal",
        "region": {"west": region[0], "east": region[1], "south": region[2], "north": region[3]},
        "heights_m": list(hrange),
        "max_error_mgal": bound,
        "budget_mb": budget,
        "size_bytes": size,
        "lattice": {
            "nh": nh,
            "nlat": nlat,
            "nlon": nlon,
            "lat0_deg": tab.lat0,
            "dlat_deg": tab.dlat,
            "lon0_deg": tab.lon0,
            "dlon_deg": tab.dlon,
            "h0_m": tab.h0,
            "dh_m": tab.dh,
            "valid_domain": {"west": w, "east": e, "south": s, "north": n, "hmin": h0, "hmax": h1},
            "storage": "float32 little-endian, C order [nh][nlat][nlon][dn, de, dd]",
        },
        "interpolation": "Catmull-Rom cubic in latitude, longitude and height (see table.h)",
        "verification": {
            "max_mgal": float(np.max(np.abs(every))),
            "rms_mgal": float(np.sqrt(np.mean(every**2))),
            "overall": _stats(every),
            "per_height": per_height,
            "random_points": {
                "engine": "fieldmap.disturbance (point kernel), uniform in the valid domain",
                **_stats(d),
            },
        },
        "refinements": history,
    }

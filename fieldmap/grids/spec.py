"""Latitude-longitude grid specifications: :class:`GridSpec` and its validating builder.

:func:`make_grid` turns a step, a latitude limit or a region, and heights into a
:class:`GridSpec`, refusing (:class:`~fieldmap.errors.InputError`, one line) anything that is
not a grid with area, within range, that fits in memory.
:mod:`fieldmap.grids.synthesis` synthesises on it
and re-exports both names.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import SupportsFloat

import numpy as np

from fieldmap import limits
from fieldmap.errors import InputError

#: Lowest and highest heights accepted, the same as for points (:mod:`fieldmap.limits` says
#: why). Units: m.
MIN_HEIGHT_M = limits.MIN_HEIGHT
MAX_HEIGHT_M = limits.MAX_HEIGHT
#: Bytes of result per node and height of a map product: east, north, up, modulus in the
#: requested unit and in mg, plus the working copies of the synthesis.
BYTES_PER_NODE = 96
#: Largest share of the physical memory the result of one product may take.
MEMORY_FRACTION = 0.5
_EPS = 1e-9


def _memory_bytes() -> int | None:
    """Physical memory of this machine in bytes (None where the OS does not say)."""
    import os

    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):  # pragma: no cover - non-POSIX
        return None


@dataclass(frozen=True)
class GridSpec:
    """A validated geodetic grid.

    Attributes
    ----------
    lat : numpy.ndarray
        Geodetic latitudes, ascending. Units: degrees.
    lon : numpy.ndarray
        Longitudes, ascending (beyond 180 for a region across the antimeridian). Units: degrees.
    heights : numpy.ndarray
        Heights above the ellipsoid. Units: m.
    step_deg : float
        Nominal spacing. Units: degrees.
    is_global : bool
        True for a global grid (all longitudes, latitudes -lat_max..lat_max).
    """

    lat: np.ndarray
    lon: np.ndarray
    heights: np.ndarray
    step_deg: float
    is_global: bool = False

    @property
    def shape(self) -> tuple[int, int, int]:
        """(number of heights, latitudes, longitudes)."""
        return (self.heights.size, self.lat.size, self.lon.size)

    @property
    def region(self) -> tuple[float, float, float, float]:
        """(west, east, south, north) of the nodes. Units: degrees."""
        return (float(self.lon[0]), float(self.lon[-1]), float(self.lat[0]), float(self.lat[-1]))


def _axis(start: float, stop: float, step: float) -> np.ndarray:
    n = int(math.floor((stop - start) / step + _EPS)) + 1
    return start + step * np.arange(n, dtype=np.float64)


def _number(value: SupportsFloat | str, what: str) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be a number, got {value!r}") from None


def _global_latitudes(lm: float, step: float) -> np.ndarray:
    """Rows of a global grid, symmetric about the equator (see :func:`make_grid`)."""
    ratio = 2.0 * lm / step
    if abs(ratio - round(ratio)) < 1e-9 * max(1.0, ratio):
        # +lat_max is reachable from -lat_max by whole steps: the rows run -lat_max..lat_max
        lat = _axis(-lm, lm, step)
        lat[-1] = lm
    else:
        # it is not: the whole multiples of the step within +-lat_max, equator included
        k = int(math.floor(lm / step + _EPS))
        lat = step * np.arange(-k, k + 1, dtype=np.float64)
    half = lat.size // 2  # make the mirror rows exact negatives of each other
    lat[lat.size - half :] = -lat[:half][::-1]
    if lat.size % 2:
        lat[half] = 0.0
    return lat


def check_memory(grid: GridSpec, layers: int = 1) -> None:
    """Refuse a product whose result would not fit in memory.

    Parameters
    ----------
    grid : GridSpec
    layers : int
        Maps per height (e.g. the orders of a truncation map).

    Raises
    ------
    InputError
        When the result (``BYTES_PER_NODE`` per node, height and layer) exceeds
        ``MEMORY_FRACTION`` of the physical memory; the message states both sizes.
    """
    nh, nlat, nlon = grid.shape
    need = float(nlat) * nlon * nh * layers * BYTES_PER_NODE
    mem = _memory_bytes()
    if mem is not None and need > MEMORY_FRACTION * mem:
        raise InputError(
            f"a grid of {nlat} x {nlon} nodes x {nh * layers} maps needs about "
            f"{need / 2**30:.1f} GiB for its result, more than {MEMORY_FRACTION:.0%} of this "
            f"machine's {mem / 2**30:.0f} GiB; use a larger step or a region"
        )


def make_grid(
    step_deg: float = 1.0,
    lat_max: float = 80.0,
    region: tuple[float, float, float, float] | None = None,
    heights_m: float | Sequence[float] | np.ndarray = (20000.0,),
    *,
    whole_in_memory: bool = True,
) -> GridSpec:
    """Build and validate a grid specification.

    Global grids are symmetric about the equator, as the mirror-row synthesis and a geodesist
    expect: when ``2 * lat_max`` is a whole number of steps the rows run -lat_max..lat_max (the
    paper's 1 deg grid: -80..80); otherwise they are the whole multiples of the step within
    +-lat_max, equator included, as the longitudes are (step 30, lat_max 80: -60..60, never the
    lopsided -80..70). ``GridSpec.region`` gives the extent actually covered.

    Parameters
    ----------
    step_deg : float
        Node spacing in latitude and longitude. Units: degrees (> 0, <= 90).
    lat_max : float
        Global grids span latitudes -lat_max..lat_max (the paper: 80) and longitudes
        -180..180-step. Units: degrees (0 < lat_max <= 90).
    region : (west, east, south, north), optional
        Regional grid instead, nodes from west/south in steps up to east/north. east < west means
        the region crosses the antimeridian. Units: degrees.
    heights_m : sequence of float
        Heights above the ellipsoid. Units: m (finite, -1e4 <= h <= 1e8, :mod:`fieldmap.limits`).
    whole_in_memory : bool
        Check that the whole result fits in memory (:func:`check_memory`); False for products
        computed and written block by block (:mod:`fieldmap.products.engine`).

    Raises
    ------
    InputError
        Non-positive or non-finite step, latitude beyond +-90, empty region or a region with no
        area, a step larger than the region (fewer than 2 rows or columns), bad heights, or a
        result larger than ``MEMORY_FRACTION`` of the physical memory (:func:`check_memory`).
    """
    step = _number(step_deg, "step")
    if not math.isfinite(step) or step <= 0:
        raise InputError(f"step must be a positive number of degrees, got {step_deg!r}")
    if step > 90:
        raise InputError(f"step {step} deg is larger than 90 deg")
    if np.size(heights_m) == 0:
        raise InputError("no height given")
    h = limits.check_heights(heights_m)
    if region is None:
        lm = _number(lat_max, "latitude limit")
        if not math.isfinite(lm) or not 0 <= lm <= 90:
            raise InputError(f"latitude limit must be within 0..90 deg, got {lat_max!r}")
        if lm == 0:
            raise InputError("latitude limit 0 gives a grid with no area; use a value in (0, 90]")
        lat = _global_latitudes(lm, step)
        nlon = 360.0 / step
        nlon = int(round(nlon)) if abs(nlon - round(nlon)) < 1e-6 else int(math.floor(nlon)) + 1
        lon = -180.0 + step * np.arange(nlon, dtype=np.float64)
        lon = lon[lon < 180.0 - _EPS]
    else:
        try:
            if len(region) != 4:
                raise InputError(f"region must be west east south north, got {region!r}")
        except TypeError:
            raise InputError(f"region must be west east south north, got {region!r}") from None
        w, e, s, n = (_number(x, "region bound") for x in region)
        if not all(math.isfinite(x) for x in (w, e, s, n)):
            raise InputError(f"region bounds must be finite, got {region!r}")
        if not (-90 <= s <= 90 and -90 <= n <= 90):
            raise InputError(
                f"region latitudes must be within -90..90 deg, got south={s} north={n}"
            )
        if n < s:
            raise InputError(f"empty region: north {n} is south of south {s}")
        if not (-360 <= w <= 360 and -360 <= e <= 360):
            raise InputError(f"region longitudes must be within -360..360 deg, got {w}, {e}")
        if s == n or w == e or w - e == 360.0:  # (170, -190) is as empty as (170, 170)
            raise InputError(
                f"empty region: {w:g} {e:g} {s:g} {n:g} (west east south north) has no area "
                "(west = east or south = north)"
            )
        if e < w:
            e += 360.0
        if e - w > 360.0 + _EPS:
            raise InputError(f"region spans more than 360 deg of longitude ({w}..{e})")
        lat = _axis(s, n, step)
        lon = _axis(w, e, step)
        if lon.size > 1 and lon[-1] - lon[0] >= 360.0 - _EPS:
            lon = lon[:-1]
    if lat.size < 2 or lon.size < 2:
        raise InputError(
            f"step {step:g} deg is larger than the region: the grid would have {lat.size} "
            f"latitude(s) x {lon.size} longitude(s); use a smaller step"
        )
    grid = GridSpec(lat=lat, lon=lon, heights=h, step_deg=step, is_global=region is None)
    if whole_in_memory:
        check_memory(grid)
    if lat.size * lon.size * h.size > 2_000_000_000:  # int32 indices, whatever the memory
        raise InputError(f"grid of {lat.size}x{lon.size}x{h.size} nodes is too large (> 2e9)")
    return grid

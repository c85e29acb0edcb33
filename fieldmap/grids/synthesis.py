"""Latitude-longitude grids: fast synthesis of gravitation on a :class:`GridSpec`.

:class:`GridSpec` (built and validated by :func:`make_grid`, both from
:mod:`fieldmap.grids.spec` and re-exported here) describes a grid of geodetic latitudes and
longitudes (degrees) at one or more heights (m above the ellipsoid). :func:`synthesize`
evaluates, on every node, the model gravitation minus a normal gravitation (the disturbance) or
the model gravitation alone, in the geodetic east-north-up frame, by circles of latitude: one
Legendre pass per (row, height) with :func:`fieldmap.kernels.grid.row_fourier8_kernel` (eight
rows and their mirrors per thread, SIMD on the CPU), then the
longitude sums of all nodes of the row by FFT (regular longitudes) or a direct sum kernel (any
longitudes). Rows are processed in blocks so memory stays bounded for any grid size and degree.
:func:`synthesize_tensor` and :func:`tensor_points` do the same for the gradient tensor (second
derivatives, :mod:`fieldmap.kernels.grid_tensor`) on grids and at points.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

import numpy as np

from fieldmap.errors import InputError
from fieldmap.grids.longitude import (  # noqa: F401 - longitude_sums, spectrum_layout re-exported
    longitude_sums,
    regular_period,
    spectrum_layout,
)
from fieldmap.grids.spec import (  # noqa: F401 - re-exported: the grid API lives here for users
    MAX_HEIGHT_M,
    MIN_HEIGHT_M,
    GridSpec,
    check_memory,
    make_grid,
)

if TYPE_CHECKING:
    from fieldmap.field.ellipsoid import Ellipsoid
    from fieldmap.models.shmodel import SHModel

#: Row units (a row and its mirror) per thread of the Legendre pass: the lanes of one vector.
GROUP = 8

#: Memory budget of one row block (bytes), for the Fourier coefficients and FFT work arrays.
BLOCK_BYTES = 192 * 2**20


QUANTITIES = ("disturbance", "gravitation", "gravity")

#: Rows below which the row set-up runs on one CPU thread: sharing out a launch costs about
#: 0.15 ms, more than a few thousand rows of set-up.
SMALL_LAUNCH = 4096

#: Seconds spent in the parts of the last :func:`synthesize` call of this process ("legendre":
#: the Legendre pass kernel, "longitude": the longitude sums, "total"), for the benchmarks.
last_timings: dict[str, float] = {}


def simd_flag(device: str) -> int:
    """Return the ``simd`` argument of the grid kernels for ``device``: 1 on the CPU, else 0.

    With 1 the kernels run the clang SIMD snippets, CPU code only
    (:func:`fieldmap.kernels.grid_simd.column8_simd`,
    :func:`fieldmap.kernels.grid_xrange.column8x_simd`): a CUDA build compiles them to a trap,
    so a CUDA launch must pass 0 and runs the plain Warp recursion (``column8``, ``column8x``),
    the same operations per lane.
    """
    return int(str(device) == "cpu")


def resolve_device(device: str | None) -> str:
    """Warp device name; an unknown device is a :class:`fieldmap._warp.DeviceError`.

    A ``DeviceError`` is an :class:`InputError` (one-line CLI message, exit 2).
    """
    from fieldmap import _warp

    return _warp.resolve_device(device)


def to_device(a: np.ndarray, dtype: Any, device: str) -> Any:
    """Warp array (``wp.int32`` or ``wp.float64``) of ``a``: on the CPU its memory, else a copy.

    The caller keeps ``a`` alive while the array is used (the Warp array holds a reference).
    """
    import warp as wp

    a = np.ascontiguousarray(a, dtype=np.int32 if dtype is wp.int32 else np.float64)
    return wp.array(a, dtype=dtype, device=device, copy=device != "cpu")


def _row_setup(
    lat_rad: np.ndarray,
    h_m: np.ndarray,
    ellipsoid: Ellipsoid,
    radius: float,
    order: int,
    device: str,
) -> tuple[list[Any], Any]:
    """Per-item geometry and normal gravitation (geodetic ENU), see ``row_setup_kernel``."""
    import warp as wp

    from fieldmap import _warp
    from fieldmap.field.normal import normal_params
    from fieldmap.kernels import grid as kgrid

    _warp.init()  # launch_chunked compiles the module once, before its threads launch
    n = lat_rad.size
    lat = to_device(lat_rad, wp.float64, device)
    hh = to_device(h_m, wp.float64, device)
    outs = [wp.zeros(n, dtype=wp.float64, device=device) for _ in range(6)]
    gamma = wp.zeros(n, dtype=wp.vec3d, device=device)
    ell = normal_params(ellipsoid)
    _warp.launch_chunked(
        kgrid.row_setup_kernel,
        n,
        [lat, hh, ell, wp.float64(radius), int(order), *outs, gamma],
        device,
        parts=1 if n < SMALL_LAUNCH else None,
    )
    return outs, gamma


def row_powers(geo: list, lmax: int, device: str) -> tuple:
    """Power tables (u^k, k <= lmax/2 + 1; q^m, m <= lmax) of the rows of ``_row_setup``.

    The inputs of :func:`fieldmap.kernels.grid.row_fourier8_kernel` after the geometry, see
    :func:`fieldmap.kernels.grid.row_powers_kernel`.
    """
    import warp as wp

    from fieldmap import _warp
    from fieldmap.kernels import grid as kgrid

    n = geo[1].shape[0]
    upow = wp.empty((lmax // 2 + 2, n), dtype=wp.float64, device=device)
    qpow = wp.empty((lmax + 1, n), dtype=wp.float64, device=device)
    nthreads = n * (-(-upow.shape[0] // 32) - (-qpow.shape[0] // 32))  # 32 powers a thread
    parts = 1 if nthreads < 4 * SMALL_LAUNCH else None
    args = [geo[1], geo[3], upow, qpow]
    _warp.launch_chunked(kgrid.row_powers_kernel, nthreads, args, device, parts=parts)
    return upow, qpow


def _coefficient_store(shape: tuple, written: bool, device: str) -> Any:
    """Warp array of Fourier coefficients (vec2d): uninitialised if the kernel writes it all.

    On the CPU the memory comes from NumPy, which asks the kernel for huge pages on large
    arrays: a few page faults instead of one per 4 kB when the memory is fresh (e.g. after
    another library returned its own to the system).
    """
    import warp as wp

    if device != "cpu":
        return (wp.empty if written else wp.zeros)(shape, dtype=wp.vec2d, device=device)
    host = (np.empty if written else np.zeros)((*shape, 2))
    return wp.array(host, dtype=wp.vec2d, device="cpu", copy=False)


def normal_rows(
    grid: GridSpec,
    ellipsoid: Ellipsoid | str | None = None,
    normal: str = "exact",
    device: str | None = None,
) -> np.ndarray:
    """Return the normal gravitation of every (height, row) in geodetic ENU.

    It is the same at all longitudes.

    Parameters
    ----------
    grid : GridSpec
    ellipsoid : fieldmap.field.ellipsoid.Ellipsoid, optional
        Default WGS84.
    normal : {"exact", "j2", "j4", "j6"}
        The exact level-ellipsoid field or the J2/J4/J6 series (eqs. 7-13 of Chen et al. 2022,
        corrected); names of :func:`fieldmap.field.normal.normal_model`.
    device : str, optional

    Returns
    -------
    numpy.ndarray
        Shape (nh, nlat, 3): east (zero), north, up. Units: m/s².
    """
    from fieldmap.field.ellipsoid import WGS84, get_ellipsoid
    from fieldmap.field.normal import NORMAL_MODELS, normal_model

    key = normal_model(normal)
    if key == "groves-j2":
        raise InputError("normal_rows computes the exact, j2, j4 and j6 normal fields only")
    device = resolve_device(device)
    ellipsoid = get_ellipsoid(WGS84 if ellipsoid is None else ellipsoid)
    nh, nlat, _ = grid.shape
    lat = np.tile(np.radians(grid.lat), nh)
    h = np.repeat(grid.heights, nlat)
    _, gamma = _row_setup(lat, h, ellipsoid, ellipsoid.a, NORMAL_MODELS[key], device)
    return gamma.numpy().reshape(nh, nlat, 3)


def centrifugal_rows(grid: GridSpec, ellipsoid: Ellipsoid | str | None = None) -> np.ndarray:
    """Centrifugal acceleration omega^2 * p_perp in geodetic ENU per (height, row).

    Units: m/s². Shape (nh, nlat, 3). North = -omega^2 d sin(phi), up = omega^2 d cos(phi), with
    d = (N + h) cos(phi) the distance from the rotation axis.
    """
    from fieldmap.field.ellipsoid import WGS84, get_ellipsoid

    ell = get_ellipsoid(WGS84 if ellipsoid is None else ellipsoid)
    phi = np.radians(grid.lat)[None, :]
    h = grid.heights[:, None]
    nrad = ell.a / np.sqrt(1.0 - ell.e2 * np.sin(phi) ** 2)
    d = (nrad + h) * np.cos(phi)
    w2 = ell.omega**2
    out = np.zeros((grid.heights.size, grid.lat.size, 3))
    out[..., 1] = -w2 * d * np.sin(phi)
    out[..., 2] = w2 * d * np.cos(phi)
    return out


#: Legendre passes of :func:`synthesize` (``legendre=``): name -> (mirrored rows share one
#: recursion, extended-range X-numbers: True, False, or None for "above degree 2700 only")
LEGENDRE: dict[str, tuple[bool, bool | None]] = {
    "auto": (True, None),
    "scaled": (True, False),
    "xrange": (True, True),
    "column": (False, None),
}


def _row_blocks(
    grid: GridSpec, nm: int, nc: int, device: str, symmetric: bool = True
) -> tuple[Any, Any, bool, Iterator[tuple[Any, Any, Any]]]:
    """Return the coefficients' layout and the row blocks of a grid synthesis.

    Returns ``(ncol, osc, ready, blocks)``: the spectrum layout of the longitudes
    (:func:`spectrum_layout`; ``osc`` on the device) and a generator of blocks of whole units (a
    row and its mirror at −latitude when ``symmetric``, else a single row; heights stacked, row
    index ``height * nlat + lat``), as many as fit a block of rows bounded by
    :data:`BLOCK_BYTES` (at least one unit; on the CPU at least two per worker thread). Each
    block is ``(items, ua, ub)``: its rows sorted, the units' first rows and their mirrors (-1:
    none).
    """
    import warp as wp

    from fieldmap import _warp

    nh, nlat, nlon = grid.shape
    nitems = nh * nlat
    if symmetric:
        pairs = mirror_pair_array(grid.lat)
    else:
        pairs = np.stack([np.arange(nlat), np.full(nlat, -1)], axis=1)
    layer = (np.arange(nh) * nlat)[:, None]
    ua = (layer + pairs[:, 0]).ravel()
    ub = np.where(pairs[:, 1] >= 0, layer + pairs[:, 1], -1).ravel()
    ucum = np.cumsum(1 + (ub >= 0))  # rows in units 0..u
    nper = regular_period(grid.lon) or nlon
    ncol, osc_np, ready = spectrum_layout(grid.lon, nm)
    osc = to_device(osc_np, wp.float64, device)
    per_item = ncol * nc * 16 * 3 + nper * nc * 16 * 2 + nlon * nc * 8 * 2 + nm * 8 * 2
    block = int(max(2, min(nitems, BLOCK_BYTES // per_item)))
    if device == "cpu" and block < nitems:
        block = max(block, min(nitems, 2 * _warp.cpu_workers()))

    def blocks() -> Iterator[tuple[Any, Any, Any]]:
        u0 = 0
        while u0 < ua.size:
            # a block of whole units: as many as fit ``block`` rows, at least one
            done = ucum[u0 - 1] if u0 else 0
            u1 = max(u0 + 1, int(np.searchsorted(ucum, done + block, side="right")))
            bra, brb = ua[u0:u1], ub[u0:u1]
            yield np.sort(np.concatenate([bra, brb[brb >= 0]])), bra, brb
            u0 = u1

    return ncol, osc, ready, blocks()


def _progress_bar(nitems: int, work: float, progress: bool | None, desc: str) -> Any:
    """Return a tqdm bar over rows, or None: ``progress``, else only for long runs on a terminal."""
    from tqdm.auto import tqdm

    # tqdm: disable=None shows the bar on a terminal only
    disable = (not progress) if progress is not None else (None if work > 2e10 else True)
    if disable is True:
        return None
    return tqdm(total=nitems, unit="row", desc=desc, leave=False, disable=disable)


def synthesize(
    model: SHModel,
    grid: GridSpec,
    ellipsoid: Ellipsoid | str | None = None,
    quantity: str = "disturbance",
    device: str | None = None,
    progress: bool | None = None,
    *,
    potential: bool = False,
    legendre: str = "auto",
) -> np.ndarray:
    """Gravitation-derived vector on every node of a grid, geodetic east-north-up.

    Parameters
    ----------
    model : fieldmap.models.shmodel.SHModel
        Fully normalised coefficients (GM and radius of the model are used as they are).
    grid : GridSpec
    ellipsoid : fieldmap.field.ellipsoid.Ellipsoid, optional
        Normal field for the disturbance and frame for the geodetic coordinates. Default WGS84.
    quantity : {"disturbance", "gravitation", "gravity"}
        ``disturbance``: model gravitation minus exact normal gravitation (the centrifugal
        parts cancel); ``gravitation``: model alone (eq. 3 of Chen et al. 2022); ``gravity``:
        model plus centrifugal.
    device : str, optional
        Warp device (default: CUDA when present, else CPU on every core).
    progress : bool, optional
        Progress bar over row blocks; default: only for long runs on a terminal.
    potential : bool
        Also return the model potential V (eq. 1 of Chen et al. 2022, no normal part
        subtracted, no centrifugal term) as a fourth component, from the same Legendre pass.
    legendre : {"auto", "scaled", "xrange", "column"}
        The Legendre pass (:data:`LEGENDRE`). Rows mirrored about the equator share one
        recursion, scaled up to degree 2700 (:data:`fieldmap.field.sh.MAX_DEGREE_GRID`, the
        limit of the scaled recursion) and with extended-range X-numbers above it
        (:mod:`fieldmap.kernels.grid_xrange`): ``"auto"`` (default); ``"scaled"`` and
        ``"xrange"`` force either at any degree (tests, benchmarks); ``"column"`` runs the
        engine's ``sh_column`` on every row (to cross-check the paths; up to degree 2700).

    Returns
    -------
    numpy.ndarray
        Shape (nh, nlat, nlon, 3): east, north, up (m/s²); (nh, nlat, nlon, 4) with the
        potential (m²/s²) last when ``potential``.
    """
    import time

    import warp as wp

    from fieldmap import _warp
    from fieldmap.field.ellipsoid import WGS84, get_ellipsoid
    from fieldmap.field.sh import MAX_DEGREE_GRID, MAX_DEGREE_POINTS, kernel_model
    from fieldmap.grids.tables import grid_tables, grid_tables_x
    from fieldmap.kernels import grid as kgrid
    from fieldmap.kernels import grid_xrange as kgridx

    if quantity not in QUANTITIES:
        raise InputError(f"quantity must be one of {', '.join(QUANTITIES)}, got {quantity!r}")
    if legendre not in LEGENDRE:
        raise InputError(
            f"legendre must be one of {', '.join(LEGENDRE)}, got {legendre!r}", param="legendre"
        )
    symmetric, xrange = LEGENDRE[legendre]
    ellipsoid = get_ellipsoid(WGS84 if ellipsoid is None else ellipsoid)
    device = resolve_device(device)
    xr = model.lmax > MAX_DEGREE_GRID if xrange is None else bool(xrange)
    if model.lmax > MAX_DEGREE_POINTS:
        raise InputError(f"degree {model.lmax} is above {MAX_DEGREE_POINTS}; truncate the model")
    if xr and not symmetric:
        raise InputError("legendre='column' (the engine's column path) stops at degree 2700")
    if xr:  # the model enters the kernel as GM, lmax and the packed tables
        head: list[Any] = [wp.float64(model.gm), int(model.lmax)]
        tabs: tuple[Any, ...] = grid_tables_x(model, model.lmax, device)
        kern = kgridx.row_fourier8x_kernel
    else:
        head = [kernel_model(model, device)]
        tabs = grid_tables(model, head[0], device) if symmetric else ()
        kern = kgrid.row_fourier8_kernel
    simd = simd_flag(device)
    nm = model.lmax + 1
    nh, nlat, nlon = grid.shape
    nitems = nh * nlat
    lat_all = np.tile(np.radians(grid.lat), nh)
    h_all = np.repeat(grid.heights, nlat)
    nc = 4 if potential else 3
    # the coefficients as the longitude FFTs read them, where the longitudes allow
    ncol, osc, ready, blocks = _row_blocks(grid, nm, nc, device, symmetric)
    out = np.empty((nitems, nc, nlon))
    bar = _progress_bar(nitems, float(nitems) * nm * nm, progress, "synthesis")
    cen = centrifugal_rows(grid, ellipsoid).reshape(nitems, 3) if quantity == "gravity" else None
    t_leg = t_lon = 0.0
    t_all = time.perf_counter()
    for items, bra, brb in blocks:
        nb = items.size
        geo, gamma = _row_setup(lat_all[items], h_all[items], ellipsoid, model.radius, 0, device)
        # the kernels write every (row, component, order) of the block. For the FFTs that
        # read the coefficients as they are, stored order by order (coef[row, c, m] at
        # m * nb * nc + row * nc + c): the eight lanes of a thread write side by side, and the
        # FFTs read the series with a stride (at degree 240 the kernel takes 30 % less time,
        # the FFTs 10 % more); else series by series (the FFTs' copies read them faster)
        shape = (ncol, nb, nc) if ready else (nb, nc, ncol)
        store = _coefficient_store(shape, symmetric, device)
        coef = store.transpose([1, 2, 0]) if ready else store
        t0 = time.perf_counter()
        if symmetric:
            # the units' rows as indices into the block, eight units a group, padded with -1
            ng = -(-bra.size // GROUP)
            ga = np.full(ng * GROUP, -1, dtype=np.int32)
            gb = np.full(ng * GROUP, -1, dtype=np.int32)
            ga[: bra.size] = np.searchsorted(items, bra)
            gb[: brb.size] = np.where(brb >= 0, np.searchsorted(items, brb), -1)
            ga, gb = ga.reshape(ng, GROUP), gb.reshape(ng, GROUP)
            ra, rb = to_device(ga, wp.int32, device), to_device(gb, wp.int32, device)
            pows = () if xr else row_powers(geo, model.lmax, device)
            _warp.launch_chunked(
                kern,
                ng * nm,
                [*head, *tabs, *geo, ra, rb, *pows, ng, simd, osc, coef],
                device,
            )
        else:
            args = [*head, *geo, nm, osc, coef]
            _warp.launch_chunked(kgrid.row_fourier_kernel, nb * nm, args, device)
        t1 = time.perf_counter()
        t_leg += t1 - t0
        W = store.numpy().view(np.complex128)[..., 0]  # A_m - i B_m
        if ready:
            W = np.moveaxis(W, 0, -1)  # (nb, nc, ncol), a view
        if quantity == "disturbance":
            W[:, :3, 0] -= gamma.numpy()
        elif quantity == "gravity":
            assert cen is not None  # computed above for this quantity
            W[:, :3, 0] += cen[items]
        if items[-1] - items[0] + 1 == nb:  # contiguous rows: sum straight into the result
            longitude_sums(W, grid.lon, device, out=out[items[0] : items[-1] + 1], ready=ready)
        else:
            out[items] = longitude_sums(W, grid.lon, device, ready=ready)
        t_lon += time.perf_counter() - t1
        if potential:  # the kernel gives V/r (see kernels.grid._coefficients)
            out[items, 3] *= geo[2].numpy()[:, None]
        if bar is not None:
            bar.update(nb)
    if bar is not None:
        bar.close()
    last_timings.update(legendre=t_leg, longitude=t_lon, total=time.perf_counter() - t_all)
    # (height, lat, component, lon) in memory; the (height, lat, lon, component) view costs nothing
    return np.moveaxis(out.reshape(nh, nlat, nc, nlon), 2, 3)


def mirror_pair_array(lat_deg: np.ndarray) -> Any:
    """:func:`mirror_pairs` as an (n, 2) integer array.

    Distinct latitudes (any grid made by :func:`make_grid`) are paired at once with NumPy,
    repeated ones row by row.
    """
    lat = np.asarray(lat_deg, dtype=np.float64).ravel()
    if lat.size > 1:
        order = None if np.all(np.diff(lat) > 0) else np.argsort(lat, kind="stable")
        srt = lat if order is None else lat[order]
        if order is None or np.all(srt[1:] > srt[:-1]):  # distinct latitudes
            pos = np.minimum(np.searchsorted(srt, -lat), lat.size - 1)
            mate = pos if order is None else order[pos]
            mate = np.where((srt[pos] == -lat) & (lat != 0), mate, -1)
            rows = np.arange(lat.size)
            first = np.flatnonzero((mate < 0) | (mate > rows))  # a row after its mate is taken
            return np.stack([first, mate[first]], axis=1)
    # repeated latitudes: each row, in order, takes the last unused row at minus its latitude
    where = {float(v): i for i, v in enumerate(lat)}
    used: set[int] = set()
    out = []
    for i, v in enumerate(lat):
        if i in used:
            continue
        j = where.get(-float(v)) if v != 0 else None
        if j is not None and j != i and j not in used:
            out.append((i, j))
            used.update((i, j))
        else:
            out.append((i, -1))
            used.add(i)
    return np.array(out, dtype=np.int64).reshape(-1, 2)


def mirror_pairs(lat_deg: np.ndarray) -> list[tuple[int, int]]:
    """Group rows into (row, mirror row at -latitude) pairs, or (row, -1) without a mirror.

    Only exact mirrors pair up (:func:`make_grid` makes symmetric global grids exactly so);
    the equator row has no mirror other than itself.
    """
    pairs = mirror_pair_array(lat_deg)
    return list(zip(pairs[:, 0].tolist(), pairs[:, 1].tolist()))


#: The six components of the tensor maps, in the order of :func:`synthesize_tensor`.
TENSOR_COMPONENTS = ("ee", "en", "eu", "nn", "nu", "uu")


def _tensor_launch(
    model: SHModel,
    geo: list,
    ga: np.ndarray,
    gb: np.ndarray,
    osc: Any,
    coef: Any,
    device: str,
) -> None:
    """Run :func:`fieldmap.kernels.grid_tensor.row_tensor_kernel` on the units (ga, gb)."""
    import warp as wp

    from fieldmap import _warp
    from fieldmap.field.sh import kernel_model
    from fieldmap.grids.tables import tensor_tables
    from fieldmap.kernels import grid_tensor as kten

    km = kernel_model(model, device)
    tabs = tensor_tables(model, km, device)
    ra, rb = to_device(ga, wp.int32, device), to_device(gb, wp.int32, device)
    nm = model.lmax + 1
    pows = row_powers(geo, model.lmax, device)
    args = [km, *tabs, *geo, ra, rb, *pows, nm, osc, coef]
    _warp.launch_chunked(kten.row_tensor_kernel, ga.size * nm, args, device)


def _check_tensor_degree(model: SHModel) -> None:
    """Refuse degrees above the scaled recursion's (the tensor has no extended-range pass)."""
    from fieldmap.field.sh import MAX_DEGREE_GRID

    if model.lmax > MAX_DEGREE_GRID:
        raise InputError(
            f"the gradient tensor is synthesised up to degree {MAX_DEGREE_GRID}, got degree "
            f"{model.lmax}; truncate the model (lmax=)",
            param="lmax",
        )


def tensor_points(
    model: SHModel,
    lat_deg: np.ndarray,
    lon_deg: np.ndarray,
    h_m: np.ndarray,
    ellipsoid: Ellipsoid | str | None = None,
    device: str | None = None,
) -> np.ndarray:
    """Gradient tensor of the model's gravitation at scattered points, geodetic ENU.

    A point is a grid of one node: its own row of Fourier coefficients in longitude
    (:func:`fieldmap.kernels.grid_tensor.row_tensor_kernel`, no mirror), summed at its
    longitude, Re Σ_m W_m e^{i m λ} with W_m = A_m − i B_m; points in blocks, so memory stays
    bounded. Same model and ellipsoid conventions as :func:`synthesize_tensor`.

    Returns
    -------
    numpy.ndarray
        Shape (n, 6): ee, en, eu, nn, nu, uu (:data:`TENSOR_COMPONENTS`). Units: s⁻².
    """
    import warp as wp

    from fieldmap.field.ellipsoid import WGS84, get_ellipsoid

    _check_tensor_degree(model)
    ellipsoid = get_ellipsoid(WGS84 if ellipsoid is None else ellipsoid)
    device = resolve_device(device)
    lat = np.ascontiguousarray(np.radians(lat_deg), dtype=np.float64).ravel()
    lam = np.radians(np.asarray(lon_deg, dtype=np.float64).ravel())
    h = np.ascontiguousarray(h_m, dtype=np.float64).ravel()
    nm = model.lmax + 1
    out = np.empty((lat.size, 6))
    osc = to_device(np.ones(nm), wp.float64, device)
    block = int(max(1, BLOCK_BYTES // (nm * 6 * 16 * 3)))
    orders = np.arange(nm, dtype=np.float64)
    for a in range(0, lat.size, block):
        b = min(lat.size, a + block)
        geo, _ = _row_setup(lat[a:b], h[a:b], ellipsoid, model.radius, 0, device)
        store = _coefficient_store((b - a, 6, nm), True, device)
        idx = np.arange(b - a, dtype=np.int32)
        _tensor_launch(model, geo, idx, np.full_like(idx, -1), osc, store, device)
        W = store.numpy().view(np.complex128)[..., 0]  # (n, 6, nm)
        ml = lam[a:b, None] * orders[None, :]
        out[a:b] = np.einsum("ncm,nm->nc", W.real, np.cos(ml)) - np.einsum(
            "ncm,nm->nc", W.imag, np.sin(ml)
        )
    return out


def synthesize_tensor(
    model: SHModel,
    grid: GridSpec,
    ellipsoid: Ellipsoid | str | None = None,
    device: str | None = None,
    progress: bool | None = None,
) -> np.ndarray:
    """Gradient tensor of the model's gravitation on every node of a grid, geodetic ENU.

    One Legendre pass per row unit (a row and its mirror at −latitude) with
    :func:`fieldmap.kernels.grid_tensor.row_tensor_kernel`: the second derivatives of the series
    as Fourier coefficients of the six components (see that module), then the longitude sums
    (FFT where the longitudes are regular), row block by row block so memory stays bounded.
    No normal field, no centrifugal term: the caller subtracts the normal field's zonal
    coefficients from the model, or adds the centrifugal tensor
    (:mod:`fieldmap.field.gradient`).

    Parameters
    ----------
    model : fieldmap.models.shmodel.SHModel
        Fully normalised coefficients, degree <= 2700.
    grid : GridSpec
    ellipsoid : fieldmap.field.ellipsoid.Ellipsoid, optional
        Frame of the geodetic coordinates. Default WGS84.
    device : str, optional
    progress : bool, optional
        Progress bar over row blocks; default: only for long runs on a terminal.

    Returns
    -------
    numpy.ndarray
        Shape (nh, nlat, nlon, 6): ∂g_i/∂x_j for (ee, en, eu, nn, nu, uu)
        (:data:`TENSOR_COMPONENTS`). Units: s⁻².
    """
    import time

    from fieldmap.field.ellipsoid import WGS84, get_ellipsoid

    _check_tensor_degree(model)
    ellipsoid = get_ellipsoid(WGS84 if ellipsoid is None else ellipsoid)
    device = resolve_device(device)
    nm = model.lmax + 1
    nh, nlat, nlon = grid.shape
    nitems = nh * nlat
    lat_all = np.tile(np.radians(grid.lat), nh)
    h_all = np.repeat(grid.heights, nlat)
    nc = 6
    ncol, osc, ready, blocks = _row_blocks(grid, nm, nc, device)
    out = np.empty((nitems, nc, nlon))
    bar = _progress_bar(nitems, float(nitems) * nm * nm * 3, progress, "tensor")
    t_leg = t_lon = 0.0
    t_all = time.perf_counter()
    for items, bra, brb in blocks:
        nb = items.size
        geo, _ = _row_setup(lat_all[items], h_all[items], ellipsoid, model.radius, 0, device)
        shape = (ncol, nb, nc) if ready else (nb, nc, ncol)
        store = _coefficient_store(shape, True, device)
        coef = store.transpose([1, 2, 0]) if ready else store
        t0 = time.perf_counter()
        ga = np.searchsorted(items, bra).astype(np.int32)
        gb = np.where(brb >= 0, np.searchsorted(items, brb), -1).astype(np.int32)
        _tensor_launch(model, geo, ga, gb, osc, coef, device)
        t1 = time.perf_counter()
        t_leg += t1 - t0
        W = store.numpy().view(np.complex128)[..., 0]
        if ready:
            W = np.moveaxis(W, 0, -1)
        if items[-1] - items[0] + 1 == nb:
            longitude_sums(W, grid.lon, device, out=out[items[0] : items[-1] + 1], ready=ready)
        else:
            out[items] = longitude_sums(W, grid.lon, device, ready=ready)
        t_lon += time.perf_counter() - t1
        if bar is not None:
            bar.update(nb)
    if bar is not None:
        bar.close()
    last_timings.update(legendre=t_leg, longitude=t_lon, total=time.perf_counter() - t_all)
    return np.moveaxis(out.reshape(nh, nlat, nc, nlon), 2, 3)

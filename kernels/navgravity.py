"""Pluggable navigation gravitation for the strapdown kernels (float64, ECEF, no centrifugal).

One device function dispatches on an integer kind so that one launch can propagate trajectories
with different navigation gravity models (Chen et al. 2022, Table 1): the J2/J4/J6 truncations of
eq. (13), the exact level-ellipsoid field and a spherical-harmonic model (eqs. 1-3) of any degree.

Compensation tables (NAV_TABLE, the section "compensation tables"): Catmull-Rom interpolation
of δg, by the scheme of :mod:`fieldmap.products.tables.model` (its module docstring; the C
header written with every table): tensor-product Catmull-Rom cubics (Keys, a = -1/2) in latitude,
longitude and height, one margin node on each horizontal side, linear ghost nodes beyond the
lowest and highest heights. The host checks that every point is inside the valid domain before
a launch (:func:`fieldmap.products.tables.model.interpolate` names the first point outside); the
kernel clamps the cells as the NumPy interpolator does.

:func:`table_gravitation_ecef` is a navigation gravity: the exact normal gravitation plus the
table's δg (north, east, down, mGal) turned into ECEF at the geodetic position of the point.
"""

import warp as wp

from .frames import ecef_to_enu, enu_to_ecef
from .normal import KIND_EXACT, NormalParams, centrifugal_ecef, normal_field_ecef
from .sh import SHKernelModel, sh_gravitation_ecef

# forward kernels only: fieldmap never differentiates through them (faster builds, whatever
# the import order relative to fieldmap._warp.init())
wp.set_module_options({"enable_backward": False})

NAV_NORMAL_EXACT = KIND_EXACT  # the J kinds are the orders 2, 4, 6, as in normal_field_ecef
NAV_SH = wp.constant(1)
#: a compensation table: the exact normal field plus the table's δg (below)
NAV_TABLE = wp.constant(3)
NAV_J2 = wp.constant(2)
NAV_J4 = wp.constant(4)
NAV_J6 = wp.constant(6)


# ------------------------------------------------------------------------------ compensation tables

_HALF = wp.constant(wp.float64(0.5))
_ONE = wp.constant(wp.float64(1.0))
_TWO = wp.constant(wp.float64(2.0))
#: mGal -> m/s²
_MGAL = wp.constant(wp.float64(1.0e-5))


@wp.struct
class TableKernel:
    """A compensation table on the device: δg (north, east, down; mGal) per lattice node.

    ``data[k, i, j]`` is the node at height ``h0 + k dh`` (m), latitude ``lat0 + i dlat`` and
    longitude ``lon0 + j dlon`` (degrees; margin nodes included).
    """

    data: wp.array3d(dtype=wp.vec3d)
    lat0: wp.float64
    dlat: wp.float64
    lon0: wp.float64
    dlon: wp.float64
    h0: wp.float64
    dh: wp.float64


@wp.func
def catmull_rom(t: wp.float64):
    """Weights of nodes i-1, i, i+1, i+2 at fraction t of cell i (Keys a = -1/2)."""
    t2 = t * t
    t3 = t2 * t
    return wp.vec4d(
        _HALF * (-t3 + _TWO * t2 - t),
        _HALF * (wp.float64(3.0) * t3 - wp.float64(5.0) * t2 + _TWO),
        _HALF * (wp.float64(-3.0) * t3 + wp.float64(4.0) * t2 + t),
        _HALF * (t3 - t2),
    )


@wp.func
def _cell(u: wp.float64, lo: int, hi: int):
    """Cell index clamped to lo..hi and the fraction within it, clamped to 0..1."""
    i = int(wp.floor(u))
    i = wp.clamp(i, lo, hi)
    t = wp.clamp(u - wp.float64(i), wp.float64(0.0), _ONE)
    return i, t


@wp.func
def _level(tab: TableKernel, k: int, i: int, j: int, wy: wp.vec4d, wx: wp.vec4d):
    """Horizontal bicubic of height node k around cell (i, j)."""
    acc = wp.vec3d()
    for a in range(4):
        row = wp.vec3d()
        for b in range(4):
            row = row + wx[b] * tab.data[k, i - 1 + a, j - 1 + b]
        acc = acc + wy[a] * row
    return acc


@wp.func
def table_ned(tab: TableKernel, lat_deg: wp.float64, lon_deg: wp.float64, h: wp.float64):
    """δg north, east, down (mGal) at a geodetic point (degrees, m), interpolated."""
    nh = tab.data.shape[0]
    nlat = tab.data.shape[1]
    nlon = tab.data.shape[2]
    y = (lat_deg - tab.lat0) / tab.dlat
    dl = lon_deg - tab.lon0
    dl = dl - wp.float64(360.0) * wp.floor(dl / wp.float64(360.0))
    x = dl / tab.dlon
    z = (h - tab.h0) / tab.dh
    i, ty = _cell(y, 1, nlat - 3)
    j, tx = _cell(x, 1, nlon - 3)
    k, tz = _cell(z, 0, nh - 2)
    wy = catmull_rom(ty)
    wx = catmull_rom(tx)
    wz = catmull_rom(tz)
    v0 = _level(tab, k, i, j, wy, wx)
    v1 = _level(tab, k + 1, i, j, wy, wx)
    lo = _TWO * v0 - v1
    if k > 0:
        lo = _level(tab, k - 1, i, j, wy, wx)
    hi = _TWO * v1 - v0
    if k < nh - 2:
        hi = _level(tab, k + 2, i, j, wy, wx)
    return wz[0] * lo + wz[1] * v0 + wz[2] * v1 + wz[3] * hi


@wp.func
def ecef_to_geodetic_rad(p: wp.vec3d, a: wp.float64, e2: wp.float64):
    """ECEF (m) -> geodetic latitude, longitude (rad), height (m); 6 fixed-point iterations.

    φ from tan φ = (z + e² N sin φ) / ρ, started at the geocentric latitude; the iteration
    contracts by ~e² per step, so 6 steps leave < 1e-15 rad at aircraft heights. At the pole
    axis (ρ = 0) the latitude is ±90° exactly.
    """
    rho = wp.sqrt(p[0] * p[0] + p[1] * p[1])
    lon = wp.atan2(p[1], p[0])
    lat = wp.atan2(p[2], rho * (_ONE - e2))
    for _ in range(6):
        s = wp.sin(lat)
        n = a / wp.sqrt(_ONE - e2 * s * s)
        lat = wp.atan2(p[2] + e2 * n * s, rho)
    s = wp.sin(lat)
    c = wp.cos(lat)
    n = a / wp.sqrt(_ONE - e2 * s * s)
    h = rho * c + p[2] * s - a * a / n  # exact for any latitude (no division by cos φ)
    return wp.vec3d(lat, lon, h)


@wp.func
def table_gravitation_ecef(tab: TableKernel, p: wp.vec3d, ell: NormalParams):
    """Exact normal gravitation plus the table's δg at ECEF ``p``: ECEF, m/s²."""
    llh = ecef_to_geodetic_rad(p, ell.a, ell.e2)
    d = table_ned(tab, wp.degrees(llh[0]), wp.degrees(llh[1]), llh[2]) * _MGAL
    g = enu_to_ecef(wp.vec3d(d[1], d[0], -d[2]), llh[0], llh[1])
    return normal_field_ecef(p, ell, KIND_EXACT, 0) + g


@wp.kernel
def table_points_kernel(
    tab: TableKernel,
    lat: wp.array(dtype=wp.float64),
    lon: wp.array(dtype=wp.float64),
    h: wp.array(dtype=wp.float64),
    out: wp.array(dtype=wp.vec3d),
):
    """δg north, east, down (mGal) at geodetic points (degrees, m): :func:`table_ned`."""
    i = wp.tid()
    out[i] = table_ned(tab, lat[i], lon[i], h[i])


@wp.kernel
def table_gravitation_kernel(
    tab: TableKernel,
    ell: NormalParams,
    p: wp.array(dtype=wp.vec3d),
    out: wp.array(dtype=wp.vec3d),
    enu: wp.array(dtype=wp.vec3d),
):
    """:func:`table_gravitation_ecef` at ECEF points, and the check rotation back to ENU."""
    i = wp.tid()
    g = table_gravitation_ecef(tab, p[i], ell)
    out[i] = g
    llh = ecef_to_geodetic_rad(p[i], ell.a, ell.e2)
    enu[i] = ecef_to_enu(g - normal_field_ecef(p[i], ell, KIND_EXACT, 0), llh[0], llh[1])


# ----------------------------------------------------------------------- the navigation gravitation


@wp.func
def nav_gravitation_ecef(
    kind: int, p: wp.vec3d, ell: NormalParams, sh: SHKernelModel, tab: TableKernel
):
    """Gravitational acceleration at ECEF ``p`` for navigation gravity ``kind``.

    kind: NAV_J2 / NAV_J4 / NAV_J6 (eq. 13 truncations), NAV_NORMAL_EXACT (closed-form level
    ellipsoid), NAV_SH (``sh`` up to ``sh.lmax``) or NAV_TABLE (exact normal field plus the
    compensation table ``tab``). Units: m -> m/s², ECEF components.
    """
    if kind == NAV_SH:
        return sh_gravitation_ecef(sh, p)
    if kind == NAV_TABLE:
        return table_gravitation_ecef(tab, p, ell)
    return normal_field_ecef(p, ell, kind, 0)


@wp.func
def nav_gravity_ecef(
    kind: int, p: wp.vec3d, ell: NormalParams, sh: SHKernelModel, tab: TableKernel
):
    """Gravity (gravitation + centrifugal, Groves eq. 3.7.5) at ECEF ``p``. Units: m -> m/s²."""
    return nav_gravitation_ecef(kind, p, ell, sh, tab) + centrifugal_ecef(p, ell.omega)


@wp.func
def held_gravitation_ecef(
    kind: int,
    p: wp.vec3d,
    ell: NormalParams,
    sh: SHKernelModel,
    tab: TableKernel,
    index: int,
    every: int,
    hold: wp.vec3d,
    slope: wp.vec3d,
    last: wp.vec3d,
):
    """Navigation gravitation with the SH disturbance updated every ``every`` samples.

    As a flight computer does (normal gravity every step, the disturbance at a slower gravity
    rate): for ``kind`` NAV_SH and ``every`` > 1 the disturbance δ = g_SH − γ_exact is evaluated
    when ``index`` (global sample index) is ``every`` or more past the last evaluation
    (``last[0]``; ``last[1]`` = 0 before the first), and between evaluations extrapolated
    linearly from the last two (``slope`` per sample): g = γ_exact(p) + δ + slope (index − j).
    Other kinds, or ``every`` ≤ 1: the full :func:`nav_gravitation_ecef`. Returns the
    gravitation (ECEF, m/s²) and the updated (hold, slope, last).
    """
    if kind != NAV_SH or every <= 1:
        return nav_gravitation_ecef(kind, p, ell, sh, tab), hold, slope, last
    normal = normal_field_ecef(p, ell, NAV_NORMAL_EXACT, 0)
    j = wp.float64(index)
    if last[1] == wp.float64(0.0) or j - last[0] >= wp.float64(every):
        d = sh_gravitation_ecef(sh, p) - normal
        if last[1] != wp.float64(0.0):
            slope = (d - hold) / (j - last[0])
        hold = d
        last = wp.vec3d(j, wp.float64(1.0), wp.float64(0.0))
    return normal + hold + slope * (j - last[0]), hold, slope, last

"""Pluggable navigation gravitation for the strapdown kernels (float64, ECEF, no centrifugal).

One device function dispatches on an integer kind so that one launch can propagate trajectories
with different navigation gravity models (Chen et al. 2022, Table 1): the J2/J4/J6 truncations of
eq. (13), the exact level-ellipsoid field and a spherical-harmonic model (eqs. 1-3) of any degree.
"""

import warp as wp

from .navtable import TableKernel, table_gravitation_ecef
from .normal import KIND_EXACT, NormalParams, centrifugal_ecef, normal_field_ecef
from .sh import SHKernelModel, sh_gravitation_ecef

# forward kernels only: fieldmap never differentiates through them (faster builds, whatever
# the import order relative to fieldmap._warp.init())
wp.set_module_options({"enable_backward": False})

NAV_NORMAL_EXACT = KIND_EXACT  # the J kinds are the orders 2, 4, 6, as in normal_field_ecef
NAV_SH = wp.constant(1)
#: a compensation table: the exact normal field plus the table's δg (kernels/navtable.py)
NAV_TABLE = wp.constant(3)
NAV_J2 = wp.constant(2)
NAV_J4 = wp.constant(4)
NAV_J6 = wp.constant(6)


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

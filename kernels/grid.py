"""Warp kernels for grid synthesis: one Legendre pass per (latitude row, height), shared by the row.

A latitude-longitude grid is a set of circles of latitude. On a circle (fixed geocentric
latitude and radius) the degree sums of Chen et al. (2022) eq. (3) do not depend on longitude,
so they are done once per (row, order m) with the engine's :func:`sh_column` and turned here into
Fourier coefficients of the three gravitation components in the *geodetic* east-north-up frame:

.. math::
    g_c(\\lambda) = \\sum_{m=0}^{N} \\left[A^c_m \\cos m\\lambda + B^c_m \\sin m\\lambda\\right],
    \\qquad c \\in \\{E, N, U\\}

(the longitude sums, by FFT where longitudes are regular, are done by the host).

The column sums carry the 1e-280 scale of Holmes & Featherstone (2002) and lack the factor
:math:`u^m` (u = cos of geocentric latitude). Multiplying by :math:`u^m` directly could underflow
(e.g. u^805 at 68 deg latitude is below 1e-308) while the column sum is huge and the product
matters, so :math:`u^m` is applied in two halves and the 1e280 scale last:
``((s * u^(m//2)) * u^(m - m//2)) * 1e280``. A product below 1e-308 after the first two factors
is at most 1e-28 of GM/r^2 and is negligible.
"""

import warp as wp

from .frames import ecef_to_enu, geodetic_to_ecef
from .normal import NormalParams, jn_gravitation, normal_gravitation_exact
from .sh import SHKernelModel, sh_column

SCALE_UP = wp.constant(wp.float64(1.0e280))

# Fourier coefficients of one (row, m): A_E, B_E, A_N, B_N, A_U, B_U (geodetic ENU, m/s^2)
vec6d = wp.types.vector(length=6, dtype=wp.float64)


@wp.func
def _powi(u: wp.float64, k: int) -> wp.float64:
    """u**k for an integer k >= 0 (u**0 = 1 also at the pole, u = 0)."""
    if k == 0:
        return wp.float64(1.0)
    return wp.pow(u, wp.float64(k))


@wp.func
def scaled_times_power(s: wp.float64, u: wp.float64, k: int) -> wp.float64:
    """Return s * u**k * 1e280 without intermediate under/overflow (see module docstring)."""
    k1 = k / 2
    return ((s * _powi(u, k1)) * _powi(u, k - k1)) * SCALE_UP


@wp.kernel
def row_setup_kernel(
    lat: wp.array(dtype=wp.float64),
    h: wp.array(dtype=wp.float64),
    ell: NormalParams,
    radius: wp.float64,
    order: int,
    t_out: wp.array(dtype=wp.float64),
    u_out: wp.array(dtype=wp.float64),
    r_out: wp.array(dtype=wp.float64),
    q_out: wp.array(dtype=wp.float64),
    cdel_out: wp.array(dtype=wp.float64),
    sdel_out: wp.array(dtype=wp.float64),
    gamma_out: wp.array(dtype=wp.vec3d),
    offset: wp.int32,
):
    """Geometry and normal gravitation of each (row, height) item.

    For geodetic latitude ``lat`` (rad) and height ``h`` (m): t = sin, u = cos of the geocentric
    latitude, r, q = R/r, cos/sin of delta = phi_geodetic - phi_geocentric, and the normal
    gravitation (no centrifugal) in geodetic ENU at longitude 0 (it is independent of longitude):
    exact level ellipsoid for ``order == 0``, else the J2/J4/J6 series (eqs. 7-13 of
    Chen et al. 2022, corrected).
    """
    i = wp.tid() + offset
    phi = lat[i]
    p = geodetic_to_ecef(phi, wp.float64(0.0), h[i], ell.a, ell.e2)
    rho = p[0]
    z = p[2]
    r = wp.sqrt(rho * rho + z * z)
    t = z / r
    u = rho / r
    sp = wp.sin(phi)
    cp = wp.cos(phi)
    t_out[i] = t
    u_out[i] = u
    r_out[i] = r
    q_out[i] = radius / r
    cdel_out[i] = cp * u + sp * t
    sdel_out[i] = sp * u - cp * t
    g = wp.vec3d()
    if order == 0:
        g = normal_gravitation_exact(p, ell)
    else:
        g = jn_gravitation(p, ell, order)
    gamma_out[i] = ecef_to_enu(g, phi, wp.float64(0.0))


@wp.kernel
def row_fourier_kernel(
    model: SHKernelModel,
    t: wp.array(dtype=wp.float64),
    u: wp.array(dtype=wp.float64),
    r: wp.array(dtype=wp.float64),
    q: wp.array(dtype=wp.float64),
    cdel: wp.array(dtype=wp.float64),
    sdel: wp.array(dtype=wp.float64),
    nm: int,
    coef: wp.array2d(dtype=vec6d),
    offset: wp.int32,
):
    """Fourier coefficients of the model gravitation for every (row, order m), one thread each.

    Thread ``i`` handles row ``i // nm`` and order ``m = i % nm``. From the column sums of
    :func:`sh_column` (eq. 3 of Chen et al. 2022, per the SH contract) the geocentric components
    are, with K = GM/r^2:

    - up:    A = -K u^m s2,         B = -K u^m s3
    - north: A =  K u^(m-1) s4,     B =  K u^(m-1) s5    (m >= 1)
    - east:  A =  K m u^(m-1) s1,   B = -K m u^(m-1) s0  (m >= 1)

    and the zonal north term A = K u s6 (s6 from column m = 1) for m = 0. The rotation by delta about east turns geocentric (north, up) into geodetic (north, up).
    """
    i = wp.tid() + offset
    row = i / nm
    m = i - row * nm
    s = sh_column(model, m, t[row], q[row])
    uu = u[row]
    rr = r[row]
    k = model.gm / (rr * rr)
    cd = cdel[row]
    sd = sdel[row]
    a_up = -k * scaled_times_power(s[2], uu, m)
    b_up = -k * scaled_times_power(s[3], uu, m)
    a_no = wp.float64(0.0)
    b_no = wp.float64(0.0)
    a_ea = wp.float64(0.0)
    b_ea = wp.float64(0.0)
    if m >= 1:
        fm = wp.float64(m)
        a_no = k * scaled_times_power(s[4], uu, m - 1)
        b_no = k * scaled_times_power(s[5], uu, m - 1)
        a_ea = k * fm * scaled_times_power(s[1], uu, m - 1)
        b_ea = -k * fm * scaled_times_power(s[0], uu, m - 1)
    if m == 0:
        # the zonal north term K u s6 lives in column m = 1; one extra column per row (cost
        # 1/(lmax/2) of the row) keeps every (row, m) thread independent
        s1c = sh_column(model, 1, t[row], q[row])
        a_no = k * scaled_times_power(s1c[6], uu, 1)
    # geocentric (north, up) -> geodetic (north, up): rotation by delta about east
    coef[row, m] = vec6d(
        a_ea,
        b_ea,
        cd * a_no - sd * a_up,
        cd * b_no - sd * b_up,
        cd * a_up + sd * a_no,
        cd * b_up + sd * b_no,
    )


@wp.kernel
def longitude_sum_kernel(
    coef: wp.array2d(dtype=wp.vec2d),
    lon: wp.array(dtype=wp.float64),
    nm: int,
    nlon: int,
    out: wp.array2d(dtype=wp.float64),
    offset: wp.int32,
):
    """Direct longitude sums sum_m (A_m cos m lon + B_m sin m lon) for irregular longitudes.

    ``coef[j, m] = (A_m, B_m)`` for series j (e.g. 3 components of each row); thread i handles
    series ``i // nlon`` at longitude ``i % nlon``. cos/sin(m lon) come from the angle-addition
    recurrence, restarted from wp.cos/wp.sin every 32 orders so rounding cannot build up.
    """
    i = wp.tid() + offset
    j = i / nlon
    kk = i - j * nlon
    lam = lon[kk]
    c1 = wp.cos(lam)
    s1 = wp.sin(lam)
    cm = wp.float64(1.0)
    sm = wp.float64(0.0)
    acc = wp.float64(0.0)
    for m in range(nm):
        if m > 0:
            if m % 32 == 0:
                cm = wp.cos(wp.float64(m) * lam)
                sm = wp.sin(wp.float64(m) * lam)
            else:
                cn = cm * c1 - sm * s1
                sm = sm * c1 + cm * s1
                cm = cn
        ab = coef[j, m]
        acc = acc + ab[0] * cm + ab[1] * sm
    out[j, kk] = acc

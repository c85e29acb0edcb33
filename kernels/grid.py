r"""Warp kernels for grid synthesis: one Legendre pass per (latitude row, height).

A latitude-longitude grid is a set of circles of latitude. On a circle (fixed geocentric
latitude and radius) the degree sums of Chen et al. (2022) eq. (3) do not depend on longitude,
so they are done once per (row, order m) with the engine's :func:`sh_column` and turned here into
Fourier coefficients of the three gravitation components in the *geodetic* east-north-up frame:

.. math::
    g_c(\lambda) = \sum_{m=0}^{N} \left[A^c_m \cos m\lambda + B^c_m \sin m\lambda\right],
    \qquad c \in \{E, N, U\}

(the longitude sums, by FFT where longitudes are regular, are done by the host).

The column sums carry the 1e-280 scale of Holmes & Featherstone (2002) and lack the factor
:math:`u^m` (u = cos of geocentric latitude). Multiplying by :math:`u^m` directly could underflow
(e.g. u^805 at 68 deg latitude is below 1e-308) while the column sum is huge and the product
matters, so :math:`u^m` is applied in two halves and the 1e280 scale last:
``((s * u^(m//2)) * u^(m - m//2)) * 1e280`` (:func:`half_powers`, one ``pow`` each). A product
below 1e-308 after the first two factors is at most 1e-28 of GM/r^2 and is negligible.
"""

import warp as wp

from .frames import ecef_to_enu, geodetic_to_ecef
from .normal import NormalParams, normal_field_ecef
from .sh import QM_MIN, SCALE, SHKernelModel, sh_column, sh_vec8

# forward kernels only: fieldmap never differentiates through them (faster builds, whatever
# the import order relative to fieldmap._warp.init())
wp.set_module_options({"enable_backward": False})

SCALE_UP = wp.constant(wp.float64(1.0e280))


@wp.func
def _powi(u: wp.float64, k: int) -> wp.float64:
    """u**k for an integer k >= 0 (u**0 = 1 also at the pole, u = 0)."""
    if k == 0:
        return wp.float64(1.0)
    return wp.pow(u, wp.float64(k))


@wp.func
def half_powers(u: wp.float64, k: int) -> wp.vec2d:
    """Return (u**(k//2), u**(k - k//2)) for k >= 0.

    u**k in two factors that cannot underflow alone while the product still matters (see the
    module docstring).
    """
    k1 = k / 2
    a = _powi(u, k1)
    if k - k1 == k1:
        return wp.vec2d(a, a)
    return wp.vec2d(a, a * u)


@wp.func
def scaled_times(s: wp.float64, hp: wp.vec2d) -> wp.float64:
    """S * u**k * 1e280 with ``hp = half_powers(u, k)``, without under/overflow on the way."""
    return ((s * hp[0]) * hp[1]) * SCALE_UP


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
    gamma_out[i] = ecef_to_enu(normal_field_ecef(p, ell, order, 0), phi, wp.float64(0.0))


@wp.func
def _coefficients(
    s: sh_vec8,
    s6: wp.float64,
    m: int,
    u: wp.float64,
    r: wp.float64,
    cd: wp.float64,
    sd: wp.float64,
    gm: wp.float64,
    coef: wp.array3d(dtype=wp.vec2d),
    row: int,
):
    """Write the Fourier coefficients of order m of one row as (A, -B) per component.

    From the column sums of :func:`sh_column` (eq. 3 of Chen et al. 2022, per the SH contract)
    the geocentric components are, with K = GM/r^2:

    - up:    A = -K u^m s2,         B = -K u^m s3
    - north: A =  K u^(m-1) s4,     B =  K u^(m-1) s5    (m >= 1); A = K u s6 for m = 0
    - east:  A =  K m u^(m-1) s1,   B = -K m u^(m-1) s0  (m >= 1)

    and a rotation by delta about east turns geocentric (north, up) into geodetic (north, up).
    (A, -B) is stored so that the host reads W_m = A_m - i B_m as one complex number. If
    ``coef`` has a fourth component, it receives the potential (eq. 1 of Chen et al. 2022)
    divided by r, A = K u^m s0, B = K u^m s1: of the size of the gravitation, because the host's
    FFT pairs two real series per complex transform and a series 1e6 times larger would leak its
    rounding into its partner (the host multiplies by r after the longitude sums).
    """
    k = gm / (r * r)
    hm = half_powers(u, m)
    a_up = -k * scaled_times(s[2], hm)
    b_up = -k * scaled_times(s[3], hm)
    a_no = wp.float64(0.0)
    b_no = wp.float64(0.0)
    a_ea = wp.float64(0.0)
    b_ea = wp.float64(0.0)
    if m >= 1:
        fm = wp.float64(m)
        h1 = half_powers(u, m - 1)
        a_no = k * scaled_times(s[4], h1)
        b_no = k * scaled_times(s[5], h1)
        a_ea = k * fm * scaled_times(s[1], h1)
        b_ea = -k * fm * scaled_times(s[0], h1)
    else:
        a_no = k * scaled_times(s6, half_powers(u, 1))
    coef[row, 0, m] = wp.vec2d(a_ea, -b_ea)
    coef[row, 1, m] = wp.vec2d(cd * a_no - sd * a_up, -(cd * b_no - sd * b_up))
    coef[row, 2, m] = wp.vec2d(cd * a_up + sd * a_no, -(cd * b_up + sd * b_no))
    if coef.shape[1] > 3:
        coef[row, 3, m] = wp.vec2d(k * scaled_times(s[0], hm), -k * scaled_times(s[1], hm))


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
    coef: wp.array3d(dtype=wp.vec2d),
    offset: wp.int32,
):
    """Fourier coefficients of the model gravitation for every (row, order m), one thread each.

    Thread ``i`` handles row ``i // nm`` and order ``m = i % nm`` with the engine's
    :func:`sh_column`; see :func:`_coefficients`. The zonal north term needs entry [6] of column
    m = 1: the m = 0 thread evaluates that column too (1/(lmax/2) of the row's work), which
    keeps every thread independent.
    """
    i = wp.tid() + offset
    row = i / nm
    m = i - row * nm
    s = sh_column(model, m, t[row], q[row])
    s6 = wp.float64(0.0)
    if m == 0 and model.lmax >= 1:
        s6 = sh_column(model, 1, t[row], q[row])[6]
    _coefficients(s, s6, m, u[row], r[row], cdel[row], sdel[row], model.gm, coef, row)


@wp.func
def _mirror(ev: sh_vec8, od: sh_vec8) -> sh_vec8:
    """Column sums at -t from the parts of even and odd n - m at t.

    Because P̄nm(-t) = (-1)^(n+m) P̄nm(t), entries [0..3] and [6] are E - O, and entries [4],
    [5] (which hold dP/dφ, odd in t for even n - m) are O - E.
    """
    out = ev - od
    out[4] = od[4] - ev[4]
    out[5] = od[5] - ev[5]
    return out


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


mat84d = wp.types.matrix(shape=(8, 4), dtype=wp.float64)


@wp.func
def sh_column_parity4(model: SHKernelModel, m: int, t: wp.vec4d, q: wp.vec4d):
    """Sum the engine's ``sh_column`` series for four rows at once, split by the parity of n - m.

    Same recursion, tables and 1e-280 scaling as ``sh_column`` (Holmes & Featherstone 2002);
    each degree's terms go to the even or the odd sums (columns k of the returned 8x4 matrices
    ``(even, odd)``), so that the mirror row at -t follows without a second recursion
    (:func:`_mirror`). The four recursions share every table load (a, b, C, S, f of order m)
    and run as four independent chains, which the CPU overlaps. A row whose q^m is below ``QM_MIN``
    gets zero sums, as in ``sh_column``.
    """
    ev = mat84d()
    od = mat84d()
    lmax = model.lmax
    if m > lmax:
        return ev, od
    fm = wp.float64(m)
    sc = SCALE * model.sect[m]
    p1 = wp.vec4d()
    for k in range(4):
        qm = wp.pow(q[k], fm)
        if qm >= QM_MIN:
            p1[k] = sc * qm
    tq = wp.cw_mul(t, q)
    qq = wp.cw_mul(q, q)
    p2 = wp.vec4d()
    c = model.cnm[m, m]
    s = model.snm[m, m]
    nf1 = wp.float64(m + 1)
    e0 = c * p1
    e1 = s * p1
    e2 = nf1 * e0
    e3 = nf1 * e1
    ed4 = wp.vec4d()
    ed5 = wp.vec4d()
    e6 = wp.vec4d()
    o0 = wp.vec4d()
    o1 = wp.vec4d()
    o2 = wp.vec4d()
    o3 = wp.vec4d()
    od4 = wp.vec4d()
    od5 = wp.vec4d()
    o6 = wp.vec4d()
    if m == 1:
        e6 = (model.fnm[0, 1] * model.cnm[0, 1]) * p1
    n = m + 1
    while n <= lmax:
        # n - m odd
        pn = model.anm[m, n] * wp.cw_mul(tq, p1) - model.bnm[m, n] * wp.cw_mul(qq, p2)
        c = model.cnm[m, n]
        s = model.snm[m, n]
        nf1 = nf1 + wp.float64(1.0)
        o0 = o0 + c * pn
        o1 = o1 + s * pn
        o2 = o2 + (nf1 * c) * pn
        o3 = o3 + (nf1 * s) * pn
        f = model.fnm[m, n]
        od4 = od4 + (c * f) * p1
        od5 = od5 + (s * f) * p1
        if m == 1:
            o6 = o6 + (model.fnm[0, n] * model.cnm[0, n]) * pn
        p2 = p1
        p1 = pn
        n = n + 1
        if n > lmax:
            break
        # n - m even
        pn = model.anm[m, n] * wp.cw_mul(tq, p1) - model.bnm[m, n] * wp.cw_mul(qq, p2)
        c = model.cnm[m, n]
        s = model.snm[m, n]
        nf1 = nf1 + wp.float64(1.0)
        e0 = e0 + c * pn
        e1 = e1 + s * pn
        e2 = e2 + (nf1 * c) * pn
        e3 = e3 + (nf1 * s) * pn
        f = model.fnm[m, n]
        ed4 = ed4 + (c * f) * p1
        ed5 = ed5 + (s * f) * p1
        if m == 1:
            e6 = e6 + (model.fnm[0, n] * model.cnm[0, n]) * pn
        p2 = p1
        p1 = pn
        n = n + 1
    for k in range(4):
        ev[0, k] = e0[k]
        ev[1, k] = e1[k]
        ev[2, k] = e2[k]
        ev[3, k] = e3[k]
        ev[6, k] = e6[k]
        od[0, k] = o0[k]
        od[1, k] = o1[k]
        od[2, k] = o2[k]
        od[3, k] = o3[k]
        od[6, k] = o6[k]
        if m >= 1:
            ev[4, k] = -t[k] * (e2[k] - e0[k]) + q[k] * ed4[k]
            ev[5, k] = -t[k] * (e3[k] - e1[k]) + q[k] * ed5[k]
            od[4, k] = -t[k] * (o2[k] - o0[k]) + q[k] * od4[k]
            od[5, k] = -t[k] * (o3[k] - o1[k]) + q[k] * od5[k]
    return ev, od


@wp.func
def _col(a: mat84d, k: int) -> sh_vec8:
    out = sh_vec8()
    for j in range(8):
        out[j] = a[j, k]
    return out


@wp.kernel
def row_fourier_group_kernel(
    model: SHKernelModel,
    t: wp.array(dtype=wp.float64),
    u: wp.array(dtype=wp.float64),
    r: wp.array(dtype=wp.float64),
    q: wp.array(dtype=wp.float64),
    cdel: wp.array(dtype=wp.float64),
    sdel: wp.array(dtype=wp.float64),
    row_a: wp.array2d(dtype=wp.int32),
    row_b: wp.array2d(dtype=wp.int32),
    nm: int,
    coef: wp.array3d(dtype=wp.vec2d),
    offset: wp.int32,
):
    """Fourier coefficients for groups of four row units per thread (grids symmetric or not).

    One recursion at row ``row_a`` serves its mirror row ``row_b`` at -t as well (same height,
    so same r and q), halving the Legendre work of grids symmetric about the equator such as
    the paper's 80S-80N; four units per thread share the table loads. Thread ``i`` handles
    group ``g = i // nm`` and order ``m = i % nm``; unit k of the group is row ``row_a[g, k]``
    (recursion at its t) and its mirror ``row_b[g, k]`` (or -1); a padding unit has ``row_a = -1``
    and writes nothing.
    """
    i = wp.tid() + offset
    g = i / nm
    m = i - g * nm
    tv = wp.vec4d()
    qv = wp.vec4d()
    for k in range(4):
        ra = row_a[g, k]
        if ra >= 0:
            tv[k] = t[ra]
            qv[k] = q[ra]
    ev, od = sh_column_parity4(model, m, tv, qv)
    e6 = wp.vec4d()
    o6 = wp.vec4d()
    if m == 0 and model.lmax >= 1:
        ev1, od1 = sh_column_parity4(model, 1, tv, qv)
        for k in range(4):
            e6[k] = ev1[6, k]
            o6[k] = od1[6, k]
    for k in range(4):
        ra = row_a[g, k]
        if ra >= 0:
            se = _col(ev, k)
            so = _col(od, k)
            _coefficients(
                se + so, e6[k] + o6[k], m, u[ra], r[ra], cdel[ra], sdel[ra], model.gm, coef, ra
            )
            rb = row_b[g, k]
            if rb >= 0:
                _coefficients(
                    _mirror(se, so),
                    e6[k] - o6[k],
                    m,
                    u[rb],
                    r[rb],
                    cdel[rb],
                    sdel[rb],
                    model.gm,
                    coef,
                    rb,
                )

r"""Warp kernels for grid synthesis: one Legendre pass per (latitude row, height).

A latitude-longitude grid is a set of circles of latitude. On a circle (fixed geocentric
latitude and radius) the degree sums of Chen et al. (2022) eq. (3) do not depend on longitude,
so they are done once per (row, order m) with the engine's :func:`sh_column` and turned here into
Fourier coefficients of the three gravitation components in the *geodetic* east-north-up frame:

.. math::
    g_c(\lambda) = \sum_{m=0}^{N} \left[A^c_m \cos m\lambda + B^c_m \sin m\lambda\right],
    \qquad c \in \{E, N, U\}

(the longitude sums, by FFT where longitudes are regular, are done by the host).

Two Legendre passes write the same coefficients: :func:`row_fourier_kernel`, one (row, order)
per thread with :func:`sh_column`, and :func:`row_fourier8_kernel`, one order for eight rows and
their mirrors per thread, whose column sums (:func:`column8`, :func:`column8_simd`,
:func:`zonal_north8`, :func:`seed8`, :func:`order_of`, the vector types ``vec8d`` and
``mat168d``) live in :mod:`fieldmap.kernels.grid_simd` and are importable from here too. This
module holds the row geometry (:func:`row_setup_kernel`), the coefficients and the longitude sums
of irregular longitudes (:func:`longitude_sum_kernel`).

The column sums carry the 1e-280 scale of Holmes & Featherstone (2002) and lack the factor
:math:`u^m` (u = cos of geocentric latitude). Multiplying by :math:`u^m` directly could underflow
(e.g. u^805 at 68 deg latitude is below 1e-308) while the column sum is huge and the product
matters, so :math:`u^m` is applied in two halves and the 1e280 scale last:
``((s * u^(m//2)) * u^(m - m//2)) * 1e280`` (:func:`half_powers`, one ``pow`` each; the eight-lane
pass reads them from per-row tables, :func:`row_powers_kernel`). A product below 1e-308 after
the first two factors is at most 1e-28 of GM/r^2 and is negligible.
"""

import warp as wp

from .frames import ecef_to_enu, geodetic_to_ecef
from .grid_simd import column8, column8_simd, mat168d, order_of, seed8, vec8d, zonal_north8
from .normal import NormalParams, normal_field_ecef
from .sh import SHKernelModel, sh_column, sh_vec8

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
def _powers_block(x: wp.float64, k0: int, out: wp.array2d(dtype=wp.float64), i: int):
    """Write x**k into out[k, i] for k0 <= k < min(k0 + 32, rows of ``out``).

    ``wp.pow`` at k0, then products: at most 31 roundings separate a power from the exact one
    (about 4e-15 relative); x**0 = 1 also at the pole (u = 0).
    """
    p = wp.float64(1.0)
    if k0 > 0:
        p = wp.pow(x, wp.float64(k0))
    k1 = wp.min(k0 + 32, out.shape[0])
    for k in range(k0, k1):
        if k > k0:
            p = p * x
        out[k, i] = p


@wp.kernel
def row_powers_kernel(
    u: wp.array(dtype=wp.float64),
    q: wp.array(dtype=wp.float64),
    upow: wp.array2d(dtype=wp.float64),
    qpow: wp.array2d(dtype=wp.float64),
    offset: wp.int32,
):
    """Powers of each row's u and q for :func:`row_fourier8_kernel`, 32 of one row per thread.

    ``upow[k, i] = u_i**k`` (k < upow.shape[0], the half powers of :func:`half_powers`),
    ``qpow[m, i] = q_i**m`` (m < qpow.shape[0], the seeds): the Legendre pass reads them
    instead of calling ``pow`` per (row, order), and the rows of a group sit side by side.
    Thread ``i`` takes row ``i % n`` and block ``i // n`` of the powers of u, then of q.
    """
    i = wp.tid() + offset
    n = u.shape[0]
    b = i / n
    row = i - b * n
    nbu = (upow.shape[0] + 31) / 32
    if b < nbu:
        _powers_block(u[row], 32 * b, upow, row)
    else:
        _powers_block(q[row], 32 * (b - nbu), qpow, row)


@wp.func
def half_powers_tab(upow: wp.array2d(dtype=wp.float64), row: int, k: int) -> wp.vec2d:
    """(u**(k//2), u**(k - k//2)) of ``row`` from its table (see :func:`half_powers`)."""
    k1 = k / 2
    return wp.vec2d(upow[k1, row], upow[k - k1, row])


@wp.func
def zero_tail(coef: wp.array3d(dtype=wp.vec2d), row: int, nm: int):
    """Zero the columns m >= nm of ``row`` (a coefficient array padded for the FFT)."""
    for c in range(coef.shape[1]):
        for j in range(nm, coef.shape[2]):
            coef[row, c, j] = wp.vec2d()


@wp.func
def _coefficients_hp(
    s: sh_vec8,
    s6: wp.float64,
    m: int,
    hm: wp.vec2d,
    h1: wp.vec2d,
    k: wp.float64,
    cd: wp.float64,
    sd: wp.float64,
    coef: wp.array3d(dtype=wp.vec2d),
    row: int,
):
    """Write the Fourier coefficients of order m of one row, see :func:`_coefficients`.

    ``k = GM/r^2`` (times the order factor), ``hm`` = (u^(m//2), u^(m - m//2)) and ``h1`` the
    same for m - 1 (for 1 when m = 0) are given, from :func:`half_powers` or the power tables
    (:func:`half_powers_tab`), so that a row and its mirror (same u and r) share them.
    """
    a_up = -k * scaled_times(s[2], hm)
    b_up = -k * scaled_times(s[3], hm)
    a_no = wp.float64(0.0)
    b_no = wp.float64(0.0)
    a_ea = wp.float64(0.0)
    b_ea = wp.float64(0.0)
    if m >= 1:
        fm = wp.float64(m)
        a_no = k * scaled_times(s[4], h1)
        b_no = k * scaled_times(s[5], h1)
        a_ea = k * fm * scaled_times(s[1], h1)
        b_ea = -k * fm * scaled_times(s[0], h1)
    else:
        a_no = k * scaled_times(s6, h1)
    coef[row, 0, m] = wp.vec2d(a_ea, -b_ea)
    coef[row, 1, m] = wp.vec2d(cd * a_no - sd * a_up, -(cd * b_no - sd * b_up))
    coef[row, 2, m] = wp.vec2d(cd * a_up + sd * a_no, -(cd * b_up + sd * b_no))
    if coef.shape[1] > 3:
        coef[row, 3, m] = wp.vec2d(k * scaled_times(s[0], hm), -k * scaled_times(s[1], hm))


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
    m1 = m - 1
    if m == 0:
        m1 = 1
    _coefficients_hp(
        s, s6, m, half_powers(u, m), half_powers(u, m1), gm / (r * r), cd, sd, coef, row
    )


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
    osc: wp.array(dtype=wp.float64),
    coef: wp.array3d(dtype=wp.vec2d),
    offset: wp.int32,
):
    """Fourier coefficients of the model gravitation for every (row, order m), one thread each.

    Thread ``i`` handles row ``i // nm`` and order ``m = i % nm`` with the engine's
    :func:`sh_column`; see :func:`_coefficients`. The zonal north term needs entry [6] of column
    m = 1: the m = 0 thread evaluates that column too (1/(lmax/2) of the row's work), which
    keeps every thread independent. Order m is written times ``osc[m]`` (1, or a power of two
    with a sign: exact), and the m = nm - 1 thread zeroes the row's columns past nm.
    """
    i = wp.tid() + offset
    row = i / nm
    m = i - row * nm
    s = sh_column(model, m, t[row], q[row])
    s6 = wp.float64(0.0)
    if m == 0 and model.lmax >= 1:
        s6 = sh_column(model, 1, t[row], q[row])[6]
    gmo = model.gm * osc[m]
    _coefficients(s, s6, m, u[row], r[row], cdel[row], sdel[row], gmo, coef, row)
    if m == nm - 1:
        zero_tail(coef, row, nm)


@wp.func
def mirror_rows(ev: sh_vec8, od: sh_vec8) -> sh_vec8:
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


@wp.func
def lane_sums(cs: mat168d, k: int, m: int, tk: wp.float64, qk: wp.float64):
    """Column sums of lane k split by parity, as ``sh_column`` entries 0-5 (``se``, ``so``).

    Entries [4], [5] (the latitude derivative, orders m >= 1) are ``-t (s2 - s0) + q f-sum``;
    the f-sums of one parity sit in the other parity's rows of ``cs`` (see :func:`column8`).
    """
    zero = wp.float64(0.0)
    e4 = zero
    e5 = zero
    o4 = zero
    o5 = zero
    if m >= 1:
        e4 = -tk * (cs[2, k] - cs[0, k]) + qk * cs[12, k]
        e5 = -tk * (cs[3, k] - cs[1, k]) + qk * cs[13, k]
        o4 = -tk * (cs[10, k] - cs[8, k]) + qk * cs[4, k]
        o5 = -tk * (cs[11, k] - cs[9, k]) + qk * cs[5, k]
    se = sh_vec8(cs[0, k], cs[1, k], cs[2, k], cs[3, k], e4, e5, zero, zero)
    so = sh_vec8(cs[8, k], cs[9, k], cs[10, k], cs[11, k], o4, o5, zero, zero)
    return se, so


@wp.kernel
def row_fourier8_kernel(
    model: SHKernelModel,
    rec: wp.array(dtype=vec8d),
    start: wp.array(dtype=wp.int32),
    zon: wp.array(dtype=wp.float64),
    t: wp.array(dtype=wp.float64),
    u: wp.array(dtype=wp.float64),
    r: wp.array(dtype=wp.float64),
    q: wp.array(dtype=wp.float64),
    cdel: wp.array(dtype=wp.float64),
    sdel: wp.array(dtype=wp.float64),
    row_a: wp.array2d(dtype=wp.int32),
    row_b: wp.array2d(dtype=wp.int32),
    upow: wp.array2d(dtype=wp.float64),
    qpow: wp.array2d(dtype=wp.float64),
    ng: int,
    simd: int,
    osc: wp.array(dtype=wp.float64),
    coef: wp.array3d(dtype=wp.vec2d),
    offset: wp.int32,
):
    """Fourier coefficients for groups of eight row units per thread, one order per thread.

    A unit is row ``row_a[g, k]`` (recursion at its t) and its mirror ``row_b[g, k]`` at -t
    (same height, so same r and q; or -1): one recursion serves both, halving the Legendre work
    of grids symmetric about the equator. Padding units have ``row_a = -1`` and write nothing.
    The eight recursions of a group are the lanes of one vector (:func:`column8_simd` on the
    CPU when ``simd`` is 1, else :func:`column8`), on the packed tables ``rec``/``start``/``zon``
    of :mod:`fieldmap.grids.tables`. Thread ``i`` handles group ``g = i % ng`` of column
    ``mi = i // ng`` (order :func:`order_of`): the groups of one order run back to back and
    share its table while it is in cache. The zonal north term needs entry [6] of column
    m = 1: the m = 0 thread sums it too (:func:`zonal_north8`). The powers of u and q come
    from the tables of :func:`row_powers_kernel`. Order m is written times ``osc[m]`` (see
    :func:`row_fourier_kernel`); the order-lmax thread zeroes its rows' columns past lmax.
    """
    i = wp.tid() + offset
    mi = i / ng
    g = i - mi * ng
    lmax = model.lmax
    m = order_of(mi, lmax)
    tv = vec8d()
    qv = vec8d()
    for k in range(8):
        ra = row_a[g, k]
        if ra >= 0:
            tv[k] = t[ra]
            qv[k] = q[ra]
    tq = wp.cw_mul(tv, qv)
    qq = wp.cw_mul(qv, qv)
    seed = seed8(model, qpow, m, row_a, g)
    cs = mat168d()
    if simd != 0:
        cs = column8_simd(rec, start[m], lmax + 1 - m, seed, tq, qq)
    else:
        cs = column8(rec, start[m], lmax + 1 - m, seed, tq, qq)
    e6 = vec8d()
    o6 = vec8d()
    if m == 0 and lmax >= 1:
        e6, o6 = zonal_north8(rec, zon, start[1], lmax, seed8(model, qpow, 1, row_a, g), tq, qq)
    m1 = m - 1  # the power u^(m-1) of the east and north terms; u^1 for the zonal north term
    if m == 0:
        m1 = 1
    for k in range(8):
        ra = row_a[g, k]
        if ra >= 0:
            se, so = lane_sums(cs, k, m, tv[k], qv[k])
            ua = u[ra]
            rra = r[ra]
            kk = model.gm / (rra * rra) * osc[m]
            hm = half_powers_tab(upow, ra, m)
            h1 = half_powers_tab(upow, ra, m1)
            _coefficients_hp(se + so, e6[k] + o6[k], m, hm, h1, kk, cdel[ra], sdel[ra], coef, ra)
            rb = row_b[g, k]
            if rb >= 0:
                if u[rb] != ua or r[rb] != rra:
                    rrb = r[rb]
                    kk = model.gm / (rrb * rrb) * osc[m]
                    hm = half_powers_tab(upow, rb, m)
                    h1 = half_powers_tab(upow, rb, m1)
                _coefficients_hp(
                    mirror_rows(se, so), e6[k] - o6[k], m, hm, h1, kk, cdel[rb], sdel[rb], coef, rb
                )
                if m == lmax:
                    zero_tail(coef, rb, lmax + 1)
            if m == lmax:
                zero_tail(coef, ra, lmax + 1)

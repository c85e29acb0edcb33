r"""Spherical-harmonic synthesis of the gravitational potential and its gradient (Warp, float64).

Potential (Chen et al. 2022 eq. 1, fully normalised, no Condon-Shortley phase):

.. math::
    V = \frac{GM}{r}\sum_{n=0}^{N} q^n \sum_{m=0}^{n}
        (\bar C_{nm}\cos m\lambda + \bar S_{nm}\sin m\lambda)\bar P_{nm}(t),
    \qquad q = R/r,\; t = \sin\varphi,\; u = \cos\varphi .

Numerical scheme (Holmes & Featherstone 2002, J. Geodesy 76:279-299): the scaled functions
``Q_nm = 1e-280 * P̄nm(t) / u^m`` are computed by the standard forward column recursion in n for
each fixed order m (their eqs. 11-13); the factor u^m is applied afterwards by Horner's scheme in
u, running m from lmax down to 0, so no intermediate quantity underflows at ±89.99° nor
overflows below degree ~2700. Derivatives (their eqs. 15-16, fully normalised):

.. math::
    \frac{d\bar P_{nm}}{d\varphi} = u^{m-1}\,(-n t Q_{nm} + f_{nm} Q_{n-1,m}) \cdot 10^{280}
    \quad (m \ge 1), \qquad
    \frac{d\bar P_{n0}}{d\varphi} = \sqrt{n(n+1)/2}\; u\, Q_{n1} \cdot 10^{280} ,

which stay finite at the poles (u = 0): the east component carries the factor m u^{m-1}, whose
m = 1 term is the pole limit. The powers q^n are folded into the recursion
(``Q'_nm = q^n Q_nm`` obeys the same recursion with ``a_nm -> a_nm q``, ``b_nm -> b_nm q²``),
and cos/sin(mλ) are evaluated directly for each order (no recurrence, so no error growth in m).

The tables live in :class:`SHKernelModel`, stored transposed as ``[m, n]`` so that one column
recursion walks contiguous memory; they are built on the host by
``fieldmap.field.sh.kernel_model``. Row ``m = 0`` of ``fnm`` holds ``sqrt(n(n+1)/2)`` (the m = 0
derivative factor; the m >= 1 rows hold ``f_nm``). This path (``sh_column``, ``sh_column_pair``,
used by the point kernels up to degree 2700 and by the grid kernels) is limited to degree 2700:
near the poles ``Q_nm`` grows like e^(n/2) and leaves the double range above it.

Extended range (``xrange = 1``, point kernels, any degree): :func:`sh_spherical` hands such a
model to :func:`sh_spherical_x` (X-numbers, Fukushima 2012; the scheme is described in the
section "extended range" below). The struct :class:`SHKernelModel` and the degree cut
:func:`sh_degree_cut` serve both paths. The module reads top-down: the struct, the
extended-range path, the standard path and the point kernels.
"""

import warp as wp

from .frames import geodetic_to_ecef

# forward kernels only: fieldmap never differentiates through them (faster builds, whatever
# the import order relative to fieldmap._warp.init())
wp.set_module_options({"enable_backward": False})


# --------------------------------------------------------------------------------- the device model

#: degrees whose q^n falls below this are left out: with |P̄nm| ≤ sqrt(2(2n+1)) and |C|, |S|
#: < 1e-3 they change V and g by < 1e-25·n² relative to the degree-0 term; far above the sphere
#: this shortens every column and keeps the folded recursion (~1e-280 q^n) clear of subnormals.
QM_MIN = wp.constant(wp.float64(1.0e-25))

sh_vec8 = wp.types.vector(length=8, dtype=wp.float64)


@wp.struct
class SHKernelModel:
    """Device-side spherical-harmonic model with its recursion tables (all ``[m, n]``)."""

    cnm: wp.array2d(dtype=wp.float64)
    snm: wp.array2d(dtype=wp.float64)
    anm: wp.array2d(dtype=wp.float64)
    bnm: wp.array2d(dtype=wp.float64)
    fnm: wp.array2d(dtype=wp.float64)
    sect: wp.array(dtype=wp.float64)
    lmax: int
    gm: wp.float64
    radius: wp.float64
    # extended-range point path (xrange = 1; the five [m, n] tables above are then unused)
    xrange: int
    xcs: wp.array(dtype=wp.vec2d)  # (C, S) packed by order: column m from m*(2P+3-m)/2
    xpack: int  # P, the degree the packing was made for (>= lmax)
    xsq: wp.array(dtype=wp.float64)  # sqrt(k), k = 0..2P+2
    xisq: wp.array(dtype=wp.float64)  # 1/sqrt(k) (0 at k = 0)
    xrn: wp.array(dtype=wp.float64)  # sqrt((2n-1)(2n+1)), n = 0..P
    xirn: wp.array(dtype=wp.float64)  # its inverse (0 at n = 0)


@wp.func
def sh_degree_cut(model: SHKernelModel, q: wp.float64):
    """Highest degree summed at q = R/r: lmax, or the last n with q^n ≥ QM_MIN (q < 1)."""
    top = model.lmax
    if q < wp.float64(1.0):
        k = wp.log(QM_MIN) / wp.log(q)
        if k < wp.float64(top):
            top = int(k)
    return top


# ----------------------------------------------------------------------------------- extended range
# Points at any degree: the path of SHKernelModel structs with xrange = 1 (built by
# fieldmap.field.sh.kernel_model above degree 2700, or on request), which sh_spherical hands to
# sh_spherical_x. Same series and notation as the standard range below (fully normalised P̄nm,
# t = sin φ, u = cos φ geocentric, q = R/r, the powers q^n folded into the column recursion of
# Holmes & Featherstone 2002); what differs is the number range.
#
# X-numbers (Fukushima 2012, J. Geodesy 86:271-285), a float64 mantissa x and an integer exponent
# e standing for ``x · 2^(960 e)``, kept normalised to ``2^-480 <= |x| < 2^480``. Each order m >= 1
# sums ``W_nm = P̄nm/u`` (the factor u^(m-1) included, so no Horner scheme and nothing to divide
# at the poles):
#
# .. math::
#     \bar P_{nm} = u W_{nm},\quad
#     \frac{d\bar P_{nm}}{d\varphi} = -n t W_{nm} + f_{nm} W_{n-1,m},\quad
#     \frac{m \bar P_{nm}}{u} = m W_{nm} ,
#
# and order 0 sums P̄n0 itself (its derivative is ``sqrt(n(n+1)/2) u W_n1``, from order 1). The
# seeds ``q^m P̄mm/u = q^m s_m u^(m-1)`` are X-numbers updated from order to order (one
# multiplication by ``u q sqrt((2m+1)/(2m))`` and a normalisation), so they never underflow even
# at degree 10,800 and 89.999°. Along a column the recursion runs on the mantissas while e < 0
# (values below 2^-480; when |x| reaches 2^480 both stored values are multiplied by 2^-960 and e
# grows by one) and switches to plain float64, with the sums, at the first value in range;
# since ``|P̄nm| <= sqrt(2(2n+1))`` nothing can overflow, and the terms left out are below
# 2^-480 each. An order whose seed is below ``2^-600`` divided by the largest possible growth of
# its column (``P̄nm/u^m`` is largest at t = ±1, Gegenbauer polynomials: at most
# ``sqrt(2L+1) 2^L max(1, q)^L`` times the seed) is skipped, which makes near-polar points cheap.
# The recursion factors are not stored: ``a_nm = rn_n /(sqrt(n-m) sqrt(n+m))``,
# ``1/a_nm = sqrt(n-m) sqrt(n+m)/rn_n``, ``b_nm = a_nm/a_{n-1,m}``, ``f_nm = (2n+1)/a_nm`` with
# ``rn_n = sqrt((2n-1)(2n+1))`` and the square roots of integers read from small tables
# (``xsq``, ``xisq``, ``xrn``, ``xirn``: 6L doubles); the coefficients are packed by order
# (``xcs``, (C, S) pairs, no zero triangle), so a degree-10,800 struct holds 0.93 GB instead of
# the 4.7 GB of five square tables. On the CPU this path costs about twice the table path at
# degree 240 to 2190 (one recursion chain instead of two interleaved, and the factors computed),
# which is why points at degree <= 2700 keep the table path.

#: X-numbers (Fukushima 2012) of the extended-range path: x·XBIG^e, |x| in [XHALFI, XHALF).
XBIG = wp.constant(wp.float64(2.0**960))
XBIGI = wp.constant(wp.float64(2.0**-960))
XHALF = wp.constant(wp.float64(2.0**480))
XHALFI = wp.constant(wp.float64(2.0**-480))
SQRT_HALF = wp.constant(wp.float64(0.5**0.5))


@wp.func
def xnorm(x: wp.float64, e: int):
    """Normalise the X-number x·2^(960 e): |x| in [2^-480, 2^480) (x = 0 is left as it is)."""
    ax = wp.abs(x)
    xx = x
    ee = e
    if ax != wp.float64(0.0):
        while ax >= XHALF:
            xx = xx * XBIGI
            ax = ax * XBIGI
            ee = ee + 1
        while ax < XHALFI:
            xx = xx * XBIG
            ax = ax * XBIG
            ee = ee - 1
    return xx, ee


@wp.func
def sh_xcolumn(
    model: SHKernelModel, m: int, lmax: int, t: wp.float64, q: wp.float64, x0: wp.float64, e0: int
):
    """Per-order sums of the extended-range column for order ``m`` (``xrange`` models).

    The column ``W'_nm = q^n P̄nm / u`` (m ≥ 1; for m = 0, ``q^n P̄n0`` itself) starts from the
    X-number seed ``x0·2^(960 e0)`` at n = m (``q^m P̄mm/u``, resp. 1) and follows the column
    recursion of Holmes & Featherstone (2002) with ``a_nm → a_nm q``, ``b_nm → b_nm q²``, the
    factors computed from the tables of square roots (``a_nm = rn_n/sqrt((n-m)(n+m))``,
    ``b_nm = a_nm/a_{n-1,m}``, ``f_nm = (2n+1)/a_nm``). While the values are below 2^-480
    (exponent e < 0) only the mantissas are carried (rescaled by 2^-960 when they reach 2^480,
    Fukushima 2012); from the first in-range value on, the plain float64 loop sums.

    Returns an ``sh_vec8``: sums over n of [0] C W', [1] S W', [2] (n+1) C W', [3] (n+1) S W',
    [4] C (−n t W'_n + q f_nm W'_{n−1}), [5] the same with S, [6] (m = 1 only)
    sqrt(n(n+1)/2) C_n0 W'_n1, [7] 0. All zero when the column never comes into range.
    """
    out = sh_vec8()
    if m > lmax:
        return out
    tq = t * q
    qq = q * q
    base = (m * (2 * model.xpack + 3 - m)) // 2 - m  # xcs[base + n] = (C_nm, S_nm)
    p1 = x0
    p2 = wp.float64(0.0)
    e = e0
    n = m
    ia1 = wp.float64(0.0)  # 1/a_{n,m}; 0 at n = m (b_{m+1,m} = 0 and f_mm = 0)
    while e < 0 and n < lmax:
        n = n + 1
        a = model.xrn[n] * (model.xisq[n - m] * model.xisq[n + m])
        b = a * ia1
        ia1 = model.xirn[n] * (model.xsq[n - m] * model.xsq[n + m])
        pn = a * tq * p1 - b * qq * p2
        p2 = p1
        p1 = pn
        if wp.abs(pn) >= XHALF:
            p1 = p1 * XBIGI
            p2 = p2 * XBIGI
            e = e + 1
    if e < 0:
        return out
    # first in-range term, degree n: p1 = W'_n, p2 = W'_{n-1}
    cs = model.xcs[base + n]
    c = cs[0]
    s = cs[1]
    nf1 = wp.float64(n + 1)
    s0 = c * p1
    s1 = s * p1
    s2 = nf1 * s0
    s3 = nf1 * s1
    fp = wp.float64(2 * n + 1) * ia1 * p2
    d4 = c * fp
    d5 = s * fp
    s6 = wp.float64(0.0)
    if m == 1:
        s6 = model.xsq[n] * model.xsq[n + 1] * model.xcs[n][0] * p1
    for k in range(n + 1, lmax + 1):
        a = model.xrn[k] * (model.xisq[k - m] * model.xisq[k + m])
        b = a * ia1
        ia1 = model.xirn[k] * (model.xsq[k - m] * model.xsq[k + m])
        pn = a * tq * p1 - b * qq * p2
        cs = model.xcs[base + k]
        c = cs[0]
        s = cs[1]
        nf1 = nf1 + wp.float64(1.0)
        wc = c * pn
        ws = s * pn
        s0 = s0 + wc
        s1 = s1 + ws
        s2 = s2 + nf1 * wc
        s3 = s3 + nf1 * ws
        fp = wp.float64(2 * k + 1) * ia1 * p1
        d4 = d4 + c * fp
        d5 = d5 + s * fp
        if m == 1:
            s6 = s6 + model.xsq[k] * model.xsq[k + 1] * model.xcs[k][0] * pn
        p2 = p1
        p1 = pn
    out[0] = s0
    out[1] = s1
    out[2] = s2
    out[3] = s3
    # sum n q^n C W = s2 - s0; the f-term used W'_{n-1} = q^{n-1} W_{n-1}, hence the factor q
    out[4] = -t * (s2 - s0) + q * d4
    out[5] = -t * (s3 - s1) + q * d5
    out[6] = s6 * SQRT_HALF
    return out


@wp.func
def sh_spherical_x(model: SHKernelModel, p: wp.vec3d):
    """Potential and gravitation of an ``xrange`` model at ECEF ``p``, any degree.

    Each order m ≥ 1 sums ``W_nm = P̄nm/u`` (u^(m−1) included, so P̄nm = u W, the east term is
    m W and dP̄nm/dφ = −n t W_n + f_nm W_{n−1}: finite at the poles, no Horner scheme). The seeds
    ``q^m P̄mm/u = q^m s_m u^(m−1)`` are X-numbers (mantissa, exponent in base 2^960) updated
    from order to order; an order whose seed is so small that no growth of its column up to
    ``lmax`` (at most sqrt(2L+1) 2^L max(1, q)^L, the bound of P̄nm/u^m at t = ±1) can bring it
    to 2^-600 is skipped. Returns ``wp.vec4d(V, g_east, g_north, g_up)`` like
    ``sh_spherical`` of :mod:`fieldmap.kernels.sh`, which calls it for such models.
    Units: m -> m²/s², m/s².
    """
    x = p[0]
    y = p[1]
    z = p[2]
    rho = wp.sqrt(x * x + y * y)
    r = wp.sqrt(rho * rho + z * z)
    t = z / r
    u = rho / r
    lam = wp.atan2(y, x)
    q = model.radius / r
    lmax = sh_degree_cut(model, q)
    col = sh_xcolumn(model, 0, lmax, t, q, wp.float64(1.0), 0)
    vs = col[0]
    rs = col[2]
    ns = wp.float64(0.0)
    es = wp.float64(0.0)
    n6 = wp.float64(0.0)
    # growth bound of a column in bits, and the seed exponent below which an order is skipped
    lf = wp.float64(lmax)
    gbits = lf + wp.float64(0.5) * wp.log2(wp.float64(2.0) * lf + wp.float64(1.0))
    if q > wp.float64(1.0):
        gbits = gbits + lf * wp.log2(q)
    kskip = int((gbits + wp.float64(1080.0)) / wp.float64(960.0)) + 1
    uq = u * q
    sx = model.xsq[3] * q  # q^1 P̄11/u = sqrt(3) q
    se = int(0)
    m = int(1)
    while m <= lmax:
        if m > 1:
            sx = sx * uq * (model.xsq[2 * m + 1] * model.xisq[2 * m])
            xn = xnorm(sx, se)
            sx = xn[0]
            se = xn[1]
        if sx == wp.float64(0.0):
            break  # u = 0: no order above 1 contributes
        if se > -kskip:
            col = sh_xcolumn(model, m, lmax, t, q, sx, se)
            ml = wp.float64(m) * lam
            cm = wp.cos(ml)
            sm = wp.sin(ml)
            vs = vs + u * (col[0] * cm + col[1] * sm)
            rs = rs + u * (col[2] * cm + col[3] * sm)
            ns = ns + (col[4] * cm + col[5] * sm)
            es = es + wp.float64(m) * (col[1] * cm - col[0] * sm)
            if m == 1:
                n6 = col[6]
        m = m + 1
    k = model.gm / r
    kr = k / r
    return wp.vec4d(k * vs, kr * es, kr * (ns + u * n6), -kr * rs)


# ------------------------------------------------------------- standard range and the point kernels

#: 1e-280 scale of the Holmes & Featherstone (2002) recursion and its inverse.
SCALE = wp.constant(wp.float64(1.0e-280))
INV_SCALE = wp.constant(wp.float64(1.0e280))


@wp.func
def sh_column(model: SHKernelModel, m: int, t: wp.float64, q: wp.float64):
    """Per-order sums of the scaled Legendre series for order ``m``.

    Returns an ``sh_vec8`` with the sums over n = m..lmax of q^n times
    [0] C Q, [1] S Q, [2] (n+1) C Q, [3] (n+1) S Q, [4] C (−n t Q_n + f Q_{n−1}), [5] the same
    with S (0 for m = 0), [6] sqrt(n(n+1)/2) C_n0 Q_n1 (m = 1 only), [7] 0; Q = Q_nm carries the
    1e-280 scale and not the u^m factor (Holmes & Featherstone 2002 eqs. 11-16).
    Units: dimensionless (t = sin φ geocentric, q = R/r).
    """
    out = sh_vec8()
    lmax = sh_degree_cut(model, q)
    if m > lmax:
        return out
    qm = wp.pow(q, wp.float64(m))
    tq = t * q
    qq = q * q
    # Q'_{m,m} = q^m Q_mm and Q'_{m-1,m} = 0: the general recursion then gives Q'_{m+1,m}
    # because b_{m+1,m} = 0.
    p1 = SCALE * model.sect[m] * qm
    p2 = wp.float64(0.0)
    c = model.cnm[m, m]
    s = model.snm[m, m]
    s0 = c * p1
    s1 = s * p1
    nf1 = wp.float64(m + 1)
    s2 = nf1 * s0
    s3 = nf1 * s1
    d4 = wp.float64(0.0)  # sum of f_nm C_nm Q'_{n-1,m} (times q later)
    d5 = wp.float64(0.0)
    s6 = wp.float64(0.0)
    if m == 1:
        s6 = model.fnm[0, 1] * model.cnm[0, 1] * p1
    for n in range(m + 1, lmax + 1):
        pn = model.anm[m, n] * tq * p1 - model.bnm[m, n] * qq * p2
        c = model.cnm[m, n]
        s = model.snm[m, n]
        nf1 = nf1 + wp.float64(1.0)
        wc = c * pn
        ws = s * pn
        s0 = s0 + wc
        s1 = s1 + ws
        s2 = s2 + nf1 * wc
        s3 = s3 + nf1 * ws
        fp = model.fnm[m, n] * p1
        d4 = d4 + c * fp
        d5 = d5 + s * fp
        if m == 1:
            s6 = s6 + model.fnm[0, n] * model.cnm[0, n] * pn
        p2 = p1
        p1 = pn
    out[0] = s0
    out[1] = s1
    out[2] = s2
    out[3] = s3
    if m >= 1:
        # sum n q^n C Q = s2 - s0; the f-term used Q'_{n-1} = q^{n-1} Q_{n-1}, hence the factor q
        out[4] = -t * (s2 - s0) + q * d4
        out[5] = -t * (s3 - s1) + q * d5
    out[6] = s6
    return out


@wp.func
def sh_column_pair(model: SHKernelModel, m: int, t: wp.float64, q: wp.float64):
    """:func:`sh_column` for the orders ``m`` and ``m − 1`` together (m ≥ 2, m ≤ lmax).

    The two column recursions run in one loop: each is a chain of dependent multiply-adds, so
    interleaving two independent chains roughly halves the latency-bound time per term.
    Returns ``(col_m, col_m_minus_1)``, each as :func:`sh_column` (entry [6] is 0: m − 1 ≥ 1).
    """
    lmax = sh_degree_cut(model, q)
    k = m - 1
    if m > lmax:
        # order m is cut off; order m - 1 may still have its single term n = m - 1
        return sh_vec8(), sh_column(model, k, t, q)
    tq = t * q
    qq = q * q
    qk = wp.pow(q, wp.float64(k))
    # column k: seed n = k, then the step n = m (b_{m,k} = 0), so both columns stand at n = m
    b1 = SCALE * model.sect[k] * qk
    pb = model.anm[k, m] * tq * b1
    cb = model.cnm[k, m]
    sb = model.snm[k, m]
    nfb = wp.float64(m + 1)
    w0c = model.cnm[k, k] * b1
    w0s = model.snm[k, k] * b1
    B0 = w0c + cb * pb
    B1 = w0s + sb * pb
    B2 = wp.float64(m) * w0c + nfb * cb * pb
    B3 = wp.float64(m) * w0s + nfb * sb * pb
    fb = model.fnm[k, m] * b1
    Bd4 = cb * fb
    Bd5 = sb * fb
    b2 = b1
    b1 = pb
    a1 = SCALE * model.sect[m] * qk * q
    a2 = wp.float64(0.0)
    A0 = model.cnm[m, m] * a1
    A1 = model.snm[m, m] * a1
    A2 = nfb * A0
    A3 = nfb * A1
    Ad4 = wp.float64(0.0)
    Ad5 = wp.float64(0.0)
    nf1 = nfb
    for n in range(m + 1, lmax + 1):
        pa = model.anm[m, n] * tq * a1 - model.bnm[m, n] * qq * a2
        pb = model.anm[k, n] * tq * b1 - model.bnm[k, n] * qq * b2
        nf1 = nf1 + wp.float64(1.0)
        ca = model.cnm[m, n]
        sa = model.snm[m, n]
        cb = model.cnm[k, n]
        sb = model.snm[k, n]
        wca = ca * pa
        wsa = sa * pa
        wcb = cb * pb
        wsb = sb * pb
        A0 = A0 + wca
        A1 = A1 + wsa
        A2 = A2 + nf1 * wca
        A3 = A3 + nf1 * wsa
        B0 = B0 + wcb
        B1 = B1 + wsb
        B2 = B2 + nf1 * wcb
        B3 = B3 + nf1 * wsb
        fa = model.fnm[m, n] * a1
        fb = model.fnm[k, n] * b1
        Ad4 = Ad4 + ca * fa
        Ad5 = Ad5 + sa * fa
        Bd4 = Bd4 + cb * fb
        Bd5 = Bd5 + sb * fb
        a2 = a1
        a1 = pa
        b2 = b1
        b1 = pb
    zero = wp.float64(0.0)
    oa = sh_vec8(A0, A1, A2, A3, -t * (A2 - A0) + q * Ad4, -t * (A3 - A1) + q * Ad5, zero, zero)
    ob = sh_vec8(B0, B1, B2, B3, -t * (B2 - B0) + q * Bd4, -t * (B3 - B1) + q * Bd5, zero, zero)
    return oa, ob


@wp.func
def _horner_step(col: sh_vec8, m: int, lam: wp.float64, u: wp.float64, acc: wp.vec4d):
    """One Horner step in u for order m >= 1: acc = acc * u + terms of order m.

    acc = (V sum, radial sum, north sum, east sum), see the module docstring.
    """
    ml = wp.float64(m) * lam
    cm = wp.cos(ml)
    sm = wp.sin(ml)
    return wp.vec4d(
        acc[0] * u + (col[0] * cm + col[1] * sm),
        acc[1] * u + (col[2] * cm + col[3] * sm),
        acc[2] * u + (col[4] * cm + col[5] * sm),
        acc[3] * u + wp.float64(m) * (col[1] * cm - col[0] * sm),
    )


@wp.func
def _m0_derivative_sum(model: SHKernelModel, t: wp.float64, q: wp.float64):
    """Entry [6] of :func:`sh_column` for m = 1 alone: sum of q^n sqrt(n(n+1)/2) C_n0 Q_n1."""
    lmax = sh_degree_cut(model, q)
    if lmax < 1:
        return wp.float64(0.0)
    tq = t * q
    qq = q * q
    p1 = SCALE * model.sect[1] * q
    p2 = wp.float64(0.0)
    s6 = model.fnm[0, 1] * model.cnm[0, 1] * p1
    for n in range(2, lmax + 1):
        pn = model.anm[1, n] * tq * p1 - model.bnm[1, n] * qq * p2
        s6 = s6 + model.fnm[0, n] * model.cnm[0, n] * pn
        p2 = p1
        p1 = pn
    return s6


@wp.func
def sh_spherical(model: SHKernelModel, p: wp.vec3d):
    """Potential and gravitation in the geocentric spherical frame at ECEF position ``p``.

    Returns ``wp.vec4d(V, g_east, g_north, g_up)`` with the components of the gradient along the
    local geocentric east, north, radial-up unit vectors (Chen et al. 2022 eqs. 2-3 in
    spherical form). Units: m -> m²/s², m/s².
    """
    if model.xrange != 0:
        return sh_spherical_x(model, p)
    x = p[0]
    y = p[1]
    z = p[2]
    rho = wp.sqrt(x * x + y * y)
    r = wp.sqrt(rho * rho + z * z)
    t = z / r
    u = rho / r
    lam = wp.atan2(y, x)
    q = model.radius / r
    acc = wp.vec4d()
    m = sh_degree_cut(model, q)
    while m >= 2:
        cols = sh_column_pair(model, m, t, q)
        acc = _horner_step(cols[0], m, lam, u, acc)
        acc = _horner_step(cols[1], m - 1, lam, u, acc)
        m = m - 2
    n6 = wp.float64(0.0)
    if m == 1:
        col = sh_column(model, 1, t, q)
        acc = _horner_step(col, 1, lam, u, acc)
        n6 = col[6]
    else:
        # order 1 was paired with order 2 above; its entry [6] (dP̄n0/dφ) comes from here
        n6 = _m0_derivative_sum(model, t, q)
    col = sh_column(model, 0, t, q)
    # order 0: only V and the radial sum get the Horner step (north/east sums start at m = 1)
    vs = acc[0] * u + col[0]
    rs = acc[1] * u + col[2]
    ns = acc[2]
    es = acc[3]
    k = model.gm / r * INV_SCALE
    kr = k / r
    return wp.vec4d(k * vs, kr * es, kr * (ns + u * n6), -kr * rs)


@wp.func
def sh_gravitation_ecef(model: SHKernelModel, p: wp.vec3d):
    """Gravitational acceleration (gradient of V, no centrifugal term) at ECEF ``p``.

    Units: m -> m/s² (ECEF components).
    """
    res = sh_spherical(model, p)
    rho = wp.sqrt(p[0] * p[0] + p[1] * p[1])
    r = wp.sqrt(rho * rho + p[2] * p[2])
    t = p[2] / r
    u = rho / r
    lam = wp.atan2(p[1], p[0])
    cl = wp.cos(lam)
    sl = wp.sin(lam)
    ge, gn, gu = res[1], res[2], res[3]
    # east = (-sin λ, cos λ, 0), north = (-t cos λ, -t sin λ, u), up = (u cos λ, u sin λ, t)
    h = u * gu - t * gn
    return wp.vec3d(h * cl - ge * sl, h * sl + ge * cl, t * gu + u * gn)


@wp.func
def sh_potential(model: SHKernelModel, p: wp.vec3d):
    """Gravitational potential V at ECEF ``p`` (Chen et al. 2022 eq. 1). Units: m -> m²/s²."""
    return sh_spherical(model, p)[0]


@wp.kernel
def sh_points_ecef_kernel(
    model: SHKernelModel,
    pos: wp.array(dtype=wp.vec3d),
    g_out: wp.array(dtype=wp.vec3d),
    offset: wp.int32,
):
    """Gravitation (ECEF, m/s²) at scattered ECEF positions (m)."""
    i = wp.tid() + offset
    g_out[i] = sh_gravitation_ecef(model, pos[i])


@wp.kernel
def sh_points_geodetic_kernel(
    model: SHKernelModel,
    lat: wp.array(dtype=wp.float64),
    lon: wp.array(dtype=wp.float64),
    h: wp.array(dtype=wp.float64),
    a: wp.float64,
    e2: wp.float64,
    g_out: wp.array(dtype=wp.vec3d),
    offset: wp.int32,
):
    """Gravitation (ECEF, m/s²) at geodetic lat, lon (rad), h (m) on the ellipsoid (a, e²)."""
    i = wp.tid() + offset
    p = geodetic_to_ecef(lat[i], lon[i], h[i], a, e2)
    g_out[i] = sh_gravitation_ecef(model, p)


@wp.kernel
def sh_potential_kernel(
    model: SHKernelModel,
    pos: wp.array(dtype=wp.vec3d),
    v_out: wp.array(dtype=wp.float64),
    offset: wp.int32,
):
    """Potential (m²/s²) at scattered ECEF positions (m)."""
    i = wp.tid() + offset
    v_out[i] = sh_potential(model, pos[i])

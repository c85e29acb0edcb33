r"""Extended-range spherical-harmonic synthesis for points at any degree (Warp, float64).

The path of :class:`~fieldmap.kernels.sh_model.SHKernelModel` structs with ``xrange = 1``
(built by ``fieldmap.field.sh.kernel_model`` above degree 2700, or on request): the point
kernels of :mod:`fieldmap.kernels.sh` reach it through ``sh_spherical``, which hands such a
model to :func:`sh_spherical_x`. Same series and notation as :mod:`fieldmap.kernels.sh`
(fully normalised P̄nm, t = sin φ, u = cos φ geocentric, q = R/r, the powers q^n folded into
the column recursion of Holmes & Featherstone 2002); what differs is the number range.

X-numbers (Fukushima 2012, J. Geodesy 86:271-285), a float64 mantissa x and an integer exponent
e standing for ``x · 2^(960 e)``, kept normalised to ``2^-480 <= |x| < 2^480``. Each order m >= 1
sums ``W_nm = P̄nm/u`` (the factor u^(m-1) included, so no Horner scheme and nothing to divide
at the poles):

.. math::
    \bar P_{nm} = u W_{nm},\quad
    \frac{d\bar P_{nm}}{d\varphi} = -n t W_{nm} + f_{nm} W_{n-1,m},\quad
    \frac{m \bar P_{nm}}{u} = m W_{nm} ,

and order 0 sums P̄n0 itself (its derivative is ``sqrt(n(n+1)/2) u W_n1``, from order 1). The
seeds ``q^m P̄mm/u = q^m s_m u^(m-1)`` are X-numbers updated from order to order (one
multiplication by ``u q sqrt((2m+1)/(2m))`` and a normalisation), so they never underflow even
at degree 10,800 and 89.999°. Along a column the recursion runs on the mantissas while e < 0
(values below 2^-480; when |x| reaches 2^480 both stored values are multiplied by 2^-960 and e
grows by one) and switches to plain float64, with the sums, at the first value in range;
since ``|P̄nm| <= sqrt(2(2n+1))`` nothing can overflow, and the terms left out are below
2^-480 each. An order whose seed is below ``2^-600`` divided by the largest possible growth of
its column (``P̄nm/u^m`` is largest at t = ±1, Gegenbauer polynomials: at most
``sqrt(2L+1) 2^L max(1, q)^L`` times the seed) is skipped, which makes near-polar points cheap.
The recursion factors are not stored: ``a_nm = rn_n /(sqrt(n-m) sqrt(n+m))``,
``1/a_nm = sqrt(n-m) sqrt(n+m)/rn_n``, ``b_nm = a_nm/a_{n-1,m}``, ``f_nm = (2n+1)/a_nm`` with
``rn_n = sqrt((2n-1)(2n+1))`` and the square roots of integers read from small tables
(``xsq``, ``xisq``, ``xrn``, ``xirn``: 6L doubles); the coefficients are packed by order
(``xcs``, (C, S) pairs, no zero triangle), so a degree-10,800 struct holds 0.93 GB instead of
the 4.7 GB of five square tables. On the CPU this path costs about twice the table path at
degree 240 to 2190 (one recursion chain instead of two interleaved, and the factors computed),
which is why points at degree <= 2700 keep the table path.
"""

import warp as wp

from .sh_model import SHKernelModel, sh_degree_cut, sh_vec8

# forward kernels only: fieldmap never differentiates through them (faster builds, whatever
# the import order relative to fieldmap._warp.init())
wp.set_module_options({"enable_backward": False})

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

r"""The grid Legendre pass at any degree: eight rows per thread with X-numbers (Warp, float64).

:func:`row_fourier8x_kernel` writes the same Fourier coefficients as
:func:`fieldmap.kernels.grid.row_fourier8_kernel` (one order m for a group of eight row units,
a row and its mirror at -latitude, per thread) for models above degree 2700, where the
1e-280-scaled recursion of :mod:`fieldmap.kernels.grid_simd` overflows near the poles (it
carries P̄nm/u^m, which reaches ~e^(n/2) there). Here each lane carries, like the extended-range
point path of :mod:`fieldmap.kernels.sh`, ``W'_nm = q^n P̄nm/u`` (order m >= 1: the factor
u^(m-1) is in the seed; order 0: ``q^n P̄n0``), which is at most ``sqrt(2(2n+1)) max(1, q)^n``:

- the seed ``q^m s_m u^(m-1)`` of each lane (s_m = P̄mm/u^m) is an X-number (Fukushima 2012;
  mantissa x and exponent e standing for ``x 2^(960 e)``), :func:`seed8x`, with u^(m-1) by
  repeated squaring (about 2 log2 m roundings);
- along the column the recursion runs on the mantissas; a lane whose exponent is below 0 adds
  nothing to its sums, and when its value reaches 2^480 both of its stored values are multiplied
  by 2^-960 and its exponent grows by one (:func:`column8x`, :func:`column8x_simd`). Once every
  lane is in range the plain eight-lane loop takes over. A lane's operations do not depend on
  the other lanes (a lane in range is multiplied by exactly 1), so a row's bits do not depend on
  which rows share its thread;
- a lane whose seed is so small that no growth of its column (at most
  ``sqrt(2L+1) 2^L max(1, q)^L``, the bound of P̄nm/u^m at t = ±1) can bring it to 2^-600
  starts at zero, and a column whose eight seeds are zero is not run: near the poles most high
  orders cost nothing.

From the sums, with ``K = GM/r^2`` (no 1e280 scale, no powers of u other than one):
up ``A = -K u s2`` (m >= 1; ``-K s2`` for m = 0), north ``A = K s4``, east ``A = K m s1``, the
zonal north term ``K u s6`` (entry [6] of column 1, whose seed ``sqrt(3) q`` is in range).
The packed tables are those of :mod:`fieldmap.grids.tables` (built order by order from closed
forms above degree 2700, :func:`fieldmap.grids.tables.pack_columns_direct`).
"""

import warp as wp

from .grid import lane_sums, mirror_rows, zero_tail
from .grid_simd import mat168d, order_of, sums_matrix, vec8d, zonal_north8
from .sh import QM_MIN, XBIGI, XHALF, sh_vec8, xnorm

# forward kernels only: fieldmap never differentiates through them (faster builds, whatever
# the import order relative to fieldmap._warp.init())
wp.set_module_options({"enable_backward": False})


@wp.func
def _xpow_seed(u: wp.float64, q: wp.float64, m: int, sm: wp.float64, lmax: int):
    """X-number ``(x, e)`` of ``q^m sm u^(m-1)`` (m >= 1), or (0, 0) when it cannot matter.

    Zero when q^m < QM_MIN (the engine's degree cut) or when the seed is below 2^-600 divided
    by the largest growth of a column to ``lmax`` (then no value of the column reaches 2^-480).
    """
    fm = wp.float64(m)
    qm = wp.pow(q, fm)
    x = wp.float64(0.0)
    e = int(0)
    if qm < QM_MIN:
        return x, e
    x = sm * qm
    b = u
    be = int(0)
    k = m - 1
    while k > 0:
        if k % 2 == 1:
            x, e = xnorm(x * b, e + be)
        k = k / 2
        if k > 0:
            b, be = xnorm(b * b, 2 * be)
    lf = wp.float64(lmax)
    gbits = lf + wp.float64(0.5) * wp.log2(wp.float64(2.0) * lf + wp.float64(1.0))
    if q > wp.float64(1.0):
        gbits = gbits + lf * wp.log2(q)
    kskip = int((gbits + wp.float64(1080.0)) / wp.float64(960.0)) + 1
    if e <= -kskip or x == wp.float64(0.0):
        return wp.float64(0.0), int(0)
    return x, e


@wp.func
def seed8x(sect: wp.array(dtype=wp.float64), m: int, lmax: int, u: vec8d, q: vec8d):
    """Mantissas and exponents (as float64) of the eight lanes' seeds, see :func:`_xpow_seed`.

    Order 0: ``q^0 P̄00 = 1`` in range.
    """
    xm = vec8d()
    xe = vec8d()
    for k in range(8):
        if q[k] > wp.float64(0.0):
            if m == 0:
                xm[k] = wp.float64(1.0)
            else:
                sx, se = _xpow_seed(u[k], q[k], m, sect[m], lmax)
                xm[k] = sx
                xe[k] = wp.float64(se)
    return xm, xe


@wp.func
def column8x(
    rec: wp.array(dtype=vec8d),
    s0: int,
    nterm: int,
    seedm: vec8d,
    seede: vec8d,
    tq: vec8d,
    qq: vec8d,
):
    """Parity-split column sums of eight lanes with X-number seeds (Warp, any device).

    As :func:`fieldmap.kernels.grid_simd.column8` (same tables, same 16 x 8 result), from the
    seeds ``seedm 2^(960 seede)``: a lane adds to its sums only while its exponent is 0.
    """
    w = rec[s0]
    p1 = seedm
    ex = seede
    p2 = vec8d()
    zero = wp.float64(0.0)
    pl = vec8d()
    slow = int(0)
    for k in range(8):
        if ex[k] == zero:
            pl[k] = p1[k]
        else:
            slow = 1
    e0 = w[2] * pl
    e1 = w[3] * pl
    e2 = w[4] * pl
    e3 = w[5] * pl
    e4 = w[6] * pl
    e5 = w[7] * pl
    o0 = vec8d()
    o1 = vec8d()
    o2 = vec8d()
    o3 = vec8d()
    o4 = vec8d()
    o5 = vec8d()
    j = int(1)
    while j < nterm:
        w = rec[s0 + j]
        pn = wp.cw_mul(w[0] * tq, p1) - wp.cw_mul(w[1] * qq, p2)
        p2 = p1
        p1 = pn
        pl = pn
        if slow != 0:
            slow = 0
            for k in range(8):
                if ex[k] < zero:
                    if wp.abs(p1[k]) >= XHALF:
                        p1[k] = p1[k] * XBIGI
                        p2[k] = p2[k] * XBIGI
                        ex[k] = ex[k] + wp.float64(1.0)
                if ex[k] == zero:
                    pl[k] = p1[k]
                else:
                    pl[k] = zero
                    slow = 1
        if j % 2 == 1:
            o0 = o0 + w[2] * pl
            o1 = o1 + w[3] * pl
            o2 = o2 + w[4] * pl
            o3 = o3 + w[5] * pl
            o4 = o4 + w[6] * pl
            o5 = o5 + w[7] * pl
        else:
            e0 = e0 + w[2] * pl
            e1 = e1 + w[3] * pl
            e2 = e2 + w[4] * pl
            e3 = e3 + w[5] * pl
            e4 = e4 + w[6] * pl
            e5 = e5 + w[7] * pl
        j = j + 1
    return sums_matrix(e0, e1, e2, e3, e4, e5, o0, o1, o2, o3, o4, o5)


_COLUMN8X_SIMD = r"""
#if defined(__CUDA_ARCH__)
    // A CUDA build compiles this function (the kernel picks it at run time, ``simd``) but
    // must never run it: the host passes simd = 0 for a CUDA device
    // (fieldmap.grids.synthesis.simd_flag) and the kernel runs column8x, the plain Warp
    // recursion. Reached anyway, the kernel stops here (a failed launch), never returns zeros.
    printf("fieldmap: column8x_simd (CPU SIMD) called on a CUDA device: launch with simd = 0\n");
    __trap();
    return wp::mat_t<16, 8, wp::float64>();  // not reached
#elif !defined(__clang__)
#error "fieldmap column8x_simd needs clang's vector extension (Warp's CPU compiler)"
#else
#pragma clang fp contract(off)
    typedef double v8 __attribute__((ext_vector_type(8)));
    typedef long l8 __attribute__((ext_vector_type(8)));
    const double* w = (const double*)wp::address(rec, s0);
    const v8 one = 1.0, zero = 0.0, big = 0x1p480, small = 0x1p-960;
    v8 p1, ex, tq8, qq8, p2 = 0.0;
    __builtin_memcpy(&p1, &seedm, 64);
    __builtin_memcpy(&ex, &seede, 64);
    __builtin_memcpy(&tq8, &tq, 64);
    __builtin_memcpy(&qq8, &qq, 64);
    v8 pl = (ex == 0.0) ? p1 : zero;
    v8 e0 = w[2] * pl, e1 = w[3] * pl, e2 = w[4] * pl, e3 = w[5] * pl, e4 = w[6] * pl,
       e5 = w[7] * pl;
    v8 o0 = 0.0, o1 = 0.0, o2 = 0.0, o3 = 0.0, o4 = 0.0, o5 = 0.0;
#define FMA __builtin_elementwise_fma
#define FM_STEP(x) (FMA((x)[0] * tq8, p1, -(((x)[1] * qq8) * p2)))
#define FM_ODD(x, v) o0 = FMA((v8)(x)[2], v, o0); o1 = FMA((v8)(x)[3], v, o1); \
    o2 = FMA((v8)(x)[4], v, o2); o3 = FMA((v8)(x)[5], v, o3); \
    o4 = FMA((v8)(x)[6], v, o4); o5 = FMA((v8)(x)[7], v, o5);
#define FM_EVEN(x, v) e0 = FMA((v8)(x)[2], v, e0); e1 = FMA((v8)(x)[3], v, e1); \
    e2 = FMA((v8)(x)[4], v, e2); e3 = FMA((v8)(x)[5], v, e3); \
    e4 = FMA((v8)(x)[6], v, e4); e5 = FMA((v8)(x)[7], v, e5);
    int j = 1;
    bool slow = __builtin_reduce_or((l8)(ex != 0.0)) != 0;
    // while a lane is below range: masked sums, rescaling (lanes in range: factor 1, exact)
    while (slow && j < nterm) {
        const double* x = w + 8 * j;
        v8 pn = FM_STEP(x);
        p2 = p1; p1 = pn;
        l8 up = (ex < 0.0) & ((p1 >= big) | (p1 <= -big));
        v8 f = up ? small : one;
        p1 = p1 * f; p2 = p2 * f;
        ex = ex + (up ? one : zero);
        pl = (ex == 0.0) ? p1 : zero;
        if (j & 1) { FM_ODD(x, pl) } else { FM_EVEN(x, pl) }
        ++j;
        if ((j & 7) == 0) slow = __builtin_reduce_or((l8)(ex != 0.0)) != 0;
    }
    // every lane in range: the plain loop, odd and even n - m in turn
    if (j < nterm && (j & 1) == 0) {
        const double* x = w + 8 * j;
        v8 pn = FM_STEP(x);
        FM_EVEN(x, pn)
        p2 = p1; p1 = pn; ++j;
    }
    for (; j + 1 < nterm; j += 2) {
        const double* x = w + 8 * j;
        v8 pn = FM_STEP(x);
        FM_ODD(x, pn)
        p2 = p1; p1 = pn;
        x += 8;
        pn = FM_STEP(x);
        FM_EVEN(x, pn)
        p2 = p1; p1 = pn;
    }
    if (j < nterm) {
        const double* x = w + 8 * j;
        v8 pn = FM_STEP(x);
        FM_ODD(x, pn)
    }
#undef FMA
#undef FM_STEP
#undef FM_ODD
#undef FM_EVEN
    wp::mat_t<16, 8, wp::float64> out;
    v8 rows[16] = {e0, e1, e2, e3, e4, e5, 0.0, 0.0, o0, o1, o2, o3, o4, o5, 0.0, 0.0};
    __builtin_memcpy(&out, rows, sizeof(rows));
    return out;
#endif
"""


@wp.func_native(_COLUMN8X_SIMD)
def column8x_simd(
    rec: wp.array(dtype=vec8d),
    s0: int,
    nterm: int,
    seedm: vec8d,
    seede: vec8d,
    tq: vec8d,
    qq: vec8d,
) -> mat168d:
    """:func:`column8x` on the CPU with explicit 8-lane SIMD vectors and explicit FMAs.

    The masked (slow) loop and the plain loop perform the same FMAs on a lane in range, so a
    lane's bits do not depend on when its group leaves the slow loop. CPU only: a trap in a
    CUDA build, an ``#error`` for a host compiler other than clang (as
    :func:`fieldmap.kernels.grid_simd.column8_simd`).
    """
    ...


@wp.func
def _coefficients_x(
    s: sh_vec8,
    s6: wp.float64,
    m: int,
    u: wp.float64,
    k: wp.float64,
    cd: wp.float64,
    sd: wp.float64,
    coef: wp.array3d(dtype=wp.vec2d),
    row: int,
):
    """Fourier coefficients of order m of one row from the sums of ``W'`` (module docstring)."""
    um = u
    if m == 0:
        um = wp.float64(1.0)
    a_up = -k * (um * s[2])
    b_up = -k * (um * s[3])
    a_no = k * s[4]
    b_no = k * s[5]
    a_ea = wp.float64(0.0)
    b_ea = wp.float64(0.0)
    if m >= 1:
        fm = wp.float64(m)
        a_ea = k * (fm * s[1])
        b_ea = -k * (fm * s[0])
    else:
        a_no = k * (u * s6)
        b_no = wp.float64(0.0)
    coef[row, 0, m] = wp.vec2d(a_ea, -b_ea)
    coef[row, 1, m] = wp.vec2d(cd * a_no - sd * a_up, -(cd * b_no - sd * b_up))
    coef[row, 2, m] = wp.vec2d(cd * a_up + sd * a_no, -(cd * b_up + sd * b_no))
    if coef.shape[1] > 3:
        coef[row, 3, m] = wp.vec2d(k * (um * s[0]), -k * (um * s[1]))


@wp.kernel
def row_fourier8x_kernel(
    gm: wp.float64,
    lmax: int,
    rec: wp.array(dtype=vec8d),
    start: wp.array(dtype=wp.int32),
    zon: wp.array(dtype=wp.float64),
    sect: wp.array(dtype=wp.float64),
    t: wp.array(dtype=wp.float64),
    u: wp.array(dtype=wp.float64),
    r: wp.array(dtype=wp.float64),
    q: wp.array(dtype=wp.float64),
    cdel: wp.array(dtype=wp.float64),
    sdel: wp.array(dtype=wp.float64),
    row_a: wp.array2d(dtype=wp.int32),
    row_b: wp.array2d(dtype=wp.int32),
    ng: int,
    simd: int,
    osc: wp.array(dtype=wp.float64),
    coef: wp.array3d(dtype=wp.vec2d),
    offset: wp.int32,
):
    """:func:`fieldmap.kernels.grid.row_fourier8_kernel` at any degree (module docstring).

    Same thread layout (group ``i % ng`` of column ``order_of(i // ng)``), units and outputs;
    the model enters as ``gm``, ``lmax`` and the tables (``sect[m]`` = P̄mm/u^m). Order m is
    written times ``osc[m]``, and columns past lmax are zeroed, as there.
    """
    i = wp.tid() + offset
    mi = i / ng
    g = i - mi * ng
    m = order_of(mi, lmax)
    tv = vec8d()
    qv = vec8d()
    uv = vec8d()
    for k in range(8):
        ra = row_a[g, k]
        if ra >= 0:
            tv[k] = t[ra]
            qv[k] = q[ra]
            uv[k] = u[ra]
    tq = wp.cw_mul(tv, qv)
    qq = wp.cw_mul(qv, qv)
    sdm, sde = seed8x(sect, m, lmax, uv, qv)
    cs = mat168d()
    live = int(0)
    for k in range(8):
        if sdm[k] != wp.float64(0.0):
            live = 1
    if live != 0:
        if simd != 0:
            cs = column8x_simd(rec, start[m], lmax + 1 - m, sdm, sde, tq, qq)
        else:
            cs = column8x(rec, start[m], lmax + 1 - m, sdm, sde, tq, qq)
    e6 = vec8d()
    o6 = vec8d()
    if m == 0 and lmax >= 1:
        z1 = vec8d()
        for k in range(8):
            z1[k] = sect[1] * qv[k]
        e6, o6 = zonal_north8(rec, zon, start[1], lmax, z1, tq, qq)
    for k in range(8):
        ra = row_a[g, k]
        if ra >= 0:
            se, so = lane_sums(cs, k, m, tv[k], qv[k])
            rra = r[ra]
            ka = gm / (rra * rra) * osc[m]
            _coefficients_x(se + so, e6[k] + o6[k], m, uv[k], ka, cdel[ra], sdel[ra], coef, ra)
            if m == lmax:
                zero_tail(coef, ra, lmax + 1)
            rb = row_b[g, k]
            if rb >= 0:
                rrb = r[rb]
                _coefficients_x(
                    mirror_rows(se, so),
                    e6[k] - o6[k],
                    m,
                    u[rb],
                    gm / (rrb * rrb) * osc[m],
                    cdel[rb],
                    sdel[rb],
                    coef,
                    rb,
                )
                if m == lmax:
                    zero_tail(coef, rb, lmax + 1)

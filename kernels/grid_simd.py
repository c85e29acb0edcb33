r"""The eight-lane Legendre pass of the grid kernels: column sums of eight rows per thread.

:func:`fieldmap.kernels.grid.row_fourier8_kernel` runs, per thread, one order m for a group of
eight row units (a row and its mirror at -latitude). The recursions of the eight rows are the
lanes of one vector: this module holds that recursion on the packed tables of
:mod:`fieldmap.grids.tables` (entry ``rec[start[m] + j]`` of degree n = m + j holds a_nm, b_nm,
C, S, (n+1) C, (n+1) S, f_{n+1,m} C_{n+1,m}, f_{n+1,m} S_{n+1,m}), in two versions with the
same operations in the same order per lane:

- :func:`column8`, plain Warp (any device, CUDA included);
- :func:`column8_simd`, a ``wp.func_native`` C++ snippet with clang's 8-lane vector extension
  (the CPU; FMA contraction on inside it only), which keeps each sum in one vector register.
  A kernel picks it at run time (``simd``, :func:`fieldmap.grids.synthesis.simd_flag`); in a
  CUDA build it is a trap (the kernel stops: never zeros), and a host compiler other than
  clang refuses it (``#error``).

Both return the sums split by the parity of n - m (the host mirrors a row at -t with them,
P̄nm(-t) = (-1)^(n+m) P̄nm(t)). :func:`zonal_north8` sums the m = 1 column's zonal north term,
:func:`seed8` gives the lanes' first values (the 1e-280 scale and the q^n fold of
:func:`fieldmap.kernels.sh.sh_column`, with the engine's degree cut), and :func:`order_of` the
launch order of the columns. Each lane is one row's own recursion: a row's bits do not depend
on which rows share its thread. The Fourier coefficients are formed in
:mod:`fieldmap.kernels.grid`.
"""

import warp as wp

from .sh import QM_MIN, SCALE, SHKernelModel

# forward kernels only: fieldmap never differentiates through them (faster builds, whatever
# the import order relative to fieldmap._warp.init())
wp.set_module_options({"enable_backward": False})

vec8d = wp.types.vector(length=8, dtype=wp.float64)
mat168d = wp.types.matrix(shape=(16, 8), dtype=wp.float64)


@wp.func
def order_of(mi: int, lmax: int) -> int:
    """Order m of the mi-th column in launch order 0, lmax, 1, lmax - 1, ...

    Consecutive pairs of columns hold lmax + 2 degrees together, so that contiguous chunks of a
    launch (one per CPU core) get the same work.
    """
    h = mi / 2
    if mi - 2 * h == 0:
        return h
    return lmax - h


@wp.func
def sums_matrix(
    e0: vec8d,
    e1: vec8d,
    e2: vec8d,
    e3: vec8d,
    e4: vec8d,
    e5: vec8d,
    o0: vec8d,
    o1: vec8d,
    o2: vec8d,
    o3: vec8d,
    o4: vec8d,
    o5: vec8d,
):
    """Return the 16 x 8 column-sum matrix: rows 0-5 even n - m, rows 8-13 odd (column8)."""
    out = mat168d()
    for k in range(8):
        out[0, k] = e0[k]
        out[1, k] = e1[k]
        out[2, k] = e2[k]
        out[3, k] = e3[k]
        out[4, k] = e4[k]
        out[5, k] = e5[k]
        out[8, k] = o0[k]
        out[9, k] = o1[k]
        out[10, k] = o2[k]
        out[11, k] = o3[k]
        out[12, k] = o4[k]
        out[13, k] = o5[k]
    return out


@wp.func
def column8(
    rec: wp.array(dtype=vec8d),
    s0: int,
    nterm: int,
    seed: vec8d,
    tq: vec8d,
    qq: vec8d,
):
    """Parity-split column sums of eight rows (lanes) along one order m (Warp, any device).

    ``rec[s0 + j]`` is the packed entry of degree n = m + j (:mod:`fieldmap.grids.tables`),
    j < ``nterm``; ``seed`` = 1e-280 q^m P̄mm / u^m per lane, ``tq`` = t q, ``qq`` = q^2 per lane
    (the q^n fold of :func:`~fieldmap.kernels.sh.sh_column`). Each lane is one row's own
    recursion (no lane ever reads another), so a row's bits do not depend on which rows share
    its thread.

    Returns a 16 x 8 matrix (rows x lanes): rows 0-5 the sums over even n - m of
    C Q, S Q, (n+1) C Q, (n+1) S Q, f_{n+1} C_{n+1} Q, f_{n+1} S_{n+1} Q, rows 8-13 the same
    over odd n - m (rows 6, 7, 14, 15 zero). The f-sums of one parity of Q_n are the
    latitude-derivative sums f_nm C_nm Q_{n-1} of the other parity of n (see the tables).
    """
    w = rec[s0]
    p1 = seed
    p2 = vec8d()
    e0 = w[2] * p1
    e1 = w[3] * p1
    e2 = w[4] * p1
    e3 = w[5] * p1
    e4 = w[6] * p1
    e5 = w[7] * p1
    o0 = vec8d()
    o1 = vec8d()
    o2 = vec8d()
    o3 = vec8d()
    o4 = vec8d()
    o5 = vec8d()
    j = s0 + 1
    jend = s0 + nterm
    while j < jend:
        # n - m odd
        w = rec[j]
        pn = wp.cw_mul(w[0] * tq, p1) - wp.cw_mul(w[1] * qq, p2)
        o0 = o0 + w[2] * pn
        o1 = o1 + w[3] * pn
        o2 = o2 + w[4] * pn
        o3 = o3 + w[5] * pn
        o4 = o4 + w[6] * pn
        o5 = o5 + w[7] * pn
        p2 = p1
        p1 = pn
        j = j + 1
        if j >= jend:
            break
        # n - m even
        w = rec[j]
        pn = wp.cw_mul(w[0] * tq, p1) - wp.cw_mul(w[1] * qq, p2)
        e0 = e0 + w[2] * pn
        e1 = e1 + w[3] * pn
        e2 = e2 + w[4] * pn
        e3 = e3 + w[5] * pn
        e4 = e4 + w[6] * pn
        e5 = e5 + w[7] * pn
        p2 = p1
        p1 = pn
        j = j + 1
    return sums_matrix(e0, e1, e2, e3, e4, e5, o0, o1, o2, o3, o4, o5)


_COLUMN8_SIMD = r"""
#if defined(__CUDA_ARCH__)
    // A CUDA build compiles this function (the kernel picks it at run time, ``simd``) but
    // must never run it: the host passes simd = 0 for a CUDA device
    // (fieldmap.grids.synthesis.simd_flag) and the kernel runs column8, the plain Warp
    // recursion. Reached anyway, the kernel stops here (a failed launch), never returns zeros.
    printf("fieldmap: column8_simd (CPU SIMD) called on a CUDA device: launch with simd = 0\n");
    __trap();
    return wp::mat_t<16, 8, wp::float64>();  // not reached
#elif !defined(__clang__)
#error "fieldmap column8_simd needs clang's vector extension (Warp's CPU compiler)"
#else
#pragma clang fp contract(fast)
    typedef double v8 __attribute__((ext_vector_type(8)));
    const double* w = (const double*)wp::address(rec, s0);
    v8 p1, p2 = 0.0, tq8, qq8;
    __builtin_memcpy(&p1, &seed, 64);
    __builtin_memcpy(&tq8, &tq, 64);
    __builtin_memcpy(&qq8, &qq, 64);
    v8 e0 = w[2] * p1, e1 = w[3] * p1, e2 = w[4] * p1, e3 = w[5] * p1, e4 = w[6] * p1,
       e5 = w[7] * p1;
    v8 o0 = 0.0, o1 = 0.0, o2 = 0.0, o3 = 0.0, o4 = 0.0, o5 = 0.0;
    int j = 1;
    for (; j + 1 < nterm; j += 2) {
        const double* x = w + 8 * j;
        v8 pn = (x[0] * tq8) * p1 - (x[1] * qq8) * p2;
        o0 += x[2] * pn; o1 += x[3] * pn; o2 += x[4] * pn;
        o3 += x[5] * pn; o4 += x[6] * pn; o5 += x[7] * pn;
        p2 = p1; p1 = pn;
        x += 8;
        pn = (x[0] * tq8) * p1 - (x[1] * qq8) * p2;
        e0 += x[2] * pn; e1 += x[3] * pn; e2 += x[4] * pn;
        e3 += x[5] * pn; e4 += x[6] * pn; e5 += x[7] * pn;
        p2 = p1; p1 = pn;
    }
    if (j < nterm) {
        const double* x = w + 8 * j;
        v8 pn = (x[0] * tq8) * p1 - (x[1] * qq8) * p2;
        o0 += x[2] * pn; o1 += x[3] * pn; o2 += x[4] * pn;
        o3 += x[5] * pn; o4 += x[6] * pn; o5 += x[7] * pn;
    }
    wp::mat_t<16, 8, wp::float64> out;
    v8 rows[16] = {e0, e1, e2, e3, e4, e5, 0.0, 0.0, o0, o1, o2, o3, o4, o5, 0.0, 0.0};
    __builtin_memcpy(&out, rows, sizeof(rows));
    return out;
#endif
"""


@wp.func_native(_COLUMN8_SIMD)
def column8_simd(
    rec: wp.array(dtype=vec8d),
    s0: int,
    nterm: int,
    seed: vec8d,
    tq: vec8d,
    qq: vec8d,
) -> mat168d:
    """:func:`column8` on the CPU with explicit 8-lane SIMD vectors (clang vector extension).

    The same operations in the same order per lane, written so that the compiler keeps every
    sum in one vector register (Warp's vector types leave the choice to LLVM's SLP vectoriser,
    which pairs the wrong operands here). FMA contraction is on inside this function only.
    CPU only: a trap in a CUDA build (the host passes ``simd = 0`` there, see
    :func:`fieldmap.grids.synthesis.simd_flag`), an ``#error`` for a host compiler other than
    clang.
    """
    ...


@wp.func
def zonal_north8(
    rec: wp.array(dtype=vec8d),
    zon: wp.array(dtype=wp.float64),
    s1: int,
    lmax: int,
    seed: vec8d,
    tq: vec8d,
    qq: vec8d,
):
    """Entry [6] of ``sh_column`` (m = 1) for eight lanes, split by the parity of n - 1.

    Sums of sqrt(n(n+1)/2) C_n0 Q_n1 (``zon[n]``) along the m = 1 column (``rec[s1 + n - 1]``),
    the recursion of :func:`column8`; the zonal north component needs them.
    """
    p1 = seed
    p2 = vec8d()
    e6 = zon[1] * p1
    o6 = vec8d()
    n = int(2)
    while n <= lmax:
        w = rec[s1 + n - 1]
        pn = wp.cw_mul(w[0] * tq, p1) - wp.cw_mul(w[1] * qq, p2)
        o6 = o6 + zon[n] * pn
        p2 = p1
        p1 = pn
        n = n + 1
        if n > lmax:
            break
        w = rec[s1 + n - 1]
        pn = wp.cw_mul(w[0] * tq, p1) - wp.cw_mul(w[1] * qq, p2)
        e6 = e6 + zon[n] * pn
        p2 = p1
        p1 = pn
        n = n + 1
    return e6, o6


@wp.func
def seed8(
    model: SHKernelModel,
    qpow: wp.array2d(dtype=wp.float64),
    m: int,
    row_a: wp.array2d(dtype=wp.int32),
    g: int,
) -> vec8d:
    """1e-280 q^m P̄mm/u^m for the lanes (rows ``row_a[g]``); 0 where q^m < QM_MIN.

    QM_MIN is the engine's degree cut; padding lanes (row -1) get 0. q^m comes from the power
    table ``qpow[m, row]`` (:func:`fieldmap.kernels.grid.row_powers_kernel`).
    """
    sc = SCALE * model.sect[m]
    p1 = vec8d()
    for k in range(8):
        ra = row_a[g, k]
        if ra >= 0:
            qm = qpow[m, ra]
            if qm >= QM_MIN:
                p1[k] = sc * qm
    return p1

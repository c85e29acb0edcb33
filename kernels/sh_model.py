"""Device-side spherical-harmonic model shared by both synthesis paths (Warp, float64).

:class:`SHKernelModel` holds the coefficients and recursion tables of one model truncated to
``lmax``, built on the host by ``fieldmap.field.sh.kernel_model``; :func:`sh_degree_cut` is the
degree cut far above the sphere that both paths apply. The two paths that read the struct live
in :mod:`fieldmap.kernels.sh` (the 1e-280 scaled recursion, degree <= 2700, also used by the
grid kernels) and :mod:`fieldmap.kernels.sh_xrange` (X-numbers, any degree, points only); this
module imports neither, so both can import it.
"""

import warp as wp

# forward kernels only: fieldmap never differentiates through them (faster builds, whatever
# the import order relative to fieldmap._warp.init())
wp.set_module_options({"enable_backward": False})

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

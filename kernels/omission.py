"""Warp kernel of the omitted field's realisations: a sum of random waves (float64).

The physics and the waves are :mod:`fieldmap.field.omission`'s; the NumPy reference is
:func:`fieldmap.reference.omission.wave_sum`. One thread per (draw, point) sums the draw's waves
in their order, so a point's value does not depend on the other points launched with it.
"""

import warp as wp

# forward kernels only (fieldmap never differentiates through them)
wp.set_module_options({"enable_backward": False})


@wp.kernel
def wave_sum(
    unit: wp.array(dtype=wp.vec3d),
    north: wp.array(dtype=wp.vec3d),
    east: wp.array(dtype=wp.vec3d),
    log_q: wp.array(dtype=wp.float64),
    inv_r: wp.array(dtype=wp.float64),
    degree: wp.array2d(dtype=wp.float64),
    amplitude: wp.array2d(dtype=wp.float64),
    phase: wp.array2d(dtype=wp.float64),
    pole: wp.array2d(dtype=wp.vec3d),
    npoints: wp.int32,
    out: wp.array2d(dtype=wp.vec3d),
    offset: wp.int32,
):
    """δg north, east, down (m/s²) of draw d's waves at point k, thread d * npoints + k.

    ``unit``, ``north``, ``east``: the point's unit position vector and local north and east
    (spherical); ``log_q`` = log(R/r); ``inv_r`` = 1/r; the waves ``(draws, W)``: degree n,
    amplitude A (m²/s²), phase, pole (unit vectors). Potential of a wave
    A (R/r)^(n+1) cos(ν ψ + φ), ν = sqrt(n(n+1)), ψ the angle between pole and point.
    """
    tid = wp.tid() + offset
    d = tid // npoints
    k = tid - d * npoints
    x = unit[k]
    nv = north[k]
    ev = east[k]
    lq = log_q[k]
    one = wp.float64(1.0)
    zero = wp.float64(0.0)
    sn = zero
    se = zero
    sd = zero
    for j in range(degree.shape[1]):
        n = degree[d, j]
        p = pole[d, j]
        c = wp.dot(x, p)
        pn = wp.dot(nv, p)  # p = cos ψ x + pn north + pe east
        pe = wp.dot(ev, p)
        s = wp.sqrt(pn * pn + pe * pe)
        psi = wp.atan2(s, c)
        nu = wp.sqrt(n * (n + one))
        arg = nu * psi + phase[d, j]
        a = amplitude[d, j] * wp.exp((n + one) * lq)
        sd = sd + a * (n + one) * wp.cos(arg)
        if s > zero:
            # ∇_h T = (1/r) dT/dψ e_ψ with e_ψ·north = -pn/sin ψ, e_ψ·east = -pe/sin ψ
            hor = a * nu * wp.sin(arg) / s
            sn = sn + hor * pn
            se = se + hor * pe
    ir = inv_r[k]
    out[d, k] = wp.vec3d(sn * ir, se * ir, sd * ir)

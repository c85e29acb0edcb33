"""Warp device functions for the normal (level-ellipsoid) gravity field, float64.

Three families, all returning ECEF vectors in m/s²:

* :func:`normal_gravitation_exact` — the closed-form gravitation of the level ellipsoid in
  ellipsoidal coordinates (u, β) (Heiskanen & Moritz 1967, §2-7 to 2-9), valid on and above the
  ellipsoid (and, as the harmonic continuation of the exterior field, anywhere outside the focal
  disc).
* :func:`jn_gravitation` — the J2 / J4 / J6 truncated zonal gravitation of Chen et al. (2022)
  eqs. (7)–(13), with the printed misprints corrected (see the function's comments).
* :func:`centrifugal_ecef` — ω²(x, y, 0) (Groves 2013 eq. 3.7.5, second term).

:class:`NormalParams` is built on the host by ``fieldmap.field.normal.normal_params(ellipsoid)``.
"""

import warp as wp

from .frames import ecef_to_enu, enu_to_ned, geodetic_to_ecef

# forward kernels only: fieldmap never differentiates through them (faster builds, whatever
# the import order relative to fieldmap._warp.init())
wp.set_module_options({"enable_backward": False})

_ZERO = wp.constant(wp.float64(0.0))
_HALF = wp.constant(wp.float64(0.5))
_ONE = wp.constant(wp.float64(1.0))
_TWO = wp.constant(wp.float64(2.0))
_THREE = wp.constant(wp.float64(3.0))
_THIRD = wp.constant(wp.float64(1.0 / 3.0))
_C15_8 = wp.constant(wp.float64(15.0 / 8.0))
_C35_16 = wp.constant(wp.float64(35.0 / 16.0))
_C7_8 = wp.constant(wp.float64(7.0 / 8.0))
_C429_5 = wp.constant(wp.float64(429.0 / 5.0))
# The alternating series of q(x) is used below this x = E/u (closed form cancels for small x).
_Q_SERIES_MAX = wp.constant(wp.float64(0.5))
_Q_SERIES_TOL = wp.constant(wp.float64(1.0e-18))

# Kind codes shared with fieldmap.field.normal (host side).
KIND_EXACT = wp.constant(0)
FRAME_ECEF = wp.constant(0)
FRAME_ENU = wp.constant(1)
FRAME_NED = wp.constant(2)


@wp.struct
class NormalParams:
    """Constants of a level ellipsoid for the device functions (all SI).

    a, b: semi-axes (m); E: linear eccentricity (m); e2: first eccentricity squared; gm: GM
    (m³/s²); omega: rotation rate (rad/s); q0: q(E/b) (H&M eq. 2-58); j2, j4, j6: unnormalised
    zonal coefficients (positive-J2 convention, H&M eq. 2-92).
    """

    a: wp.float64
    b: wp.float64
    E: wp.float64
    e2: wp.float64
    gm: wp.float64
    omega: wp.float64
    q0: wp.float64
    j2: wp.float64
    j4: wp.float64
    j6: wp.float64


@wp.func
def q_and_dq(x: wp.float64):
    r"""Return (q(x), dq/dx) with :math:`q(x) = \tfrac12[(1 + 3/x^2)\arctan x - 3/x]`.

    Heiskanen & Moritz (1967) eq. 2-58 with x = E/u. For x < 0.5 the alternating series

    .. math::
        q = \tfrac12\sum_{k\ge1} (-1)^{k+1}\frac{4k\,x^{2k+1}}{(2k+1)(2k+3)},\qquad
        q' = \tfrac12\sum_{k\ge1} (-1)^{k+1}\frac{4k\,x^{2k}}{2k+3}

    avoids the cancellation of the closed form (for the Earth x ≤ e' ≈ 0.082, so the closed form
    would lose about five digits).
    """
    q = _ZERO
    dq = _ZERO
    if x < _Q_SERIES_MAX:
        x2 = x * x
        p = _ONE  # x^(2k)
        sign = _ONE
        k = int(1)
        done = int(0)
        while done == 0 and k < 80:
            p = p * x2
            fk = wp.float64(k)
            c = wp.float64(4.0) * fk * p / (_TWO * fk + _THREE)
            dq = dq + sign * c
            tq = c * x / (_TWO * fk + _ONE)
            q = q + sign * tq
            if c < _Q_SERIES_TOL * dq:
                done = 1
            sign = -sign
            k = k + 1
        q = _HALF * q
        dq = _HALF * dq
    else:
        at = wp.atan(x)
        ix = _ONE / x
        ix2 = ix * ix
        q = _HALF * ((_ONE + _THREE * ix2) * at - _THREE * ix)
        dq = _HALF * (
            -wp.float64(6.0) * ix2 * ix * at + (_ONE + _THREE * ix2) / (_ONE + x * x) + _THREE * ix2
        )
    return wp.vec2d(q, dq)


@wp.func
def normal_gravitation_exact(p: wp.vec3d, ell: NormalParams):
    r"""Exact gravitation (no centrifugal) of the level ellipsoid at ECEF point ``p``. Units: m/s².

    Potential in ellipsoidal coordinates (u, β) (Heiskanen & Moritz 1967 eqs. 2-50, 2-61, 2-62):

    .. math::
        V = \frac{GM}{E}\arctan\frac{E}{u}
            + \tfrac12\omega^2 a^2 \frac{q(E/u)}{q_0}\left(\sin^2\beta - \tfrac13\right)

    with x = √(u²+E²) cosβ cosλ, y = √(u²+E²) cosβ sinλ, z = u sinβ. Gradient via the metric of
    (u, β): h_u² = D/(u²+E²), h_β² = D, D = u² + E² sin²β, so

    .. math::
        \nabla V = \frac{u^2+E^2}{D} V_u \frac{\partial\mathbf r}{\partial u}
                 + \frac{V_\beta}{D} \frac{\partial\mathbf r}{\partial\beta}.

    The horizontal part is written as k·(x, y) with the factor cos β / p cancelled analytically,
    so the poles (p = 0) and the equator (sin β = 0) need no special case.
    """
    x = p[0]
    y = p[1]
    z = p[2]
    E = ell.E
    E2 = E * E
    P2 = x * x + y * y
    d = P2 + z * z - E2
    disc = wp.sqrt(d * d + _TWO * _TWO * E2 * z * z)
    # u² is the larger root of u⁴ − (r² − E²)u² − E²z² = 0; pick the form without cancellation.
    u2 = _ZERO
    if d >= _ZERO:
        u2 = _HALF * (d + disc)
    else:
        u2 = _TWO * E2 * z * z / (disc - d)
    u = wp.sqrt(u2)
    v2 = u2 + E2
    v = wp.sqrt(v2)
    nb = wp.sqrt(z * z * v2 + u2 * P2)  # = u v; sinβ = z v / nb, cosβ = u p / nb
    sb = z * v / nb
    sb2 = sb * sb
    cb2 = u2 * P2 / (nb * nb)
    qd = q_and_dq(E / u)
    c = _HALF * ell.omega * ell.omega * ell.a * ell.a / ell.q0
    # ∂V/∂u; d q(E/u)/du = q'(x)·(−E/u²)
    Vu = -ell.gm / v2 - c * (sb2 - _THIRD) * qd[1] * E / u2
    # ∂V/∂β = 2 c q sinβ cosβ; below, 2 c q carries the sinβ cosβ factors explicitly.
    cq2 = _TWO * c * qd[0]
    D = u2 + E2 * sb2
    # horizontal: G_p = v (u cosβ V_u − sinβ V_β)/D, divided by p (cosβ/p = u/nb)
    k = v * u * (u * Vu - cq2 * sb2) / (nb * D)
    gz = sb * (v2 * Vu + cq2 * u * cb2) / D
    return wp.vec3d(k * x, k * y, gz)


@wp.func
def jn_gravitation(p: wp.vec3d, ell: NormalParams, order: int):
    r"""Return the truncated zonal gravitation (J2, J2+J4 or J2+J4+J6) at ECEF ``p``. Units: m/s².

    Chen et al. (2022) eq. (13), corrected. With s = z/ρ and t = (a/ρ)²:

    .. math::
        \mathbf g = -\frac{GM}{\rho^3}\Big[A\,\mathbf r + B\,z\,\hat{\mathbf z}\Big],\quad
        A = 1 + \tfrac32 J_2 t(1-5s^2) + \tfrac{15}{8}J_4 t^2(-1+14s^2-21s^4)
            + \tfrac{35}{16}J_6 t^3(1-27s^2+99s^4-\tfrac{429}{5}s^6),

        B = 3J_2 t + \tfrac52 J_4 t^2 (7s^2-3) + \tfrac78 J_6 t^3(99s^4-90s^2+15).

    Derivation: the n-th term of eq. (7), T = −GM J a^{2n} P(s)/ρ^{2n+1}, has gradient
    −(GM/ρ³) J t^n [−((2n+1)P + sP′) r + (P′/s) z ẑ].

    Misprints in the paper, corrected here:
    * eq. (9): the J2 bracket reads (3/2 z²/ρ⁵ − 1/2 z²/ρ⁵); correct is (3/2 z²/ρ⁵ − 1/2 · 1/ρ³);
      every term carries R_c²; correct is R_c², R_c⁴, R_c⁶ for J2, J4, J6.
    * eq. (11): ∂(z^m/ρ^n)/∂x = −n z^m x/ρ^(n+2) (the factor n is missing).
    * eq. (13): the J4 term of A has R_c⁴/ρ⁶ (correct: R_c⁴/ρ⁴) and −21z²/ρ² (correct: −21z⁴/ρ⁴).
    Checked in tests/test_normal.py against central finite differences and complex-step
    derivatives of the potential eq. (7) with P2, P4, P6 of eq. (8), and against the
    zonal series truncated at the same order.
    """
    x = p[0]
    y = p[1]
    z = p[2]
    r2 = x * x + y * y + z * z
    rho = wp.sqrt(r2)
    s2 = z * z / r2
    t = ell.a * ell.a / r2
    A = _ONE + wp.float64(1.5) * ell.j2 * t * (_ONE - wp.float64(5.0) * s2)
    B = _THREE * ell.j2 * t
    if order >= 4:
        t2 = t * t
        A = A + _C15_8 * ell.j4 * t2 * (-_ONE + wp.float64(14.0) * s2 - wp.float64(21.0) * s2 * s2)
        B = B + wp.float64(2.5) * ell.j4 * t2 * (wp.float64(7.0) * s2 - _THREE)
    if order >= 6:
        t3 = t * t * t
        s4 = s2 * s2
        A = A + _C35_16 * ell.j6 * t3 * (
            _ONE - wp.float64(27.0) * s2 + wp.float64(99.0) * s4 - _C429_5 * s4 * s2
        )
        B = B + _C7_8 * ell.j6 * t3 * (
            wp.float64(99.0) * s4 - wp.float64(90.0) * s2 + wp.float64(15.0)
        )
    k = -ell.gm / (r2 * rho)
    return wp.vec3d(k * A * x, k * A * y, k * (A + B) * z)


@wp.func
def centrifugal_ecef(p: wp.vec3d, omega: wp.float64):
    """Centrifugal acceleration ω²(x, y, 0) at ECEF ``p`` (Groves 2013 eq. 3.7.5). Units: m/s²."""
    w2 = omega * omega
    return wp.vec3d(w2 * p[0], w2 * p[1], _ZERO)


@wp.func
def normal_field_ecef(p: wp.vec3d, ell: NormalParams, kind: int, with_centrifugal: int):
    """Return normal gravitation (kind 0: exact; 2, 4, 6: J-truncated) [+ centrifugal], ECEF."""
    g = wp.vec3d(_ZERO, _ZERO, _ZERO)
    if kind == KIND_EXACT:
        g = normal_gravitation_exact(p, ell)
    else:
        g = jn_gravitation(p, ell, kind)
    if with_centrifugal != 0:
        g = g + centrifugal_ecef(p, ell.omega)
    return g


@wp.kernel
def normal_points_kernel(
    lat: wp.array(dtype=wp.float64),
    lon: wp.array(dtype=wp.float64),
    h: wp.array(dtype=wp.float64),
    ell: NormalParams,
    kind: int,
    with_centrifugal: int,
    frame: int,
    out: wp.array(dtype=wp.vec3d),
    offset: wp.int32,
):
    """Evaluate normal gravity at geodetic points (lat, lon rad, h m) in ECEF/ENU/NED (m/s²)."""
    i = wp.tid() + offset
    p = geodetic_to_ecef(lat[i], lon[i], h[i], ell.a, ell.e2)
    g = normal_field_ecef(p, ell, kind, with_centrifugal)
    if frame != FRAME_ECEF:
        g = ecef_to_enu(g, lat[i], lon[i])
        if frame == FRAME_NED:
            g = enu_to_ned(g)
    out[i] = g


@wp.kernel
def normal_ecef_kernel(
    pts: wp.array(dtype=wp.vec3d),
    ell: NormalParams,
    kind: int,
    with_centrifugal: int,
    out: wp.array(dtype=wp.vec3d),
    offset: wp.int32,
):
    """Evaluate normal gravitation (+ centrifugal) at ECEF points (m), ECEF result (m/s²)."""
    i = wp.tid() + offset
    out[i] = normal_field_ecef(pts[i], ell, kind, with_centrifugal)

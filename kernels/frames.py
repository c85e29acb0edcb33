"""Warp device functions for the frames (float64): Earth-fixed, and the launch frames.

Earth-fixed: geodetic <-> ECEF and the local ENU axes. The launch frames of Chen et al. (2022)
eqs. (16)-(20): same conventions and misprint corrections as ``fieldmap.nav.frames`` (see its
docstring): eq. (16) uses λ + ω t, eq. (17) uses R11 = −sin A0 sin λ0 − cos A0 sin B0 cos λ0.
Angles in radians.
"""

import warp as wp

# forward kernels only: fieldmap never differentiates through them (faster builds, whatever
# the import order relative to fieldmap._warp.init())
wp.set_module_options({"enable_backward": False})


@wp.func
def geodetic_to_ecef(
    lat: wp.float64, lon: wp.float64, h: wp.float64, a: wp.float64, e2: wp.float64
):
    """Geodetic latitude, longitude (rad), height (m) -> ECEF position (m)."""
    sl = wp.sin(lat)
    cl = wp.cos(lat)
    n = a / wp.sqrt(wp.float64(1.0) - e2 * sl * sl)
    return wp.vec3d(
        (n + h) * cl * wp.cos(lon),
        (n + h) * cl * wp.sin(lon),
        (n * (wp.float64(1.0) - e2) + h) * sl,
    )


@wp.func
def ecef_to_enu(v: wp.vec3d, lat: wp.float64, lon: wp.float64):
    """Rotate an ECEF vector into local east-north-up at geodetic lat, lon (rad)."""
    sl = wp.sin(lat)
    cl = wp.cos(lat)
    so = wp.sin(lon)
    co = wp.cos(lon)
    e = -so * v[0] + co * v[1]
    n = -sl * co * v[0] - sl * so * v[1] + cl * v[2]
    u = cl * co * v[0] + cl * so * v[1] + sl * v[2]
    return wp.vec3d(e, n, u)


@wp.func
def enu_to_ecef(v: wp.vec3d, lat: wp.float64, lon: wp.float64):
    """Rotate a local east-north-up vector at geodetic lat, lon (rad) into ECEF."""
    sl = wp.sin(lat)
    cl = wp.cos(lat)
    so = wp.sin(lon)
    co = wp.cos(lon)
    return wp.vec3d(
        -so * v[0] - sl * co * v[1] + cl * co * v[2],
        co * v[0] - sl * so * v[1] + cl * so * v[2],
        cl * v[1] + sl * v[2],
    )


@wp.func
def enu_to_ned(v: wp.vec3d):
    """Reorder an east-north-up vector into north-east-down."""
    return wp.vec3d(v[1], v[0], -v[2])


# -- the launch frames (seed 002 eqs. 16-20) ----------------------------------------------


@wp.struct
class LaunchParams:
    """A launch-centred inertial frame: R_t^a (eq. 17), launch point in the t-frame, Earth rate."""

    C_t_to_a: wp.mat33d
    r_launch: wp.vec3d
    omega: wp.float64


@wp.func
def C_t_to_a(lon0: wp.float64, B0: wp.float64, A0: wp.float64):
    """R_t^a of eq. (17) (R11 corrected); lon0, B0 (geodetic), A0 (azimuth) in rad."""
    sA = wp.sin(A0)
    cA = wp.cos(A0)
    sB = wp.sin(B0)
    cB = wp.cos(B0)
    sl = wp.sin(lon0)
    cl = wp.cos(lon0)
    return wp.mat33d(
        -sA * sl - cA * sB * cl,
        sA * cl - cA * sB * sl,
        cA * cB,
        cB * cl,
        cB * sl,
        sB,
        -cA * sl + sA * sB * cl,
        cA * cl + sA * sB * sl,
        -sA * cB,
    )


@wp.func
def C_e_to_t(t: wp.float64, omega: wp.float64):
    """R_e^t of eq. (19): rotation by +omega*t about the polar axis (t in s, omega in rad/s)."""
    c = wp.cos(omega * t)
    s = wp.sin(omega * t)
    zero = wp.float64(0.0)
    return wp.mat33d(c, -s, zero, s, c, zero, zero, zero, wp.float64(1.0))


@wp.func
def C_l_to_t(lat_gc: wp.float64, lon: wp.float64, t: wp.float64, omega: wp.float64):
    """R_l^t of eq. (16) with the sign of omega*t corrected (geocentric lat, lon in rad)."""
    sp = wp.sin(lat_gc)
    cp = wp.cos(lat_gc)
    lam = lon + omega * t
    sl = wp.sin(lam)
    cl = wp.cos(lam)
    return wp.mat33d(-sl, -sp * cl, cp * cl, cl, -sp * sl, cp * sl, wp.float64(0.0), cp, sp)


@wp.func
def C_e_to_a(lp: LaunchParams, t: wp.float64):
    """R_e^a = R_t^a R_e^t, eq. (20)."""
    return lp.C_t_to_a * C_e_to_t(t, lp.omega)


@wp.func
def a_to_ecef(lp: LaunchParams, P_a: wp.vec3d, t: wp.float64):
    """A-frame position (m) at time t (s) -> ECEF position: r_e = R_t^e (R_a^t P_a + r_launch)."""
    r_t = wp.transpose(lp.C_t_to_a) * P_a + lp.r_launch
    return wp.transpose(C_e_to_t(t, lp.omega)) * r_t


@wp.func
def ecef_to_a(lp: LaunchParams, r_e: wp.vec3d, t: wp.float64):
    """ECEF position (m) at time t (s) -> a-frame position P_a = R_t^a (R_e^t r_e − r_launch)."""
    return lp.C_t_to_a * (C_e_to_t(t, lp.omega) * r_e - lp.r_launch)


@wp.func
def vector_e_to_a(lp: LaunchParams, v_e: wp.vec3d, t: wp.float64):
    """Rotate an ECEF vector into the a-frame at time t, eq. (20)."""
    return lp.C_t_to_a * (C_e_to_t(t, lp.omega) * v_e)

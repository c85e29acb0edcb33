"""Warp device functions for the launch frames of Chen et al. (2022) eqs. (16)-(20) (float64).

Same conventions and misprint corrections as ``fieldmap.nav.frames`` (see its docstring):
eq. (16) uses λ + ω t, eq. (17) uses R11 = −sin A0 sin λ0 − cos A0 sin B0 cos λ0. Angles in radians.
"""

import warp as wp

# forward kernels only: fieldmap never differentiates through them (faster builds, whatever
# the import order relative to fieldmap._warp.init())
wp.set_module_options({"enable_backward": False})


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

"""Warp device functions for Earth-fixed frames (float64)."""

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

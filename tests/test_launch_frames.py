"""Launch frames of Chen et al. (2022) eqs. (16)-(20): NumPy functions and their Warp twins."""

import numpy as np
import pytest
import warp as wp

from fieldmap.field.ellipsoid import WGS84
from fieldmap.field.frames import C_e_to_enu, ecef_to_geodetic, geodetic_to_ecef
from fieldmap.nav.frames import (
    C_e_to_a,
    C_e_to_t,
    C_l_to_a,
    C_l_to_t,
    C_t_to_a,
    LaunchFrame,
)

LAUNCHES = [(105.3, 27.1, 63.0), (-70.0, -33.5, 200.0), (10.0, 80.0, 0.0), (0.0, 0.0, 90.0)]
W = WGS84.omega


def _orthonormal(C):
    np.testing.assert_allclose(
        C @ np.swapaxes(C, -1, -2), np.broadcast_to(np.eye(3), C.shape), rtol=0, atol=2e-15
    )
    np.testing.assert_allclose(np.linalg.det(C), 1.0, rtol=0, atol=2e-15)


@pytest.mark.parametrize("launch", LAUNCHES)
def test_matrices_are_rotations(launch):
    _orthonormal(C_t_to_a(*launch))
    t = np.array([0.0, 17.0, 3600.0, 86164.0])
    _orthonormal(C_e_to_t(t))
    _orthonormal(
        C_l_to_t(np.array([-40.0, 0.0, 33.0, 89.0]), np.array([5.0, 100.0, -120.0, 0.0]), t)
    )
    _orthonormal(C_e_to_a(t, *launch))


def test_printed_R11_is_a_misprint():
    # eq. (17) as printed: R11 with cos B0 -> rows not orthonormal (unless B0 = 45° or cos A0 = 0)
    C = C_t_to_a(105.3, 27.1, 63.0, printed=True)
    assert np.abs(C @ C.T - np.eye(3)).max() > 1e-2
    np.testing.assert_allclose(C[0, 1:], C_t_to_a(105.3, 27.1, 63.0)[0, 1:], rtol=0, atol=0)


@pytest.mark.parametrize("lon0,B0", [(105.3, 27.1), (-70.0, -33.5), (10.0, 80.0)])
def test_axes_at_launch(lon0, B0):
    enu = C_e_to_enu(B0, lon0)  # rows east, north, up (frames.py, independent code)
    east = C_t_to_a(lon0, B0, 90.0)
    np.testing.assert_allclose(east[0], enu[0], atol=1e-15)  # A0 = 90°: x towards east
    np.testing.assert_allclose(east[1], enu[2], atol=1e-15)  # y along the geodetic up
    np.testing.assert_allclose(east[2], -enu[1], atol=1e-15)  # z = x × y = south
    north = C_t_to_a(lon0, B0, 0.0)
    np.testing.assert_allclose(north[0], enu[1], atol=1e-15)  # A0 = 0°: x towards north
    az = 37.0
    C = C_t_to_a(lon0, B0, az)
    s, c = np.sin(np.radians(az)), np.cos(np.radians(az))
    np.testing.assert_allclose(C[0], s * enu[0] + c * enu[1], atol=1e-15)


def test_earth_rotation_sense():
    # An Earth-fixed point moves eastwards in inertial space: dr_t/dt = ω × r at t = 0.
    r = np.array(geodetic_to_ecef(30.0, 40.0, 0.0))
    dt = 1.0  # central difference: truncation (ω dt)²/6 ≈ 1e-9 relative
    num = (C_e_to_t(dt) @ r - C_e_to_t(-dt) @ r) / (2 * dt)
    np.testing.assert_allclose(num, np.cross([0, 0, W], r), rtol=3e-9)
    # after a sidereal day... a quarter turn: ECEF x-axis lies along t-frame y
    np.testing.assert_allclose(C_e_to_t(np.pi / 2 / W) @ [1.0, 0, 0], [0, 1.0, 0], atol=1e-15)


@pytest.mark.parametrize("launch", LAUNCHES)
def test_round_trips_and_origin(launch):
    lf = LaunchFrame(*launch, h0=120.0)
    np.testing.assert_allclose(lf.ecef_to_a(lf.r_launch, 0.0), 0.0, atol=1e-9)
    rng = np.random.default_rng(5)
    P = rng.normal(0, 5e5, (50, 3))
    t = rng.uniform(0, 3000, 50)
    np.testing.assert_allclose(lf.ecef_to_a(lf.a_to_ecef(P, t), t), P, rtol=0, atol=1e-8)
    V = rng.normal(0, 3e3, (50, 3))
    r_e, v_e = lf.a_state_to_ecef(P, V, t)
    P2, V2 = lf.ecef_state_to_a(r_e, v_e, t)
    np.testing.assert_allclose(P2, P, rtol=0, atol=1e-8)  # 2e-9 m measured
    np.testing.assert_allclose(V2, V, rtol=0, atol=1e-11)  # 1.8e-12 m/s measured
    # the launch point stays in place in ECEF; in the a-frame it drifts by Earth rotation
    # closed form: the chord of a circle of radius rho = hypot(x, y) turned by ω t
    rho = np.hypot(*lf.r_launch[:2])
    np.testing.assert_allclose(
        np.linalg.norm(lf.ecef_to_a(lf.r_launch, 600.0)),
        2 * rho * np.sin(W * 600.0 / 2),
        rtol=1e-14,  # 1.5e-16 measured
    )
    # a-frame "up" at launch is the geodetic up: a point 1 km above launch at t=0 is at y = 1 km
    lat, lon, _ = LAUNCHES[0][1], LAUNCHES[0][0], 0
    lf0 = LaunchFrame(lon, lat, 30.0)
    up = np.array(geodetic_to_ecef(lat, lon, 1000.0))
    np.testing.assert_allclose(lf0.ecef_to_a(up, 0.0), [0, 1000.0, 0], rtol=0, atol=1e-8)


def _geocentric(r):
    return np.degrees(np.arctan2(r[..., 2], np.hypot(r[..., 0], r[..., 1]))), np.degrees(
        np.arctan2(r[..., 1], r[..., 0])
    )


@pytest.mark.parametrize("launch", LAUNCHES)
def test_eq18_equals_eq20(launch):
    """g^a via the l-frame (eq. 18) equals g^a via ECEF (eq. 20); the printed λ − ωt does not."""
    rng = np.random.default_rng(11)
    lat = rng.uniform(-80, 80, 40)
    lon = rng.uniform(-180, 180, 40)
    r = np.stack(geodetic_to_ecef(lat, lon, rng.uniform(0, 1e5, 40)), -1)
    g_e = rng.normal(0, 9.8, (40, 3))
    t = rng.uniform(10, 5000, 40)
    phi, lam = _geocentric(r)
    g_l = np.einsum("...ij,...j->...i", C_e_to_enu(phi, lam), g_e)  # geocentric ENU components
    via_l = np.einsum("...ij,...j->...i", C_l_to_a(phi, lam, t, *launch), g_l)
    via_e = np.einsum("...ij,...j->...i", C_e_to_a(t, *launch), g_e)
    np.testing.assert_allclose(via_l, via_e, rtol=0, atol=1e-13)
    printed = C_t_to_a(*launch) @ C_l_to_t(phi, lam - 2 * np.degrees(W * t), t)  # λ - ωt
    via_printed = np.einsum("...ij,...j->...i", printed, g_l)
    assert np.abs(via_printed - via_e).max() > 1e-3


# ---------------------------------------------------------------- Warp twins
from fieldmap.kernels import frames as klf  # noqa: E402


@wp.kernel
def _frames_kernel(
    lp: klf.LaunchParams,
    P: wp.array(dtype=wp.vec3d),
    t: wp.array(dtype=wp.float64),
    r_out: wp.array(dtype=wp.vec3d),
    back: wp.array(dtype=wp.vec3d),
    rot: wp.array(dtype=wp.vec3d),
    lt: wp.array(dtype=wp.mat33d),
    lat_gc: wp.float64,
    lon: wp.float64,
):
    i = wp.tid()
    r = klf.a_to_ecef(lp, P[i], t[i])
    r_out[i] = r
    back[i] = klf.ecef_to_a(lp, r, t[i])
    rot[i] = klf.vector_e_to_a(lp, P[i], t[i])
    lt[i] = klf.C_l_to_t(lat_gc, lon, t[i], lp.omega)


@wp.kernel
def _cta_kernel(lon0: wp.float64, B0: wp.float64, A0: wp.float64, out: wp.array(dtype=wp.mat33d)):
    out[0] = klf.C_t_to_a(lon0, B0, A0)


def test_warp_frames_match_numpy(device):
    lf = LaunchFrame(105.3, 27.1, 63.0, h0=500.0)
    cta = wp.zeros(1, dtype=wp.mat33d, device=device)
    wp.launch(
        _cta_kernel,
        dim=1,
        inputs=[np.radians(lf.lon0), np.radians(lf.B0), np.radians(lf.A0), cta],
        device=device,
    )
    np.testing.assert_allclose(cta.numpy()[0], lf.C_t_to_a, rtol=0, atol=1e-15)
    lp = klf.LaunchParams()
    lp.C_t_to_a = wp.mat33d(*lf.C_t_to_a.ravel())
    lp.r_launch = wp.vec3d(*lf.r_launch)
    lp.omega = WGS84.omega
    rng = np.random.default_rng(3)
    P = rng.normal(0, 4e5, (64, 3))
    t = rng.uniform(0, 3000, 64)
    outs = [wp.zeros(64, dtype=wp.vec3d, device=device) for _ in range(3)]
    lt = wp.zeros(64, dtype=wp.mat33d, device=device)
    wp.launch(
        _frames_kernel,
        dim=64,
        inputs=[
            lp,
            wp.array(P, dtype=wp.vec3d, device=device),
            wp.array(t, dtype=wp.float64, device=device),
            *outs,
            lt,
            np.radians(31.0),
            np.radians(-12.0),
        ],
        device=device,
    )
    r, back, rot = (o.numpy() for o in outs)
    np.testing.assert_allclose(r, lf.a_to_ecef(P, t), rtol=1e-15, atol=1e-8)
    np.testing.assert_allclose(back, P, rtol=0, atol=1e-8)
    np.testing.assert_allclose(rot, lf.vector_e_to_a(P, t), rtol=1e-14, atol=1e-9)
    np.testing.assert_allclose(lt.numpy(), C_l_to_t(31.0, -12.0, t), rtol=0, atol=1e-15)
    # geodetic sanity: the a-frame origin at t = 0 maps to the launch height
    lat, lon, h = ecef_to_geodetic(*lf.a_to_ecef(np.zeros(3), 0.0))
    np.testing.assert_allclose([lat, lon, h], [27.1, 105.3, 500.0], rtol=0, atol=1e-8)

"""NED strapdown kernel: NumPy reference, navtk mechanization_standard, a body at rest."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from fieldmap.field.ellipsoid import WGS84
from fieldmap.nav.mechanize import dcm_to_quat, quat_to_dcm
from fieldmap.reference import normal as rnorm


def _g_ned_j2(llh):
    """J2 gravitation (Groves eq. 3.7.7) + centrifugal (eq. 3.7.5) in NED at (rad, rad, m) rows."""
    from fieldmap.field.frames import C_e_to_enu, enu_to_ned, geodetic_to_ecef

    lat, lon = np.degrees(llh[:, 0]), np.degrees(llh[:, 1])
    r = np.stack(geodetic_to_ecef(lat, lon, llh[:, 2]), -1)
    g = rnorm.groves_j2_gravitation(*r.T, WGS84.GM, WGS84.J2, WGS84.a)
    g = g + WGS84.omega**2 * r * [1.0, 1.0, 0.0]
    return enu_to_ned(np.einsum("nij,nj->ni", C_e_to_enu(lat, lon), g))


def _ned_motion(N, dt):
    """Aircraft-like increments from smooth body rates and specific forces (same for any dt)."""
    t = (np.arange(N) + 0.5) * dt
    w = np.stack([0.05 * np.sin(0.7 * t), 0.03 * np.cos(0.3 * t), 0.02 + 0 * t], -1)
    f = np.stack([2 + 0.5 * np.sin(t), 0.3 * np.cos(2 * t), -9.8 + 0.2 * np.sin(0.5 * t)], -1)
    C0 = Rotation.from_euler("ZYX", [40, 3, -2], degrees=True).as_matrix()
    return w * dt, f * dt, C0


LLH0 = np.array([np.radians(30.0), np.radians(100.0), 1000.0])
VNED0 = np.array([150.0, 80.0, -5.0])


def _kernel_run(dth, dv, dt, C0, output_every, device):
    """Run the NED kernel (J2 gravity) from LLH0, VNED0 and attitude C0."""
    from fieldmap.nav.mechanize import NavConfig, NedStart, propagate_ned

    return propagate_ned(
        dth,
        dv,
        dt,
        NedStart(30.0, 100.0, 1000.0, VNED0, dcm_to_quat(C0)),
        NavConfig("j2", output_every=output_every),
        device=device,
    )


def _reference_run(dth, dv, dt, C0, output_every, **kw):
    """Run the NumPy reference (J2 gravity) from LLH0, VNED0, C0: (llh, v, C) of trajectory 0."""
    from fieldmap.reference.strapdown import propagate_ned_reference

    L, V, C = propagate_ned_reference(
        (dth[None], dv[None], dt),
        (LLH0[None], VNED0[None], C0[None]),
        _g_ned_j2,
        WGS84,
        output_every=output_every,
        **kw,
    )
    return L[0], V[0], C[0]


def test_ned_kernel_equals_reference(device):
    N, dt = 1000, 0.01
    dth, dv, C0 = _ned_motion(N, dt)
    res = _kernel_run(dth, dv, dt, C0, 100, device)
    L, V, C = _reference_run(dth, dv, dt, C0, 100)
    np.testing.assert_allclose(np.radians(res.lat[0]), L[:, 0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.radians(res.lon[0]), L[:, 1], rtol=0, atol=1e-15)
    np.testing.assert_allclose(res.h[0], L[:, 2], rtol=0, atol=1e-9)
    np.testing.assert_allclose(res.v_ned[0], V, rtol=0, atol=1e-12 * np.abs(V).max())
    np.testing.assert_allclose(quat_to_dcm(res.q[0]), C, rtol=0, atol=1e-13)


def _navtk_same_gravity(dth, dv, dt, C0):
    """Run navtk's mechanization_standard fed increments that make its gravity equal ours.

    At each step navtk evaluates its Savage gravity at the start position and forms
    f = C (dv' + ½ dθ×dv')/dt; choosing (I + ½[dθ×]) dv' = dv + ½ dθ×dv + C^T (g_ours − g_navtk) dt
    makes its velocity update use g_ours exactly.
    """
    ni = pytest.importorskip("navtk.inertial")
    nu = pytest.importorskip("navtk.navutils")
    opt = ni.MechanizationOptions(
        grav_model=nu.GravModels.SAVAGE, dcm_method=ni.DcmIntegrationMethods.EXPONENTIAL
    )
    llh, v, C, v_prev = LLH0.copy(), VNED0.copy(), C0.copy(), VNED0.copy()
    for k in range(dth.shape[0]):
        C_n_e = np.asarray(nu.lat_lon_wander_to_C_n_to_e(llh[0], llh[1], 0.0))
        dg = _g_ned_j2(llh[None])[0] - np.asarray(nu.calculate_gravity_savage_ned(C_n_e, llh[2]))
        th = dth[k]
        skew = np.array([[0, -th[2], th[1]], [th[2], 0, -th[0]], [-th[1], th[0], 0]])
        rhs = dv[k] + 0.5 * np.cross(th, dv[k]) + C.T @ dg * dt
        out = ni.mechanization_standard(
            np.linalg.solve(np.eye(3) + 0.5 * skew, rhs), th, dt, llh, C, v, v_prev, opt
        )
        v_prev = v
        llh, v, C = (np.asarray(o, dtype=np.float64) for o in out)
    return llh, v, C


def test_ned_reference_equals_navtk_with_body_rate_attitude():
    """Navtk (T&W body-rate attitude form) equals our reference run with that attitude form."""
    N, dt = 1000, 0.01
    dth, dv, C0 = _ned_motion(N, dt)
    llh, v, C = _navtk_same_gravity(dth, dv, dt, C0)
    L, V, Cr = _reference_run(dth, dv, dt, C0, N, attitude="body", frame_rotation=False)
    np.testing.assert_allclose(L[-1, :2], llh[:2], rtol=0, atol=1e-15)  # rad: ~6 nm
    np.testing.assert_allclose(L[-1, 2], llh[2], rtol=0, atol=1e-9)
    np.testing.assert_allclose(V[-1], v, rtol=0, atol=1e-11)
    np.testing.assert_allclose(Cr[-1], C, rtol=0, atol=1e-13)


def test_ned_kernel_converges_to_navtk():
    """Kernel (split attitude update, exact for constant rates) vs navtk: first-order agreement.

    The differences are the attitude update C Rot(dθ − C^T ω_in dt) (navtk) vs
    Rot(−ω_in dt) C Rot(dθ) (ours) and our n-frame rotation term −½ ω_in × Δv^n, both O(dt²) per
    step: halving dt halves the difference.
    """
    diffs = []
    for N, dt in ((500, 0.02), (1000, 0.01)):
        dth, dv, C0 = _ned_motion(N, dt)
        llh, v, C = _navtk_same_gravity(dth, dv, dt, C0)
        res = _kernel_run(dth, dv, dt, C0, N, "cpu")
        dpos = np.array(
            [
                (np.radians(res.lat[0, -1]) - llh[0]) * 6.37e6,
                (np.radians(res.lon[0, -1]) - llh[1]) * 6.37e6 * np.cos(llh[0]),
                res.h[0, -1] - llh[2],
            ]
        )
        diffs.append(
            (
                np.linalg.norm(dpos),
                np.linalg.norm(res.v_ned[0, -1] - v),
                np.abs(quat_to_dcm(res.q[0, -1]) - C).max(),
            )
        )
    diffs = np.array(diffs)
    assert np.all(diffs[1] < [5e-4, 1e-4, 1e-7])  # 10 s, 1.5 km flown
    # next-order terms move the ratio by O(dt): 1.2e-4 measured
    np.testing.assert_allclose(diffs[0] / diffs[1], 2.0, rtol=5e-3)


def test_ned_body_at_rest_on_earth_stays_put(device):
    """At rest on the rotating Earth: gyros sense ω_ie, accelerometers sense f = −g (up).

    With these exact increments the mechanization keeps the body in place (Groves eq. 3.7.5
    convention, Groves 2013 §2.4.7); flipping the sign of f makes it fall at 2g.
    """
    from fieldmap.nav.mechanize import NavConfig, NedStart, propagate_ned

    lat = np.radians(34.0)
    llh = np.array([[lat, np.radians(108.0), 500.0]])
    g = _g_ned_j2(llh)[0]
    assert g[2] > 9.7  # gravity points down in NED ...
    w_ie = WGS84.omega * np.array([np.cos(lat), 0.0, -np.sin(lat)])
    C = Rotation.from_euler("ZYX", [70, 2, -1], degrees=True).as_matrix()
    N, dt = 10000, 0.01  # 100 s
    dth = np.broadcast_to(C.T @ w_ie * dt, (N, 3))
    dv = np.broadcast_to(C.T @ (-g) * dt, (N, 3))  # ... so the sensed force points up
    res = propagate_ned(
        np.stack([dth, dth]),
        np.stack([dv, -dv]),
        dt,
        NedStart(34.0, 108.0, 500.0, np.zeros(3), dcm_to_quat(C)),
        NavConfig("j2", output_every=N),
        device=device,
    )
    assert abs(res.h[0, -1] - 500.0) < 1e-6
    assert abs(res.lat[0, -1] - 34.0) < 1e-12 and abs(res.lon[0, -1] - 108.0) < 1e-12
    assert np.abs(res.v_ned[0, -1]).max() < 1e-9
    np.testing.assert_allclose(quat_to_dcm(res.q[0, -1]), C, rtol=0, atol=1e-12)
    assert res.h[1, -1] < 500.0 - 0.9 * g[2] * 100.0**2  # flipped sign: falls at ~2g

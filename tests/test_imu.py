"""Exact IMU synthesis: stationary closed form, replay, floor, gravity offset, validation.

Replay through the two-sample mechanization: an independent NumPy replay written here, and the
Warp kernel.
"""

import numpy as np
import pytest

from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import WGS84
from fieldmap.nav.frames import LaunchFrame
from fieldmap.nav.imu import (
    Gravitation,
    ImuIncrements,
    ImuSampling,
    gauss_legendre01,
    synthesize,
)
from fieldmap.nav.trajectory import BoostGlide, Stationary

FRAME = LaunchFrame(lon0=108.2, B0=34.0, A0=195.0, h0=400.0)


def j2_gravitation(r):
    """Groves (2013) eq. 3.7.7 with the WGS84 GM, a and derived J2 (independent code)."""
    r = np.atleast_2d(r)
    mu, J2, R0 = WGS84.GM, WGS84.J2, WGS84.a
    n = np.linalg.norm(r, axis=1, keepdims=True)
    zr2 = (r[:, 2:3] / n) ** 2
    fac = np.concatenate([1 - 5 * zr2, 1 - 5 * zr2, 3 - 5 * zr2], axis=1)
    return -mu / n**3 * (r + 1.5 * J2 * R0**2 / n**2 * fac * r)


def _skew(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def _expm_so3(phi):
    a = np.linalg.norm(phi)
    K = _skew(phi)
    if a < 1e-12:
        return np.eye(3) + K
    return np.eye(3) + np.sin(a) / a * K + (1 - np.cos(a)) / a**2 * K @ K


def replay(imu, traj, gravitation):
    """Two-sample launch-centred inertial mechanization (Chen et al. 2022 Fig. 1, eq. 15), DCMs."""
    k0 = traj.kinematics([imu.t0])
    P, V, C = k0.P_a[0].copy(), k0.V_a[0].copy(), k0.C_b_to_a[0].copy()
    dt, T = imu.dt, 2 * imu.dt
    for k in range(imu.n_samples // 2):
        a1, a2 = imu.dtheta[2 * k], imu.dtheta[2 * k + 1]
        v1, v2 = imu.dv[2 * k], imu.dv[2 * k + 1]
        a, v = a1 + a2, v1 + v2
        dv_b = v + 0.5 * np.cross(a, v) + 2.0 / 3.0 * (np.cross(a1, v2) + np.cross(v1, a2))
        tm = imu.t0 + k * T + dt
        r_e = FRAME.a_to_ecef(P + 0.5 * T * V, tm)
        g_a = FRAME.vector_e_to_a(gravitation(r_e)[0], tm)
        V_new = V + C @ dv_b + g_a * T
        P = P + 0.5 * T * (V + V_new)
        V = V_new
        C = C @ _expm_so3(a + 2.0 / 3.0 * np.cross(a1, a2))
    return P, V, C


def test_gauss_legendre_integrates_polynomials_exactly():
    x, w = gauss_legendre01(3)
    assert np.isclose(w.sum(), 1.0, rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.sum(w * x**5), 1.0 / 6.0, rtol=1e-14)


def test_stationary_increments_equal_reaction_to_gravity():
    """At rest: dv/dt = −C_n^b (γ + centrifugal) (up: Groves 2013 §2.4.7), dθ/dt = C_e^b ω_ie."""
    st = Stationary(FRAME, 1.0)
    imu = synthesize(st, ImuSampling(100.0, 2), j2_gravitation)
    r = FRAME.r_launch
    g_e = j2_gravitation(r)[0] + WGS84.omega**2 * np.array([r[0], r[1], 0.0])
    f_b = -st.C_b_e.T @ g_e  # body = NED
    np.testing.assert_allclose(
        imu.dv / imu.dt, np.broadcast_to(f_b, imu.dv.shape), rtol=0, atol=1e-12
    )
    assert f_b[2] < -9.7  # NED down component negative: the sensed force points up
    w_b = st.C_b_e.T @ np.array([0.0, 0.0, WGS84.omega])
    np.testing.assert_allclose(
        imu.dtheta / imu.dt, np.broadcast_to(w_b, imu.dtheta.shape), rtol=0, atol=1e-18
    )


def test_replay_reaches_the_floor_and_converges_at_second_order():
    bg = BoostGlide()
    finals = {}
    for rate in (100.0, 200.0):
        imu = synthesize(bg, ImuSampling(rate, 3), j2_gravitation, duration=40.0)
        P, V, C = replay(imu, bg, j2_gravitation)
        kt = bg.kinematics([imu.duration])
        finals[rate] = (
            np.linalg.norm(P - kt.P_a[0]),
            np.linalg.norm(V - kt.V_a[0]),
            np.linalg.norm(C.T @ kt.C_b_to_a[0] - np.eye(3)),
        )
    # floor at 200 Hz over 40 s of the boost (largest jerk of the flight): below a millimetre
    assert finals[200.0][0] < 1e-3 and finals[200.0][1] < 1e-4 and finals[200.0][2] < 1e-12
    # the mechanization's truncation error, not the synthesis, dominates: O(T²) convergence
    assert 3.0 < finals[100.0][0] / finals[200.0][0] < 5.0


def test_kernel_replay_equals_numpy_replay():
    from fieldmap.nav.mechanize import LciStart, NavConfig, dcm_to_quat, propagate_lci

    bg = BoostGlide()
    imu = synthesize(bg, ImuSampling(100.0, 2), Gravitation("j2"), duration=20.0)
    P_ref, V_ref, _ = replay(imu, bg, j2_gravitation)
    k0 = bg.kinematics([0.0])
    res = propagate_lci(
        imu.dtheta,
        imu.dv,
        imu.dt,
        LciStart(k0.P_a[0], k0.V_a[0], dcm_to_quat(k0.C_b_to_a[0]), FRAME),
        NavConfig("j2"),
        device="cpu",
    )
    # same algorithm, two code paths: rounding only (4e-12 m and 8e-13 m/s measured after 20 s)
    np.testing.assert_allclose(res.P[0, -1], P_ref, rtol=0, atol=1e-10)
    np.testing.assert_allclose(res.V[0, -1], V_ref, rtol=0, atol=2e-11)
    kt = bg.kinematics([imu.duration])
    assert np.linalg.norm(res.P[0, -1] - kt.P_a[0]) < 1e-3


def test_constant_gravity_offset_gives_half_dg_t2():
    """Truth = J2 + δg (constant in ECEF), navigation J2: δP(t) ≈ −½ δg t² at short times."""
    dg_e = np.array([3e-4, -2e-4, 5e-4])  # m/s², about 60 mGal

    def truth(r):
        return j2_gravitation(r) + dg_e

    bg = BoostGlide()
    tend = 10.0
    imu = synthesize(bg, ImuSampling(100.0, 2), truth, duration=tend)
    P, V, _ = replay(imu, bg, j2_gravitation)
    # subtract the run without offset (the mechanization's own floor, ~1e-4 m in the boost)
    imu0 = synthesize(bg, ImuSampling(100.0, 2), j2_gravitation, duration=tend)
    P0, V0, _ = replay(imu0, bg, j2_gravitation)
    kt = bg.kinematics([tend])
    assert np.linalg.norm(P0 - kt.P_a[0]) < 5e-4
    dg_a = FRAME.vector_e_to_a(dg_e, tend / 2)
    # gravity-gradient feedback over 10 s is ~Γt²/12 ~ 1e-5 relative; Earth rotation turns δg by
    # 7e-4 rad over the run (evaluated at mid-time here): 1e-3 relative covers both
    np.testing.assert_allclose(
        P - P0, -0.5 * dg_a * tend**2, rtol=0, atol=1e-3 * 0.5 * np.linalg.norm(dg_e) * tend**2
    )
    np.testing.assert_allclose(
        V - V0, -dg_a * tend, rtol=0, atol=1e-3 * np.linalg.norm(dg_e) * tend
    )


def test_truth_sh_floor_is_ten_times_below_the_smallest_model_effect():
    """EIGEN-6S degree 240 truth, 30 s, 100 Hz: floor (nav = truth) ≤ 1/10 of the SH200 effect."""
    from fieldmap.nav.study import build_scenario, propagate

    sc = build_scenario(duration=30.0, sampling=ImuSampling(100.0, 2), device="cpu")
    out = propagate(sc, ["sh200", sc.truth_key])
    assert sc.truth_key == "sh240"
    effect, floor = out["pos"][0, -1], out["pos"][1, -1]
    assert floor * 10.0 < effect, (floor, effect)
    assert out["vel"][1, -1] * 10.0 < out["vel"][0, -1]


@pytest.mark.parametrize(
    "dth, dv, dt, msg",
    [
        (np.zeros((4, 3)), np.zeros((6, 3)), 0.01, "differ in length"),
        (np.zeros((4, 3)), np.zeros((4, 3)), 0.0, "positive"),
        (np.zeros((4, 3)), np.zeros((4, 3)), -0.01, "positive"),
        (np.full((4, 3), np.nan), np.zeros((4, 3)), 0.01, "NaN"),
        (np.zeros((4, 2)), np.zeros((4, 2)), 0.01, "shape"),
        (np.zeros((5, 3)), np.zeros((5, 3)), 0.01, "even"),
    ],
)
def test_bad_increments_are_rejected(dth, dv, dt, msg):
    with pytest.raises(InputError, match=msg):
        ImuIncrements(dth, dv, dt)


def test_bad_synthesis_requests():
    bg = BoostGlide()
    with pytest.raises(InputError):
        ImuSampling(-100.0)
    with pytest.raises(InputError):
        synthesize(bg, ImuSampling(100.0), j2_gravitation, duration=5000.0)
    with pytest.raises(InputError, match="beyond"):
        Gravitation("sh", lmax=999)
    with pytest.raises(InputError, match="unknown"):
        Gravitation("j3")


def test_imu_sampling_is_one_validated_object():
    """Rate and Gauss nodes travel as one ImuSampling, checked when built."""
    for bad in ({"rate_hz": 0.0}, {"rate_hz": "200"}, {"n_gauss": 0}, {"n_gauss": 2.5}):
        with pytest.raises(InputError):
            ImuSampling(**bad)
    bg = BoostGlide()
    g = Gravitation("j2")
    new = synthesize(bg, ImuSampling(100.0, 2), g, duration=4.0)
    assert isinstance(new, ImuIncrements)
    assert new.meta == {**new.meta, "rate_hz": 100.0, "n_gauss": 2}

"""IMU error models: units, draw statistics, determinism, noise scaling with √Hz, kernel use."""

import numpy as np
import pytest

from fieldmap.errors import InputError
from fieldmap.nav import sensors as ie


def test_unit_constants():
    # 1 µg = 1e-6 · 9.80665 m/s² (Chen et al. 2022 §4.1 use g = 9.80665); 1 °/h = π/180/3600 rad/s
    assert ie.UG == pytest.approx(9.80665e-6, rel=1e-15, abs=0)
    assert ie.DEG_H == pytest.approx(4.84813681109536e-06, rel=1e-14, abs=0)
    assert ie.DEG_RTH == pytest.approx(np.radians(1.0) / 60.0, rel=1e-15, abs=0)
    assert ie.ARCSEC == pytest.approx(np.radians(1.0 / 3600.0), rel=1e-15, abs=0)


def test_tables_hold_the_paper_values():
    assert [ie.TABLE2_GROUPS[g].accel_bias_ug for g in (1, 2, 3, 4)] == [100.0, 10.0, 1.0, 0.0]
    assert [ie.TABLE2_GROUPS[g].accel_vrw_ug_per_sqrt_hz for g in (1, 2, 3, 4)] == [
        10.0,
        1.0,
        0.1,
        0.0,
    ]
    t4 = ie.TABLE4
    assert (
        t4.gyro_bias_deg_per_h,
        t4.gyro_arw_deg_per_sqrt_h,
        t4.gyro_misalignment_arcsec,
        t4.gyro_scale_factor_ppm,
    ) == (0.003, 0.0003, 0.5, 10.0)
    assert (
        t4.accel_bias_ug,
        t4.accel_vrw_ug_per_sqrt_hz,
        t4.accel_misalignment_arcsec,
        t4.accel_scale_factor_ppm,
    ) == (
        10.0,
        1.0,
        0.5,
        10.0,
    )


def test_draws_are_deterministic_per_seed():
    a = ie.draw(ie.TABLE4, 7, seed=42)
    b = ie.draw(ie.TABLE4, 7, seed=42)
    c = ie.draw(ie.TABLE4, 7, seed=43)
    for name in ("acc_bias", "gyro_bias", "acc_M", "gyro_M", "seed"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert not np.array_equal(a.acc_bias, c.acc_bias)
    assert len(set(a.seed.tolist())) == 7


def test_bias_draw_statistics_match_their_definition():
    spec = ie.ImuErrorSpec(accel_bias_ug=100.0, gyro_bias_deg_per_h=0.003)
    g = ie.draw(spec, 20000, seed=1, mode="gauss")
    sigma = 100.0 * ie.UG
    # 60000 samples: the std of the sample std is σ/√(2·60000) ≈ 0.3 %; 2 % is > 6σ
    assert np.std(g.acc_bias) == pytest.approx(sigma, rel=0.02)
    assert abs(np.mean(g.acc_bias)) < 0.02 * sigma
    s = ie.draw(spec, 1000, seed=1, mode="sign")
    np.testing.assert_allclose(np.abs(s.acc_bias), sigma, rtol=1e-15)
    assert 0.4 < np.mean(s.acc_bias > 0) < 0.6
    f = ie.draw(spec, 3, seed=1, mode="fixed")
    np.testing.assert_allclose(f.acc_bias, sigma, rtol=1e-15)
    np.testing.assert_allclose(f.gyro_bias, 0.003 * ie.DEG_H, rtol=1e-15)


def test_bias_shifts_the_mean_of_the_increments_by_b_dt():
    d = ie.draw(
        ie.ImuErrorSpec(accel_bias_ug=100.0, gyro_bias_deg_per_h=1.0), 1, seed=3, mode="fixed"
    )
    dt = 0.005
    th, v = ie.apply(np.zeros((10, 3)), np.zeros((10, 3)), dt, d)
    np.testing.assert_allclose(v, 100.0 * ie.UG * dt, rtol=1e-14)
    np.testing.assert_allclose(th, ie.DEG_H * dt, rtol=1e-14)


def test_white_noise_scales_with_sqrt_hz():
    """σ in µg/√Hz: per-sample std σ√dt, and the velocity error after 1 s has std σ·√1 s."""
    spec = ie.ImuErrorSpec(accel_vrw_ug_per_sqrt_hz=10.0, gyro_arw_deg_per_sqrt_h=0.01)
    d = ie.draw(spec, 1, seed=5)
    sigma = 10.0 * ie.UG
    for rate in (100.0, 400.0):
        dt = 1.0 / rate
        n_sec = 400
        th, v = ie.apply(
            np.zeros((int(rate) * n_sec, 3)),
            np.zeros((int(rate) * n_sec, 3)),
            dt,
            d,
            rng=np.random.default_rng(int(rate)),
        )
        assert np.std(v) == pytest.approx(sigma * np.sqrt(dt), rel=0.02)
        assert np.std(th) == pytest.approx(0.01 * ie.DEG_RTH * np.sqrt(dt), rel=0.02)
        per_second = v.reshape(n_sec, int(rate), 3).sum(axis=1)  # 1200 one-second sums
        assert np.std(per_second) == pytest.approx(sigma, rel=0.08)


def test_scale_factor_and_misalignment_matrix():
    spec = ie.ImuErrorSpec(accel_scale_factor_ppm=10.0, accel_misalignment_arcsec=0.5)
    d = ie.draw(spec, 500, seed=9)
    M = d.acc_M
    # M = diag(1 + s) R(ε): row norms are 1 + s_i, and R = diag(1+s)^-1 M is a rotation
    s = np.linalg.norm(M, axis=2) - 1.0
    assert np.std(s) == pytest.approx(10e-6, rel=0.1)
    R = M / (1.0 + s)[:, :, None]
    np.testing.assert_allclose(
        np.swapaxes(R, 1, 2) @ R, np.broadcast_to(np.eye(3), R.shape), rtol=0, atol=1e-15
    )
    eps = np.stack([R[:, 2, 1], R[:, 0, 2], R[:, 1, 0]], -1)
    assert np.std(eps) == pytest.approx(0.5 * ie.ARCSEC, rel=0.1)
    np.testing.assert_allclose(
        ie.rotation(np.array([[0.0, 0.0, np.pi / 2]]))[0] @ [1, 0, 0], [0, 1, 0], rtol=0, atol=1e-15
    )


def test_kernel_bias_gives_half_b_t2():
    """The draws drive fieldmap.nav.mechanize's kernel: 100 µg fixed bias at rest -> ½ b t²."""
    from fieldmap.nav.frames import LaunchFrame
    from fieldmap.nav.imu import Gravitation, ImuSampling, synthesize
    from fieldmap.nav.mechanize import LciStart, NavConfig, dcm_to_quat, propagate_lci
    from fieldmap.nav.trajectory import Stationary

    fr = LaunchFrame(108.2, 34.0, 195.0, 400.0)
    st = Stationary(fr, 20.0)
    imu = synthesize(st, ImuSampling(100.0, 1), Gravitation("j2"))
    d = ie.draw(ie.ImuErrorSpec(accel_bias_ug=100.0), 2, seed=0, mode="fixed")
    d2 = ie.ErrorDraws.concat([d, ie.draw(ie.ImuErrorSpec(), 1)])
    k0 = st.kinematics([0.0])
    res = propagate_lci(
        imu.dtheta,
        imu.dv,
        imu.dt,
        LciStart(k0.P_a[0], k0.V_a[0], dcm_to_quat(k0.C_b_to_a[0]), fr),
        NavConfig("j2", errors=d2.kernel_errors()),
        device="cpu",
    )
    kt = st.kinematics(res.t[-1:])
    err = np.linalg.norm(res.P[:, -1] - kt.P_a[0], axis=1)
    expect = 0.5 * np.sqrt(3) * 100.0 * ie.UG * 20.0**2
    # gravity-gradient feedback is at most ~G t²/12 ≈ 5e-5 relative over 20 s (1.6e-8 measured:
    # for a bias along (1, 1, 1) in NED axes the first-order term nearly cancels)
    np.testing.assert_allclose(err[:2], expect, rtol=2e-4)
    assert err[2] < 1e-7  # no bias: the floor of 1 Gauss node and the mechanization (1.5e-9 m)


def test_bad_specs_are_rejected():
    with pytest.raises(InputError):
        ie.ImuErrorSpec(accel_bias_ug=-1.0)
    with pytest.raises(InputError):
        ie.ImuErrorSpec(gyro_bias_deg_per_h=float("nan"))
    with pytest.raises(InputError, match="mode"):
        ie.draw(ie.TABLE4, 2, mode="uniform")
    with pytest.raises(InputError):
        ie.draw(ie.TABLE4, 0)
    with pytest.raises(InputError):
        ie.apply(np.zeros((2, 3)), np.zeros((2, 3)), 0.0, ie.draw(ie.TABLE4, 1))

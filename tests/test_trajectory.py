"""Reference trajectories: derivatives vs finite differences, region bounds, closed forms."""

import numpy as np
import pytest

from fieldmap.errors import InputError
from fieldmap.nav.frames import LaunchFrame
from fieldmap.nav.trajectory import BoostGlide, Coning, ConstantVelocity, Stationary

FRAME = LaunchFrame(lon0=108.2, B0=34.0, A0=195.0, h0=400.0)
# 4th-order central difference weights for f'(t) with step h
STENCIL = np.array([1.0, -8.0, 8.0, -1.0]) / 12.0
OFFSETS = np.array([-2.0, -1.0, 1.0, 2.0])


def _fd(fun, t, h):
    vals = [fun(t + o * h) for o in OFFSETS]
    return sum(w * v for w, v in zip(STENCIL, vals)) / h


def _trajectories():
    return [
        BoostGlide(),
        Stationary(FRAME, 100.0),
        ConstantVelocity(FRAME, 100.0),
        Coning(FRAME, 100.0, half_angle=0.02, rate=3.0),
    ]


@pytest.mark.parametrize("traj", _trajectories(), ids=lambda t: t.name)
def test_translation_derivatives_match_finite_differences(traj):
    t = np.linspace(0.05, traj.duration - 0.05, 37)
    k = traj.kinematics(t)
    h = 1e-2
    for pos, vel, acc in (("r_e", "v_e", "a_e"), ("P_a", "V_a", "A_a")):
        dpos = _fd(lambda s: getattr(traj.kinematics(s), pos), t, h)
        dvel = _fd(lambda s: getattr(traj.kinematics(s), vel), t, h)
        # roundoff of 4th-order FD on 6.4e6 m positions: ~1e-16*6.4e6/1e-2*1.5 ~ 1e-7 m/s
        # (1.7e-7 measured); on ~3e3 m/s velocities ~1e-16*3e3/1e-2*1.5 ~ 5e-11 m/s² (1e-10
        # measured; the truncation h⁴ f⁽⁵⁾/30 is far smaller on these smooth profiles)
        np.testing.assert_allclose(dpos, getattr(k, vel), rtol=0, atol=2e-6)
        np.testing.assert_allclose(dvel, getattr(k, acc), rtol=0, atol=2e-9)


@pytest.mark.parametrize("traj", _trajectories(), ids=lambda t: t.name)
def test_attitude_orthonormal_and_rate_matches_finite_differences(traj):
    t = np.linspace(0.05, traj.duration - 0.05, 29)
    k = traj.kinematics(t)
    C = k.C_b_to_a
    np.testing.assert_allclose(
        np.swapaxes(C, 1, 2) @ C, np.broadcast_to(np.eye(3), C.shape), rtol=0, atol=1e-14
    )
    np.testing.assert_allclose(np.linalg.det(C), 1.0, rtol=0, atol=1e-14)
    dC = _fd(lambda s: traj.kinematics(s).C_b_to_a, t, 1e-3)
    W = np.swapaxes(C, 1, 2) @ dC  # = [w_b]x
    w_fd = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], -1)
    np.testing.assert_allclose(w_fd, k.w_b, rtol=0, atol=1e-10)


def test_boost_glide_stays_in_the_paper_region_and_altitudes():
    bg = BoostGlide()
    assert 600.0 <= bg.duration <= 1000.0
    t = np.linspace(0.0, bg.duration, 4001)
    lat, lon, h = bg.geodetic(t)
    # Chen et al. (2022) §5.1: roughly 103-109°E and 20-35°N
    assert lat.min() >= 20.0 and lat.max() <= 35.0
    assert lon.min() >= 103.0 and lon.max() <= 109.0
    # boost to about 67 km, then glide near 30 km
    assert 65e3 <= h.max() <= 69e3
    assert 80.0 < t[np.argmax(h)] < 200.0
    glide = t > 260.0
    assert 25e3 <= h[glide].min() and h[glide].max() <= 35e3
    assert abs(h[0] - FRAME.h0) < 1.0  # starts at the a-frame origin
    k = bg.kinematics(t)
    np.testing.assert_allclose(k.P_a[0], 0.0, atol=1e-6)
    speed = np.linalg.norm(k.v_e, axis=1)
    assert speed[glide].min() > 1400.0  # hypersonic (> Mach 5 at 30 km)


def test_stationary_closed_form():
    st = Stationary(FRAME, 50.0)
    t = np.array([0.0, 10.0, 50.0])
    k = st.kinematics(t)
    w = np.array([0.0, 0.0, FRAME.omega])
    r = FRAME.r_launch
    # inertial velocity and centripetal acceleration of an Earth-fixed point, rotated into a
    np.testing.assert_allclose(
        k.V_a, FRAME.vector_e_to_a(np.broadcast_to(np.cross(w, r), (3, 3)), t), rtol=0, atol=1e-9
    )
    np.testing.assert_allclose(
        k.A_a,
        FRAME.vector_e_to_a(np.broadcast_to(np.cross(w, np.cross(w, r)), (3, 3)), t),
        rtol=0,
        atol=1e-12,
    )
    # body rate = Earth rate resolved in the NED body axes: (ω cos B, 0, −ω sin B)
    B = np.radians(FRAME.B0)
    np.testing.assert_allclose(
        k.w_b,
        np.broadcast_to([FRAME.omega * np.cos(B), 0, -FRAME.omega * np.sin(B)], (3, 3)),
        rtol=0,
        atol=1e-18,
    )


def test_coning_rate_closed_form_values():
    al, W = 0.05, 2.0
    c = Coning(FRAME, 10.0, half_angle=al, rate=W)
    t = np.array([0.0, 0.3, 1.7])
    k = c.kinematics(t)
    expect = W * np.stack(
        [
            -np.sin(al) * np.sin(W * t),
            np.sin(al) * np.cos(W * t),
            np.full_like(t, np.cos(al) - 1.0),
        ],
        -1,
    )
    np.testing.assert_allclose(k.w_b, expect, rtol=0, atol=1e-15)
    # the attitude is periodic: back to C0 after one coning period
    np.testing.assert_allclose(
        c.kinematics([2 * np.pi / W]).C_b_to_a[0], k.C_b_to_a[0], rtol=0, atol=1e-14
    )


def test_below_surface_is_rejected():
    down = ConstantVelocity(FRAME, 100.0, v_enu=(0.0, 0.0, -50.0))
    with pytest.raises(InputError, match="below the surface"):
        down.check_above_surface()
    with pytest.raises(InputError):
        Stationary(FRAME, -1.0)

"""Baro-aided vertical channel of the NED kernel: NumPy reference and the loop's closed forms."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from fieldmap import _warp
from fieldmap.field.ellipsoid import WGS84
from fieldmap.nav.mechanize import (
    Baro,
    NavConfig,
    NedStart,
    baro_gains,
    dcm_to_quat,
    propagate_ned,
    quat_to_dcm,
)
from fieldmap.reference import normal as rnorm
from fieldmap.reference.strapdown import propagate_ned_reference

DEVICES = _warp.devices()
LLH0 = np.array([np.radians(30.0), np.radians(100.0), 1000.0])
VNED0 = np.array([150.0, 80.0, -5.0])


def _g_ned_j2(llh):
    """J2 gravitation (Groves eq. 3.7.7) + centrifugal (eq. 3.7.5) in NED at (rad, rad, m) rows."""
    from fieldmap.field.frames import C_e_to_enu, enu_to_ned, geodetic_to_ecef

    lat, lon = np.degrees(llh[:, 0]), np.degrees(llh[:, 1])
    r = np.stack(geodetic_to_ecef(lat, lon, llh[:, 2]), -1)
    g = rnorm.groves_j2_gravitation(*r.T, WGS84.GM, WGS84.J2, WGS84.a)
    g = g + WGS84.omega**2 * r * [1.0, 1.0, 0.0]
    return enu_to_ned(np.einsum("nij,nj->ni", C_e_to_enu(lat, lon), g))


@pytest.mark.parametrize("device", DEVICES)
def test_baro_loop_kernel_equals_reference(device):
    """Kernel with the third-order loop, a 7 m baro bias and a varying h_ref = NumPy reference."""
    N, dt = 2000, 0.01
    t = (np.arange(N) + 0.5) * dt
    w = np.stack([0.05 * np.sin(0.7 * t), 0.03 * np.cos(0.3 * t), 0.02 + 0 * t], -1)
    f = np.stack([2 + 0.5 * np.sin(t), 0.3 * np.cos(2 * t), -9.8 + 0.2 * np.sin(0.5 * t)], -1)
    C0 = Rotation.from_euler("ZYX", [40, 3, -2], degrees=True).as_matrix()
    h_ref = 1000.0 + 5.0 * np.arange(N) * dt + 3.0 * np.sin(0.2 * np.arange(N) * dt)
    k1, k2, k3 = baro_gains(20.0)
    res = propagate_ned(
        w * dt,
        f * dt,
        dt,
        NedStart(30.0, 100.0, 1000.0, VNED0, dcm_to_quat(C0)),
        NavConfig("j2", output_every=100, baro=Baro(h_ref, k1, k2, k3, bias=7.0)),
        device=device,
    )
    L, V, C = propagate_ned_reference(
        ((w * dt)[None], (f * dt)[None], dt), (LLH0[None], VNED0[None], C0[None]), _g_ned_j2, WGS84,
        output_every=100, baro={"k1": k1, "k2": k2, "k3": k3, "h_ref": h_ref[None], "bias": 7.0},
    )  # fmt: skip
    # same algorithm in two code paths (quaternion vs DCM attitude): rounding only
    np.testing.assert_allclose(np.radians(res.lat[0]), L[0, :, 0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(res.h[0], L[0, :, 2], rtol=0, atol=1e-9)
    np.testing.assert_allclose(res.v_ned[0], V[0], rtol=0, atol=1e-12 * np.abs(V).max())
    np.testing.assert_allclose(quat_to_dcm(res.q[0]), C[0], rtol=0, atol=1e-13)
    # the loop really acted: without it the heights differ by far more than the tolerance
    free = propagate_ned(
        w * dt,
        f * dt,
        dt,
        NedStart(30.0, 100.0, 1000.0, VNED0, dcm_to_quat(C0)),
        NavConfig("j2", output_every=100),
        device=device,
    )
    assert np.abs(free.h[0, -1] - res.h[0, -1]) > 0.1


def _at_rest(n, dt, lat=45.0, h=500.0):
    """Exact increments of a body at rest in NED attitude (J2 truth = J2 navigation)."""
    llh = np.array([[np.radians(lat), 0.0, h]])
    g = _g_ned_j2(llh)[0]
    om = WGS84.omega
    w_ie = np.array([om * np.cos(np.radians(lat)), 0.0, -om * np.sin(np.radians(lat))])
    return np.tile(w_ie * dt, (n, 1)), np.tile(-g * dt, (n, 1))


def test_baro_loop_absorbs_an_accelerometer_bias():
    """Steady state of the loop against its closed form.

    δh → baro bias, velocity error → 0 and δa → −b_D + (2g/r) bias (the loop also cancels
    the free-air gradient error of the biased height, 3.086e-6 s⁻² per m: Heiskanen & Moritz
    1967 eq. 2-124).

    The free channel with the same 100 µg down bias runs away (½bt² plus the 2g/R instability).
    """
    dt, n = 0.05, 24000  # 20 min
    dth, dv = _at_rest(n, dt)
    b = 100e-6 * 9.80665
    errors = {"acc_bias": np.array([0.0, 0.0, b])}
    k1, k2, k3 = baro_gains(60.0)
    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    aided = propagate_ned(
        dth,
        dv,
        dt,
        NedStart(45.0, 0.0, 500.0, np.zeros(3), q0),
        NavConfig(
            "j2", errors=errors, output_every=n, baro=Baro(np.full(n, 500.0), k1, k2, k3, bias=4.0)
        ),
        device="cpu",
    )
    free = propagate_ned(
        dth,
        dv,
        dt,
        NedStart(45.0, 0.0, 500.0, np.zeros(3), q0),
        NavConfig("j2", errors=errors, output_every=n),
        device="cpu",
    )
    # 20 τ after the start the triple pole has decayed to e^-20 (20³/2 e^-20 ~ 8e-6)
    assert aided.h[0, -1] - 500.0 == pytest.approx(4.0, abs=1e-3)
    # 1e-7 m/s² is 1 % of the gradient term (1.23e-5 m/s²)
    assert aided.final["baro"][0, 0] == pytest.approx(-b + 3.086e-6 * 4.0, abs=1e-7)
    assert abs(aided.v_ned[0, -1, 2]) < 1e-4
    assert 500.0 - free.h[0, -1] > 0.5 * b * (n * dt) ** 2  # down bias: sinks at least ½bt²

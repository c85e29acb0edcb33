"""Ellipsoid constants and Earth-fixed frames against published values and round trips."""

import math

import mpmath
import numpy as np
import pytest

from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import GRS80, WGS84, Ellipsoid, _q_series, get_ellipsoid
from fieldmap.field.frames import C_e_to_enu, ecef_to_geodetic, enu_to_ned, geodetic_to_ecef


def test_wgs84_derived_constants():
    # NIMA TR8350.2 (2000) Table 3.3 / 3.4: J2 = 1.08262982131e-3 (from a, f, GM, omega),
    # gamma_e = 9.7803253359, gamma_p = 9.8321849378 m/s2, b = 6356752.3142 m
    # tolerances: the published digits (last-digit rounding 4.6e-12, 2.1e-8, 8.2e-7 relative)
    assert WGS84.J2 == pytest.approx(1.08262982131e-3, rel=1e-11, abs=0)
    assert WGS84.gamma_a == pytest.approx(9.7803253359, abs=1e-10)
    assert WGS84.gamma_b == pytest.approx(9.8321849378, abs=1e-10)
    assert WGS84.b == pytest.approx(6356752.3142, abs=1e-4)
    # H&M (1967) eq. 2-92 with the J2 above, in 30-digit mpmath: J4 -2.3709112e-6, J6 6.08346e-9
    assert WGS84.J4 == pytest.approx(-2.3709112e-6, rel=1e-7, abs=0)
    assert WGS84.J6 == pytest.approx(6.08346e-9, rel=1e-6, abs=0)


def test_grs80_derived_constants():
    # Moritz (2000), GRS80: J2 = 0.00108263 (defining), e2 = 0.00669438002290,
    # gamma_e = 9.7803267715, gamma_p = 9.8321863685 m/s2, J4 = -0.00000237091222,
    # J6 = 0.00000000608347
    assert GRS80.J2 == pytest.approx(0.00108263, rel=1e-9)
    assert GRS80.e2 == pytest.approx(0.00669438002290, abs=1e-14)
    assert GRS80.gamma_a == pytest.approx(9.7803267715, abs=1e-10)
    assert GRS80.gamma_b == pytest.approx(9.8321863685, abs=1e-10)
    assert GRS80.J4 == pytest.approx(-0.00000237091222, rel=1e-8, abs=0)
    assert GRS80.J6 == pytest.approx(0.00000000608347, rel=1e-6, abs=0)  # 6 digits: 8.2e-7


@pytest.mark.parametrize("x", [1e-3, 0.05, 0.0820944, 0.3, 0.4999, 0.5, 0.9, 3.0])
def test_q_function_against_mpmath(x):
    # H&M eq. 2-58 evaluated in 50-digit arithmetic, no cancellation issue there
    mpmath.mp.dps = 50
    xm = mpmath.mpf(x)
    exact = 0.5 * ((1 + 3 / xm**2) * mpmath.atan(xm) - 3 / xm)
    assert _q_series(x) == pytest.approx(float(exact), rel=1e-13, abs=0)


def test_ellipsoid_validation_and_lookup():
    with pytest.raises(ValueError):
        Ellipsoid("bad", a=-1.0, f=0.003, GM=3.9e14, omega=7e-5)
    with pytest.raises(ValueError):
        Ellipsoid("bad", a=6e6, f=float("nan"), GM=3.9e14, omega=7e-5)
    with pytest.raises(ValueError):
        Ellipsoid("bad", a=6e6, f=1.5, GM=3.9e14, omega=7e-5)
    assert get_ellipsoid("wgs-84") is WGS84 and get_ellipsoid(GRS80) is GRS80
    with pytest.raises(InputError):
        get_ellipsoid("clarke1866")


def test_geodetic_ecef_round_trip():
    rng = np.random.default_rng(3)
    lat = np.concatenate([rng.uniform(-90, 90, 2000), [90, -90, 89.9999, 0.0]])
    lon = np.concatenate([rng.uniform(-180, 180, 2000), [0, 10, -170, 180.0]])
    h = np.concatenate([rng.uniform(-1e4, 1e6, 2000), [0, 1e5, -5e3, 3.6e7]])
    x, y, z = geodetic_to_ecef(lat, lon, h)
    lat2, lon2, h2 = ecef_to_geodetic(x, y, z)
    assert np.max(np.abs(lat2 - lat)) < 1e-12
    dlon = (lon2 - lon + 180) % 360 - 180
    assert np.max(np.abs(dlon[np.abs(lat) < 90])) < 1e-11
    assert np.max(np.abs(h2 - h)) < 1e-7


def test_geodetic_to_ecef_known_points():
    # equator/prime meridian and pole: closed forms x = a + h, z = b + h
    x, y, z = geodetic_to_ecef(0.0, 0.0, 100.0)
    assert (x, y, z) == pytest.approx((WGS84.a + 100.0, 0.0, 0.0), abs=1e-9)
    x, y, z = geodetic_to_ecef(90.0, 0.0, 100.0)
    # x, y at the pole are a·cos(90°) ≈ 4e-10 m of rounding
    assert z == pytest.approx(WGS84.b + 100.0, abs=1e-8) and math.hypot(x, y) < 1e-9


def test_enu_basis_orthonormal_and_up_is_ellipsoid_normal():
    lat, lon = np.array([10.0, -60.0, 89.0]), np.array([20.0, 135.0, -45.0])
    C = C_e_to_enu(lat, lon)
    eye = np.einsum("...ij,...kj->...ik", C, C)
    assert np.allclose(eye, np.eye(3), atol=1e-15)
    assert np.allclose(np.linalg.det(C), 1.0, atol=1e-15)
    # "up" is the ellipsoid normal: finite-difference tangents (step 1e-6 deg, O(1e-8) error) are
    # orthogonal to it
    for k in range(3):
        p0 = np.array(geodetic_to_ecef(lat[k], lon[k], 0.0))
        dn = np.array(geodetic_to_ecef(lat[k] + 1e-6, lon[k], 0.0)) - p0
        de = np.array(geodetic_to_ecef(lat[k], lon[k] + 1e-6, 0.0)) - p0
        assert abs(C[k, 2] @ dn) < 1e-7 * np.linalg.norm(dn)
        assert abs(C[k, 2] @ de) < 1e-7 * np.linalg.norm(de)
    assert np.array_equal(enu_to_ned(np.array([1.0, 2.0, 3.0])), [2.0, 1.0, -3.0])

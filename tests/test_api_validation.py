"""Bad input to the core Python API: points, grids, map products, launch frames, thresholds.

Every bad argument raises :class:`fieldmap.errors.InputError` (a ``FieldmapError``) with a
one-line message naming the problem, never a raw NumPy error or a silent NaN. Boundary values
just inside the accepted ranges still give finite, physically right results.
"""

from __future__ import annotations

import numpy as np
import pytest

from fieldmap import gravity as GR
from fieldmap import normal as N
from fieldmap.ellipsoid import WGS84
from fieldmap.errors import FieldmapError, InputError

LMAX = 4  # small degree: these tests are about input checks, not the series


def _one_line(info) -> str:
    msg = str(info.value)
    assert "\n" not in msg and isinstance(info.value, FieldmapError)
    return msg


# ----------------------------------------------------------------------------- geodetic points
POINT_FUNCS = [
    ("disturbance", lambda *p: GR.disturbance(*p, lmax=LMAX, device="cpu")),
    ("gravitation", lambda *p: GR.gravitation(*p, lmax=LMAX, device="cpu")),
    ("gravity", lambda *p: GR.gravity(*p, lmax=LMAX, device="cpu")),
    ("normal_gravity", lambda *p: N.normal_gravity(*p, device="cpu")),
]


@pytest.mark.parametrize("name, func", POINT_FUNCS, ids=[f[0] for f in POINT_FUNCS])
@pytest.mark.parametrize(
    "point, msg",
    [
        (([1.0, 2.0], [1.0, 2.0, 3.0], 0.0), r"shapes \(2,\), \(3,\), \(\) do not broadcast"),
        ((np.zeros((2, 3)), np.zeros(2), 0.0), r"shapes \(2, 3\), \(2,\), \(\) do not broadcast"),
        ((0.0, 1e6, 0.0), r"longitude must be within \[-540, 540\) degrees, got 1e\+06"),
        ((0.0, 540.0, 0.0), r"longitude .* got 540"),
        ((0.0, -540.5, 0.0), r"longitude .* got -540.5"),
        ((0.0, 0.0, 1e300), r"height 1e\+300 m is above 1e\+08 m"),
        ((0.0, 0.0, [0.0, 1.0000001e8]), r"height 1e\+08 m is above 1e\+08 m"),
        ((91.0, 0.0, 0.0), r"latitude must be within \[-90, 90\] degrees, got 91"),
        ((0.0, 0.0, -2e4), r"height -20000 m is below -10000 m"),
        ((0.0, np.nan, 0.0), "longitude must be finite"),
    ],
)
def test_bad_points_raise(name, func, point, msg):
    with pytest.raises(InputError, match=msg) as info:
        func(*point)
    _one_line(info)


@pytest.mark.parametrize("name, func", POINT_FUNCS, ids=[f[0] for f in POINT_FUNCS])
def test_longitude_range_is_geographiclib_s(name, func):
    """[-540, 540) is accepted (GeographicLib's DMS::DecodeLatLon range) and wraps by 360 deg."""
    lat = np.array([10.0, -35.0, 60.0])
    a = func(lat, np.array([-540.0, 400.0, 539.5]), 20e3)
    b = func(lat, np.array([-180.0, 40.0, 179.5]), 20e3)
    # the same ECEF points up to the rounding of cos/sin of the larger angles
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-10 * np.max(np.abs(b)))


def test_highest_height_is_finite_and_near_point_mass():
    """At h = MAX_HEIGHT = 1e8 m the field is finite and ≈ GM/r² (J2 (a/r)² ~ 4e-6 relative)."""
    assert GR.MAX_HEIGHT == N.MAX_HEIGHT == 1e8
    r = WGS84.a + 1e8  # on the equator, geodetic height = distance - a
    for g in (
        GR.gravitation(0.0, 0.0, 1e8, lmax=LMAX, device="cpu"),
        N.normal_gravity(0.0, 0.0, 1e8, centrifugal=False, device="cpu"),
    ):
        assert np.all(np.isfinite(g))
        np.testing.assert_allclose(np.linalg.norm(g), WGS84.GM / r**2, rtol=1e-5)
    d = GR.disturbance(0.0, 0.0, 1e8, lmax=LMAX, device="cpu")
    assert np.all(np.isfinite(d)) and np.linalg.norm(d) < 1.0  # mGal, far above the masses


@pytest.mark.parametrize(
    "xyz, msg",
    [
        ((1e300, 0.0, 0.0), r"more than 1e\+08 m above the ellipsoid"),
        ((1e200, 1e200, 0.0), r"more than 1e\+08 m above the ellipsoid"),
        ((0.0, 0.0, WGS84.b + 1.01e8), r"more than 1e\+08 m above the ellipsoid"),
        ((7e7, 7e7, 7e7), r"more than 1e\+08 m above the ellipsoid"),
        (([7e6, 7e6], [0.0, 0.0, 0.0], 0.0), r"shapes \(2,\), \(3,\), \(\) do not broadcast"),
        ((0.0, 0.0, 0.0), "below the ellipsoid"),
    ],
)
def test_bad_ecef_points_raise(xyz, msg):
    with pytest.raises(InputError, match=msg) as info:
        N.normal_gravitation_ecef(*xyz, device="cpu")
    _one_line(info)


def test_ecef_far_point_is_finite():
    """Just inside the limit: finite and equal to the geodetic call at the same point."""
    g = N.normal_gravitation_ecef(0.0, 0.0, WGS84.b + 0.99e8, device="cpu")
    ref = N.normal_gravity(90.0, 0.0, 0.99e8, centrifugal=False, frame="ecef", device="cpu")
    np.testing.assert_allclose(g, ref, rtol=1e-12, atol=1e-12 * np.linalg.norm(ref))

"""Public gravity API (fieldmap.field.gravity).

Disturbance bookkeeping, centrifugal term, frames, units, input errors.
"""

import numpy as np
import pytest

from fieldmap.errors import FieldmapError, InputError
from fieldmap.field import gravity
from fieldmap.field.ellipsoid import GRS80, WGS84
from fieldmap.models.shmodel import SHModel
from fieldmap.reference.normal import zonal_sh_model


def points(n=25, seed=0):
    """Random geodetic points 0..100 km plus both poles and the equator."""
    rng = np.random.default_rng(seed)
    lat = np.r_[np.degrees(np.arcsin(rng.uniform(-1, 1, n))), 90.0, -90.0, 0.0]
    lon = np.r_[rng.uniform(-180, 180, n), 0.0, 45.0, 0.0]
    h = np.r_[rng.uniform(0.0, 1e5, n), 0.0, 2e4, 1e5]
    return lat, lon, h


@pytest.mark.parametrize("ell", [WGS84, GRS80], ids=["WGS84", "GRS80"])
def test_disturbance_of_normal_field_vanishes(device, ell):
    """The ellipsoid's own field as an SH model has δg = 0, whatever its GM and radius.

    The coefficients are rescaled to other constants, so each field must use its own.
    """
    lat, lon, h = points()
    for gm, radius in [(None, None), (3.986004415e14, 6378136.3), (3.9860046e14, 6.4e6)]:
        model = zonal_sh_model(ell, 12, gm, radius)
        dg = gravity.disturbance(lat, lon, h, model=model, ellipsoid=ell, device=device)
        assert np.max(np.abs(dg)) < 2e-7  # mGal; 1e-13 of g is 1e-7 mGal


def test_disturbance_degree0_term(device):
    """Model GM ≠ ellipsoid GM, same normalised coefficients: δg = (GM_m/GM_e − 1) γ.

    The model field is (GM_m/GM_e) × the normal gravitation, so the degree-0 part stays.
    """
    lat, lon, h = points(seed=1)
    base = zonal_sh_model(WGS84)
    gm_m = 3.986004415e14  # EIGEN-6S earth_gravity_constant
    model = SHModel("gm", gm_m, base.radius, base.C, base.S, base.lmax)
    dg = gravity.disturbance(lat, lon, h, model=model, units="m/s2", frame="ecef", device=device)
    from fieldmap.field.normal import normal_gravity

    gam = normal_gravity(
        lat, lon, h, normal="exact", centrifugal=False, frame="ecef", device=device
    )
    expect = (gm_m / WGS84.GM - 1.0) * gam
    np.testing.assert_allclose(dg, expect, rtol=0, atol=1e-13 * 9.8)
    up = gravity.disturbance(lat, lon, h, model=model, units="mGal", device=device)[:, 2]
    assert np.all(up > 6e-4) and np.all(up < 8e-4)  # (GM_e − GM_m)/r² ≈ 0.0007 mGal


def test_gravity_minus_gravitation_is_centrifugal(device):
    """Closed form in ENU: ω² p (0, −sin φ, cos φ), p = (N + h) cos φ (Groves 2013 eq. 3.7.5)."""
    from fieldmap.models.registry import load_model

    model = load_model("eigen-6s", lmax=30)
    lat, lon, h = points(seed=2)
    g = gravity.gravity(lat, lon, h, model=model, device=device)
    gv = gravity.gravitation(lat, lon, h, model=model, device=device)
    phi = np.radians(lat)
    N = WGS84.a / np.sqrt(1 - WGS84.e2 * np.sin(phi) ** 2)
    p = (N + h) * np.cos(phi)
    cf = WGS84.omega**2 * p[:, None] * np.stack([0 * phi, -np.sin(phi), np.cos(phi)], axis=-1)
    # g − gv cancels two ~9.8 m/s² values: a few ulp of 9.8 is the floor
    np.testing.assert_allclose(g - gv, cf, rtol=0, atol=4 * np.spacing(9.8))


def test_frames_and_units(device):
    """NED is a reordering of ENU, ENU rotates back to ECEF, unit factors are exact."""
    from fieldmap.models.registry import load_model

    model = load_model("eigen-6s", lmax=60)
    lat, lon, h = points(seed=3)
    enu = gravity.disturbance(lat, lon, h, model=model, device=device)
    ned = gravity.disturbance(lat, lon, h, model=model, frame="ned", device=device)
    ecef = gravity.disturbance(lat, lon, h, model=model, frame="ecef", device=device)
    np.testing.assert_array_equal(ned, np.stack([enu[:, 1], enu[:, 0], -enu[:, 2]], axis=-1))
    # ENU basis written out here (rows east, north, up in ECEF)
    p, lam = np.radians(lat), np.radians(lon)
    east = np.stack([-np.sin(lam), np.cos(lam), 0 * lam], axis=-1)
    north = np.stack([-np.sin(p) * np.cos(lam), -np.sin(p) * np.sin(lam), np.cos(p)], axis=-1)
    up = np.stack([np.cos(p) * np.cos(lam), np.cos(p) * np.sin(lam), np.sin(p)], axis=-1)
    back = enu[:, :1] * east + enu[:, 1:2] * north + enu[:, 2:] * up
    # a rotation of the same numbers: rounding only (1.4e-16 of max|δg| measured)
    np.testing.assert_allclose(back, ecef, rtol=0, atol=1e-14 * np.max(np.abs(ecef)))
    kw = dict(model=model, frame="ecef", device=device)
    ms2 = gravity.disturbance(lat, lon, h, units="m/s2", **kw)
    np.testing.assert_allclose(ecef, ms2 * 1e5, rtol=1e-15)  # 1 mGal = 1e-5 m/s²
    mg = gravity.disturbance(lat, lon, h, units="mg", **kw)
    np.testing.assert_allclose(mg, ms2 / 9.80665e-3, rtol=1e-15)  # 1 mg = 9.80665e-3 m/s²


def test_eigen6s_plausible(device):
    """Bundled EIGEN-6S at h = 0: |g| within 9.76..9.84 m/s², |δg| below 1000 mGal.

    The Earth's largest gravity anomalies are a few hundred mGal.
    """
    lat, lon, _ = points(200, seed=4)
    h = np.zeros_like(lat)
    g = gravity.gravity(lat, lon, h, device=device)
    mag = np.linalg.norm(g, axis=-1)
    assert np.all((mag > 9.76) & (mag < 9.84))
    assert np.all(g[:, 2] < 0)
    dg = gravity.disturbance(lat, lon, h, device=device)
    assert np.max(np.linalg.norm(dg, axis=-1)) < 1000.0
    assert 5.0 < np.sqrt(np.mean(dg[:, 2] ** 2)) < 100.0


def test_shapes_and_truncation():
    """Inputs broadcast, lmax equals an explicit truncation, empty input gives empty output."""
    from fieldmap.models.registry import load_model

    model = load_model("eigen-6s")
    assert gravity.disturbance(10.0, 20.0, 0.0, model=model.truncated(10)).shape == (3,)
    lat = np.array([[0.0, 10.0, 20.0], [30.0, 40.0, 50.0]])
    out = gravity.gravitation(lat, 5.0, 1e3, model=model.truncated(10))
    assert out.shape == (2, 3, 3)
    a = gravity.gravitation(lat, 5.0, 1e3, model=load_model("eigen-6s", lmax=10))
    np.testing.assert_array_equal(out, a)
    assert gravity.disturbance([], [], [], model=model).shape == (0, 3)


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(lat=90.5),
        dict(lat=np.nan),
        dict(lon=np.inf),
        dict(h=-2e4),
        dict(h="x"),
        dict(frame="xyz"),
        dict(units="gal"),
        dict(model="no-such-model"),
        dict(ellipsoid="bessel"),
    ],
)
def test_bad_input(kwargs):
    """Each bad argument raises InputError (a FieldmapError)."""
    args = dict(lat=10.0, lon=20.0, h=0.0)
    for k in ("lat", "lon", "h"):
        if k in kwargs:
            args[k] = kwargs.pop(k)
    with pytest.raises(InputError):
        gravity.disturbance(args["lat"], args["lon"], args["h"], **kwargs)
    assert issubclass(InputError, FieldmapError)

"""Geodesist's quantities T, Δg, ξ, η, N vs GeographicLib, closed forms, finite differences."""

from __future__ import annotations

import numpy as np
import pytest

from fieldmap.errors import InputError
from fieldmap.field import geodesy as gd
from fieldmap.field.ellipsoid import WGS84
from fieldmap.field.frames import ecef_to_geodetic, geodetic_to_ecef
from fieldmap.models.geographiclib import gravity_tool, run_gravity_tool, write_egm
from fieldmap.models.registry import load_model
from fieldmap.models.shmodel import SHModel
from fieldmap.reference import normal as ref_normal
from fieldmap.reference import sh as ref_sh

needs_tool = pytest.mark.skipif(
    gravity_tool() is None, reason="GeographicLib's Gravity (geographiclib-tools) missing"
)


def _points(n, seed, hmax=100e3):
    """Uniform on the sphere, h 0..hmax, plus the poles and ±89.99°."""
    rng = np.random.default_rng(seed)
    lat = np.degrees(np.arcsin(rng.uniform(-1, 1, n)))
    lon = rng.uniform(-180, 180, n)
    h = rng.uniform(0.0, hmax, n)
    lat[:5] = [90.0, -90.0, 89.99, -89.99, 0.0]
    return lat, lon, h


@pytest.fixture(scope="module")
def eigen6s():
    """Return the bundled model."""
    return load_model("eigen-6s")


@needs_tool
def test_anomaly_and_geoid_vs_gravity_tool(tmp_path, eigen6s):
    """Gravity -A and -H on 300 random points, EIGEN-6S to degree 240 (bundled).

    Measured: 9e-12 mGal, 3e-12 arcsec, 3e-12 m (float64 rounding of the tool's and our sums).
    """
    name = write_egm(eigen6s, tmp_path)
    lat, lon, h = _points(300, seed=5)
    tool_a = run_gravity_tool(np.c_[lat, lon, h], tmp_path, name, "anomaly", precision=12)
    ours = gd.gravity_anomaly(lat, lon, h, model=eigen6s)
    assert np.abs(tool_a).max(axis=0).min() > 10.0  # real signals: > 10 mGal, > 10 arcsec
    np.testing.assert_allclose(ours.anomaly_mgal, tool_a[:, 0], rtol=0, atol=1e-6)  # mGal
    np.testing.assert_allclose(ours.xi_arcsec, tool_a[:, 1], rtol=0, atol=1e-6)
    np.testing.assert_allclose(ours.eta_arcsec, tool_a[:, 2], rtol=0, atol=1e-6)  # arcsec
    tool_n = run_gravity_tool(np.c_[lat, lon, 0 * h], tmp_path, name, "geoid", precision=12)
    n = gd.geoid_height(lat, lon, model=eigen6s)
    assert np.abs(tool_n).max() > 50.0
    np.testing.assert_allclose(n, tool_n[:, 0], rtol=0, atol=1e-6)  # m


def test_t_is_model_minus_ellipsoid_potential(eigen6s):
    """T(degree0) = V_model − U_ellipsoid from the NumPy references (series vs closed form).

    V by the independent NumPy summation, U by the closed form in ellipsoidal coordinates
    (H&M eqs. 2-61, 2-62); their difference cancels 6e7 m²/s² to ~500, so 1e-7 m²/s² is
    float64 rounding. Without degree 0, T differs by exactly (GM − GM_e)/r.
    """
    m = eigen6s.truncated(60)
    lat, lon, h = _points(40, seed=8)
    x, y, z = geodetic_to_ecef(lat, lon, h)
    expect = ref_sh.potential(m, x, y, z) - ref_normal.exact_potential(x, y, z, WGS84)
    t0 = gd.disturbing_potential(lat, lon, h, model=m, degree0=True)
    assert np.abs(expect).max() > 100.0
    np.testing.assert_allclose(t0, expect, rtol=0, atol=1e-7)
    t = gd.disturbing_potential(lat, lon, h, model=m)
    r = np.sqrt(x * x + y * y + z * z)
    np.testing.assert_allclose(t0 - t, (m.gm - WGS84.GM) / r, rtol=1e-9, atol=0)


def test_point_mass_closed_forms():
    """A point mass with WGS84's GM: T = GM/r − U (closed form), Δg, ξ, η from its gradient.

    The model has no zonal terms, so T is minus the ellipsoid's whole zonal series; the closed
    forms are the level ellipsoid's potential and gravitation in ellipsoidal coordinates.
    """
    pm = SHModel("point mass", WGS84.GM, 6378137.0, np.ones((1, 1)), np.zeros((1, 1)), 0)
    lat, lon, h = _points(50, seed=9, hmax=1e6)
    x, y, z = geodetic_to_ecef(lat, lon, h)
    rv = np.stack([x, y, z], axis=-1)
    r = np.linalg.norm(rv, axis=-1)
    t_cf = WGS84.GM / r - ref_normal.exact_potential(x, y, z, WGS84)
    g_cf = -WGS84.GM * rv / r[:, None] ** 3 - ref_normal.exact_gravitation_ecef(x, y, z, WGS84)
    t = gd.disturbing_potential(lat, lon, h, model=pm)
    np.testing.assert_allclose(t, t_cf, rtol=0, atol=2e-8)  # |T| up to 7e4 m²/s²
    up = rv / r[:, None]
    lam = np.radians(lon)
    east = np.stack([-np.sin(lam), np.cos(lam), 0 * lam], axis=-1)
    north = np.cross(up, east)
    gam = np.linalg.norm(
        ref_normal.exact_gravitation_ecef(x, y, z, WGS84)
        + WGS84.omega**2 * np.stack([x, y, 0 * z], axis=-1),
        axis=-1,
    )
    dg_cf = (-np.sum(g_cf * up, -1) - 2 * t_cf / r) * 1e5
    xi_cf = -np.sum(g_cf * north, -1) / gam * gd.ARCSEC_PER_RAD
    eta_cf = -np.sum(g_cf * east, -1) / gam * gd.ARCSEC_PER_RAD
    a = gd.gravity_anomaly(lat, lon, h, model=pm)
    assert np.abs(dg_cf).max() > 1e3 and np.abs(xi_cf).max() > 100.0
    np.testing.assert_allclose(a.anomaly_mgal, dg_cf, rtol=0, atol=1e-6)
    np.testing.assert_allclose(a.xi_arcsec, xi_cf, rtol=0, atol=1e-8)
    np.testing.assert_allclose(a.eta_arcsec, eta_cf, rtol=0, atol=1e-8)
    # geoid: T on the ellipsoid over Somigliana's gamma, both closed forms
    lat0 = lat
    x0, y0, z0 = geodetic_to_ecef(lat0, lon, 0 * lat0)
    r0 = np.sqrt(x0**2 + y0**2 + z0**2)
    t_surf = WGS84.GM / r0 - ref_normal.exact_potential(x0, y0, z0, WGS84)
    phi = np.radians(lat0)
    c2, s2 = np.cos(phi) ** 2, np.sin(phi) ** 2
    somi = (WGS84.a * WGS84.gamma_a * c2 + WGS84.b * WGS84.gamma_b * s2) / np.sqrt(
        WGS84.a**2 * c2 + WGS84.b**2 * s2
    )
    np.testing.assert_allclose(gd.geoid_height(lat0, lon, model=pm), t_surf / somi, atol=2e-9)


def test_anomaly_vs_finite_differences_of_t(eigen6s):
    """Δg, ξ, η from central differences of T along the geocentric up, north, east directions.

    Steps of ±5 m (straight lines in ECEF): the O(d²) error is < 1e-12 m/s² at degree 240 and
    the rounding of T (1e-13 m²/s², T is summed directly, not as V − U) gives 1e-14 m/s².
    """
    lat, lon, h = _points(30, seed=12)
    lat[:2] = [60.0, -45.0]  # poles: the frame depends on the longitude, tested above
    x, y, z = geodetic_to_ecef(lat, lon, h)
    rv = np.stack([x, y, z], axis=-1)
    r = np.linalg.norm(rv, axis=-1)
    up = rv / r[:, None]
    lam = np.radians(lon)
    east = np.stack([-np.sin(lam), np.cos(lam), 0 * lam], axis=-1)
    north = np.cross(up, east)
    d = 5.0

    def t_at(p):
        la, lo, hh = ecef_to_geodetic(p[:, 0], p[:, 1], p[:, 2])
        return gd.disturbing_potential(la, lo, hh, model=eigen6s)

    t = gd.disturbing_potential(lat, lon, h, model=eigen6s)
    deriv = {
        k: (t_at(rv + d * e) - t_at(rv - d * e)) / (2 * d)
        for k, e in (("up", up), ("north", north), ("east", east))
    }
    gam = np.linalg.norm(
        ref_normal.exact_gravitation_ecef(x, y, z, WGS84)
        + WGS84.omega**2 * np.stack([x, y, 0 * z], axis=-1),
        axis=-1,
    )
    a = gd.gravity_anomaly(lat, lon, h, model=eigen6s)
    np.testing.assert_allclose(a.anomaly_mgal, (-deriv["up"] - 2 * t / r) * 1e5, rtol=0, atol=1e-6)
    np.testing.assert_allclose(
        a.xi_arcsec, -deriv["north"] / gam * gd.ARCSEC_PER_RAD, rtol=0, atol=1e-6
    )
    np.testing.assert_allclose(
        a.eta_arcsec, -deriv["east"] / gam * gd.ARCSEC_PER_RAD, rtol=0, atol=1e-6
    )


def test_normal_series_not_truncated_with_the_model(eigen6s):
    """A degree-2 truncation still subtracts the whole normal field (closed form, not J2 only).

    (GeographicLib truncates the normal series with the model; with ``-N 2`` its T lacks the
    ellipsoid's J4, about 70 m²/s².)
    """
    m2 = eigen6s.truncated(2)
    dm = gd.disturbing_model(m2)
    assert dm.lmax == gd.NORMAL_DEGREE and dm.C[4, 0] != 0.0 and dm.C[0, 0] == 0.0
    lat, lon, h = _points(20, seed=4)
    x, y, z = geodetic_to_ecef(lat, lon, h)
    r = np.sqrt(x * x + y * y + z * z)
    expect = (
        ref_sh.potential(m2, x, y, z)
        - ref_normal.exact_potential(x, y, z, WGS84)
        - (m2.gm - WGS84.GM) / r
    )
    assert np.abs(expect).max() > 50.0
    t = gd.disturbing_potential(lat, lon, h, model=m2)
    np.testing.assert_allclose(t, expect, rtol=0, atol=1e-7)


def test_bad_input(eigen6s):
    """Impossible coordinates and degrees are InputErrors."""
    with pytest.raises(InputError, match="latitude"):
        gd.gravity_anomaly([91.0], [0.0], [0.0], model=eigen6s)
    with pytest.raises(InputError):
        gd.geoid_height([np.nan], [0.0], model=eigen6s)
    with pytest.raises(InputError, match="lmax"):
        gd.geoid_height([0.0], [0.0], model=eigen6s, lmax=241)


def _cli(args, stdin):
    import os
    import subprocess
    import sys

    return subprocess.run(
        [sys.executable, "-m", "fieldmap", *args],
        input=stdin,
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ},
    )


def test_cli_point_quantities(eigen6s):
    """``fieldmap point --quantity anomaly|geoid|potential`` prints the API's numbers.

    A geoid line with h ≠ 0 is a bad line (as ``Gravity -H``), the others are still printed.
    """
    pts = np.array([[45.0, 10.0, 1000.0], [-89.99, 170.0, 0.0], [0.0, -75.5, 20e3]])
    text = "".join(f"{a!r} {b!r} {c!r}\n" for a, b, c in pts.tolist())
    lat, lon, h = pts.T
    out = _cli(["point", "--quantity", "anomaly", "--precision", "10"], text)
    assert out.returncode == 0, out.stderr
    got = np.array([[float(v) for v in ln.split()] for ln in out.stdout.splitlines()])
    np.testing.assert_allclose(
        got, np.stack(gd.gravity_anomaly(lat, lon, h), axis=-1), rtol=0, atol=1e-9
    )
    out = _cli(["point", "--quantity", "potential", "--precision", "10"], text)
    got = np.array([float(v) for v in out.stdout.split()])
    np.testing.assert_allclose(got, gd.disturbing_potential(lat, lon, h), rtol=0, atol=1e-9)
    out = _cli(["point", "--quantity", "geoid", "--precision", "10"], text)
    lines = out.stdout.splitlines()
    assert out.returncode == 1 and lines[0].startswith("ERROR:") and "h must be 0" in lines[2]
    expect = gd.geoid_height(lat[1], lon[1])
    assert float(lines[1]) == pytest.approx(float(expect), abs=1e-9)


# --------------------------------------------------------------------------------------------
# grids


def _devices():
    import warp as wp

    from fieldmap import _warp

    _warp.init()
    return [str(d) for d in wp.get_devices()]


@pytest.mark.parametrize("device", _devices())
@pytest.mark.parametrize("legendre", ["auto", "column"])
def test_grid_potential_vs_numpy_reference(eigen6s, device, legendre):
    """Potential from the grid kernel vs the NumPy reference summation at every node.

    Degree 60, two heights, regular and irregular longitudes (FFT and direct sums), ±89.5°.
    Relative to |V| ≈ 6e7 m²/s²: 1e-15 measured; the gradient is unchanged by the extra component.
    """
    from fieldmap.grids.spec import GridSpec
    from fieldmap.grids.synthesis import synthesize

    m = eigen6s.truncated(60)
    lat = np.array([-89.5, -41.0, -7.5, 0.0, 7.5, 41.0, 89.5])
    for lon in (np.arange(-180.0, 180.0, 20.0), np.array([-170.0, -3.3, 0.0, 12.7, 95.0])):
        grid = GridSpec(lat=lat, lon=lon, heights=np.array([0.0, 3.0e4]), step_deg=1.0)
        out = synthesize(
            m, grid, quantity="gravitation", device=device, legendre=legendre, potential=True
        )
        plain = synthesize(m, grid, quantity="gravitation", device=device, legendre=legendre)
        # the FFT pairs other series when there are four; V/r is of the size of g, so the
        # pairing changes g by rounding only (3.5e-18 m/s² measured)
        np.testing.assert_allclose(out[..., :3], plain, rtol=0, atol=1e-15)
        H, LA, LO = np.meshgrid(grid.heights, lat, lon, indexing="ij")
        x, y, z = geodetic_to_ecef(LA, LO, H)
        ref = ref_sh.potential(m, x.ravel(), y.ravel(), z.ravel()).reshape(H.shape)
        np.testing.assert_allclose(out[..., 3], ref, rtol=5e-15, atol=0)


@pytest.mark.parametrize("device", _devices())
def test_grid_quantities_vs_points(eigen6s, device):
    """T, Δg, ξ, η, N on a grid equal the point functions at the nodes.

    Measured: 3e-12 m²/s², 4e-12 mGal, 1.3e-12 arcsec, 3e-13 m (summation order).
    """
    from fieldmap.grids.spec import GridSpec

    lat = np.array([-89.0, -30.0, 0.0, 30.0, 60.0, 89.0])
    lon = np.arange(-180.0, 180.0, 30.0)
    grid = GridSpec(lat=lat, lon=lon, heights=np.array([0.0, 2.0e4]), step_deg=30.0)
    H, LA, LO = np.meshgrid(grid.heights, lat, lon, indexing="ij")
    t = gd.grid_quantities(eigen6s, grid, "potential", device=device)["potential"]
    pt = gd.disturbing_potential(LA, LO, H, model=eigen6s, device=device)
    np.testing.assert_allclose(t, pt, rtol=0, atol=1e-9)
    a = gd.gravity_anomaly(LA, LO, H, model=eigen6s, device=device)
    dg = gd.grid_quantities(eigen6s, grid, "anomaly", device=device)["anomaly"]
    np.testing.assert_allclose(dg, a.anomaly_mgal, rtol=0, atol=1e-9)
    de = gd.grid_quantities(eigen6s, grid, "deflection", device=device)
    np.testing.assert_allclose(de["xi"], a.xi_arcsec, rtol=0, atol=1e-9)
    np.testing.assert_allclose(de["eta"], a.eta_arcsec, rtol=0, atol=1e-9)
    n = gd.grid_quantities(eigen6s, grid, "geoid", device=device)["geoid"]
    assert n.shape == (1, lat.size, lon.size)
    np.testing.assert_allclose(n[0], gd.geoid_height(LA[0], LO[0], model=eigen6s), atol=1e-9)


# --------------------------------------------------------------------------------------------
# maps


def test_quantity_map_dataset(eigen6s):
    """quantity_map: CF attributes, values equal to the point functions, sweeps stack heights."""
    from fieldmap.products.maps import quantity_map
    from fieldmap.products.variables import summary

    ds = quantity_map("geoid", model=eigen6s, step_deg=30.0, height_km=20.0)
    assert ds.attrs["Conventions"] == "CF-1.8" and ds.attrs["quantity"] == "geoid"
    v = ds["geoid"]
    assert v.attrs["units"] == "m"
    assert v.attrs["standard_name"] == "geoid_height_above_reference_ellipsoid"
    assert float(ds["height"].values) == 0.0  # the geoid is computed at the surface
    LA, LO = np.meshgrid(ds["latitude"].values, ds["longitude"].values, indexing="ij")
    np.testing.assert_allclose(v.values, gd.geoid_height(LA, LO, model=eigen6s), atol=1e-9)
    sw = quantity_map("deflection", model=eigen6s, step_deg=30.0, height_km=[0.0, 50.0])
    assert sw["xi"].dims == ("height", "latitude", "longitude") and sw["xi"].attrs["units"] == (
        "arcsec"
    )
    a = gd.gravity_anomaly(LA, LO, 50e3, model=eigen6s)
    np.testing.assert_allclose(sw["eta"].values[1], a.eta_arcsec, rtol=0, atol=1e-8)
    s = summary(sw)
    assert s["height_m"] == [0.0, 50e3] and s["xi"]["max"][1] == pytest.approx(
        float(sw["xi"].values[1].max()), abs=0
    )
    with pytest.raises(InputError, match="quantity"):
        quantity_map("curvature", model=eigen6s)


def test_cli_map_quantity(tmp_path, eigen6s):
    """``fieldmap map --quantity anomaly`` writes NetCDF, JSON, PNG with the API's values."""
    import json

    import xarray as xr

    out = tmp_path / "out"
    run = _cli(
        [
            "map",
            "--quantity",
            "anomaly",
            "--region",
            "100",
            "112",
            "18",
            "37",
            "--step-deg",
            "1",
            "--height-km",
            "20",
            "--out",
            str(out),
        ],
        "",
    )
    assert run.returncode == 0, run.stderr
    files = sorted(p.name for p in out.iterdir())
    assert any(f.endswith(".nc") for f in files) and any(f.endswith("_anomaly.png") for f in files)
    nc = next(out.glob("*.nc"))
    with xr.open_dataset(nc) as ds:
        LA, LO = np.meshgrid(ds["latitude"].values, ds["longitude"].values, indexing="ij")
        expect = gd.gravity_anomaly(LA, LO, 20e3, model=eigen6s).anomaly_mgal
        np.testing.assert_allclose(ds["anomaly"].values, expect, rtol=0, atol=1e-9)
        assert ds["anomaly"].attrs["units"] == "mGal"
    js = json.loads(next(out.glob("*.json")).read_text())
    assert js["product"] == "anomaly" and js["anomaly"]["max"] == pytest.approx(expect.max())
    bad = _cli(
        ["map", "--quantity", "anomaly", "--step-deg", "0", "--out", str(tmp_path / "x")], ""
    )
    assert bad.returncode == 2 and not (tmp_path / "x").exists()


def test_cli_quantity_choices_match_products():
    """The --quantity choices spelt out in cli/maps are the products' quantities."""
    from fieldmap.cli import build_parser
    from fieldmap.products.variables import QUANTITIES

    sub = build_parser()._subparsers._group_actions[0].choices
    for cmd in ("map", "sweep"):
        (act,) = [a for a in sub[cmd]._actions if a.dest == "quantity"]
        assert tuple(act.choices) == QUANTITIES


def test_gravity_anomaly_returns_one_unit_per_field(eigen6s):
    """Δg, ξ, η come as named arrays of the points' shape, one unit each."""
    lat, lon = np.array([[10.0, 20.0], [30.0, -40.0]]), np.array([[5.0, 6.0], [7.0, 8.0]])
    res = gd.gravity_anomaly(lat, lon, 0.0, model=eigen6s)
    assert isinstance(res, gd.SphericalAnomaly)
    dg, xi, eta = res
    assert dg.shape == xi.shape == eta.shape == (2, 2)
    assert res[0] is res.anomaly_mgal and res[1:] == (res.xi_arcsec, res.eta_arcsec)


def test_gravity_anomaly_units(eigen6s):
    """``units=`` as in ``disturbance``: mGal by default (same bits), mg and m/s² on request."""
    from fieldmap.units import MG, MGAL

    lat, lon, h = np.array([10.0, -45.0, 80.0]), np.array([5.0, 120.0, -60.0]), 1000.0
    ref = gd.gravity_anomaly(lat, lon, h, model=eigen6s.truncated(60))
    assert ref.units == "mGal"
    same = gd.gravity_anomaly(lat, lon, h, model=eigen6s.truncated(60), units="MGAL")
    assert same.units == "mGal"
    for got, want in zip(same, ref):
        np.testing.assert_array_equal(got, want)
    for name, size in (("mg", MG), ("m/s2", 1.0), ("m s-2", 1.0)):
        a = gd.gravity_anomaly(lat, lon, h, model=eigen6s.truncated(60), units=name)
        assert a.units == ("mg" if name == "mg" else "m/s2")
        np.testing.assert_allclose(a.anomaly, ref.anomaly * MGAL / size, rtol=1e-15, atol=0)
        np.testing.assert_allclose(a.anomaly_mgal, ref.anomaly, rtol=1e-15, atol=0)
        np.testing.assert_array_equal(a.xi_arcsec, ref.xi_arcsec)  # ξ, η stay in arcsec
        np.testing.assert_array_equal(a.eta_arcsec, ref.eta_arcsec)
        assert a._replace(xi_arcsec=a.eta_arcsec).units == a.units
    with pytest.raises(InputError, match="units must be one of"):
        gd.gravity_anomaly(lat, lon, h, model=eigen6s.truncated(60), units="gal")

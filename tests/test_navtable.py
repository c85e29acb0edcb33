"""Compensation tables in the kernels (issue 18): ``kernels/navgravity.py`` vs the NumPy paths.

The kernel interpolation is checked against :func:`fieldmap.products.tables.model.interpolate`
(the NumPy interpolator, written separately) at random points — cells next to the domain edges,
the ghost heights, a table across the antimeridian — and the navigation gravitation against the
exact normal gravitation of :mod:`fieldmap.field.normal` plus the interpolated δg rotated with
:func:`fieldmap.field.frames.C_e_to_enu` at the geodetic point of
:func:`fieldmap.field.frames.ecef_to_geodetic` (Bowring's iteration, not the kernel's).
"""

from __future__ import annotations

import numpy as np
import pytest

from fieldmap.errors import InputError
from fieldmap.field import frames
from fieldmap.field.ellipsoid import WGS84
from fieldmap.field.normal import normal_gravitation_ecef
from fieldmap.nav.gravity import table_gravitation, table_points
from fieldmap.products.tables.model import CompensationTable, interpolate


def _table(lon0=170.0, seed=4) -> CompensationTable:
    rng = np.random.default_rng(seed)
    nh, nlat, nlon = 4, 9, 12
    lat = 20.0 + 0.5 * np.arange(nlat)
    lon = lon0 + 0.75 * np.arange(nlon)
    h = 1000.0 + 4000.0 * np.arange(nh)
    H, LA, LO = np.meshgrid(h, lat, lon, indexing="ij")
    smooth = (
        np.stack(
            [
                30 * np.sin(LA / 3) * np.cos(LO / 5),
                20 * np.cos(LA / 2 + LO / 7),
                -15 * np.sin(LO / 4),
            ],
            axis=-1,
        )
        * np.exp(-H / 3e4)[..., None]
    )
    data = smooth + rng.normal(0.0, 2.0, smooth.shape)  # rough, so that every weight matters
    return CompensationTable(
        lat0=20.0, dlat=0.5, lon0=lon0, dlon=0.75, h0=1000.0, dh=4000.0, data=data
    )


def _inside(tab, n, seed=1):
    rng = np.random.default_rng(seed)
    w, e, s, nn, h0, h1 = tab.domain
    lat = rng.uniform(s, nn, n)
    lon = rng.uniform(w, e, n)
    h = rng.uniform(h0, h1, n)
    # the domain's corners and the ghost heights exactly
    lat[:4], lon[:4], h[:4] = [s, nn, s, nn], [w, e, e, w], [h0, h1, h1, h0]
    lon = np.where(lon > 180.0, lon - 360.0, lon)  # across the antimeridian, as a user gives it
    return lat, lon, h


@pytest.mark.parametrize("lon0", [170.0, -10.0])
def test_kernel_interpolation_equals_numpy(device, lon0):
    tab = _table(lon0)
    lat, lon, h = _inside(tab, 400)
    got = table_points(tab, lat, lon, h, device=device)
    want = interpolate(tab, lat, lon, h)
    assert np.abs(want).max() > 10.0
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-11)


def test_kernel_reproduces_the_nodes(device):
    tab = _table()
    H, LA, LO = np.meshgrid(tab.heights, tab.latitudes[1:-1], tab.longitudes[1:-1], indexing="ij")
    got = table_points(tab, LA, LO, H, device=device).reshape(H.shape + (3,))
    np.testing.assert_allclose(got, tab.data[:, 1:-1, 1:-1], rtol=0, atol=1e-11)


def test_navigation_gravitation_is_normal_plus_rotated_table(device):
    tab = _table()
    lat, lon, h = _inside(tab, 200, seed=2)
    x, y, z = frames.geodetic_to_ecef(lat, lon, h, WGS84)
    got = table_gravitation(tab, x, y, z, device=device)
    la, lo, hh = frames.ecef_to_geodetic(x, y, z, WGS84)
    d = interpolate(tab, la, lo, hh) * 1e-5  # north, east, down; m/s²
    enu = np.stack([d[:, 1], d[:, 0], -d[:, 2]], axis=-1)
    c = frames.C_e_to_enu(la, lo)  # rows: east, north, up in ECEF
    want = normal_gravitation_ecef(x, y, z, normal="exact", ellipsoid=WGS84) + np.einsum(
        "nij,ni->nj", c, enu
    )
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-13)  # m/s² (1e-8 mGal)


def test_points_outside_are_refused():
    tab = _table()
    with pytest.raises(InputError, match="outside the table"):
        table_points(tab, [25.0, 10.0], [175.0, 175.0], [2000.0, 2000.0])


# ------------------------------------------------------------------- navigating with a table
def _write(tmp_path, data, name="t.bin"):
    from fieldmap.products.tables.files import binary_bytes

    tab = CompensationTable(lat0=25.0, dlat=1.0, lon0=100.0, dlon=1.0, h0=0.0, dh=2000.0, data=data)
    path = tmp_path / name
    path.write_bytes(binary_bytes(tab))
    return f"table:{path}"


def _motion(n=2, ns=400, dt=0.005):
    rng = np.random.default_rng(7)
    dth = rng.normal(0, 0.01, (1, ns, 3)) * dt
    dv = (rng.normal(0, 0.5, (1, ns, 3)) + [0.0, 0.0, -9.79]) * dt
    return dth, dv, dt


def test_a_zero_table_navigates_as_the_exact_normal_field(tmp_path, device):
    from fieldmap.nav.mechanize import LciStart, NavConfig, NedStart, propagate_lci, propagate_ned

    name = _write(tmp_path, np.zeros((3, 10, 10, 3)))
    dth, dv, dt = _motion()
    ned = propagate_ned(
        dth,
        dv,
        dt,
        NedStart(30.0, 105.0, 1500.0, [100.0, 20.0, 0.0], [1.0, 0, 0, 0]),
        NavConfig(["exact", name], imu_set=[0, 0], output_every=40),
        device=device,
    )
    for key in ("lat", "lon", "h", "v_ned"):
        np.testing.assert_array_equal(getattr(ned, key)[0], getattr(ned, key)[1])
    from fieldmap.nav.frames import LaunchFrame

    frame = LaunchFrame(105.0, 30.0, 0.0, h0=1500.0)
    lci = propagate_lci(
        dth,
        dv,
        dt,
        LciStart(np.zeros(3), [100.0, 0.0, 20.0], [1.0, 0, 0, 0], frame),
        NavConfig(["exact", name], imu_set=[0, 0], output_every=20),
        device=device,
    )
    np.testing.assert_array_equal(lci.P[0], lci.P[1])


def test_a_constant_down_table_adds_half_a_t_squared(tmp_path, device):
    from fieldmap.nav.mechanize import NavConfig, NedStart, propagate_ned

    data = np.zeros((3, 10, 10, 3))
    data[..., 2] = 100.0  # δg down, mGal: 1e-3 m/s² more gravity
    name = _write(tmp_path, data)
    dth, dv, dt = _motion(ns=2000)
    ned = propagate_ned(
        dth,
        dv,
        dt,
        NedStart(30.0, 105.0, 1500.0, [50.0, 20.0, 0.0], [1.0, 0, 0, 0]),
        NavConfig(["exact", name], imu_set=[0, 0], output_every=2000),
        device=device,
    )
    t = 2000 * dt
    dh = ned.h[1, -1] - ned.h[0, -1]
    assert dh == pytest.approx(-0.5 * 1e-3 * t * t, rel=2e-3)


def test_two_tables_in_one_launch_are_refused(tmp_path):
    from fieldmap.nav.mechanize import NavConfig, NedStart, propagate_ned

    a = _write(tmp_path, np.zeros((3, 10, 10, 3)), "a.bin")
    b = _write(tmp_path, np.zeros((3, 10, 10, 3)), "b.bin")
    dth, dv, dt = _motion()
    with pytest.raises(InputError, match="one compensation table per launch"):
        propagate_ned(
            dth,
            dv,
            dt,
            NedStart(30.0, 105.0, 1500.0, [50.0, 0, 0], [1.0, 0, 0, 0]),
            NavConfig([a, b], imu_set=[0, 0]),
        )


# ------------------------------------------------------------------------ flight studies
ROUTE = "45,7,3000;45.3,7.4,5000;45.1,7.9,5000"


@pytest.fixture(scope="module")
def table60(tmp_path_factory):
    from fieldmap.models.registry import load_model
    from fieldmap.products.tables.build import build_table
    from fieldmap.products.tables.files import binary_bytes

    m60 = load_model("eigen-6s", lmax=60)
    tab, rep = build_table((6.8, 8.1, 44.8, 45.5), (2.5, 5.5), 0.5, model=m60)
    path = tmp_path_factory.mktemp("tab") / "t60.bin"
    path.write_bytes(binary_bytes(tab))
    return f"table:{path}", rep


def test_flight_with_a_table_stays_within_the_double_integral_of_its_bound(table60):
    """A table verified to ε adds at most ½ ε t² of horizontal error (truth = the table's model)."""
    from fieldmap.nav.study import FlightStudy, run_flight
    from fieldmap.nav.trajectory import FlightTrajectory, route_flight

    name, rep = table60
    ft = FlightTrajectory(route_flight(ROUTE, 200.0))
    t = 240.0
    res = run_flight(
        FlightStudy(
            ft, models=["j4", name, "sh60"], duration=t, rate_hz=100.0, truth_lmax=60, output_dt=2.0
        ),
        device="cpu",
    )
    m = res.summary["models"]
    eps = 0.5e-5  # 0.5 mGal in m/s²
    assert m[name]["added_horizontal_error_m"] <= 0.5 * eps * t * t
    assert m[name]["added_horizontal_error_m"] < 0.1 * m["j4"]["added_horizontal_error_m"]
    # the table's δg error along the track is its interpolation error (same model as the truth)
    dg = np.abs(res.dg[name]).max() * 1e5
    assert dg <= 0.5 + 1e-3, dg


def test_table_order_and_a_flight_outside_the_table(table60):
    from fieldmap.nav.budget import simplicity_order
    from fieldmap.nav.study import FlightStudy, run_flight
    from fieldmap.nav.trajectory import FlightTrajectory, route_flight

    name, _ = table60
    assert simplicity_order(["sh60", name, "exact", "j2"]) == ["j2", "exact", name, "sh60"]
    far = FlightTrajectory(route_flight("46,7,3000;46.3,7.4,5000", 200.0))
    with pytest.raises(InputError, match="does not cover the flight"):
        run_flight(
            FlightStudy(far, models=["j4", name], duration=60.0, truth_lmax=60), device="cpu"
        )


def test_auto_models_are_the_normal_ones_and_a_degree_ladder():
    from fieldmap.models.registry import load_model
    from fieldmap.nav.study import check_model_names

    model = load_model("eigen-6s", lmax=100)
    got = check_model_names(["auto", "sh24"], model)
    assert got == ["j2", "j4", "j6", "exact", "sh12", "sh24", "sh36", "sh72", "sh100"]

"""Bad input to the core Python API: points, grids, map products, launch frames, thresholds.

Every bad argument raises :class:`fieldmap.errors.InputError` (a ``FieldmapError``) with a
one-line message naming the problem, never a raw NumPy error or a silent NaN. Boundary values
just inside the accepted ranges still give finite, physically right results.
"""

from __future__ import annotations

import numpy as np
import pytest

from fieldmap.errors import FieldmapError, InputError
from fieldmap.field import gravity as GR
from fieldmap.field import normal as N
from fieldmap.field.ellipsoid import WGS84
from fieldmap.grids import spec as gridspec
from fieldmap.grids import synthesis as G
from fieldmap.nav.launch_frames import LaunchFrame
from fieldmap.products import maps, stats

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


# ----------------------------------------------------------------------------- grids
@pytest.mark.parametrize(
    "kwargs, msg",
    [
        ({"heights_m": [20e3, 1e300]}, r"height 1e\+300 m is above 1e\+08 m"),
        ({"heights_m": [1.0000001e8]}, r"is above 1e\+08 m"),
        ({"heights_m": ["x"]}, "heights must be numbers"),
        ({"region": (10, 10, 0, 10)}, "empty region: .* has no area"),
        ({"region": (0, 10, 10, 10)}, "empty region: .* has no area"),
        ({"region": (170, -190, 0, 10)}, "empty region: .* has no area"),
        ({"lat_max": 0}, "latitude limit 0 gives a grid with no area"),
        ({"lat_max": 0.4}, r"larger than the region: .* 1 latitude\(s\) x 360"),
        ({"step_deg": 5, "region": (0, 1, 0, 1)}, r"1 latitude\(s\) x 1 longitude\(s\)"),
        ({"step_deg": 5, "region": (0, 10, 0, 1)}, r"1 latitude\(s\) x 3 longitude\(s\)"),
        ({"lat_max": "x"}, "latitude limit must be a number"),
        ({"region": 5}, "west east south north"),
        ({"region": (0, "x", 0, 1)}, "region bound must be a number"),
    ],
)
def test_bad_grids_raise(kwargs, msg):
    with pytest.raises(InputError, match=msg) as info:
        G.make_grid(**kwargs)
    _one_line(info)


def test_highest_grid_height_accepted():
    assert G.make_grid(30.0, heights_m=[-1000.0, 1e8]).heights.tolist() == [-1000.0, 1e8]


def test_grid_refused_by_the_memory_its_result_needs(monkeypatch):
    """96 B per node and height against half the physical memory; the message states sizes."""
    monkeypatch.setattr(gridspec, "_memory_bytes", lambda: 8 * 2**30)
    # 1 deg: 161 x 360 nodes x 2 heights x 96 B = 11 MB, fine
    assert G.make_grid(1.0, heights_m=[20e3, 30e3]).shape == (2, 161, 360)
    # 0.03 deg: 5333 x 12000 nodes x 96 B = 5.7 GiB > 4 GiB
    with pytest.raises(InputError, match=r"5333 x 12000 nodes x 1 maps needs about 5\.7 GiB") as i:
        G.make_grid(0.03)
    assert "8 GiB" in _one_line(i)
    # the 2e9-node limit of before let through grids of ~190 GB
    monkeypatch.setattr(gridspec, "_memory_bytes", lambda: 1 * 2**30)
    with pytest.raises(InputError, match="GiB"):
        G.make_grid(0.1, heights_m=[20e3, 30e3, 50e3])
    # a truncation map holds one map per order: 1201 x 3600 nodes fit once (0.4 GiB), not 3 times
    with pytest.raises(InputError, match=r"x 3 maps needs"):
        maps.truncation_map(step_deg=0.1, orders=(2, 4, 6), lat_max=60, device="cpu")


@pytest.mark.parametrize(
    "step, lat_max, top, nrows",
    [
        (1.0, 80.0, 80.0, 161),  # the paper's grid: 2 lat_max a whole number of steps
        (30.0, 80.0, 60.0, 5),  # was -80..70: now the multiples of 30 within +-80
        (6.0, 80.0, 78.0, 27),
        (2.0, 81.0, 81.0, 82),  # +81 reachable from -81 by whole steps: kept, no equator row
        (0.3, 80.0, 79.8, 533),
        (5.0 / 60.0, 80.0, 80.0, 1921),
        (7.0, 90.0, 84.0, 25),
    ],
)
def test_global_grids_are_symmetric(step, lat_max, top, nrows):
    g = G.make_grid(step, lat_max)
    assert g.lat.size == nrows
    np.testing.assert_array_equal(g.lat, -g.lat[::-1])  # exact mirrors, for mirror_pairs
    assert abs(g.lat[-1] - top) < 1e-9 and g.lat[-1] <= lat_max
    np.testing.assert_allclose(np.diff(g.lat), step, rtol=1e-9)
    if nrows % 2:
        assert g.lat[nrows // 2] == 0.0  # the equator row is exactly 0
    pairs = G.mirror_pairs(g.lat)
    assert len(pairs) == (nrows + 1) // 2


def test_symmetric_grid_names_its_extent():
    """The file stem of the CLI is built from the region: step 30 now says latmax60, not 70."""
    g = G.make_grid(30.0, 80.0)
    assert g.region == (-180.0, 150.0, -60.0, 60.0)


# ----------------------------------------------------------------------------- map products
@pytest.mark.parametrize(
    "func, kwargs, msg",
    [
        ("disturbance_map", {"height_km": 1e300}, r"height 1e\+300 km is above 100000 km"),
        ("disturbance_map", {"height_km": 1e306}, r"height 1e\+306 km is above 100000 km"),
        ("truncation_map", {"height_km": 1e300}, r"height 1e\+300 km is above 100000 km"),
        ("component_maps", {"height_km": 1.5e5}, "is above 100000 km"),
        ("altitude_sweep", {"height_km": [20, 1e300]}, "is above 100000 km"),
        ("altitude_sweep", {"height_km": [20, 30, 20]}, "20 km is repeated"),
        ("altitude_sweep", {"height_km": [20.0, 20]}, "20 km is repeated"),
        ("truncation_map", {"orders": [2.5]}, r"among 2, 4, 6, got \[2.5\]"),
        ("truncation_map", {"orders": [2, 4.0001]}, "among 2, 4, 6"),
        ("truncation_map", {"orders": ["x"]}, "among 2, 4, 6"),
        ("truncation_map", {"orders": [4, 4.0]}, "distinct"),
        ("disturbance_map", {"thresholds_mg": [0.05, 0.1, 0.05]}, "repeated threshold"),
        ("disturbance_map", {"lat_max": 0}, "no area"),
        ("disturbance_map", {"region": (0, 10, 5, 5)}, "no area"),
    ],
)
def test_bad_map_products_raise(func, kwargs, msg):
    kwargs = {"step_deg": 30.0, "device": "cpu", **kwargs}
    if func != "truncation_map":
        kwargs["lmax"] = LMAX
    with pytest.raises(InputError, match=msg) as info:
        getattr(maps, func)(**kwargs)
    _one_line(info)


def test_truncation_orders_given_as_floats_are_whole():
    tr = maps.truncation_map(step_deg=30.0, orders=(2.0, 6), device="cpu")
    assert tr["order"].values.tolist() == [2, 6] and np.all(np.isfinite(tr.max_mg.values))


def test_truncation_at_highest_height_is_finite():
    """1e5 km was all NaN at 1e300 km; the highest accepted height gives finite, tiny errors."""
    tr = maps.truncation_map(height_km=1e5, step_deg=30.0, orders=(2,), device="cpu")
    assert np.all(np.isfinite(tr.modulus_mg.values)) and 0 < float(tr.max_mg[0]) < 1e-3
    # closed form: J2 minus exact is the J4 term of H&M eq. 2-92, U4 = −GM J4 a⁴ P4(sin φc)/r⁵,
    # |∇U4| = GM |J4| a⁴/r⁶ · |(5 P4, dP4/dφc)|; the J6 term is (a/r)² J6/J4 ~ 1e-5 of it
    # (2e-5 measured)
    from fieldmap.field import frames

    lat = tr.latitude.values
    x, y, z = frames.geodetic_to_ecef(lat, 0.0 * lat, 1e8)
    r = np.sqrt(x * x + y * y + z * z)
    s = z / r
    k = WGS84.GM * abs(WGS84.J4) * WGS84.a**4 / r**6
    radial = 5 * k * (35 * s**4 - 30 * s**2 + 3) / 8
    north = k * (140 * s**3 - 60 * s) / 8 * np.sqrt(1 - s * s)
    expect_mg = np.hypot(radial, north) / 9.80665e-3
    got = tr.modulus_mg.values[0]
    np.testing.assert_allclose(got, np.broadcast_to(expect_mg[:, None], got.shape), rtol=1e-3)


# ----------------------------------------------------------------------------- thresholds
def test_repeated_thresholds_raise():
    with pytest.raises(InputError, match=r"repeated threshold in \[0.05, 0.1, 0.05\]") as info:
        stats.parse_thresholds([0.05, 0.1, 0.05])
    _one_line(info)
    assert stats.parse_thresholds([0.1, 0.02]) == (0.02, 0.1)


def test_map_statistics_bad_arrays_raise():
    with pytest.raises(InputError, match="non-finite"):
        stats.map_statistics(np.full((2, 3), np.nan), np.array([0.0, 1.0]))
    with pytest.raises(InputError, match=r"shape \(3, 3\)"):
        stats.map_statistics(np.ones((3, 3)), np.array([0.0, 1.0]))


# ----------------------------------------------------------------------------- launch frames
@pytest.mark.parametrize(
    "kwargs, msg",
    [
        ({"B0": 91.0}, r"launch latitude B0 .* within \[-90, 90\] degrees, got 91"),
        ({"B0": -90.5}, "launch latitude B0"),
        ({"lon0": float("nan")}, "launch longitude lon0 must be a finite number"),
        ({"lon0": 540.0}, r"launch longitude lon0 .* \[-540, 540\)"),
        ({"A0": float("inf")}, "launch azimuth A0"),
        ({"h0": float("nan")}, "launch height h0"),
        ({"h0": 1e300}, "launch height h0"),
        ({"B0": "north"}, "launch latitude B0 must be a number"),
        ({"ellipsoid": "Clarke1866"}, "unknown ellipsoid"),
    ],
)
def test_bad_launch_frames_raise(kwargs, msg):
    args = {"lon0": 105.0, "B0": 25.0, "A0": 90.0, **kwargs}
    with pytest.raises(InputError, match=msg) as info:
        LaunchFrame(**args)
    _one_line(info)


def test_launch_frame_fields_normalised():
    lf = LaunchFrame(105, 90, -190, h0=0, ellipsoid="grs80")
    assert (lf.lon0, lf.B0, lf.A0, lf.h0) == (105.0, 90.0, -190.0, 0.0)
    assert lf.ellipsoid.name == "GRS80"
    C = lf.C_t_to_a
    np.testing.assert_allclose(C @ C.T, np.eye(3), rtol=0, atol=1e-15)


# ----------------------------------------------------------------------------- one vocabulary
def test_units_table_spellings():
    """One table of units, case-insensitive, with the CF/UDUNITS spellings as aliases."""
    from fieldmap.units import MG, MGAL, get_unit

    for spelling, name in [
        ("mGal", "mGal"),
        ("MGAL", "mGal"),
        ("mg", "mg"),
        ("m/s2", "m/s2"),
        ("m s-2", "m/s2"),
        ("m/s^2", "m/s2"),
        ("m/s²", "m/s2"),
        ("0.00980665 m s-2", "mg"),
    ]:
        assert get_unit(spelling).name == name, spelling
    assert get_unit("mGal").si == MGAL == 1e-5 and get_unit("mg").si == MG == 9.80665e-3
    for bad in ("gal", "mgals", "", None, 3):
        with pytest.raises(InputError, match="units must be one of mGal, mg, m/s2") as info:
            get_unit(bad)
        _one_line(info)


def test_disturbance_units_agree_across_api():
    """``units=`` spelled any accepted way gives the same numbers, at points and on maps."""
    a = GR.disturbance(30.0, 105.0, 20e3, lmax=LMAX, units="m s-2", device="cpu")
    b = GR.disturbance(30.0, 105.0, 20e3, lmax=LMAX, units="mGal", device="cpu")
    np.testing.assert_allclose(a * 1e5, b, rtol=1e-15)
    m1 = maps.disturbance_map(lmax=LMAX, step_deg=30.0, units="m/s2", device="cpu")
    m2 = maps.disturbance_map(lmax=LMAX, step_deg=30.0, units="M S-2", device="cpu")
    m3 = maps.disturbance_map(lmax=LMAX, step_deg=30.0, units="mGal", device="cpu")
    np.testing.assert_array_equal(m1["up"].values, m2["up"].values)
    np.testing.assert_allclose(m1["up"].values * 1e5, m3["up"].values, rtol=1e-14)
    assert m1["up"].attrs["units"] == "m s-2" and m3["up"].attrs["units"] == "mGal"


def test_point_functions_share_one_signature_convention():
    """latitude, longitude, height positional; everything else keyword-only and type-hinted."""
    import inspect

    import fieldmap

    for name in ("gravitation", "gravity", "disturbance", "normal_gravity"):
        params = list(inspect.signature(getattr(fieldmap, name)).parameters.values())
        assert [p.name for p in params[:3]] == ["latitude", "longitude", "height"], name
        assert all(p.kind is p.POSITIONAL_OR_KEYWORD for p in params[:3]), name
        assert all(p.kind is p.KEYWORD_ONLY for p in params[3:]), name
        assert all(p.annotation is not p.empty for p in params), name
    params = inspect.signature(fieldmap.normal_gravitation_ecef).parameters
    assert [p.kind for p in params.values()][3:] == [inspect.Parameter.KEYWORD_ONLY] * 5


def test_deprecated_spellings_still_work():
    """0.1 calls (positional options, unit=, kind=, lat_deg=...) warn and give the same result."""
    want = GR.disturbance(30.0, 105.0, 20e3, lmax=LMAX, units="mg", device="cpu")
    with pytest.warns(DeprecationWarning, match=r"disturbance\(\): pass model, lmax by keyword"):
        got = GR.disturbance(30.0, 105.0, 20e3, "eigen-6s", LMAX, units="mg", device="cpu")
    np.testing.assert_array_equal(got, want)
    with pytest.warns(DeprecationWarning, match="unit= is now units="):
        got = GR.disturbance(lat=30.0, lon=105.0, h=20e3, lmax=LMAX, unit="mg", device="cpu")
    np.testing.assert_array_equal(got, want)
    want = N.normal_gravity(30.0, 105.0, 20e3, normal="j4", ellipsoid="GRS80", frame="ned")
    with pytest.warns(DeprecationWarning, match="kind= is now normal="):
        got = N.normal_gravity(
            lat_deg=30.0, lon_deg=105.0, h_m=20e3, kind="J4", ellipsoid="GRS80", frame="ned"
        )
    np.testing.assert_array_equal(got, want)
    with pytest.warns(DeprecationWarning, match="pass ellipsoid, kind by keyword"):
        got = N.normal_gravity(30.0, 105.0, 20e3, "GRS80", "j4", frame="ned")
    np.testing.assert_array_equal(got, want)
    grid = gridspec.make_grid(30.0, heights_m=[20e3])
    with pytest.warns(DeprecationWarning, match="order= is now normal="):
        rows = G.normal_rows(grid, order=4, device="cpu")
    np.testing.assert_array_equal(rows, G.normal_rows(grid, normal="j4", device="cpu"))
    with pytest.raises(TypeError, match="takes 3 positional arguments but 11 were given"):
        GR.disturbance(0.0, 0.0, 0.0, *range(8))
    with pytest.raises(TypeError, match="got both 'unit'"):
        GR.disturbance(0.0, 0.0, 0.0, unit="mg", units="mg")


def test_one_normal_vocabulary():
    """normal= of the API, --normal of the CLI and the grid rows take the same names."""
    from fieldmap.cli.point import NORMALS

    assert NORMALS == tuple(N.NORMAL_MODELS)
    assert N.normal_model("GROVES_J2") == N.normal_model("groves-j2") == "groves-j2"
    with pytest.raises(InputError, match=r"unknown normal-gravity model 'j8' \(known: exact, j2"):
        N.normal_model("j8")
    a = N.normal_gravity(10.0, 0.0, 0.0, normal="Groves_J2", groves_j2=None, device="cpu")
    b = N.normal_gravity(10.0, 0.0, 0.0, normal="j2", device="cpu")
    np.testing.assert_allclose(a, b, rtol=1e-15)


def test_points_and_grids_share_one_height_range():
    """One rule (fieldmap.limits): -10 km .. 1e8 m for points and grids alike."""
    from fieldmap import limits

    assert GR.MIN_HEIGHT == N.MIN_HEIGHT == gridspec.MIN_HEIGHT_M == limits.MIN_HEIGHT == -10e3
    assert GR.MAX_HEIGHT == N.MAX_HEIGHT == gridspec.MAX_HEIGHT_M == limits.MAX_HEIGHT == 1e8
    gridspec.make_grid(30.0, heights_m=[-10e3])  # accepted, as a point is
    GR.gravitation(0.0, 0.0, -10e3, lmax=LMAX, device="cpu")
    msgs = set()
    for call in (
        lambda: gridspec.make_grid(30.0, heights_m=[-10001.0]),
        lambda: GR.gravitation(0.0, 0.0, -10001.0, lmax=LMAX, device="cpu"),
        lambda: N.normal_gravity(0.0, 0.0, -10001.0, device="cpu"),
    ):
        with pytest.raises(InputError) as info:
            call()
        msgs.add(_one_line(info))
    assert msgs == {
        "height -10001 m is below -10000 m: the models are not meant for points this far below "
        "the ellipsoid"
    }

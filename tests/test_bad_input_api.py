"""Bad input to the public Python API: models, points, grids, map products, navigation, verify.

Every bad argument raises a :class:`fieldmap.errors.FieldmapError` subclass (``InputError``,
``ModelFileError``) with a one-line message naming the problem, never a raw NumPy error or a silent
NaN. Boundary values just inside the accepted ranges still give finite, physically right results.
The same rules seen through the CLI are in ``test_bad_input_cli.py`` (whose model fixtures this
file shares).
"""

from __future__ import annotations

import numpy as np
import pytest
from test_bad_input_cli import ALIEN_MODELS, BAD_MODELS, work  # noqa: F401 - ``work`` is a fixture

from fieldmap.errors import FieldmapError, InputError, ModelFileError
from fieldmap.field import gravity as GR
from fieldmap.field import normal as N
from fieldmap.field.ellipsoid import WGS84
from fieldmap.grids import spec as gridspec
from fieldmap.grids import synthesis as G
from fieldmap.nav.frames import LaunchFrame
from fieldmap.products import maps
from fieldmap.products import statistics as stats

LMAX = 4  # small degree: these tests are about input checks, not the series


def _model():
    """EIGEN-6S to degree LMAX (load_model keeps it: one load)."""
    from fieldmap.models.registry import load_model

    return load_model("eigen-6s", lmax=LMAX)


def _one_line(info) -> str:
    msg = str(info.value)
    assert "\n" not in msg and isinstance(info.value, FieldmapError)
    return msg


# ----------------------------------------------------------------------------- models
def test_api_models_and_reader(work):  # noqa: F811 (fixture)
    """``load_model`` and ``read_icgem`` raise FieldmapError subclasses for bad arguments."""
    from fieldmap.models.icgem import read_icgem
    from fieldmap.models.registry import load_model

    for lmax in (1.5, float("nan"), float("inf"), "x", True, [3]):
        with pytest.raises(InputError, match="integer degree"):
            load_model(lmax=lmax)
        with pytest.raises(InputError, match="integer degree"):
            read_icgem("good.gfc", lmax=lmax)
    assert load_model("good.gfc", lmax=2.0).lmax == 2  # an integral float is a degree
    assert load_model(None, lmax=4).lmax == 4  # None: the default model
    with pytest.raises(InputError, match="outside 0..2"):
        read_icgem("good.gfc", lmax=-1)
    for bad in (123, 4.5, object()):
        with pytest.raises(InputError, match="model must be"):
            load_model(bad)
    with pytest.raises(InputError, match="must be a path"):
        read_icgem(None)
    for epoch in ([2010], {"y": 1}, True, "2010-02-30", float("nan")):
        with pytest.raises(InputError, match="epoch"):
            load_model(epoch=epoch)
    for name, (_, msg) in BAD_MODELS.items():
        with pytest.raises(ModelFileError, match=msg.replace("+", r"\+")) as info:
            read_icgem(name)
        assert name in str(info.value) and "\n" not in str(info.value)
    for name, (_, _, msg) in ALIEN_MODELS.items():
        assert read_icgem(name).lmax == 2  # a valid file ...
        with pytest.raises(InputError, match="not an Earth model"):
            load_model(name)  # ... but not a model fieldmap evaluates


# ----------------------------------------------------------------------------- geodetic points
POINT_FUNCS = [
    ("disturbance", lambda *p: GR.disturbance(*p, model=_model(), device="cpu")),
    ("gravitation", lambda *p: GR.gravitation(*p, model=_model(), device="cpu")),
    ("gravity", lambda *p: GR.gravity(*p, model=_model(), device="cpu")),
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
        ((0.0, 0.0, [0.0, 1.0000001e8]), r"height 100000010.0 m is above 1e\+08 m"),
        ((91.0, 0.0, 0.0), r"latitude must be within \[-90, 90\] degrees, got 91"),
        ((0.0, 0.0, -2e4), r"height -20000 m is below -10000 m"),
        ((0.0, np.nan, 0.0), "longitude must be finite"),
        (([np.nan], [0.0], [0.0]), "latitude must be finite"),
        ((["a"], [0.0], [0.0]), "latitude must be numeric"),
        (([0.0], [np.inf], [0.0]), "longitude must be finite"),
        (([0.0], [0.0], [np.inf]), "height must be finite"),
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


def test_bad_degree_and_frame_raise():
    from fieldmap.models.registry import load_model

    with pytest.raises(InputError, match=r"lmax 500 exceeds the degree 240 of model EIGEN-6S") as i:
        GR.disturbance([0.0], [0.0], [0.0], model=load_model("eigen-6s", lmax=500), device="cpu")
    _one_line(i)
    with pytest.raises(InputError, match="frame") as i:
        GR.disturbance([0.0], [0.0], [0.0], frame="xyz", device="cpu")
    _one_line(i)


def test_highest_height_is_finite_and_near_point_mass():
    """At h = MAX_HEIGHT = 1e8 m the field is finite and ≈ GM/r² (J2 (a/r)² ~ 4e-6 relative)."""
    assert GR.MAX_HEIGHT == N.MAX_HEIGHT == 1e8
    r = WGS84.a + 1e8  # on the equator, geodetic height = distance - a
    for g in (
        GR.gravitation(0.0, 0.0, 1e8, model=_model(), device="cpu"),
        N.normal_gravity(0.0, 0.0, 1e8, centrifugal=False, device="cpu"),
    ):
        assert np.all(np.isfinite(g))
        np.testing.assert_allclose(np.linalg.norm(g), WGS84.GM / r**2, rtol=1e-5)
    d = GR.disturbance(0.0, 0.0, 1e8, model=_model(), device="cpu")
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
        ("disturbance_map", {"region": (0, 10, 20, 10)}, "north 10.0 is south of south 20.0"),
        ("disturbance_map", {"step_deg": 0}, "step must be a positive number"),
        ("disturbance_map", {"step_deg": "x"}, "step must be a number, got 'x'"),
        ("disturbance_map", {"lat_max": 91}, "latitude limit must be within 0..90"),
        ("disturbance_map", {"height_km": float("nan")}, "heights must be finite"),
        ("disturbance_map", {"height_km": -100}, "height -100 km is below -10 km"),
        ("disturbance_map", {"lmax": 241}, "lmax 241 exceeds the degree 240"),
        ("disturbance_map", {"lmax": 1.5}, "integer degree, got 1.5"),
        ("disturbance_map", {"thresholds_mg": [-1]}, "thresholds must be positive finite"),
        ("disturbance_map", {"model": "nonexist.gfc"}, "unknown model 'nonexist.gfc'"),
        ("disturbance_map", {"epoch": "garbage"}, "bad epoch 'garbage'"),
        ("altitude_sweep", {"height_km": []}, "heights: no value given"),
        ("altitude_sweep", {"height_km": [20, float("inf")]}, "heights must be finite"),
        ("truncation_map", {"orders": [3]}, r"among 2, 4, 6, got \[3\]"),
    ],
)
def test_bad_map_products_raise(func, kwargs, msg):
    kwargs = {"step_deg": 30.0, "device": "cpu", **kwargs}
    if func != "truncation_map":
        kwargs.setdefault("lmax", LMAX)
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


# ----------------------------------------------------------------------- navigation and verify
def test_api_navsim_inputs():
    """Navigation inputs: IMU arrays, dt, names, degrees, trajectories below the surface."""
    from fieldmap.models.registry import load_model
    from fieldmap.nav import imu, study
    from fieldmap.nav import paper as navsim
    from fieldmap.nav.frames import LaunchFrame
    from fieldmap.nav.trajectory import Stationary

    good = np.zeros((10, 3))
    for dth, dv, dt, msg in (
        (good, good, 0.0, "positive"),
        (good, good, -0.005, "positive"),
        (good, good, float("nan"), "positive"),
        (good, good, "x", "must be a number"),
        (good, np.zeros((12, 3)), 0.005, "differ in length"),
        (good, np.zeros((10, 2)), 0.005, r"shape \(n, 3\)"),
        (good[:9], good[:9], 0.005, "even number"),
        ([["a", "b", "c"]] * 10, good, 0.005, "numeric arrays"),
        (np.full((10, 3), np.nan), good, 0.005, "NaN or inf"),
        (good, np.full((10, 3), np.inf), 0.005, "NaN or inf"),
    ):
        with pytest.raises(InputError, match=msg):
            imu.validate_increments(dth, dv, dt)
    model = load_model(lmax=40)
    for names, msg in ((["j8"], "unknown"), (["sh41"], "outside 2..40"), ([], "no navigation")):
        with pytest.raises(InputError, match=msg):
            navsim.check_model_names(names, model)
    with pytest.raises(InputError, match="unknown gravity model kind"):
        imu.Gravitation("j8")
    with pytest.raises(InputError, match="output interval"):
        study.build_scenario(duration=2.0, output_dt=float("nan"))
    with pytest.raises(InputError, match="more than"):
        imu.sample_count(800.0, 1e6)
    for n in (0, -1, 2.5, 1000):
        with pytest.raises(InputError, match="Gauss"):
            imu.gauss_legendre01(n)
    frame = LaunchFrame(lon0=105.0, B0=25.0, A0=90.0)
    for kw in ({"lat": 91.0}, {"h": float("nan")}, {"lon": "x"}):
        with pytest.raises(InputError):
            Stationary(frame, 10.0, **kw)
    for duration in ("x", None, float("nan"), 0.0):
        with pytest.raises(InputError, match="duration"):
            Stationary(frame, duration)
    with pytest.raises(InputError, match="not present"):
        imu.Gravitation("j2", device="cuda:7")
    with pytest.raises(InputError, match="integer degree"):
        imu.Gravitation("sh", model=model, lmax=2.5)
    for kw in ({"duration": "x"}, {"output_dt": -1.0}):
        with pytest.raises(InputError, match="must be a positive number"):
            study.build_scenario(**kw)
    with pytest.raises(InputError, match="must be a positive number"):
        imu.ImuSampling(float("inf"))
    deep = Stationary(frame, 10.0, h=-5000.0)
    with pytest.raises(InputError, match="below the surface"):
        imu.synthesize(deep, imu.ImuSampling(20.0), imu.Gravitation("j2"))


def test_api_verify():
    """``fieldmap.cli.verify.run_checks`` checks its arguments before running anything."""
    from fieldmap.cli.verify import run_checks

    for kw, msg in (
        ({"devices": ["cuda:7"]}, "not present"),
        ({"devices": "tpu"}, "not present"),
        ({"lmax": 241}, "0..240"),
        ({"lmax": 2.5}, "integer degree"),
        ({"points": 1}, "5..1000000"),
        ({"points": "x"}, "must be an integer"),
        ({"points": None}, "must be an integer"),
        ({"points": 1e300}, "5..1000000"),
    ):
        with pytest.raises(InputError, match=msg):
            run_checks(**kw)


def test_api_imu_errors():
    """IMU error specs, draws and their application refuse bad values with InputError."""
    from fieldmap.nav import sensors as ie

    for value in (-1.0, float("nan"), "x", None, True):
        with pytest.raises(InputError, match="accel_bias_ug"):
            ie.ImuErrorSpec(accel_bias_ug=value)
    for kw, msg in (
        ({"n": 0}, ">= 1"),
        ({"n": 2.5}, "integer"),
        ({"n": 2, "seed": -1}, ">= 0"),
        ({"n": 2, "seed": "x"}, "integer"),
        ({"n": 2, "mode": "x"}, "bias mode"),
    ):
        with pytest.raises(InputError, match=msg):
            ie.draw(ie.TABLE4, **kw)
    d = ie.draw(ie.TABLE4, 2)
    z = np.zeros((4, 3))
    for args, kw, msg in (
        ((z, z, 0.0, d), {}, "positive"),
        ((z, z, 0.005, d), {"run": 5}, "run 5"),
        ((z, np.zeros((6, 3)), 0.005, d), {}, "differ in length"),
        ((z, z * np.nan, 0.005, d), {}, "NaN or inf"),
    ):
        with pytest.raises(InputError, match=msg):
            ie.apply(*args, **kw)


def test_build_scenario_long_output_interval():
    """An output interval longer than the flight stores the last state (no endless search)."""
    from fieldmap.nav import study
    from fieldmap.nav.imu import ImuSampling

    sc = study.build_scenario(duration=2.0, sampling=ImuSampling(50.0), truth_lmax=8, output_dt=1e9)
    assert sc.t_out[-1] == pytest.approx(sc.imu.t0 + sc.imu.duration)


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
    a = GR.disturbance(30.0, 105.0, 20e3, model=_model(), units="m s-2", device="cpu")
    b = GR.disturbance(30.0, 105.0, 20e3, model=_model(), units="mGal", device="cpu")
    np.testing.assert_allclose(a * 1e5, b, rtol=1e-15)
    m1 = maps.disturbance_map(model=_model(), step_deg=30.0, units="m/s2", device="cpu")
    m2 = maps.disturbance_map(model=_model(), step_deg=30.0, units="M S-2", device="cpu")
    m3 = maps.disturbance_map(model=_model(), step_deg=30.0, units="mGal", device="cpu")
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
    from fieldmap.field.normal import normal_gravitation_ecef

    params = inspect.signature(normal_gravitation_ecef).parameters
    assert [p.kind for p in params.values()][3:] == [inspect.Parameter.KEYWORD_ONLY] * 5


def test_one_normal_vocabulary():
    """normal= of the API, --normal of the CLI and the grid rows take the same names."""
    from fieldmap.cli.point import NORMALS

    assert NORMALS == tuple(N.NORMAL_MODELS)
    assert N.normal_model("GROVES_J2") == N.normal_model("groves-j2") == "groves-j2"
    with pytest.raises(InputError, match=r"unknown normal-gravity model 'j8' \(known: exact, j2"):
        N.normal_model("j8")
    a = N.normal_gravity(10.0, 0.0, 0.0, normal="Groves_J2", device="cpu")
    b = N.normal_gravity(10.0, 0.0, 0.0, normal="groves-j2", device="cpu")
    np.testing.assert_array_equal(a, b)


def test_points_and_grids_share_one_height_range():
    """One rule (fieldmap.limits): -10 km .. 1e8 m for points and grids alike."""
    from fieldmap import limits

    assert GR.MIN_HEIGHT == N.MIN_HEIGHT == gridspec.MIN_HEIGHT_M == limits.MIN_HEIGHT == -10e3
    assert GR.MAX_HEIGHT == N.MAX_HEIGHT == gridspec.MAX_HEIGHT_M == limits.MAX_HEIGHT == 1e8
    gridspec.make_grid(30.0, heights_m=[-10e3])  # accepted, as a point is
    GR.gravitation(0.0, 0.0, -10e3, model=_model(), device="cpu")
    msgs = set()
    for call in (
        lambda: gridspec.make_grid(30.0, heights_m=[-10001.0]),
        lambda: GR.gravitation(0.0, 0.0, -10001.0, model=_model(), device="cpu"),
        lambda: N.normal_gravity(0.0, 0.0, -10001.0, device="cpu"),
    ):
        with pytest.raises(InputError) as info:
            call()
        msgs.add(_one_line(info))
    assert msgs == {
        "height -10001 m is below -10000 m: the models are not meant for points this far below "
        "the ellipsoid"
    }

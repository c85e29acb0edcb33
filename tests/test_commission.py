"""Coefficient σ in the readers and the cache, and the propagated commission error (issue 18).

The checks of :func:`fieldmap.commission_sigma` share no code with it: a Monte Carlo over
coefficients drawn from their σ evaluated with the Warp point functions, finite differences of
those functions for one coefficient, and a closed form for P̄22.
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

import fieldmap
from fieldmap.errors import InputError
from fieldmap.field.commission import commission_sigma
from fieldmap.models import cache
from fieldmap.models.icgem import read_icgem, write_icgem
from fieldmap.models.registry import kaula_model, load_model
from fieldmap.models.shmodel import SHModel

LAT = np.array([10.0, -45.0, 70.0, 0.5, -89.0])
LON = np.array([20.0, 100.0, -60.0, 179.0, 33.0])
H = 2000.0


def _with_sigma(model: SHModel, seed=3) -> SHModel:
    rng = np.random.default_rng(seed)
    tri = np.tril(np.ones_like(model.C))
    sc = rng.uniform(1e-12, 1e-11, model.C.shape) * tri
    ss = rng.uniform(1e-12, 1e-11, model.C.shape) * tri
    ss[:, 0] = 0.0
    return dataclasses.replace(model, sigma_c=sc, sigma_s=ss)


# ----------------------------------------------------------------------------------- readers
def test_gfc_roundtrip_keeps_sigma(tmp_path):
    model = _with_sigma(kaula_model(25, seed=5))
    path = tmp_path / "s.gfc"
    write_icgem(path, model)
    back = read_icgem(path)
    assert back.sigma_c is not None and back.sigma_s is not None
    np.testing.assert_array_equal(back.sigma_c, model.sigma_c)
    np.testing.assert_array_equal(back.sigma_s, model.sigma_s)
    cut = back.truncated(10)
    assert cut.sigma_c.shape == cut.C.shape == (11, 11)
    np.testing.assert_array_equal(read_icgem(path, lmax=10).sigma_s, cut.sigma_s)


def test_gfc_without_sigma(tmp_path):
    path = tmp_path / "n.gfc"
    write_icgem(path, kaula_model(8, seed=2))
    assert read_icgem(path).sigma_c is None and read_icgem(path).sigma_s is None


def _head(errors="formal"):
    return (
        "begin_of_head\nearth_gravity_constant 3.986004415e14\nradius 6378136.3\n"
        f"max_degree 2\nerrors {errors}\nend_of_head\n"
    )


def test_time_variable_sigma_is_static_part(tmp_path):
    body = (
        "gfc 0 0 1.0 0.0 0.0 0.0\n"
        "gfc 1 0 0.0 0.0 0.0 0.0\ngfc 1 1 0.0 0.0 0.0 0.0\n"
        "gfct 2 0 -4.8e-4 0.0 2.0e-13 0.0 20050101\n"
        "trnd 2 0 1.0e-11 0.0 9.0e-12 0.0\n"
        "acos 2 0 1.0e-11 0.0 7.0e-12 0.0 1.0\n"
        "gfc 2 1 0.0 0.0 3.0e-13 4.0e-13\n"
        "gfc 2 2 2.4e-6 -1.4e-6 5.0e-13 6.0e-13\n"
    )
    path = tmp_path / "tv.gfc"
    path.write_text(_head() + body)
    m = read_icgem(path, epoch=2010.0)
    assert m.sigma_c[2, 0] == 2.0e-13 and m.sigma_s[2, 2] == 6.0e-13 and m.sigma_c[2, 1] == 3e-13
    assert m.sigma_c[0, 0] == 0.0
    path.write_text(_head("no") + body)
    assert read_icgem(path).sigma_c is None


def test_bundled_eigen6s_has_sigma():
    m = load_model("eigen-6s", lmax=30)
    assert m.sigma_c.shape == (31, 31)
    assert m.sigma_c[2, 0] == pytest.approx(1.9551e-13)  # the gfct line's sigma C


def test_cache_roundtrip_sigma(tmp_path):
    model = _with_sigma(kaula_model(12, seed=7))
    path = tmp_path / "c.gfc"
    write_icgem(path, model)
    root = str(tmp_path / "cache")
    assert cache.store([str(path)], "v|all", read_icgem(path), root=root)
    back = cache.load([str(path)], "v|all", root=root)
    np.testing.assert_array_equal(back.sigma_c, model.sigma_c)
    np.testing.assert_array_equal(back.sigma_s, model.sigma_s)
    # an entry of the old format (no sigma arrays) is dropped, not misread
    (meta,) = (tmp_path / "cache" / "entries").glob("*/meta.json")
    rec = json.loads(meta.read_text())
    rec["format"] = 1
    meta.write_text(json.dumps(rec))
    assert cache.load([str(path)], "v|all", root=root) is None


def test_model_without_sigma_is_refused():
    with pytest.raises(InputError, match="no coefficient standard deviations"):
        commission_sigma(10.0, 20.0, 0.0, model=kaula_model(10, seed=1), quantity="geoid")
    with pytest.raises(InputError, match="quantity"):
        commission_sigma(10.0, 20.0, 0.0, quantity="potential")


# ---------------------------------------------------------------------- propagated sigma
def _single(base: SHModel, n, m, which, sigma) -> SHModel:
    sc, ss = np.zeros_like(base.C), np.zeros_like(base.C)
    (sc if which == "C" else ss)[n, m] = sigma
    return dataclasses.replace(base, sigma_c=sc, sigma_s=ss)


def _wgs84_ecef_and_gamma0(lat_deg, lon_deg):
    a, e2 = 6378137.0, 6.69437999014e-3
    phi, lam = np.radians(lat_deg), np.radians(lon_deg)
    nrad = a / np.sqrt(1 - e2 * np.sin(phi) ** 2)
    x, y = nrad * np.cos(phi) * np.cos(lam), nrad * np.cos(phi) * np.sin(lam)
    z = nrad * (1 - e2) * np.sin(phi)
    gamma0 = (
        9.7803253359
        * (1 + 1.93185265241e-3 * np.sin(phi) ** 2)
        / np.sqrt(1 - e2 * np.sin(phi) ** 2)
    )
    return x, y, z, gamma0


def test_closed_form_p22():
    """σ only on C22: σ(N) = GM/(r γ0) q² P̄22(sin ψ) |cos 2λ| σ, P̄22 = (√15/2) cos² ψ."""
    base = kaula_model(6, seed=4)
    sigma = 3e-10
    model = _single(base, 2, 2, "C", sigma)
    x, y, z, gamma0 = _wgs84_ecef_and_gamma0(LAT, LON)
    r = np.sqrt(x * x + y * y + z * z)
    cos_psi = np.hypot(x, y) / r
    p22 = math.sqrt(15.0) / 2.0 * cos_psi**2
    want = (
        base.gm / (r * gamma0) * (base.radius / r) ** 2 * p22 * np.abs(np.cos(2 * np.radians(LON)))
    )
    got = commission_sigma(LAT, LON, 0.0, model=model, quantity="geoid")
    np.testing.assert_allclose(got, want * sigma, rtol=1e-9)


@pytest.mark.parametrize("n,m,which", [(37, 11, "S"), (20, 0, "C"), (9, 9, "C")])
def test_single_coefficient_matches_finite_difference(n, m, which):
    """σ only on one coefficient: |∂f/∂coef| σ, the derivative by the Warp point functions."""
    base = load_model("eigen-6s", lmax=40)
    sigma, step = 2e-11, 1e-8
    model = _single(base, n, m, which, sigma)
    bumped = dataclasses.replace(base, **{which: base.C.copy() if which == "C" else base.S.copy()})
    getattr(bumped, which)[n, m] += step
    for quantity, f in (
        ("geoid", lambda mm: fieldmap.geoid_height(LAT, LON, model=mm)),
        ("anomaly", lambda mm: fieldmap.gravity_anomaly(LAT, LON, H, model=mm).anomaly_mgal),
        ("disturbance", lambda mm: fieldmap.disturbance(LAT, LON, H, model=mm)),
    ):
        want = np.abs(f(bumped) - f(base)) / step * sigma
        got = commission_sigma(LAT, LON, H, model=model, quantity=quantity)
        np.testing.assert_allclose(got, want, rtol=2e-5, atol=1e-6 * want.max(), err_msg=quantity)


def test_monte_carlo_agrees_with_propagation():
    """Monte Carlo: sample σ of 400 perturbed models against the propagated σ.

    Within 4 standard errors (1/√(2N) = 3.5 %) at five points, for N, Δg and the three δg
    components; the mean ratio within 2 standard errors.
    """
    base = load_model("eigen-6s", lmax=60)
    ndraw = 400
    rng = np.random.default_rng(2024)

    def evaluate(mm):
        return np.concatenate(
            [
                fieldmap.geoid_height(LAT, LON, model=mm)[:, None],
                fieldmap.gravity_anomaly(LAT, LON, H, model=mm).anomaly_mgal[:, None],
                fieldmap.disturbance(LAT, LON, H, model=mm),
            ],
            axis=1,
        )

    ref = evaluate(base)
    draws = np.empty((ndraw,) + ref.shape)
    for k in range(ndraw):
        dC = rng.standard_normal(base.C.shape) * base.sigma_c
        dS = rng.standard_normal(base.C.shape) * base.sigma_s
        draws[k] = evaluate(dataclasses.replace(base, C=base.C + dC, S=base.S + dS)) - ref
    sample = draws.std(axis=0, ddof=1)
    prop = np.concatenate(
        [
            commission_sigma(LAT, LON, 0.0, model=base, quantity="geoid")[:, None],
            commission_sigma(LAT, LON, H, model=base, quantity="anomaly")[:, None],
            commission_sigma(LAT, LON, H, model=base, quantity="disturbance"),
        ],
        axis=1,
    )
    tol = 4.0 / math.sqrt(2 * ndraw)
    np.testing.assert_allclose(sample / prop, 1.0, atol=tol)
    assert abs(np.mean(sample / prop) - 1.0) < 2.0 / math.sqrt(2 * ndraw)


def test_shapes_and_lmax():
    s = commission_sigma(np.zeros((2, 3)), 10.0, 0.0, quantity="disturbance", lmax=20)
    assert s.shape == (2, 3, 3) and np.all(s > 0)
    full = commission_sigma(30.0, 40.0, quantity="geoid", lmax=60)
    low = commission_sigma(30.0, 40.0, quantity="geoid", lmax=20)
    assert full.shape == () and 0 < low < full


# ----------------------------------------------------------------------------------- CLI
def _point(monkeypatch, capsys, args, stdin):
    import io

    from fieldmap import cli

    monkeypatch.setattr("sys.stdin", io.StringIO(stdin))
    rc = cli.main(["point", *args])
    out, err = capsys.readouterr()
    return rc, out, err


def test_cli_sigma_quantities(monkeypatch, capsys):
    pts = "45 10 1000\n-89.99 170 100000\n"
    rc, out, _ = _point(
        monkeypatch, capsys, ["--quantity", "disturbance-sigma", "--lmax", "50"], pts
    )
    assert rc == 0
    got = np.array([[float(v) for v in line.split()] for line in out.splitlines()])
    want = commission_sigma([45, -89.99], [10, 170], [1000, 1e5], lmax=50)
    np.testing.assert_allclose(got, want, atol=6e-4)
    rc, out, _ = _point(
        monkeypatch, capsys, ["--quantity", "geoid-sigma", "--lmax", "50"], "45 10\n"
    )
    assert rc == 0 and float(out) == pytest.approx(
        commission_sigma(45, 10, quantity="geoid", lmax=50), abs=6e-5
    )
    rc, out, _ = _point(monkeypatch, capsys, ["--quantity", "anomaly-sigma"], "45 10 0\n")
    assert rc == 0 and len(out.split()) == 1


def test_cli_model_without_sigma(monkeypatch, capsys, tmp_path):
    path = tmp_path / "k.gfc"
    write_icgem(path, kaula_model(10, seed=1))
    args = ["--quantity", "geoid-sigma", "--model", str(path)]
    rc, out, err = _point(monkeypatch, capsys, args, "45 10 0\n")
    assert rc == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert "no coefficient standard deviations" in err


# ------------------------------------------------------------------------------------ grids
def test_grid_sigma_maps_equal_the_point_sigma_at_every_node():
    """commission_grid's row folding gives commission_sigma's values at the nodes, poles too."""
    from fieldmap.products.maps import quantity_map

    model = load_model("eigen-6s", lmax=60)
    kw = dict(model=model, step_deg=15.0, lat_max=90.0)
    for quantity, names in (
        ("disturbance-sigma", ("sigma_east", "sigma_north", "sigma_up")),
        ("anomaly-sigma", ("anomaly_sigma",)),
        ("geoid-sigma", ("geoid_sigma",)),
    ):
        ds = quantity_map(quantity, height_km=[0, 30], **kw)
        assert ds.attrs["quantity"] == quantity and "diagonal propagation" in ds.attrs["definition"]
        lat2, lon2 = np.meshgrid(ds.latitude.values, ds.longitude.values, indexing="ij")
        heights = [0.0] if quantity == "geoid-sigma" else [0.0, 30e3]
        what = quantity[: -len("-sigma")]
        for k, h in enumerate(heights):
            want = commission_sigma(lat2, lon2, h, model=model, quantity=what)
            want = want.reshape(want.shape[:2] + (-1,))
            for c, name in enumerate(names):
                got = ds[name].values if "height" not in ds[name].dims else ds[name].values[k]
                assert got.shape == lat2.shape
                np.testing.assert_allclose(got, want[..., c], rtol=1e-12, err_msg=name)
        assert float(ds[names[0]].min()) > 0.0


def test_grid_sigma_same_bits_for_any_block_size_and_refuses_models_without_sigma():
    from fieldmap.products.maps import quantity_map

    kw = dict(model=load_model("eigen-6s", lmax=40), region=(0, 20, -10, 10), step_deg=2.0)
    ref = quantity_map("disturbance-sigma", **kw)
    for extra in ({"rows_per_block": 1}, {"scheduler": "threads"}):
        other = quantity_map("disturbance-sigma", **kw, **extra)
        for name in ref.data_vars:
            np.testing.assert_array_equal(ref[name].values, other[name].values)
    with pytest.raises(InputError, match="no coefficient standard deviations"):
        quantity_map("geoid-sigma", model=kaula_model(10, seed=1), step_deg=30.0)
    with pytest.raises(InputError, match="degree0"):
        quantity_map("anomaly-sigma", step_deg=30.0, degree0=True)


def test_nga_files_keep_their_sigma_columns(tmp_path):
    """NGA's 'n m C S σC σS' lines: the reader keeps σ (as ICGEM's) and the sigma follows."""
    from fieldmap.models.nga import read_nga, write_nga

    base = _with_sigma(load_model("eigen-6s", lmax=30))
    path = tmp_path / "EGM2008_to30_TideFree"
    write_nga(path, base)
    got = read_nga(path)
    tri = np.tril(np.ones_like(base.C, dtype=bool))
    tri[:2] = False  # degrees 0 and 1 are not written
    np.testing.assert_allclose(got.sigma_c[tri], base.sigma_c[tri], rtol=1e-9)
    np.testing.assert_allclose(got.sigma_s[tri], base.sigma_s[tri], rtol=1e-9)
    assert got.sigma_c[:2].max() == 0.0 and got.sigma_s[:, 0].max() == 0.0
    a = commission_sigma(LAT, LON, H, model=got, quantity="anomaly")
    b = commission_sigma(LAT, LON, H, model=dataclasses.replace(base, gm=got.gm, radius=got.radius,
                         sigma_c=got.sigma_c, sigma_s=got.sigma_s), quantity="anomaly")  # fmt: skip
    np.testing.assert_allclose(a, b, rtol=1e-12)
    assert got.lmax == 30 and read_nga(path, lmax=10).sigma_c.shape == (11, 11)
    bad = tmp_path / "EGM96_bad"
    bad.write_text("2 0 -4.8e-4 0.0 -1.0e-10 0.0\n2 1 0 0 0 0\n2 2 0 0 0 0\n")
    with pytest.raises(fieldmap.ModelFileError, match="standard deviation is negative"):
        read_nga(bad)


def test_flight_study_reports_the_truth_sigma_along_the_track():
    """Navsim's δg output carries the truth model's commission σ (NED) at the track points."""
    from fieldmap.nav.study import FlightStudy, run_flight
    from fieldmap.nav.trajectory import FlightTrajectory, route_flight

    ft = FlightTrajectory(route_flight("45,7,3000;45.3,7.4,5000", 200.0))
    res = run_flight(
        FlightStudy(ft, models=["j4"], duration=60.0, rate_hz=50.0, truth_lmax=40, output_dt=2.0)
    )
    lat, lon, h = res.track.T
    enu = commission_sigma(lat, lon, h, model=load_model("eigen-6s", lmax=40))
    np.testing.assert_allclose(res.dg_sigma * 1e5, enu[:, [1, 0, 2]], rtol=1e-12)
    assert res.dg_sigma.min() > 0.0
    meta = res.summary["meta"]["truth_commission_sigma_max_mgal"]
    assert meta["down"] == pytest.approx(enu[:, 2].max(), rel=1e-12)
    ds = res.to_dataset()
    assert ds["truth_gravity_sigma"].dims == ("time", "axis")
    nosig = run_flight(
        FlightStudy(
            ft,
            models=["j4"],
            duration=10.0,
            rate_hz=50.0,
            truth=kaula_model(20, seed=2),
            output_dt=2.0,
        )
    )
    assert nosig.dg_sigma is None and "truth_gravity_sigma" not in nosig.to_dataset()
    assert nosig.summary["meta"]["truth_commission_sigma_max_mgal"] is None

"""Map products, area-weighted statistics, atomic writers, plots (fieldmap.products)."""

import json

import numpy as np
import pytest

import fieldmap
from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import WGS84
from fieldmap.products import io, maps, plots, stats


# ----------------------------------------------------------------------------- statistics
def test_area_fraction_closed_form():
    """|sin φ| > 0.5 ⇔ |φ| > 30°: exactly half of the sphere's area (∫cos φ dφ)."""
    lat = np.arange(-90, 90.0001, 0.05)
    v = np.repeat(np.abs(np.sin(np.radians(lat)))[:, None], 8, axis=1)
    s = stats.map_statistics(v, lat, thresholds_mg=(0.5,))
    assert s["area_fraction_above"]["0.5"] == pytest.approx(0.5, abs=5e-4)
    # area-weighted mean of |sin φ| over the sphere = ∫|sin φ| cos φ dφ / 2 = 1/2
    assert s["mean_mg"] == pytest.approx(0.5, abs=1e-5)
    # median of |sin φ| by area: sin φ uniform on [-1, 1] (Archimedes) -> median 0.5
    assert s["p50_mg"] == pytest.approx(0.5, abs=1e-3)
    assert s["max_mg"] == 1.0


def test_weighted_percentile_simple():
    assert stats.weighted_percentile([1, 2, 3, 4], [1, 1, 1, 1], 50) == 2
    assert stats.weighted_percentile([1, 2, 3, 4], [0, 0, 0, 1], 10) == 4


def test_bad_thresholds():
    for bad in ([], [0], [-1], ["x"], [float("nan")]):
        with pytest.raises(InputError):
            stats.parse_thresholds(bad)


# ----------------------------------------------------------------------------- products
@pytest.fixture(scope="module")
def small_map():
    return fieldmap.disturbance_map(lmax=60, step_deg=6.0, height_km=20, device="cpu")


def test_disturbance_dataset_structure(small_map):
    ds = small_map
    for v in ("east", "north", "up", "modulus"):
        assert ds[v].dims == ("latitude", "longitude")
        assert ds[v].attrs["units"] == "mGal"
    assert ds["modulus_mg"].attrs["units"] == "mg"
    a = ds.attrs
    assert a["Conventions"] == "CF-1.8"
    assert a["model"] == "EIGEN-6S" and a["model_lmax"] == 60 and a["height_m"] == 20000.0
    assert a["ellipsoid"] == "WGS84" and "EIGEN-6S degree 60" in a["source"]
    assert ds["latitude"].attrs["units"] == "degrees_north"
    mod = np.sqrt(ds.east**2 + ds.north**2 + ds.up**2)
    np.testing.assert_allclose(ds.modulus, mod, rtol=1e-14)
    np.testing.assert_allclose(ds.modulus_mg * 9.80665e-3, ds.modulus * 1e-5, rtol=1e-14)
    assert a["max_mg"] == pytest.approx(float(ds.modulus_mg.max()))
    fr = [a[f"area_fraction_above_{k}_mg"] for k in ("0.02", "0.05", "0.06", "0.1")]
    assert all(0 <= f <= 1 for f in fr) and fr == sorted(fr, reverse=True)


def test_disturbance_matches_point_api(small_map):
    from fieldmap.field.gravity import disturbance

    ds = small_map
    la, lo = np.meshgrid(ds.latitude.values, ds.longitude.values, indexing="ij")
    ref = disturbance(la, lo, 20e3, model="eigen-6s", lmax=60, units="mGal", device="cpu")
    got = np.stack([ds.east, ds.north, ds.up], axis=-1)
    # grid (FFT) and point paths both cancel g − γ: a few ulp of g (1e-15 of g, 1e-9 mGal measured)
    assert np.max(np.abs(got - ref)) < 2e-14 * 9.8 / 1e-5


def test_units_mg_and_region_subset(small_map):
    reg = maps.disturbance_map(
        lmax=60, step_deg=6.0, region=(150, -138, -12, 12), units="mg", device="cpu"
    )  # global 6 deg rows: the multiples of 6 within +-80 (make_grid), so -12..12 are among them
    assert reg["east"].attrs["units"] == "0.00980665 m s-2"  # milli-g as UDUNITS reads it
    assert reg.attrs["grid_kind"] == "regional"
    sub = small_map.sel(
        latitude=reg.latitude.values, longitude=((reg.longitude.values + 180) % 360) - 180
    )
    np.testing.assert_allclose(  # 3e-14 relative measured
        reg.modulus.values, sub.modulus_mg.values, rtol=1e-12, atol=1e-14
    )


def test_sweep_consistent_with_single_maps(small_map):
    sw = fieldmap.altitude_sweep(lmax=60, step_deg=6.0, height_km=[20, 100], device="cpu")
    assert sw["modulus"].dims == ("height", "latitude", "longitude")
    np.testing.assert_allclose(sw.modulus.isel(height=0), small_map.modulus, rtol=1e-13)
    # upward continuation attenuates the field: max and mean fall with height
    assert sw.max_mg.values[1] < sw.max_mg.values[0]
    assert sw.mean_mg.values[1] < sw.mean_mg.values[0]
    s = maps.summary(sw)
    assert s["height_m"] == [20000.0, 100000.0] and set(s["area_fraction_above"]) == {
        "0.02",
        "0.05",
        "0.06",
        "0.1",
    }


def _j4_term_gravitation(lat_deg, h):
    """Minus the gravitation of the J4 zonal term, by central differences of the potential.

    The normal potential is GM/r [1 − Σ J2n (a/r)^2n P2n(sin φc)] (H&M eq. 2-92 convention), so
    its J4 term is −GM J4 a^4 P4 / r^5 and J2-only minus exact ≈ ∇(+GM J4 a^4 P4 / r^5).
    Geodetic ENU.
    """
    from fieldmap.field import frames

    def pot(x, y, z):
        r = np.sqrt(x * x + y * y + z * z)
        s = z / r
        p4 = (35 * s**4 - 30 * s**2 + 3) / 8
        return WGS84.GM * WGS84.J4 * WGS84.a**4 * p4 / r**5

    x, y, z = frames.geodetic_to_ecef(lat_deg, 0.0, h)
    d = 1.0
    g = np.stack(
        [
            (pot(x + d, y, z) - pot(x - d, y, z)) / (2 * d),
            (pot(x, y + d, z) - pot(x, y - d, z)) / (2 * d),
            (pot(x, y, z + d) - pot(x, y, z - d)) / (2 * d),
        ],
        axis=-1,
    )
    return np.einsum("...ij,...j->...i", frames.C_e_to_enu(lat_deg, 0.0 * lat_deg), g)


def test_truncation_j2_error_is_the_j4_term():
    """J2 minus exact = −(J4 term) − (J6 term) − …; the J4 term dominates (J6/J4 ~ 3e-3)."""
    tr = fieldmap.truncation_map(height_km=20, orders=(2, 4), step_deg=10.0, units="m s-2")
    lat = tr.latitude.values
    j2 = np.stack([tr.sel(order=2)[c].values[:, 0] for c in ("east", "north", "up")], axis=-1)
    expected = _j4_term_gravitation(lat, 20e3)
    assert np.max(np.abs(j2 - expected)) < 5e-3 * np.max(np.abs(expected))
    s = maps.summary(tr)
    assert set(s["max_mg"]) == {"j2", "j4"}
    # magnitudes of Chen et al. 2022 §4.2: J2 ~ 0.01 mg, J4 ~ 1e-5 mg
    assert 0.005 < s["max_mg"]["j2"] < 0.02 and 5e-6 < s["max_mg"]["j4"] < 1e-4
    with pytest.raises(InputError):
        fieldmap.truncation_map(orders=(3,))


def test_component_maps_consistent():
    cm = maps.component_maps(lmax=30, step_deg=15.0, device="cpu")
    for c in ("east", "north", "up"):
        assert cm[f"model_{c}"].attrs["units"] == "m s-2"
    assert np.all(cm.model_up < -9.7) and np.all(cm.normal_up < -9.7)
    np.testing.assert_array_equal(cm.normal_east, 0.0)
    d = fieldmap.disturbance_map(lmax=30, step_deg=15.0, device="cpu", units="m s-2")
    # cancels two ~9.8 m/s² values: a few ulp of 9.8 (3.5e-15 m/s² measured)
    np.testing.assert_allclose(cm.model_up - cm.normal_up, d.up, rtol=0, atol=1e-14 * 9.8)


def test_bad_inputs_raise():
    with pytest.raises(InputError, match="degree|lmax"):
        fieldmap.disturbance_map(lmax=500)
    with pytest.raises(InputError, match="units"):
        fieldmap.disturbance_map(units="furlongs")
    with pytest.raises(InputError, match="one height"):
        fieldmap.disturbance_map(height_km=[20, 30])
    with pytest.raises(InputError, match="below"):
        fieldmap.disturbance_map(height_km=-11)  # the limit is -10 km (fieldmap.limits)
    with pytest.raises(InputError, match="ellipsoid"):
        fieldmap.disturbance_map(ellipsoid="Clarke1866")


# ----------------------------------------------------------------------------- I/O and plots
def test_atomic_writers(tmp_path, small_map):
    p = io.write_netcdf(small_map, tmp_path / "a.nc")
    import xarray as xr

    with xr.open_dataset(p) as back:
        np.testing.assert_array_equal(back.modulus.values, small_map.modulus.values)
        assert back.attrs["Conventions"] == "CF-1.8"
    io.write_json({"x": 1}, tmp_path / "a.json")
    assert json.loads((tmp_path / "a.json").read_text()) == {"x": 1}

    class Boom(Exception):
        pass

    with pytest.raises(Boom):
        with io.atomic_path(tmp_path / "b.nc") as tmp:
            tmp.write_bytes(b"partial")
            raise Boom
    assert sorted(f.name for f in tmp_path.iterdir()) == ["a.json", "a.nc"]


def test_out_dir_checks(tmp_path):
    f = tmp_path / "file"
    f.write_text("x")
    with pytest.raises(InputError):
        io.check_out_dir(f)
    with pytest.raises(InputError):
        io.prepare_out_dir(f / "sub")
    io.check_out_dir(tmp_path / "new" / "deeper")
    assert not (tmp_path / "new").exists()


def test_plots_render(tmp_path, small_map):
    figs = {
        "iso": plots.plot_isolines(small_map, [0.02, 0.06, 0.1]),
        "thr": plots.plot_threshold(small_map, 0.06),
    }
    for name, fig in figs.items():
        title = fig.axes[0].get_title()
        assert "EIGEN-6S degree 60" in title and "20 km" in title
        assert any("mg" in ax.get_ylabel() for ax in fig.axes[1:]) or name == "thr"
        io.write_png(fig, tmp_path / f"{name}.png")
        assert (tmp_path / f"{name}.png").read_bytes()[:4] == b"\x89PNG"


def test_coastline_data():
    from fieldmap.products import coastline

    lon, lat = coastline.coastlines()
    ok = np.isfinite(lon)
    assert ok.sum() > 50000 and np.all(np.abs(lon[ok]) <= 180) and np.all(np.abs(lat[ok]) <= 90)
    # Cape Agulhas (34.83 S, 20.0 E) lies on the coast within a few km
    d = np.hypot(lon[ok] - 20.0, lat[ok] + 34.83)
    assert d.min() < 0.1
    w, _ = coastline.shifted(0.0)
    assert np.nanmin(w) >= 0 and np.nanmax(w) < 360
    # the wrap at 0/360 E is broken with NaN: no segment runs across the map (largest step of
    # the 1:50m data between neighbouring vertices is < 10 degrees)
    assert np.nanmax(np.abs(np.diff(w))) < 10.0
    w2, _ = coastline.shifted(-180.0)
    assert np.nanmin(w2) >= -180 and np.nanmax(w2) < 180 and np.nanmax(np.abs(np.diff(w2))) < 10.0

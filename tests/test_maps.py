"""Map products, area-weighted statistics, atomic writers, plots (fieldmap.products)."""

import json
import sys

import numpy as np
import pytest

import fieldmap
from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import WGS84
from fieldmap.products import engine, io, maps, plots, variables
from fieldmap.products import statistics as stats


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


def _percentile_by_definition(values, weights, q):
    """Smallest value whose cumulative weight reaches q % of the total: a plain Python loop."""
    pairs = sorted(zip(np.ravel(values).tolist(), np.ravel(weights).tolist()))
    target = q / 100.0 * sum(w for _, w in pairs)
    acc = 0.0
    for v, w in pairs:
        acc += w
        if acc >= target:
            return v
    return pairs[-1][0]


@pytest.mark.parametrize("seed", range(6))
def test_weighted_percentiles_one_pass_equal_the_definition(seed):
    """All percentiles from one bucket pass pick the values a full sort picks.

    Integer weights and values (ties, zero weights) keep every cumulative sum exact; random
    ones cover the general case (no sum lands within rounding of a target).
    """
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 5000))
    if seed % 2:
        v, w = rng.integers(0, 7, n).astype(float), rng.integers(0, 4, n).astype(float)
        w[0] = 1.0
    else:
        v, w = rng.gamma(2.0, 0.02, n), rng.random(n)
    qs = [0.0, 0.1, 25.0, 50.0, 90.0, 99.0, 99.9, 100.0, *(100 * rng.random(4))]
    got = stats.weighted_percentiles(v, w, qs)
    np.testing.assert_array_equal(got, [_percentile_by_definition(v, w, q) for q in qs])


def test_weighted_percentiles_crowded_values_and_an_outlier():
    """Values crowded far from an outlier fall in one bucket: refined, still the definition."""
    rng = np.random.default_rng(5)
    v = np.concatenate([rng.random(30000) * 1e-3, [1e6]])
    w = rng.random(v.size)
    qs = [0.0, 1.0, 50.0, 99.0, 99.999, 100.0]
    got = stats.weighted_percentiles(v, w, qs)
    np.testing.assert_array_equal(got, [_percentile_by_definition(v, w, q) for q in qs])


def test_map_percentiles_equal_the_definition():
    """On a map: row weights broadcast to every node, three percentiles from one pass."""
    rng = np.random.default_rng(11)
    lat = np.linspace(-80, 80, 33)
    v = rng.gamma(2.0, 0.02, (33, 24))
    s = stats.map_statistics(v, lat, percentiles=(50, 90, 99))
    w = stats.weights_2d(lat, 24)
    for q in (50, 90, 99):
        assert s[f"p{q}_mg"] == _percentile_by_definition(v, w, q)


def test_statistics_weigh_area_not_nodes():
    """A field 1 poleward of 59.5° and 0 elsewhere: its mean is the area of the polar caps.

    The rows are 1° apart from -90 to 90; the cap rows |φ| ≥ 60 stand for the bands
    |φ| ≥ 59.5°, whose share of the sphere is 1 − sin 59.5° = 0.1384, while they are
    62/181 = 0.343 of the nodes.
    """
    lat = np.arange(-90.0, 90.5, 1.0)
    v = np.repeat((np.abs(lat) >= 60)[:, None].astype(float), 36, axis=1)
    s = stats.map_statistics(v, lat, thresholds_mg=(0.5,))
    cap = 1.0 - np.sin(np.radians(59.5))
    assert s["mean_mg"] == pytest.approx(cap, rel=1e-12)
    assert s["area_fraction_above"]["0.5"] == pytest.approx(cap, rel=1e-12)
    assert s["rms_mg"] == pytest.approx(np.sqrt(cap), rel=1e-12)
    assert s["p50_mg"] == 0.0 and s["p90_mg"] == 1.0  # 86 % of the area is 0


def test_truncation_statistics_are_area_weighted():
    """mean_mg of a truncation map weighs cells by area, like every other product's."""
    tr = fieldmap.truncation_map(height_km=20, orders=(2,), step_deg=3.0, lat_max=90.0)
    v = tr.modulus_mg.values[0]
    lat = np.radians(tr.latitude.values)
    # independent cell areas: the band between mid-latitudes, ∝ Δ sin φ (cos φ dφ integrated)
    edges = np.concatenate([[-np.pi / 2], 0.5 * (lat[1:] + lat[:-1]), [np.pi / 2]])
    area = np.diff(np.sin(edges))
    expect = float(np.sum(area * v.mean(axis=1)) / area.sum())
    assert float(tr.mean_mg[0]) == pytest.approx(expect, rel=1e-12)
    assert float(tr.rms_mg[0]) == pytest.approx(
        np.sqrt(np.sum(area * (v**2).mean(axis=1)) / area.sum()), rel=1e-12
    )
    # the J2 error grows towards the poles: a node mean would be 5 % larger
    assert float(v.mean()) > 1.03 * expect
    s = variables.summary(tr)
    assert s["mean_mg"]["j2"] == float(tr.mean_mg[0]) and s["rms_mg"]["j2"] > s["mean_mg"]["j2"]


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
    # milli-g in UDUNITS terms ("mg" would be milligram)
    assert ds["modulus_mg"].attrs["units"] == "0.00980665 m s-2"
    a = ds.attrs
    assert a["Conventions"] == "CF-1.8"
    assert a["model"] == "EIGEN-6S" and a["model_lmax"] == 60 and a["height_m"] == 20000.0
    assert a["ellipsoid"] == "WGS84" and "EIGEN-6S degree 60" in a["source"]
    assert ds["latitude"].attrs["units"] == "degrees_north"
    mod = np.sqrt(ds.east**2 + ds.north**2 + ds.up**2)
    np.testing.assert_allclose(ds.modulus, mod, rtol=1e-14)
    np.testing.assert_allclose(ds.modulus_mg * 9.80665e-3, ds.modulus * 1e-5, rtol=1e-14)
    assert a["max_mg"] == pytest.approx(float(ds.modulus_mg.max()))
    fr = [a[f"area_fraction_above_{k}_mg"] for k in ("0p02", "0p05", "0p06", "0p1")]
    assert all(0 <= f <= 1 for f in fr) and fr == sorted(fr, reverse=True)


def test_disturbance_matches_point_api(small_map):
    from fieldmap.field.gravity import disturbance

    ds = small_map
    la, lo = np.meshgrid(ds.latitude.values, ds.longitude.values, indexing="ij")
    ref = disturbance(la, lo, 20e3, model=fieldmap.load_model("eigen-6s", lmax=60), device="cpu")
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
    s = variables.summary(sw)
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
    s = variables.summary(tr)
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


def _texts(fig) -> str:
    """Every title, axis label and legend entry of a figure, one per line."""
    out = [fig._suptitle.get_text() if fig._suptitle else ""]
    for ax in fig.axes:
        out += [ax.get_title(), ax.get_xlabel(), ax.get_ylabel()]
        if ax.get_legend():
            out += [t.get_text() for t in ax.get_legend().get_texts()]
    return "\n".join(out)


def test_plots_render_with_labels(tmp_path, small_map):
    """Every figure of the products renders, names its model and height, and labels its units."""
    sw = fieldmap.altitude_sweep(lmax=60, step_deg=6.0, height_km=[20, 50], device="cpu")
    tr = fieldmap.truncation_map(step_deg=10.0, orders=(2, 4))
    cm = maps.component_maps(lmax=30, step_deg=15.0, device="cpu")
    reg = maps.disturbance_map(lmax=60, step_deg=1.0, region=(100, 112, 18, 36), device="cpu")
    figs = {  # name: (figure, texts it must show)
        "iso": (
            plots.plot_isolines(small_map, [0.02, 0.06, 0.1]),
            ["EIGEN-6S degree 60", "h = 20 km", "|δg| (mg)", "0.06 mg", "0.1 mg"],
        ),
        "thr": (
            plots.plot_threshold(small_map, 0.06),
            ["EIGEN-6S degree 60", "h = 20 km", "|δg| > 0.06 mg", "% of area", "coastline"],
        ),
        "region": (plots.plot_isolines(reg), ["EIGEN-6S degree 60", "|δg| (mg)", "0.05 mg"]),
        "panels": (
            plots.plot_isolines_panels(sw, [0, 1]),
            ["EIGEN-6S degree 60", "h = 20 km", "h = 50 km", "|δg| (mg)"],
        ),
        "sweep": (plots.plot_sweep(sw), ["EIGEN-6S degree 60", "(mg)", "area fraction (%)"]),
        "truncation": (plots.plot_truncation(tr), ["J2 minus exact", "J4 minus exact", " mg)"]),
        "components": (
            plots.plot_components(cm, "model"),
            ["EIGEN-6S degree 30", "h = 20 km", "g east (mGal)", "g up (m/s²)"],
        ),
    }
    import matplotlib.pyplot as plt

    for name, (fig, wanted) in figs.items():
        text = _texts(fig)
        missing = [w for w in wanted if w not in text]
        assert not missing, f"{name}: {missing} not in {text!r}"
        if name in ("iso", "thr"):  # rendering takes 1-5 s a figure here: two are enough
            io.write_png(fig, tmp_path / f"{name}.png")
            assert (tmp_path / f"{name}.png").read_bytes()[:4] == b"\x89PNG"
        plt.close(fig)


def test_map_figures_style():
    """Proportional colour bar, grey coastlines, no black isoline, a labelled graticule."""
    import matplotlib.colors as mcolors

    reg = maps.disturbance_map(lmax=60, step_deg=1.0, region=(100, 112, 18, 36), device="cpu")
    fig = plots.plot_isolines(reg, [0.02, 0.05, 0.06, 0.1], vmax=0.18)
    ax, cax = fig.axes[0], fig.axes[1]
    # uneven band edges (0, 0.02, 0.04, 0.05, 0.06, 0.08, ...) drawn in proportion to value
    edges = plots._bands(0.18, [0.02, 0.05, 0.06, 0.1])
    assert len(set(np.round(np.diff(edges), 9))) > 1
    to_frac = cax.transData + cax.transAxes.inverted()
    frac = [to_frac.transform((0.5, e))[1] for e in edges]
    np.testing.assert_allclose(frac, edges / 0.18, atol=1e-9)
    lines = [ln for ln in ax.get_lines() if ln.get_linewidth() < 0.5]  # the coastline
    assert lines and all(mcolors.to_rgb(ln.get_color())[0] > 0.3 for ln in lines)
    assert ax.collections  # the isolines (the colours are an image)
    for coll in ax.collections:
        for c in np.atleast_2d(coll.get_edgecolor()):
            assert not np.allclose(c[:3], 0.0)
    assert any(line.get_visible() for line in ax.get_xgridlines())
    assert ax.xaxis.get_major_formatter()(105.0, 0) == "105°E"
    assert ax.yaxis.get_major_formatter()(-20.0, 0) == "20°S"
    assert ax.xaxis.get_major_formatter()(-120.0, 0) == "120°W"


def test_map_figure_gives_every_node_a_pixel():
    """A 0.02° grid 1,001 nodes wide is drawn at least 1,001 pixels wide; wider ones are capped.

    The figure grows (same fonts and line widths) rather than its dpi.
    """
    import matplotlib.pyplot as plt

    fine = maps.disturbance_map(lmax=30, step_deg=0.02, region=(0, 20, 0, 4), device="cpu")
    fig = plots.plot_threshold(fine, 0.05)
    fig.canvas.draw()
    px = fig.axes[0].get_window_extent().width * io.PNG_DPI / fig.dpi  # as saved
    assert px >= fine.sizes["longitude"]
    plt.close(fig)
    coarse = plots.plot_threshold(fine.isel(longitude=slice(None, None, 20)), 0.05)
    assert coarse.get_figwidth() < 9.0  # the usual 8-inch map
    plt.close(coarse)
    assert plots.map_scale(100, 50, 8.0, 4.0) == 1.0
    assert plots.map_scale(7200, 3201, 8.0, 3.6) * 8.0 * plots.DPI <= plots.MAX_MAP_PIXELS + 1e-6


def test_progress_bar_on_request_or_on_a_terminal(capsys, monkeypatch):
    """A bar over the row blocks on stderr: asked for, or by default for long grids on a tty."""
    fieldmap.disturbance_map(lmax=10, step_deg=30.0, device="cpu", progress=True)
    assert "blocks" in capsys.readouterr().err
    fieldmap.disturbance_map(lmax=10, step_deg=30.0, device="cpu")  # short, and not a tty
    assert capsys.readouterr().err == ""
    assert not engine.show_progress(10**8)  # pytest's stderr is not a terminal
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert engine.show_progress(engine.PROGRESS_NODES) and not engine.show_progress(10**4)
    assert not engine.show_progress(10**8, progress=False)  # quiet


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


def test_maps_of_one_grid_are_independent():
    """Maps of the same grid share their (immutable) coordinate indexes, nothing else."""
    a = fieldmap.disturbance_map("eigen-6s", lmax=8, step_deg=30.0, device="cpu")
    b = fieldmap.disturbance_map("eigen-6s", lmax=8, step_deg=30.0, device="cpu")
    a["latitude"].attrs["long_name"] = "changed"
    a["east"].values[...] = 0.0
    shifted = a.assign_coords(latitude=a.latitude + 1.0)
    assert b["latitude"].attrs["long_name"] == "geodetic latitude"
    assert np.any(b["east"].values != 0.0)
    assert np.array_equal(b.latitude.values, a.latitude.values)
    assert np.array_equal(shifted.latitude.values, a.latitude.values + 1.0)
    assert float(b.sel(latitude=30.0, longitude=0.0).east) != 0.0


def test_dataset_index_cache_is_bounded():
    """The shared coordinate indexes: at most 16 kept, each Dataset indexed by its own values."""
    import xarray as xr

    from fieldmap.products import variables as blockmeta

    for k in range(20):
        lat = xr.Variable("latitude", np.arange(3.0) + k)
        ds = blockmeta.dataset(
            {"v": (("latitude",), np.arange(3.0) * k, {})}, {"latitude": lat}, {}
        )
        assert float(ds.sel(latitude=k + 2.0).v) == 2.0 * k
        xr.testing.assert_identical(
            ds, xr.Dataset({"v": ("latitude", np.arange(3.0) * k)}, coords={"latitude": lat})
        )
    assert len(blockmeta._INDEXES) <= 16


def test_shared_coordinate_index_cannot_be_written_through():
    """Writing into one map's index values fails instead of changing the next map's grid."""
    a = fieldmap.disturbance_map("eigen-6s", lmax=8, step_deg=30.0, device="cpu")
    with pytest.raises(ValueError, match="read-only"):
        np.asarray(a.latitude.to_index())[:] = 0.0
    b = fieldmap.disturbance_map("eigen-6s", lmax=8, step_deg=30.0, device="cpu")
    np.testing.assert_array_equal(b.latitude.values, np.arange(-60.0, 61.0, 30.0))
    assert float(b.sel(latitude=30.0, longitude=0.0).east) != 0.0

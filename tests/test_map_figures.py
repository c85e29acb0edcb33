"""One map style for every quantity, tide systems in names and titles, unit slips (issue 36).

Through the public API and ``fieldmap map`` (:func:`fieldmap.cli.main`): each quantity's
figures have their title inside the canvas, coastlines, degree ticks and equal aspect; signed
fields get a colour bar symmetric about zero, clipped at the 99th percentile of |x| with the clip
shown by its arrows; the gradient tensor is one six-panel figure; a tide system other than the
model's own is in the file names and titles; a height typed in metres or thresholds typed in
mGal give a warning (one line on stderr from the CLI, a ``UserWarning`` from Python).
"""

from __future__ import annotations

import warnings

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import fieldmap  # noqa: E402
from fieldmap.cli import main  # noqa: E402
from fieldmap.errors import UnitWarning  # noqa: E402
from fieldmap.models.registry import load_model  # noqa: E402
from fieldmap.models.tide import convert_tide_system  # noqa: E402
from fieldmap.products import plots  # noqa: E402
from fieldmap.products.statistics import area_weights, weighted_percentile  # noqa: E402

OPTS = {"lmax": 24, "step_deg": 10.0}


@pytest.fixture(scope="module")
def model24():
    return load_model("eigen-6s", lmax=24)


def _inside(fig, texts):
    """Every text's box lies within the figure's canvas (as saved without bbox='tight')."""
    fig.canvas.draw()
    canvas = fig.bbox
    for t in texts:
        if not t.get_text():
            continue
        box = t.get_window_extent()
        assert box.x0 >= canvas.x0 - 0.5 and box.x1 <= canvas.x1 + 0.5, t.get_text()
        assert box.y0 >= canvas.y0 - 0.5 and box.y1 <= canvas.y1 + 0.5, t.get_text()


def _titles(fig):
    out = [ax.title for ax in fig.axes]
    if fig._suptitle is not None:
        out.append(fig._suptitle)
    return out


def _map_style(ax):
    """Coastlines, degree tick labels, equal aspect: the map panel of every quantity."""
    assert [ln for ln in ax.get_lines() if ln.get_linewidth() < 0.5], "no coastline"
    assert ax.xaxis.get_major_formatter()(-120.0, 0) == "120°W"
    assert ax.yaxis.get_major_formatter()(20.0, 0) == "20°N"
    assert ax.get_aspect() == 1.0


def test_signed_map_symmetric_clipped_at_the_99th_percentile(model24):
    ds = fieldmap.quantity_map("anomaly", model=model24, height_km=20.0, step_deg=10.0)
    fig = plots.plot_quantity(ds, "anomaly")
    ax = fig.axes[0]
    mesh = ax.get_images()[0]
    lo, hi = mesh.norm.vmin, mesh.norm.vmax
    assert lo == -hi  # symmetric about zero
    v = ds["anomaly"].values
    w = np.broadcast_to(area_weights(ds["latitude"].values)[:, None], v.shape)
    assert hi == pytest.approx(weighted_percentile(np.abs(v), w, 99.0), rel=1e-12)
    assert np.abs(v).max() > hi  # clipped: the largest values are beyond the scale...
    assert mesh.colorbar.extend in ("both", "max", "min")  # ...and the bar says so
    assert "99th percentile" in mesh.colorbar.ax.get_ylabel()
    _map_style(ax)
    _inside(fig, _titles(fig))
    plt.close(fig)


def test_magnitude_map_starts_at_zero_and_one_sign_fields_are_not_symmetric(model24):
    sig = fieldmap.quantity_map(
        "omission-sigma", model=model24, height_km=[20.0, 50.0], **{"step_deg": 10.0}
    )
    fig = plots.plot_quantity(sig, "omission_sigma_modulus", height_index=1)
    assert "h = 50 km" in fig.axes[0].get_title()
    mesh = fig.axes[0].get_images()[0]
    assert mesh.norm.vmin > 0  # a constant field: its value mid-scale, not a black map
    assert "the same at every node" in " ".join(t.get_text() for t in fig.axes[0].texts)
    _inside(fig, _titles(fig))  # a long name, wrapped to the canvas
    plt.close(fig)
    grav = fieldmap.quantity_map("gradient", model=model24, height_km=20.0, step_deg=10.0)
    c = plots.colours(grav["T_uu"].values, grav["latitude"].values, plots.Style(scale="auto"))
    assert c.kind == "level" and c.vmin > 0  # ~3060 E everywhere: its own range, not ±


def test_tensor_is_one_six_panel_figure(tmp_path, model24):
    ds = fieldmap.quantity_map("gradient-disturbance", model=model24, height_km=20.0,
                               step_deg=10.0)  # fmt: skip
    fig = plots.plot_panels(ds)
    maps = [ax for ax in fig.axes if ax.get_images()]
    assert [ax.get_title() for ax in maps] == ["T_ee", "T_en", "T_eu", "T_nn", "T_nu", "T_uu"]
    for ax in maps:
        _map_style(ax)
    _inside(fig, _titles(fig))
    plt.close(fig)
    out = tmp_path / "o"
    argv = ["map", "--quantity", "gradient", "--lmax", "12", "--step-deg", "30", "--out", str(out)]
    assert main(argv) == 0
    pngs = sorted(p.name for p in out.glob("*.png"))
    assert pngs == ["gradient_eigen-6s_L12_h20km_latmax60_step30_tensor.png"]


def test_omission_maps_in_the_map_style(model24):
    from fieldmap.products.degree import omission_map

    ds = omission_map(model24, degrees=[8, 16], height_km=20.0, step_deg=10.0)
    fig = plots.plot_omission(ds)
    maps = [ax for ax in fig.axes if ax.get_images()]
    assert len(maps) == 2
    for ax in maps:
        _map_style(ax)
        assert ax.get_images()[0].norm.vmin == 0.0  # a size: from zero
    _inside(fig, _titles(fig))
    plt.close(fig)


def test_every_quantity_figure_has_its_title_inside(model24):
    """One map of each quantity of the registry, as ``fieldmap map`` draws it."""
    from fieldmap.field.water import field_difference
    from fieldmap.products.quantities import MAP_QUANTITIES, quantity

    for name in MAP_QUANTITIES:
        if name == "disturbance":
            ds = fieldmap.disturbance_map(model=model24, step_deg=20.0)
            figs = plots.disturbance_figures(ds, [0.02, 0.05])
        else:
            model = model24
            if name == "ewh":
                model = field_difference(load_model("eigen-6s", lmax=24, epoch=2012.0), model24)
            kw = {} if quantity(name).surface else {"height_km": 20.0}
            ds = fieldmap.quantity_map(name, model=model, step_deg=20.0, **kw)
            figs = plots.quantity_figures(ds, name)
        for suffix, make in figs:
            fig = make()
            _inside(fig, _titles(fig))
            plt.close(fig)


def test_tide_system_in_file_names_and_titles(tmp_path, capsys):
    out = tmp_path / "o"
    base = ["map", "--quantity", "geoid", "--lmax", "8", "--step-deg", "30", "--out", str(out)]
    assert main(base) == 0
    assert main([*base, "--tide-system", "zero_tide"]) == 0
    assert main([*base, "--tide-system", "tide_free"]) == 0  # the file's own: the same names
    names = sorted(p.name for p in out.iterdir())
    assert names == [
        "geoid_eigen-6s_L8_h0km_latmax60_step30.json",
        "geoid_eigen-6s_L8_h0km_latmax60_step30.nc",
        "geoid_eigen-6s_L8_h0km_latmax60_step30_geoid.png",
        "geoid_eigen-6s_L8_zero_tide_h0km_latmax60_step30.json",
        "geoid_eigen-6s_L8_zero_tide_h0km_latmax60_step30.nc",
        "geoid_eigen-6s_L8_zero_tide_h0km_latmax60_step30_geoid.png",
    ]
    capsys.readouterr()
    zero = convert_tide_system(load_model("eigen-6s", lmax=8), "zero_tide")
    ds = fieldmap.disturbance_map(model=zero, step_deg=30.0)
    fig = plots.plot_isolines(ds)
    assert "EIGEN-6S degree 8 (zero_tide)" in fig.axes[0].get_title()
    plt.close(fig)
    own = fieldmap.disturbance_map(model=load_model("eigen-6s", lmax=8), step_deg=30.0)
    fig = plots.plot_isolines(own)
    assert "tide" not in fig.axes[0].get_title()
    plt.close(fig)


def test_height_in_metres_warns_from_python_and_the_cli(tmp_path, capsys):
    with pytest.warns(UserWarning, match=r"height_km=20000: .*were metres meant"):
        ds = fieldmap.disturbance_map(height_km=20000, **OPTS)
    assert ds.attrs["max_mg"] < 1e-3  # computed all the same
    out = tmp_path / "o"
    argv = ["map", "--height-km", "20000", "--lmax", "12", "--step-deg", "30", "--no-plots"]
    assert main([*argv, "--out", str(out)]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith("fieldmap map: warning: --height-km 20000: ")
    assert "20000 m = 20 km" in err[0]
    assert any(out.glob("*.nc"))  # a warning, not a refusal


def test_thresholds_in_mgal_warn_from_python_and_the_cli(tmp_path, capsys):
    with pytest.warns(UserWarning, match=r"thresholds_mg=20, 50: no node reaches 20, 50 mg"):
        fieldmap.disturbance_map(thresholds_mg=[20, 50], **OPTS)
    out = tmp_path / "o"
    argv = ["map", "--thresholds-mg", "20", "50", "--lmax", "12", "--step-deg", "30"]
    assert main([*argv, "--out", str(out), "--no-plots"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith("fieldmap map: warning: --thresholds-mg 20 50: no node reaches")
    assert "20, 50 mGal = 0.0204, 0.051 mg" in err[0]


def test_no_warning_for_a_plain_map_or_sweep(tmp_path, capsys):
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnitWarning)
        fieldmap.disturbance_map(**OPTS)
        # 100 km: the 0.1 mg threshold catches nothing, but it is near the data (an answer)
        fieldmap.altitude_sweep(height_km=[20, 100, 1000], **OPTS)
    assert main(["map", "--lmax", "12", "--step-deg", "30", "--out", str(tmp_path / "o")]) == 0
    assert capsys.readouterr().err == ""


def test_a_sweep_warns_once(recwarn):
    fieldmap.altitude_sweep(height_km=[20, 20000, 30000], **OPTS)
    slips = [w for w in recwarn if issubclass(w.category, UnitWarning)]
    assert len(slips) == 1 and "height_km=20000" in str(slips[0].message)

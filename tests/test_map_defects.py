"""Defects of issue 25 in the map products, each with a test that failed on the code before it.

- the ellipsoid error lists the known ellipsoids on every path (it was dropped on the engine's);
- one statistics layout: a sweep carries every statistic a map carries, per height, under the
  same names, and the heights can be selected in the unit they were given (``height_km``);
- the isoline map's colour bar covers the maximum of the data;
- ``fieldmap table`` takes ``--height-km`` as ``map`` does (``--heights-km`` still works, with a
  deprecation note on stderr);
- a streamed product honours the model, degree, heights and grid it is given (``setup=``
  overrode them silently).
"""

from __future__ import annotations

import contextlib
import io

import numpy as np
import pytest

import fieldmap
from fieldmap import cli
from fieldmap.errors import InputError

KW = dict(lmax=12, step_deg=10.0, device="cpu")


def run_cli(argv):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            rc = cli.main([str(a) for a in argv])
        except SystemExit as exc:
            rc = exc.code
    return rc, out.getvalue(), err.getvalue()


@pytest.mark.parametrize(
    "make",
    [
        lambda: fieldmap.disturbance_map(ellipsoid="mars", **KW),
        lambda: fieldmap.altitude_sweep(ellipsoid="mars", height_km=[10, 20], **KW),
        lambda: fieldmap.quantity_map("anomaly", ellipsoid="mars", **KW),
        lambda: fieldmap.truncation_map(ellipsoid="mars", step_deg=10.0),
        lambda: fieldmap.component_maps(ellipsoid="mars", **KW),
    ],
    ids=["map", "sweep", "quantity", "truncation", "components"],
)
def test_unknown_ellipsoid_lists_the_known_ones(make):
    with pytest.raises(InputError, match=r"unknown ellipsoid 'mars' \(known: .*WGS84"):
        make()


def test_streamed_map_unknown_ellipsoid_lists_the_known_ones(tmp_path):
    argv = ["map", "--step-deg", "10", "--lmax", "12", "--ellipsoid", "mars"]
    rc, _, err = run_cli([*argv, "--scheduler", "threads", "--out", tmp_path / "o"])
    assert rc == 2
    assert "known: " in err and "WGS84" in err
    assert not (tmp_path / "o").exists()


def test_sweep_statistics_have_the_map_layout_and_height_km_selects():
    sweep = fieldmap.altitude_sweep(height_km=[10, 20], **KW)
    one = fieldmap.disturbance_map(height_km=20, **KW)
    stats = [k for k in one.attrs if k.endswith("_mg") and not k.startswith("area_fraction")]
    stats = [k for k in stats if k != "thresholds_mg"]
    assert {"max_mg", "mean_mg", "rms_mg", "p50_mg", "p90_mg", "p99_mg"} <= set(stats)
    at20 = sweep.sel(height_km=20)
    assert float(at20["height"]) == 20e3
    for k in stats:
        assert sweep[k].dims == ("height",), k
        assert float(at20[k]) == pytest.approx(one.attrs[k], rel=1e-12), k
    np.testing.assert_array_equal(at20["modulus_mg"].values, one["modulus_mg"].values)
    assert float(one["height_km"]) == 20.0


def test_isoline_colour_bar_covers_the_maximum():
    from matplotlib.colors import BoundaryNorm

    from fieldmap.products import plots

    ds = fieldmap.disturbance_map(height_km=20, lmax=240, step_deg=5.0, device="cpu")
    top = float(ds["modulus_mg"].max())
    fig = plots.plot_isolines(ds, [0.02, 0.06, 0.1])
    norms = [c.norm for ax in fig.axes for c in ax.collections if isinstance(c.norm, BoundaryNorm)]
    assert norms
    for norm in norms:
        assert norm.boundaries[-1] >= top
        assert norm.vmax >= top


def test_table_takes_height_km_and_warns_on_heights_km(tmp_path):
    base = ["table", "--region", "0", "2", "40", "42", "--max-error-mgal", "5", "--lmax", "12"]
    rc, _, err = run_cli([*base, "--height-km", "5,10", "--out", tmp_path / "a"])
    assert rc == 0, err
    assert "deprecated" not in err
    rc, _, err = run_cli([*base, "--heights-km", "5,10", "--out", tmp_path / "b"])
    assert rc == 0, err
    assert "--heights-km is deprecated" in err and "--height-km" in err
    a = (tmp_path / "a" / "table.bin").read_bytes()
    assert a == (tmp_path / "b" / "table.bin").read_bytes()


def test_streamed_product_is_the_request(tmp_path):
    """Model, degree, heights and grid of a streamed file are the request's (not setup='s)."""
    import xarray as xr

    from fieldmap.products.engine import compute, write_product
    from fieldmap.products.request import MapRequest

    req = MapRequest.build(lmax=12, heights_m=[3e4], region=(0, 40, 0, 40), step_deg=10.0)
    write_product(req, tmp_path / "m.nc")
    ref = compute(req)
    with xr.open_dataset(tmp_path / "m.nc") as ds:
        assert ds.attrs["model_lmax"] == 12 and float(ds["height"]) == 3e4
        assert ds.sizes["latitude"] == 5 and ds.sizes["longitude"] == 5
        np.testing.assert_array_equal(ds["modulus"].values, ref["modulus"].values)
    with pytest.raises(TypeError):  # no second, silently ignored, description of the product
        write_product(req, tmp_path / "n.nc", setup=(req.grid, req.ellipsoid, req.model))


def test_truncation_and_component_maps_run_on_the_engine(monkeypatch):
    from fieldmap.products import engine

    calls = []
    real = engine.compute_block

    def spy(job, model):
        calls.append(job.quantity)
        return real(job, model)

    monkeypatch.setattr(engine, "compute_block", spy)
    fieldmap.truncation_map(orders=(2, 4), step_deg=30.0)
    fieldmap.component_maps(lmax=12, step_deg=30.0)
    assert calls == ["truncation", "truncation", "components"]


def test_one_summary_with_one_header_for_every_product():
    from fieldmap.products.variables import summary

    header = ("product", "model", "lmax", "ellipsoid", "grid_step_deg", "region_deg", "height_m")
    kinds = {
        "disturbance": fieldmap.disturbance_map(**KW),
        "sweep": fieldmap.altitude_sweep(height_km=[10, 20], **KW),
        "anomaly": fieldmap.quantity_map("anomaly", **KW),
        "truncation": fieldmap.truncation_map(step_deg=10.0),
    }
    for product, ds in kinds.items():
        s = summary(ds)
        assert tuple(s)[: len(header)] == header, product
        assert s["product"] == product


def test_one_place_for_summaries_and_figures():
    """One summary() in the products, and the threshold figures named in one place."""
    import pathlib

    root = pathlib.Path(fieldmap.__file__).parent
    defs = [p.name for p in (root / "products").rglob("*.py") if "\ndef summary(" in p.read_text()]
    assert defs == ["variables.py"]
    for p in (root / "cli").glob("*.py"):
        assert "above_{t" not in p.read_text(), p.name


def test_omission_statistics_in_the_common_vocabulary():
    from fieldmap.products.degree import omission_map

    ds = omission_map(degrees=(6,), height_km=[10, 20], **KW)
    for stat in ("max", "mean", "rms", "p99"):
        assert ds[f"{stat}_mg"].dims == ("degree", "height"), stat
        assert ds[f"{stat}_mg"].attrs["units"] == ds["modulus_mg"].attrs["units"]
    assert float(ds["max_mg"].sel(height_km=20)[0]) == float(
        ds["modulus_mg"].sel(height_km=20)[0].max()
    )

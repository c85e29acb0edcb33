"""One engine for every map product: the same bits for any block size, executor and sink.

The façades (:func:`fieldmap.disturbance_map`, :func:`fieldmap.altitude_sweep`,
:func:`fieldmap.quantity_map`) all run the block engine; here the default call is compared with
other block sizes, the thread executor, a LocalCluster and the streamed NetCDF and zarr files,
values and statistics alike.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import fieldmap
from fieldmap.errors import InputError
from fieldmap.products import variables
from fieldmap.products.statistics import DEFAULT_PERCENTILES, area_weights, weighted_percentiles

KW = dict(lmax=40, step_deg=3.0, device="cpu")


def _same(a: xr.Dataset, b: xr.Dataset) -> None:
    assert set(a.variables) == set(b.variables)
    for v in a.variables:
        assert np.array_equal(a[v].values, b[v].values), v
    for k in a.attrs:
        if k != "history":
            assert np.array_equal(np.asarray(a.attrs[k]), np.asarray(b.attrs[k])), k


@pytest.mark.parametrize(
    "make",
    [
        lambda **kw: fieldmap.disturbance_map(height_km=20, **KW, **kw),
        lambda **kw: fieldmap.altitude_sweep(height_km=[20, 50], **KW, **kw),
        lambda **kw: fieldmap.quantity_map("anomaly", height_km=[0, 20], **KW, **kw),
        lambda **kw: fieldmap.quantity_map("geoid", **KW, **kw),
    ],
    ids=["map", "sweep", "anomaly_sweep", "geoid"],
)
def test_any_block_size_and_the_thread_executor_give_the_same_bits(make):
    ref = make()
    for kw in ({"rows_per_block": 2}, {"rows_per_block": 5}, {"scheduler": "threads"}):
        _same(ref, make(**kw))


def test_regional_and_shifted_grids_same_bits_for_any_block_size():
    kw = dict(lmax=60, step_deg=0.5, region=(100.25, 112.75, -3.5, 7.0), device="cpu")
    ref = fieldmap.disturbance_map(**kw)
    for rows in (1, 3, 7):
        _same(ref, fieldmap.disturbance_map(**kw, rows_per_block=rows))


def test_percentile_method_is_explicit_and_recorded():
    hist = fieldmap.disturbance_map(height_km=20, **KW)
    exact = fieldmap.disturbance_map(height_km=20, **KW, percentile_method="exact")
    assert "histogram" in hist.attrs["percentile_method"]
    assert "exact" in exact.attrs["percentile_method"]
    w = area_weights(exact["latitude"].values)[:, None]
    want = weighted_percentiles(exact["modulus_mg"].values, w, DEFAULT_PERCENTILES)
    for q, v in zip(DEFAULT_PERCENTILES, want):
        assert exact.attrs[f"p{q:g}_mg"] == v  # one of the map's values, exactly
        assert abs(hist.attrs[f"p{q:g}_mg"] / v - 1) <= 2.0**-13
    assert variables.summary(exact)["percentile_method"] == exact.attrs["percentile_method"]
    with pytest.raises(InputError, match="percentile_method"):
        fieldmap.disturbance_map(**KW, percentile_method="median-of-medians")


def test_lazy_products_say_they_have_no_statistics():
    pytest.importorskip("dask")
    lazy = fieldmap.disturbance_map(**KW, chunks=8)
    with pytest.raises(InputError, match="no statistics"):
        variables.summary(lazy)
    with pytest.raises(InputError, match="percentile_method"):
        fieldmap.disturbance_map(**KW, chunks=8, percentile_method="exact")


def test_epoch_on_a_model_object_is_refused_not_ignored():
    from fieldmap.models.registry import load_model

    mod = load_model("eigen-6s", lmax=10)
    with pytest.raises(InputError, match="epoch"):
        fieldmap.disturbance_map(mod, step_deg=30.0, epoch=2030.0)


def test_quantity_map_in_the_public_api():
    assert "quantity_map" in fieldmap.__all__


def _fieldmap(*args, timeout=180):
    exe = Path(sys.executable).with_name("fieldmap")
    return subprocess.run([str(exe), *args], capture_output=True, text=True, timeout=timeout)


@pytest.mark.parametrize("quantity", ["disturbance", "geoid"])
def test_cli_default_equals_streamed_and_cluster(tmp_path, quantity):
    """``fieldmap map``: in memory (default), --scheduler threads, local:2 and zarr: one product."""
    pytest.importorskip("distributed")
    pytest.importorskip("zarr")
    common = ["map", "--lmax", "40", "--step-deg", "3", "--no-plots", "--quantity", quantity]
    runs = {
        "default": [],
        "threads": ["--scheduler", "threads", "--rows-per-block", "6"],
        "local2": ["--scheduler", "local:2"],
        "zarr": ["--format", "zarr", "--rows-per-block", "4"],
    }
    for name, extra in runs.items():
        r = _fieldmap(*common, *extra, "--out", str(tmp_path / name))
        assert r.returncode == 0, (name, r.stderr)

    def product(name):
        (p,) = [*(tmp_path / name).glob("*.nc"), *(tmp_path / name).glob("*.zarr")]
        (j,) = (tmp_path / name).glob("*.json")
        doc = json.loads(j.read_text())
        doc.pop("product_path", None)
        ds = xr.open_zarr(p) if p.suffix == ".zarr" else xr.open_dataset(p)
        return ds.load(), doc

    ref, ref_doc = product("default")
    for name in ("threads", "local2", "zarr"):
        ds, doc = product(name)
        assert doc == ref_doc, name  # the JSON statistics: the same bits
        for v in ref.data_vars:
            assert np.array_equal(ds[v].values, ref[v].values), (name, v)


def test_cli_refuses_what_a_streamed_product_cannot_do(tmp_path):
    base = ["map", "--lmax", "10", "--step-deg", "30", "--no-plots", "--out", str(tmp_path / "x")]
    for extra, words in (
        (["--scheduler", "threads", "--float32"], "--float32"),
        (["--format", "zarr", "--percentile-method", "exact"], "--percentile-method"),
        (["--quantity", "geoid", "--percentile-method", "exact"], "--percentile-method"),
    ):
        r = _fieldmap(*base, *extra)
        assert r.returncode == 2, (extra, r.stderr)
        assert words in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert not (tmp_path / "x").exists()


def test_cli_float32_honoured_for_quantity_maps(tmp_path):
    r = _fieldmap(
        "map", "--quantity", "geoid", "--lmax", "10", "--step-deg", "30", "--no-plots",
        "--float32", "--out", str(tmp_path),
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    (p,) = tmp_path.glob("*.nc")
    with xr.open_dataset(p) as ds:
        assert ds["geoid"].encoding["dtype"] == np.float32

"""The one-pass block statistics give the bits of the separate conversion and reduction."""

import math

import numpy as np
import pytest

from fieldmap import _warp
from fieldmap.errors import InputError
from fieldmap.products import layouts
from fieldmap.products import statistics as bs
from fieldmap.products.statistics import area_weights
from fieldmap.products.variables import vector_vars

THRESHOLDS = (0.02, 0.05, 0.06, 0.10)


def _reference(v, rw, thresholds, hw):
    """block_partial as first written: one histogram range for the block, int64 counts."""
    vmax, vmin = float(v.max()), float(v.min())
    if not (math.isfinite(vmax) and math.isfinite(vmin)):
        raise InputError("map holds non-finite values")
    lo = int(bs._hist_index(np.array([vmin]))[0]) if vmin > 0 else 0
    k = bs._hist_index(v) - lo
    w = np.repeat(hw, v.shape[1])
    hist = np.bincount(k.ravel(), weights=w)
    nz = np.flatnonzero(hist)
    return {
        "max": vmax,
        "min": vmin,
        "sw": [rw * v.sum(axis=1)],
        "sw2": [rw * (v * v).sum(axis=1)],
        "above": [[rw * np.add.reduce(v > t, axis=1, dtype=np.int64)] for t in thresholds],
        "hist": ((nz + lo).astype(np.int32), hist[nz]),
    }


def _assert_same(a, b):
    assert a["max"] == b["max"] and a["min"] == b["min"]
    for key in ("sw", "sw2"):
        assert len(a[key]) == 1 and np.array_equal(a[key][0], b[key][0])
    assert len(a["above"]) == len(b["above"])
    for x, y in zip(a["above"], b["above"]):
        assert np.array_equal(x[0], y[0]) and x[0].dtype == y[0].dtype
    for x, y in zip(a["hist"], b["hist"]):
        assert np.array_equal(x, y) and x.dtype == y.dtype


def _vectors(rng, nlat, nlon, layout):
    """m/s² vectors of moduli over several octaves, in the given memory layout."""
    scale = 10.0 ** rng.uniform(-7, -3, size=(nlat, nlon, 1))
    vec = rng.normal(size=(nlat, nlon, 3)) * scale
    if layout == "rows":  # (row, component, longitude), as the grid synthesis writes them
        return np.moveaxis(np.ascontiguousarray(np.moveaxis(vec, -1, 1)), 1, -1)
    return vec


@pytest.mark.parametrize("threads", [1, 2, 3])
@pytest.mark.parametrize("layout", ["rows", "c"])
@pytest.mark.parametrize("units", ["mGal", "m/s2", "mg"])
@pytest.mark.parametrize("shape", [(1, 7), (5, 12), (37, 72), (181, 360)])
def test_disturbance_partial_same_bits(threads, layout, units, shape):
    rng = np.random.default_rng(sum(shape) + threads)
    vec = _vectors(rng, *shape, layout)
    lat = np.linspace(-80, 80, shape[0])
    rw = area_weights(lat)
    hw = bs.histogram_weights(rw, shape[1])
    ref_vec = vec.copy(order="K")  # the same layout: the same order of the sums of squares
    ref = {k: v[1] for k, v in vector_vars(ref_vec, (), units, "", overwrite=True).items()}
    with _warp.threads(threads):
        data, part = layouts.disturbance_partial(vec, units, rw, THRESHOLDS, hw)
        again = bs.block_partial(ref["modulus_mg"], rw, THRESHOLDS, hw)
    assert list(data) == list(ref)
    for name in ref:
        assert np.array_equal(data[name], ref[name], equal_nan=False), name
    assert np.array_equal(vec, ref_vec)  # converted in place, as vector_vars(overwrite=True)
    want = _reference(ref["modulus_mg"], rw, THRESHOLDS, hw)
    _assert_same(part, want)
    _assert_same(again, want)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_disturbance_partial_non_finite(bad):
    rng = np.random.default_rng(1)
    vec = _vectors(rng, 64, 40, "rows")
    vec[50, 3, 1] = bad
    rw = area_weights(np.linspace(-80, 80, 64))
    with _warp.threads(2), pytest.raises(InputError, match="map holds non-finite values"):
        layouts.disturbance_partial(vec, "mGal", rw, THRESHOLDS, bs.histogram_weights(rw, 40))


def test_scalar_bin_matches_array_bins():
    rng = np.random.default_rng(2)
    lo, hi = bs.HIST_RANGE_MG
    x = np.concatenate(
        [10.0 ** rng.uniform(-320, 300, 5000), -rng.random(50), [0.0, -0.0, 5e-324, lo, hi]]
    )
    assert [bs._bin(float(v)) for v in x] == bs._hist_index(x).tolist()


@pytest.mark.parametrize("stacked", [False, True])
def test_dataset_without_merge_is_the_constructors(stacked):
    import xarray as xr

    from fieldmap.field.ellipsoid import get_ellipsoid
    from fieldmap.grids.spec import make_grid
    from fieldmap.models.registry import load_model
    from fieldmap.products import variables

    grid = make_grid(10.0, 80.0, None, np.array([2e4, 5e4] if stacked else [2e4]))
    tmpl = variables.disturbance_template(
        load_model("eigen-6s", lmax=4), grid, get_ellipsoid("WGS84"), "mGal", THRESHOLDS, stacked
    )
    rng = np.random.default_rng(3)
    data = {
        name: xr.Variable(tmpl.dims, rng.random(grid.shape if stacked else grid.shape[1:]), a)
        for name, a in tmpl.variables.items()
    }
    if stacked:
        stat = {"max_mg": 1.0, "mean_mg": 0.5, "p50_mg": 0.4, "p99_mg": 0.9}
        stat["area_fraction_above"] = {f"{t:g}": 0.1 for t in THRESHOLDS}
        data.update(variables.sweep_statistics([stat, stat], THRESHOLDS))
    fast = variables.dataset(dict(data), tmpl.coords, dict(tmpl.attrs))
    want = xr.Dataset(dict(data), coords=tmpl.coords, attrs=dict(tmpl.attrs))
    xr.testing.assert_identical(fast, want)
    xr.testing._assert_internal_invariants(fast, check_default_indexes=True)
    assert list(fast.variables) == list(want.variables)
    assert list(fast.xindexes) == list(want.xindexes)
    for name in want.xindexes:
        assert fast.xindexes[name].equals(want.xindexes[name])
    assert fast.encoding == want.encoding
    assert float(fast.sel(latitude=30.0)["modulus"].sum()) == float(
        want.sel(latitude=30.0)["modulus"].sum()
    )

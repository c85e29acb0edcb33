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

"""The degree you need (issue 18): SH omission maps and the smallest degree within a tolerance.

The degree found is checked with a path that shares no code with the grid engine: the point
functions (``fieldmap.disturbance`` with ``lmax=``) at the grid nodes, full model minus degree d.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import fieldmap
from fieldmap.cli import main
from fieldmap.errors import InputError
from fieldmap.products.degree import check_degrees, degree_needed, omission_map

L = 60
REGION = (0.0, 60.0, -30.0, 30.0)
STEP = 7.5
HEIGHTS_KM = (20.0, 50.0)


def _nodes():
    """Nodes of the region, built here (not by the grid module)."""
    w, e, s, n = REGION
    lat = np.arange(s, n + STEP / 2, STEP)
    lon = np.arange(w, e + STEP / 2, STEP)
    return np.meshgrid(lat, lon, indexing="ij")


def _point_omission_max(d: int) -> float:
    """Return the max |δg_L − δg_d| (mGal) over the nodes and heights, from the point functions."""
    lat, lon = _nodes()
    worst = 0.0
    full_model, part_model = (fieldmap.load_model("eigen-6s", lmax=n) for n in (L, d))
    for h in HEIGHTS_KM:
        full = fieldmap.disturbance(lat, lon, 1e3 * h, model=full_model, units="mGal")
        part = fieldmap.disturbance(lat, lon, 1e3 * h, model=part_model, units="mGal")
        worst = max(worst, float(np.linalg.norm(full - part, axis=-1).max()))
    return worst


@pytest.fixture(scope="module")
def found():
    return degree_needed(
        "eigen-6s",
        tolerance_mgal=10.0,
        lmax=L,
        height_km=HEIGHTS_KM,
        region=REGION,
        step_deg=STEP,
    )


def test_degree_needed_checked_by_point_functions(found):
    d = found["degree_needed"]
    assert 2 < d < L
    at, below = _point_omission_max(d), _point_omission_max(d - 1)
    assert at <= 10.0 < below
    assert found["omission_max_mgal"] == pytest.approx(at, rel=1e-8)
    assert found["omission_max_below_mgal"] == pytest.approx(below, rel=1e-8)
    assert found["evaluated"][d] == found["omission_max_mgal"]


def test_grid_nodes_are_the_point_nodes():
    ds = omission_map("eigen-6s", degrees=[L], lmax=L, height_km=20, region=REGION, step_deg=STEP)
    lat, lon = _nodes()
    np.testing.assert_array_equal(ds["latitude"].values, lat[:, 0])
    np.testing.assert_array_equal(ds["longitude"].values, lon[0])


def test_edge_degrees():
    kw = dict(lmax=L, height_km=20, region=REGION, step_deg=STEP)
    loose = degree_needed("eigen-6s", tolerance_mgal=1e6, **kw)
    assert loose["degree_needed"] == 2 and loose["omission_max_mgal"] <= 1e6
    tight = degree_needed("eigen-6s", tolerance_mgal=1e-9, **kw)
    assert tight["degree_needed"] == L
    assert tight["omission_max_mgal"] == 0.0 and tight["omission_max_below_mgal"] > 1e-9


def test_full_degree_is_zero_and_rms_decreases():
    """Omission of L is zero; EIGEN-6S at 20 km, global: RMS falls with degree (Kaula)."""
    degs = (2, 18, 36, 90, 180, 240)
    ds = omission_map("eigen-6s", degrees=degs, height_km=20, step_deg=5.0)
    assert ds.attrs["model_lmax"] == 240
    assert list(ds["degree"].values) == list(degs)
    assert float(np.abs(ds["modulus"].sel(degree=240)).max()) == 0.0
    rms = ds["rms_mgal"].values[:, 0]
    assert np.all(np.diff(rms) < 0), rms
    assert np.all(ds["max_mgal"].values >= ds["p99_mgal"].values)
    assert np.all(ds["p99_mgal"].values >= ds["mean_mgal"].values)


@pytest.mark.parametrize(
    "degrees, msg",
    [
        ([61], "outside 2..60"),
        ([1], "outside 2..60"),
        ([2.5], "not an integer"),
        (["18.0"], "not an integer"),
        ([True], "not an integer"),
        ([18, 36, 18], "given twice"),
        ([], "no degree"),
    ],
)
def test_bad_degrees(degrees, msg):
    with pytest.raises(InputError, match=msg):
        check_degrees(degrees, L)


@pytest.mark.parametrize("tol", [0.0, -1.0, float("nan"), float("inf"), "x"])
def test_bad_tolerance(tol):
    with pytest.raises(InputError, match="tolerance"):
        degree_needed("eigen-6s", tolerance_mgal=tol, lmax=L, step_deg=30)


def test_cli_degrees_and_tolerance(tmp_path, capsys):
    out = tmp_path / "o"
    argv = ["truncation", "--degrees", "18,36", "--tolerance-mgal", "10", "--lmax", str(L)]
    argv += ["--region", *map(str, REGION), "--step-deg", str(STEP)]
    argv += ["--height-km", "20,50", "--no-plots", "--out", str(out)]
    assert main(argv) == 0
    text = capsys.readouterr().out
    (js,) = out.glob("*.json")
    doc = json.loads(js.read_text())
    d = doc["degree_needed"]
    assert f"degree needed for 10 mGal: {d} " in text
    assert doc["tolerance_mgal"] == 10.0 and doc["degrees"] == [18, 36]
    assert doc["omission_max_at_degree_needed_mgal"] <= 10.0
    assert doc["omission_max_below_degree_needed_mgal"] > 10.0
    assert set(doc["max_mgal"]) == {"18", "36"} and len(doc["max_mgal"]["18"]) == 2
    assert len(list(out.glob("*.nc"))) == 1 and not list(out.glob("*.png"))


def test_cli_tolerance_alone_maps_the_degree_found(tmp_path, capsys):
    out = tmp_path / "o"
    argv = ["truncation", "--tolerance-mgal", "10", "--lmax", str(L), "--step-deg", "15"]
    assert main([*argv, "--out", str(out)]) == 0
    doc = json.loads(next(out.glob("*.json")).read_text())
    assert doc["degrees"] == [doc["degree_needed"]]
    assert {p.suffix for p in out.iterdir()} == {".json", ".nc", ".png"}


@pytest.mark.parametrize(
    "args, msg",
    [
        (["--degrees", "18", "--orders", "2"], "--orders and --degrees"),
        (["--tolerance-mgal", "5", "--orders", "2,4"], "--orders and --tolerance-mgal"),
        (["--degrees", "241"], "outside 2..240"),
        (["--degrees", "18", "--lmax", "10"], "outside 2..10"),
        (["--degrees", "2.5"], "not an integer"),
        (["--degrees", "18,18"], "given twice"),
        (["--tolerance-mgal", "0"], "> 0"),
        (["--tolerance-mgal", "nan"], "> 0"),
        (["--tolerance-mgal", "-3"], "> 0"),
        (["--model", "eigen-6s"], "--model applies"),
        (["--degrees", "18", "--scheduler", "threads"], "--scheduler"),
    ],
)
def test_cli_bad_input(tmp_path, capsys, args, msg):
    out = tmp_path / "o"
    assert main(["truncation", "--step-deg", "30", *args, "--out", str(out)]) == 2
    cap = capsys.readouterr()
    lines = cap.err.strip().splitlines()
    assert len(lines) == 1 and msg in lines[0], cap.err
    assert cap.out == "" and not out.exists()

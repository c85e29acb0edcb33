"""CLI ``fieldmap map|sweep|truncation``: outputs, JSON summaries, one-line errors, no writes."""

import json
import subprocess
import sys

import pytest

from fieldmap.cli import main

SMALL = ["--step-deg", "10", "--lmax", "40"]


def test_map_writes_outputs(tmp_path, capsys):
    out = tmp_path / "o"
    assert main(["map", *SMALL, "--height-km", "20", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "EIGEN-6S degree 40" in text and "area above" in text
    names = sorted(p.name for p in out.iterdir())
    stem = "disturbance_eigen-6s_L40_h20km_step10"
    assert f"{stem}.nc" in names and f"{stem}.json" in names and f"{stem}_isolines.png" in names
    assert f"{stem}_above_0.06mg.png" in names and f"{stem}_above_0.1mg.png" in names
    assert not [n for n in names if n.startswith(".")]  # no temporary files left
    js = json.loads((out / f"{stem}.json").read_text())
    assert js["model"] == "EIGEN-6S" and js["lmax"] == 40 and js["height_m"] == 20000.0
    assert 0 < js["mean_mg"] < js["max_mg"] < 1.0
    assert set(js["area_fraction_above"]) == {"0.02", "0.05", "0.06", "0.1"}
    assert all(0 <= v <= 1 for v in js["area_fraction_above"].values())
    # the files hold what the API computes for the same request
    import numpy as np
    import xarray as xr

    import fieldmap

    ds = fieldmap.disturbance_map(lmax=40, step_deg=10.0, height_km=20, device="cpu")
    assert js["max_mg"] == pytest.approx(float(ds.modulus_mg.max()), rel=1e-12, abs=0)
    assert js["mean_mg"] == pytest.approx(ds.attrs["mean_mg"], rel=1e-12, abs=0)
    with xr.open_dataset(out / f"{stem}.nc") as nc:
        np.testing.assert_allclose(nc.modulus_mg.values, ds.modulus_mg.values, rtol=1e-12)


def test_map_region_thresholds(tmp_path):
    out = tmp_path / "r"
    rc = main(
        [
            "map",
            "--lmax",
            "60",
            "--step-deg",
            "0.5",
            "--region",
            "100",
            "112",
            "18",
            "37",
            "--thresholds-mg",
            "0.025,0.05",
            "0.075",
            "0.10",
            "--no-plots",
            "--out",
            str(out),
        ]
    )
    assert rc == 0
    (js_path,) = out.glob("*.json")
    assert "region100_112_18_37" in js_path.name
    js = json.loads(js_path.read_text())
    assert set(js["area_fraction_above"]) == {"0.025", "0.05", "0.075", "0.1"}
    assert js["region_deg"] == [100.0, 112.0, 18.0, 37.0]


def test_sweep_and_truncation(tmp_path, capsys):
    out = tmp_path / "s"
    assert main(["sweep", *SMALL, "--height-km", "20", "50", "100", "--out", str(out)]) == 0
    table = capsys.readouterr().out
    assert "h (km)" in table and "100" in table
    (js_path,) = out.glob("sweep_*.json")
    js = json.loads(js_path.read_text())
    assert js["height_m"] == [20000.0, 50000.0, 100000.0] and len(js["max_mg"]) == 3
    assert len(list(out.glob("sweep_*_isolines_h*km.png"))) == 3
    assert main(["truncation", "--step-deg", "10", "--orders", "2,4,6", "--out", str(out)]) == 0
    (tj,) = out.glob("truncation_*.json")
    js = json.loads(tj.read_text())
    assert set(js["max_mg"]) == {"j2", "j4", "j6"}
    assert js["max_mg"]["j2"] > js["max_mg"]["j4"] > js["max_mg"]["j6"] > 0


@pytest.mark.parametrize("command", ["map", "sweep", "truncation"])
def test_float32_netcdf(tmp_path, command):
    """--float32 stores the maps in single precision; statistics and coordinates stay float64."""
    import numpy as np
    import xarray as xr

    base = ["--step-deg", "10", "--no-plots"] + (
        ["--lmax", "40"] if command != "truncation" else []
    )
    for flag, sub in (([], "d"), (["--float32"], "f")):
        assert main([command, *base, *flag, "--out", str(tmp_path / sub)]) == 0
    (p64,) = (tmp_path / "d").glob("*.nc")
    (p32,) = (tmp_path / "f").glob("*.nc")
    with xr.open_dataset(p64) as a, xr.open_dataset(p32) as b:
        assert a.modulus_mg.dtype == np.float64 and b.modulus_mg.dtype == np.float32
        assert b.latitude.dtype == np.float64
        x = a.modulus_mg.values
        assert np.all(np.abs(b.modulus_mg.values - x) <= 2.0**-24 * np.abs(x))
        if "max_mg" in a:
            assert b.max_mg.dtype == np.float64


@pytest.mark.parametrize(
    "args, msg",
    [
        (["map", "--step-deg", "0"], "step"),
        (["map", "--step-deg", "-2"], "step"),
        (["map", "--lat-max", "95"], "latitude"),
        (["map", "--region", "10", "20", "40", "30"], "empty region"),
        (["map", "--height-km", "nan"], "finite"),
        (["map", "--height-km", "-100"], "below"),
        (["map", "--lmax", "241"], "241"),
        (["map", "--thresholds-mg", "0.1,x"], "thresholds"),
        (["map", "--device", "cuda:9"], "device"),
        (["map", "--model", "/nonexistent/model.gfc"], "model.gfc"),
        (["sweep", "--height-km", "20", "inf"], "finite"),
        (["sweep", "--height-km", "20", "20"], "repeated"),
        (["truncation", "--orders", "2,8"], "orders"),
    ],
)
def test_bad_input_one_line_nothing_written(tmp_path, capsys, args, msg):
    out = tmp_path / "never"
    assert main([*args, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "error" in err[0] and msg in err[0]
    assert not out.exists()


def test_unwritable_out_dir(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["map", *SMALL, "--out", str(blocker)]) == 2
    assert "not a folder" in capsys.readouterr().err
    assert blocker.read_text() == "x"


def test_console_script_help():
    r = subprocess.run(
        [sys.executable, "-m", "fieldmap", "map", "--help"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 0
    for opt in (
        "--model",
        "--lmax",
        "--height-km",
        "--step-deg",
        "--lat-max",
        "--region",
        "--thresholds-mg",
        "--device",
        "--out",
        "--float32",
    ):
        assert opt in r.stdout


def test_one_list_syntax(tmp_path, capsys):
    """Lists (heights, orders, thresholds) read the same as separate or comma-separated values."""
    runs = {}
    for name, args in {
        "spaces": ["--height-km", "20", "50", "--thresholds-mg", "0.05", "0.1"],
        "commas": ["--height-km", "20,50", "--thresholds-mg", "0.05,0.1"],
        "mixed": ["--height-km", "20,", "50", "--thresholds-mg", "0.05", ",0.1"],
    }.items():
        out = tmp_path / name
        argv = ["sweep", "--step-deg", "30", "--lmax", "4", "--no-plots", *args, "--out", str(out)]
        assert main(argv) == 0
        (js,) = out.glob("sweep_*.json")
        runs[name] = json.loads(js.read_text())
    assert runs["spaces"]["height_m"] == [20000.0, 50000.0]
    assert runs["spaces"]["area_fraction_above"].keys() == {"0.05", "0.1"}
    assert runs["spaces"]["max_mg"] == runs["commas"]["max_mg"] == runs["mixed"]["max_mg"]
    for name, orders in {"a": ["2", "4"], "b": ["2,4"], "c": ["j2", "J4"]}.items():
        out = tmp_path / f"t{name}"
        argv = ["truncation", "--step-deg", "30", "--no-plots", "--orders", *orders]
        assert main([*argv, "--out", str(out)]) == 0
        (js,) = out.glob("truncation_*.json")
        runs[name] = json.loads(js.read_text())["max_mg"]
    assert runs["a"] == runs["b"] == runs["c"] and set(runs["a"]) == {"j2", "j4"}
    capsys.readouterr()

"""Gravity compensation tables (``fieldmap table``, ``table:FILE`` models), issue 18.

The checks share no code with the implementation where it matters: the binary file is parsed
here with ``struct`` from the layout the C header documents, the C header's own interpolation
function is compiled and run, and the interpolated table is compared with GeographicLib's
``Gravity`` at random points inside the lattice (never at nodes).
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import shutil
import struct
import subprocess
import sys

import numpy as np
import pytest

import fieldmap
from fieldmap import cli
from fieldmap.errors import InputError
from fieldmap.models.geographiclib import gravity_tool, run_gravity_tool, write_egm
from fieldmap.products.tables.model import CompensationTable, interpolate, load_table

BOUND = 0.5  # mGal
REGION = ("5", "10", "40", "45")


def run_cli(argv, stdin=""):
    """Run ``fieldmap ARGV`` in this process: (exit status, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    stream = io.StringIO(stdin)
    stream.buffer = io.BytesIO(stdin.encode())  # type: ignore[attr-defined]
    old = sys.stdin
    sys.stdin = stream
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                rc = cli.main([str(a) for a in argv])
            except SystemExit as exc:
                rc = exc.code
    finally:
        sys.stdin = old
    return rc, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """Build the 5° x 5°, 0-20 km, 0.5 mGal table of EIGEN-6S (degree 240) with the CLI."""
    out = tmp_path_factory.mktemp("table")
    argv = ["table", "--region", *REGION, "--height-km", "0,20", "--max-error-mgal", BOUND]
    rc, stdout, err = run_cli([*argv, "--out", out])
    assert rc == 0, err
    return out, stdout


def _random_interior(n, seed, domain=(5.0, 10.0, 40.0, 45.0, 0.0, 20e3)):
    w, e, s, nn, h0, h1 = domain
    rng = np.random.default_rng(seed)
    return rng.uniform(s, nn, n), rng.uniform(w, e, n), rng.uniform(h0, h1, n)


def test_files_and_report(built):
    out, stdout = built
    assert sorted(p.name for p in out.iterdir()) == [
        "table.bin",
        "table.h",
        "table.json",
        "table.nc",
    ]
    rep = json.loads((out / "table.json").read_text())
    ver = rep["verification"]
    assert ver["max_mgal"] <= BOUND and 0 < ver["rms_mgal"] < ver["max_mgal"]
    lat = rep["lattice"]
    heights = lat["h0_m"] + lat["dh_m"] * np.arange(lat["nh"])
    # one row per node height and per mid-height, every component
    assert len(ver["per_height"]) == 2 * lat["nh"] - 1
    for row in ver["per_height"]:
        assert set(row["max_mgal"]) == set(row["rms_mgal"]) == {"dn", "de", "dd"}
        assert max(row["max_mgal"].values()) <= BOUND
    assert {r["height_m"] for r in ver["per_height"]} >= set(heights.tolist())
    assert ver["random_points"]["points"] >= 1000
    assert rep["size_bytes"] == (out / "table.bin").stat().st_size <= 8e6
    assert lat["valid_domain"] == pytest.approx(
        {"west": 5, "east": 10, "south": 40, "north": 45, "hmin": 0, "hmax": 20e3}
    )
    assert "verified on" in stdout and "written:" in stdout


def _parse_bin(raw: bytes):
    """Parse the binary file from the layout documented in table.h (no fieldmap code)."""
    assert raw[:8] == b"FMGTAB\x00\x01"
    version, hbytes, nh, nlat, nlon, ncomp, vbytes, lmax = struct.unpack_from("<8I", raw, 8)
    doubles = struct.unpack_from("<16d", raw, 40)
    assert (version, hbytes, ncomp, vbytes) == (1, 168, 3, 4)
    data = np.frombuffer(raw, "<f4", offset=168).reshape(nh, nlat, nlon, 3)
    return (nh, nlat, nlon, lmax), doubles, data


def test_binary_layout_equals_netcdf(built):
    import xarray as xr

    out, _ = built
    (nh, nlat, nlon, lmax), d, data = _parse_bin((out / "table.bin").read_bytes())
    lat0, dlat, lon0, dlon, h0, dh = d[:6]
    west, east, south, north, hmin, hmax = d[6:12]
    assert lmax == 240 and d[12] == BOUND and d[13] <= BOUND
    assert (south, north, west, east, hmin, hmax) == pytest.approx((40, 45, 5, 10, 0, 20e3))
    assert south == pytest.approx(lat0 + dlat) and east == pytest.approx(lon0 + (nlon - 2) * dlon)
    with xr.open_dataset(out / "table.nc") as ds:
        assert ds.attrs["Conventions"] == "CF-1.8"
        assert ds["dn"].attrs["units"] == "mGal" and "NED" in ds["dd"].attrs["long_name"]
        assert "Catmull-Rom" in ds.attrs["interpolation"]
        for k, c in enumerate(("dn", "de", "dd")):
            v = ds[c].transpose("height", "latitude", "longitude").values
            assert v.dtype == np.float32
            np.testing.assert_array_equal(v, data[..., k])
        np.testing.assert_allclose(ds["latitude"].values, lat0 + dlat * np.arange(nlat), atol=1e-12)
        np.testing.assert_allclose(
            ds["longitude"].values, lon0 + dlon * np.arange(nlon), atol=1e-12
        )
        np.testing.assert_allclose(ds["height"].values, h0 + dh * np.arange(nh), atol=1e-9)
    a, b = load_table(out / "table.bin"), load_table(out / "table.nc")
    lat, lon, h = _random_interior(200, 3)
    np.testing.assert_array_equal(a.interpolate(lat, lon, h), b.interpolate(lat, lon, h))


@pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler")
def test_c_header_interpolates_as_python(built, tmp_path):
    """table.h's fm_table_interp, compiled, gives the NumPy interpolator's numbers."""
    out, _ = built
    lat, lon, h = _random_interior(300, 5)
    lat[:3], lon[:3], h[:3] = [40, 45, 42], [5, 10, 7], [0, 20e3, 20e3]  # the edges
    (tmp_path / "pts.txt").write_text(
        "".join(f"{a:.17g} {b:.17g} {c:.17g}\n" for a, b, c in zip(lat, lon, h))
    )
    src = tmp_path / "interp.c"
    src.write_text(
        '#include <stdio.h>\n#include <stdlib.h>\n#include "table.h"\n'
        "int main(int argc, char **argv) {\n"
        '  FILE *f = fopen(argv[1], "rb"); fseek(f, 0, SEEK_END); long n = ftell(f);\n'
        "  rewind(f); char *buf = malloc(n); if (fread(buf, 1, n, f) != (size_t)n) return 2;\n"
        "  const fm_table_header *hd = (const fm_table_header *)buf;\n"
        "  const float *data = (const float *)(buf + hd->header_bytes);\n"
        "  double la, lo, hh, v[3];\n"
        '  while (scanf("%lf %lf %lf", &la, &lo, &hh) == 3) {\n'
        '    if (fm_table_interp(hd, data, la, lo, hh, v)) printf("outside\\n");\n'
        '    else printf("%.17g %.17g %.17g\\n", v[0], v[1], v[2]);\n'
        "  }\n  return 0;\n}\n"
    )
    exe = tmp_path / "interp"
    subprocess.run(
        ["gcc", "-std=c99", "-Wall", "-Werror", "-O2", "-I", str(out), str(src), "-o", str(exe),
         "-lm"],
        check=True,
    )  # fmt: skip
    with open(tmp_path / "pts.txt") as fin:
        res = subprocess.run([str(exe), str(out / "table.bin")], stdin=fin, capture_output=True,
                             text=True, check=True)  # fmt: skip
    c_vals = np.array([[float(x) for x in line.split()] for line in res.stdout.splitlines()])
    py = load_table(out / "table.bin").interpolate(lat, lon, h)
    np.testing.assert_allclose(c_vals, py, rtol=0, atol=1e-9)
    res = subprocess.run([str(exe), str(out / "table.bin")], input="46 7 0\n40 7 -1\n",
                         capture_output=True, text=True, check=True)  # fmt: skip
    assert res.stdout.split() == ["outside", "outside"]


@pytest.mark.skipif(gravity_tool() is None, reason="GeographicLib's Gravity missing")
def test_geographiclib_at_random_interior_points(built, tmp_path):
    """Interpolated table vs GeographicLib's Gravity -D, 400 points off the nodes."""
    from fieldmap.models.registry import load_model

    out, _ = built
    tab = load_table(out / "table.bin")
    lat, lon, h = _random_interior(400, 17)
    # never at a node: at least 5 % of a spacing away on every axis
    for v, v0, dv in ((lat, tab.lat0, tab.dlat), (lon, tab.lon0, tab.dlon), (h, tab.h0, tab.dh)):
        frac = np.mod((v - v0) / dv, 1.0)
        v += np.where(frac < 0.05, 0.1 * dv, 0.0) - np.where(frac > 0.95, 0.1 * dv, 0.0)
    name = write_egm(load_model("eigen-6s"), tmp_path)
    enu = run_gravity_tool(np.c_[lat, lon, h], tmp_path, name, "disturbance", precision=10)
    ned = np.c_[enu[:, 1], enu[:, 0], -enu[:, 2]]
    err = tab.interpolate(lat, lon, h) - ned
    # GeographicLib vs fieldmap is ~1e-9 mGal (test_geographiclib.py); 1e-6 covers it
    assert np.max(np.abs(err)) <= BOUND + 1e-6
    assert np.max(np.abs(err)) > 1e-3  # a real interpolation error, not node values


def test_point_table_model(built):
    """``fieldmap point --model table:FILE`` = the Python API = the interpolator; ≈ the model."""
    out, _ = built
    lat, lon, h = _random_interior(50, 23)
    text = "".join(f"{a:.17g} {b:.17g} {c:.17g}\n" for a, b, c in zip(lat, lon, h))
    rc, stdout, err = run_cli(["point", "--model", f"table:{out / 'table.nc'}"], text)
    assert rc == 0, err
    printed = np.array([[float(x) for x in line.split()] for line in stdout.splitlines()])
    api = fieldmap.disturbance(lat, lon, h, model=f"table:{out / 'table.bin'}")
    ned = interpolate(load_table(out / "table.bin"), lat, lon, h)
    np.testing.assert_allclose(api, np.c_[ned[:, 1], ned[:, 0], -ned[:, 2]], atol=1e-12)
    np.testing.assert_allclose(printed, api, atol=6e-4)  # 3 decimals
    direct = fieldmap.disturbance(lat, lon, h, model="eigen-6s")
    assert np.max(np.abs(api - direct)) <= BOUND
    # the frames and units of the API
    tab = f"table:{out / 'table.bin'}"
    ecef = fieldmap.disturbance(lat, lon, h, model=tab, frame="ecef", units="m/s2")
    assert np.linalg.norm(ecef, axis=1) * 1e5 == pytest.approx(np.linalg.norm(api, axis=1))
    assert fieldmap.disturbance(lat[:2], lon[:2], h[:2], model=tab, frame="ned")[0, 2] == (
        pytest.approx(-api[0, 2])
    )
    with pytest.raises(InputError, match="outside the table"):
        fieldmap.disturbance(46.0, 7.0, 0.0, model=tab)


def test_point_outside_is_a_bad_line(built):
    out, _ = built
    rc, stdout, err = run_cli(
        ["point", "--model", f"table:{out / 'table.bin'}"], "42 7 100\n46 7 100\n42 7 30000\n"
    )
    assert rc == 1
    lines = stdout.splitlines()
    assert len(lines) == 3 and not lines[0].startswith("ERROR")
    assert lines[1].startswith("ERROR: point 46 7 100 is outside the table")
    assert lines[2].startswith("ERROR:") and "2 of 3 input lines" in err


def test_budget_refused(tmp_path):
    out = tmp_path / "o"
    argv = ["table", "--region", *REGION, "--height-km", "0,20", "--max-error-mgal", "0.5"]
    rc, stdout, err = run_cli([*argv, "--budget-mb", "0.02", "--out", out])
    line = err.strip().splitlines()[-1]
    assert rc == 2 and stdout == "" and not out.exists()
    assert line.startswith("fieldmap table: error: cannot meet 0.5 mGal within --budget-mb 0.02")
    assert "next refinement needs" in line


@pytest.mark.parametrize(
    "args, words",
    [
        (("--region", "5", "10", "45", "40"), "south < north"),
        (("--region", "5", "10", "nan", "45"), "finite"),
        (("--region", "5", "10", "40", "89.5"), "89"),
        (("--region", "0", "360", "40", "45"), "less than 360"),
        (("--height-km", "20,0"), "MIN < MAX"),
        (("--height-km", "0"), "MIN,MAX"),
        (("--height-km", "0,2e6"), "above"),
        (("--max-error-mgal", "-0.5"), "positive"),
        (("--max-error-mgal", "nan"), "positive"),
        (("--budget-mb", "0"), "positive"),
        (("--width-km", "10"), "--corridor"),
        (("--corridor", "missing.csv"), "not found"),
        (("--out", "/proc/forbidden"), "output"),
    ],
)
def test_bad_input(args, words, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    base = {"--region": REGION, "--height-km": ("0,20",), "--max-error-mgal": ("0.5",)}
    for k in range(0, len(args), 1):
        if args[k] in base:
            base[args[k]] = ()
    argv = ["table"]
    for k, v in base.items():
        if v:
            argv += [k, *v]
    argv += list(args)
    if args[0] == "--region":
        argv = ["table", "--height-km", "0,20", "--max-error-mgal", "0.5", *args]
    rc, stdout, err = run_cli(argv)
    lines = err.strip().splitlines()
    assert rc == 2 and stdout == "" and len(lines) == 1, err
    assert words in lines[0] and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_no_region_refused(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    rc, _, err = run_cli(["table", "--height-km", "0,20", "--max-error-mgal", "1"])
    assert rc == 2 and "--region" in err and list(tmp_path.iterdir()) == []


def test_antimeridian_and_corridor(tmp_path):
    """A region across ±180 and a corridor around a flight; both within the bound."""
    out = tmp_path / "am"
    argv = ["table", "--region", "179", "-179", "-1", "1", "--height-km", "5,10"]
    rc, _, err = run_cli([*argv, "--max-error-mgal", "1", "--lmax", "120", "--out", out])
    assert rc == 0, err
    tab = f"table:{out / 'table.bin'}"
    lat, lon, h = np.array([0.3, -0.7, 0.0]), np.array([179.5, -179.2, 180.0]), np.full(3, 7e3)
    got = fieldmap.disturbance(lat, lon, h, model=tab)
    want = fieldmap.disturbance(lat, lon, h, model=fieldmap.load_model("eigen-6s", lmax=120))
    assert np.max(np.abs(got - want)) <= 1.0
    csv = tmp_path / "flight.csv"
    t = np.arange(31.0)
    csv.write_text(
        "time_s,lat_deg,lon_deg,height_m\n"
        + "".join(f"{a},{45 + 0.01 * a},7.0,3000.0\n" for a in t)
    )
    out = tmp_path / "corr"
    argv = ["table", "--corridor", csv, "--width-km", "20", "--height-km", "0,5"]
    rc, _, err = run_cli([*argv, "--max-error-mgal", "2", "--lmax", "60", "--out", out])
    assert rc == 0, err
    w, e, s, n, _, _ = load_table(out / "table.bin").domain
    dlat = math.degrees(20e3 / 6356752.0)
    assert s == pytest.approx(45 - dlat) and n == pytest.approx(45.3 + dlat)
    assert w < 7 - dlat < 7 + dlat < e  # wider in longitude at 45°


def test_interpolator_reproduces_polynomials():
    """Catmull-Rom reproduces quadratics horizontally; linear in height (ghost nodes)."""
    lat0, dlat, lon0, dlon, h0, dh = 9.0, 0.5, 99.0, 0.25, 0.0, 1000.0
    nh, nlat, nlon = 3, 8, 9
    k, i, j = np.meshgrid(np.arange(nh), np.arange(nlat), np.arange(nlon), indexing="ij")
    la, lo, hh = lat0 + i * dlat, lon0 + j * dlon, h0 + k * dh

    def f(a, b, c):
        return np.stack([a**2 - 3 * a * b + 0.5 * b**2, b - 2e-3 * c, 0.001 * c * a], axis=-1)

    tab = CompensationTable(lat0, dlat, lon0, dlon, h0, dh, f(la, lo, hh))
    rng = np.random.default_rng(1)
    w, e, s, n, hmin, hmax = tab.domain
    pts = rng.uniform(s, n, 500), rng.uniform(w, e, 500), rng.uniform(hmin, hmax, 500)
    np.testing.assert_allclose(tab.interpolate(*pts), f(*pts), rtol=1e-12, atol=1e-9)
    assert np.isnan(tab.interpolate([s - 0.1], [w], [0.0], outside="nan")).all()
    with pytest.raises(InputError, match="outside"):
        tab.interpolate(s, w, hmax + 1.0)

"""CF-1.8 compliance of every NetCDF product, checked by the CF checker and by hand.

``cfchecks`` (PyPI ``cfchecker``, which needs the UDUNITS-2 library, Debian ``libudunits2-0``)
normally downloads the CF standard-name, area-type and region tables; the tests give it the
copies shipped beside the repository in ``../shared/data/cf`` (or the folder named by the
environment variable ``FIELDMAP_CF_TABLES``).
"""

import gzip
import os
import re
import shutil
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import fieldmap
from fieldmap.errors import InputError
from fieldmap.products import io, maps, variables
from fieldmap.units import UNITS

TABLES = {
    "-s": "cf-standard-name-table.xml",
    "-a": "area-type-table.xml",
    "-r": "standardized-region-list.xml",
}
ROOT = Path(__file__).resolve().parents[1]
SMALL = dict(lmax=30, step_deg=10.0, device="cpu")


def _tables_dir() -> Path | None:
    for cand in (os.environ.get("FIELDMAP_CF_TABLES"), ROOT.parent / "shared" / "data" / "cf"):
        if cand and all(
            (Path(cand) / n).exists() or (Path(cand) / f"{n}.gz").exists() for n in TABLES.values()
        ):
            return Path(cand)
    return None


def _products() -> dict:
    """One small Dataset of every kind the package writes as NetCDF."""
    from fieldmap.nav.study import to_dataset
    from fieldmap.products.maps import quantity_map

    nav = types.SimpleNamespace(
        pos=np.linspace(0.0, 5.0, 10).reshape(2, 5),
        vel=np.linspace(0.0, 1.0, 10).reshape(2, 5),
        labels=["j2", "sh40"],
        t=np.arange(5.0),
        study="table1",
        meta={"truth_model": "EIGEN-6S", "truth_degree": 60},
    )
    return {
        "disturbance": fieldmap.disturbance_map(**SMALL),
        "disturbance_mg": fieldmap.disturbance_map(**SMALL, units="mg"),
        "regional": maps.disturbance_map(
            lmax=30, step_deg=2.0, region=(100, 112, 18, 36), device="cpu"
        ),
        "sweep": fieldmap.altitude_sweep(**SMALL, height_km=[20, 50]),
        "truncation": fieldmap.truncation_map(step_deg=10.0, orders=(2, 4, 6)),
        "components": maps.component_maps(**SMALL),
        "navsim": to_dataset(nav),
        "geoid": quantity_map("geoid", **SMALL),
        "anomaly": quantity_map("anomaly", **SMALL, height_km=20),
        "deflection_sweep": quantity_map("deflection", **SMALL, height_km=[20, 50]),
        "potential": quantity_map("potential", **SMALL, height_km=20),
        "gradient": quantity_map("gradient", **SMALL, height_km=20),
    }


#: the NetCDF files of ``fieldmap navsim``, one of each kind: name -> the command's options
NAVSIM_RUNS = {
    "navsim_paper": ["--study", "table1", "--duration", "4", "--lmax", "10", "--models", "j2"],
    "navsim_log_monte_carlo": ["--imu", "tactical", "--draws", "2"],
    "navsim_log_covariance": ["--imu", "tactical", "--method", "covariance"],
    "navsim_gnss_monte_carlo": ["--imu", "tactical", "--draws", "2", "--gnss-outage", "40:30"],
    "navsim_gnss_covariance": [
        "--imu", "tactical", "--method", "covariance", "--gnss-outage", "40:30"
    ],
}  # fmt: skip


def _flight_files(folder: Path) -> dict[str, Path]:
    """Run ``fieldmap navsim`` once per kind of flight NetCDF; return name -> its file.

    The flights are a 2-minute log (a CSV without attitude: read and conditioned as a user's
    log) flown by Monte Carlo and by covariance, free and with a GNSS outage; and the paper's
    table 1. Tiny runs: 10 Hz IMU, degree 10, no figures.
    """
    from fieldmap.cli import main

    k = np.arange(121.0)
    log = folder / "log.csv"
    log.write_text(
        "time_s,lat_deg,lon_deg,height_m\n"
        + "".join(f"{t:g},{47 + t * 200 / 111_000:.9f},8.0,{1000 + 2 * t:g}\n" for t in k)
    )
    flight = ["--trajectory", str(log), "--lmax", "10", "--models", "j4,sh8", "--rate", "10"]
    out = {}
    for name, args in NAVSIM_RUNS.items():
        where = folder / name
        argv = args if "--study" in args else [*flight, *args]
        assert main(["navsim", *argv, "--no-timing", "--no-plots", "--out", str(where)]) == 0
        (out[name],) = where.glob("*.nc")
    return out


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cf")
    out = {}
    for name, ds in _products().items():
        out[name] = io.write_netcdf(ds, folder / f"{name}.nc")
    ds = fieldmap.disturbance_map(**SMALL)
    out["disturbance_float32"] = io.write_netcdf(ds, folder / "f32.nc", dtype="float32")
    # written block by block by the block engine (fieldmap map --scheduler ...)
    from fieldmap.products.engine import write_product
    from fieldmap.products.request import MapRequest

    small = dict(lmax=30, step_deg=10.0, device="cpu", rows_per_block=4)
    for name, heights, stacked in (
        ("streamed_map", (2e4,), False),
        ("streamed_sweep", (2e4, 5e4), True),
    ):
        path = folder / f"{name}.nc"
        write_product(MapRequest.build(heights_m=heights, stacked=stacked, **small), path)
        out[name] = path
    out.update(_flight_files(folder))
    for name, q, heights in (
        ("streamed_geoid", "geoid", (0.0,)),
        ("streamed_deflection_sweep", "deflection", (2e4, 5e4)),
        ("streamed_gradient_sweep", "gradient-disturbance", (2e4, 5e4)),
    ):
        path = folder / f"{name}.nc"
        kw = {} if q == "geoid" else {"heights_m": heights}
        write_product(MapRequest.build(quantity=q, stacked=True, **kw, **small), path)
        out[name] = path
    return out


@pytest.fixture(scope="module")
def cfchecks_report(files, tmp_path_factory):
    """Per file: (errors, warnings, the ERROR/WARN lines), from one cfchecks run on all files."""
    pytest.importorskip("cfchecker", reason="cfchecker is in the test extra: pip install .[test]")
    src = _tables_dir()
    if src is None:
        pytest.skip(
            "CF tables not found: set FIELDMAP_CF_TABLES or put ../shared/data/cf beside the "
            "repository (cf-standard-name-table.xml[.gz], area-type-table.xml[.gz], "
            "standardized-region-list.xml[.gz])"
        )
    folder = tmp_path_factory.mktemp("cf-tables")
    args = []
    for opt, name in TABLES.items():
        dst = folder / name
        if (src / name).exists():
            shutil.copyfile(src / name, dst)
        else:  # cfchecks reads plain XML only
            with gzip.open(src / f"{name}.gz", "rb") as fin, open(dst, "wb") as fout:
                shutil.copyfileobj(fin, fout)
        args += [opt, str(dst)]
    paths = [str(p) for p in files.values()]
    run = subprocess.run(
        [sys.executable, "-m", "cfchecker.cfchecks", *args, *paths],
        capture_output=True,
        text=True,
        timeout=300,
    )
    sections = re.split(r"^CHECKING NetCDF FILE: ", run.stdout, flags=re.M)[1:]
    assert len(sections) == len(paths), run.stdout[-2000:] + run.stderr[-2000:]
    report = {}
    for sec in sections:
        path = sec.splitlines()[0].strip()
        errors = int(re.search(r"^ERRORS detected: (\d+)", sec, re.M)[1])
        warnings = int(re.search(r"^WARNINGS given: (\d+)", sec, re.M)[1])
        lines = [ln for ln in sec.splitlines() if ln.startswith(("ERROR", "WARN"))]
        report[path] = (errors, warnings, lines)
    return report


PRODUCTS = [
    "disturbance",
    "disturbance_mg",
    "disturbance_float32",
    "regional",
    "sweep",
    "truncation",
    "components",
    "navsim",
    "streamed_map",
    "streamed_sweep",
    "geoid",
    "anomaly",
    "deflection_sweep",
    "potential",
    "streamed_geoid",
    "streamed_deflection_sweep",
    "gradient",
    "streamed_gradient_sweep",
    *NAVSIM_RUNS,
]


@pytest.mark.parametrize("product", PRODUCTS)
def test_cfchecks_no_errors_no_warnings(product, files, cfchecks_report):
    errors, warnings, lines = cfchecks_report[str(files[product])]
    assert (errors, warnings) == (0, 0), "\n".join(lines)


@pytest.mark.parametrize("product", PRODUCTS)
def test_names_units_and_coordinates_by_hand(product, files):
    """Legal names (CF 1.8 §2.3), UDUNITS-readable units, coordinates without fill values."""
    import netCDF4

    legal = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
    with netCDF4.Dataset(files[product]) as nc:
        assert all(legal.match(a) for a in nc.ncattrs()), nc.ncattrs()
        for name, var in nc.variables.items():
            assert legal.match(name)
            # names starting with "_" (_FillValue, _Encoding) are reserved by the NetCDF library
            assert all(legal.match(a) or a.startswith("_") for a in var.ncattrs()), name
            if name in nc.dimensions or name == "height":  # coordinate variables
                assert "_FillValue" not in var.ncattrs(), name
            if "units" in var.ncattrs():
                assert var.units != "mg", f"{name}: 'mg' is milligram in UDUNITS"
            if var.ndim >= 2 and var.dtype.kind == "f":
                f = var.filters()
                assert f["zlib"] and f["shuffle"] and f["complevel"] == io.COMPLEVEL, name


def test_milli_g_units_convert_as_acceleration():
    """The units written for mg mean 9.80665e-3 m s-2 to UDUNITS (not a milligram)."""
    cfunits = pytest.importorskip("cfunits", reason="cfunits comes with cfchecker (test extra)")
    mg = cfunits.Units(variables.MG_UNITS)
    assert mg.isvalid and mg.equivalent(cfunits.Units("m s-2"))
    assert not cfunits.Units("mg").equivalent(cfunits.Units("m s-2"))  # why "mg" is not used
    # 1 mg = 980.665 mGal = 9.80665e-3 m s-2 (standard gravity, CGPM 1901)
    got = cfunits.Units.conform(1.0, mg, cfunits.Units("mGal"))
    assert got == pytest.approx(980.665, rel=1e-14)
    for name in UNITS:
        assert cfunits.Units(variables.cf_units(name)).equivalent(cfunits.Units("m s-2")), name
        assert variables.units_scale(variables.cf_units(name)) == UNITS[name].si


def test_attribute_names_keep_json_keys():
    assert variables.fraction_attr(0.05) == "area_fraction_above_0p05_mg"
    assert variables.fraction_attr(0.1) == "area_fraction_above_0p1_mg"
    assert variables.attr_name("p99.9_mg") == "p99p9_mg"
    ds = fieldmap.disturbance_map(**SMALL, thresholds_mg=(0.025, 0.05))
    s = variables.summary(ds)
    assert set(s["area_fraction_above"]) == {"0.025", "0.05"}  # JSON keys as written
    assert s["area_fraction_above"]["0.025"] == ds.attrs["area_fraction_above_0p025_mg"]


def test_float32_round_trip_within_the_documented_bound(tmp_path):
    """float32 storage: every value within 2**-24 of itself (round to nearest), maps only."""
    ds = fieldmap.disturbance_map(lmax=60, step_deg=2.0, device="cpu")
    p64 = io.write_netcdf(ds, tmp_path / "a.nc")
    p32 = io.write_netcdf(ds, tmp_path / "b.nc", dtype="float32")
    assert p32.stat().st_size < 0.6 * p64.stat().st_size  # 0.49 measured (81 x 180 nodes)
    with xr.open_dataset(p32) as back:
        for name in ("east", "north", "up", "modulus", "modulus_mg"):
            assert back[name].dtype == np.float32
            x = ds[name].values
            err = np.abs(back[name].values.astype(np.float64) - x)
            assert np.all(err <= 2.0**-24 * np.abs(x)), name
            assert np.max(err) > 0  # the values were rounded: the check is not vacuous
        # in mGal: at most 6e-8 of the largest value (the bound quoted in the docs)
        assert np.max(np.abs(back.modulus.values - ds.modulus.values)) <= 6e-8 * float(
            ds.modulus.max()
        )
        assert back.latitude.dtype == np.float64
        np.testing.assert_array_equal(back.latitude.values, ds.latitude.values)
    with xr.open_dataset(p64) as back:
        np.testing.assert_array_equal(back.modulus.values, ds.modulus.values)


def test_bad_netcdf_dtype_writes_nothing(tmp_path):
    ds = fieldmap.disturbance_map(**SMALL)
    with pytest.raises(InputError, match="dtype"):
        io.write_netcdf(ds, tmp_path / "x.nc", dtype="float16")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name", [n for n in NAVSIM_RUNS if n != "navsim_paper"])
def test_flight_files_name_the_path_and_their_labels(name, files):
    """The flown path as CF latitude/longitude/height; labels as auxiliary coordinates.

    A string label (run, model, axis…) is no CF coordinate variable (those are numeric): each
    is a ``<dim>_label`` variable that the data variables name in ``coordinates``; read back,
    the labels select (``sel(model_label="j4")``).
    """
    import netCDF4

    with netCDF4.Dataset(files[name]) as nc:
        for var, std, units in (
            ("latitude", "latitude", "degrees_north"),
            ("longitude", "longitude", "degrees_east"),
            ("height", "height_above_reference_ellipsoid", "m"),
        ):
            v = nc.variables[var]
            assert (v.standard_name, v.units) == (std, units) and v.long_name, var
        dims = set(nc.dimensions)
        strings = [n for n, v in nc.variables.items() if v.dtype == str or v.dtype.kind == "S"]
        assert strings and not set(strings) & dims, strings  # no string coordinate variable
        assert {"model_label", "axis_label"} <= set(strings)
        if "run" in dims:
            assert nc.variables["draw"].units == "1"
            assert "run_label" in nc.variables["position_error"].coordinates.split()
    with xr.open_dataset(files[name]) as ds:
        err = ds.set_xindex("model_label")
        first = str(ds["model_label"].values[0])
        assert err.sel(model_label=first)["model_label"].item() == first

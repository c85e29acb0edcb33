"""Permanent-tide systems (fieldmap.models.tide): conversions, round trips, the geoid term, CLI."""

from __future__ import annotations

import itertools
import json
import math

import numpy as np
import pytest

from fieldmap.cli import main
from fieldmap.errors import InputError
from fieldmap.models.registry import kaula_model, load_model
from fieldmap.models.shmodel import SHModel
from fieldmap.models.tide import (
    EKMAN1989_CM,
    IERS2010,
    NGA_EGM,
    TIDE_SYSTEMS,
    convert_tide_system,
    mean_minus_zero_geoid,
)

# EGM2008's C̄20 as NGA publishes it: the tide-free value is the ``gfc 2 0`` line of ICGEM's
# EGM2008.gfc (tide_system tide_free) and of NGA's EGM2008_to2190_TideFree; the zero-tide value
# is the one NGA's EGM2008 README gives (and the TrackerComponentLibrary quotes as "documented
# on the web site providing the EGM2008 coefficients"). The zero-tide C̄20 is the more negative
# one: the permanent deformation flattens the Earth.
EGM2008_C20_TIDE_FREE = -0.484165143790815e-3
EGM2008_C20_ZERO_TIDE = -0.484169317366974e-3


def _egm2008_degree2(system: str, c20: float) -> SHModel:
    C = np.zeros((3, 3))
    C[0, 0], C[2, 0] = 1.0, c20
    return SHModel("EGM2008", 3.986004415e14, 6378136.3, C, np.zeros((3, 3)), 2190, system)


def test_iers_constants():
    """ΔC̄20 of IERS 2010 §6.2.2: (4.4228e-8)(−0.31460)(0.30190) = −4.2007e-9."""
    assert IERS2010.offset("tide_free", "zero_tide") == pytest.approx(-4.2007e-9, abs=1e-13)
    # zero -> mean: the direct term alone, A0·H0 = −1.39141e-8
    assert IERS2010.offset("zero_tide", "mean_tide") == pytest.approx(-1.39141e-8, abs=1e-13)
    assert IERS2010.offset("mean_tide", "tide_free") == pytest.approx(
        -(1 + 0.30190) * -1.39141e-8, rel=1e-5
    )


def test_egm2008_published_pair_agrees():
    """EGM2008 tide-free converted with NGA's constants is NGA's zero-tide C̄20, to its last digit.

    The published values have 15 significant digits (last digit 1e-18): agreement within
    5e-19 is agreement to rounding. With IERS 2010's k20 = 0.30190 instead of NGA's 0.3 the
    two differ by 0.0019 · A0H0 = 2.7e-11 (more than EGM2008's own σ of C̄20, 7.5e-12).
    """
    free = _egm2008_degree2("tide_free", EGM2008_C20_TIDE_FREE)
    zero = _egm2008_degree2("zero_tide", EGM2008_C20_ZERO_TIDE)
    got = convert_tide_system(free, "zero_tide", NGA_EGM)
    assert got.tide_system == "zero_tide"
    assert abs(got.C[2, 0] - EGM2008_C20_ZERO_TIDE) <= 5e-19
    back = convert_tide_system(zero, "tide_free", NGA_EGM)
    assert abs(back.C[2, 0] - EGM2008_C20_TIDE_FREE) <= 5e-19
    iers = convert_tide_system(free, "zero_tide")
    assert abs(iers.C[2, 0] - EGM2008_C20_ZERO_TIDE) == pytest.approx(2.71e-11, abs=0.02e-11)


@pytest.mark.parametrize("start", TIDE_SYSTEMS)
def test_round_trips_are_exact(start):
    """There and back, by any path, restores C̄20 to the last bit; other coefficients untouched."""
    base = load_model("eigen-6s", lmax=12)
    model = convert_tide_system(base, start)  # as if the file were in ``start``
    model = SHModel(
        model.name, model.gm, model.radius, model.C.copy(), model.S, model.nominal_degree, start
    )  # forget the origin: ``start`` is now the file's own system
    for path in itertools.permutations(TIDE_SYSTEMS):
        m = model
        for system in (*path, *reversed(path), start):
            m = convert_tide_system(m, system)
            assert m.tide_system == system
        assert m.C[2, 0] == model.C[2, 0]  # bit for bit
        np.testing.assert_array_equal(m.C, model.C)
        np.testing.assert_array_equal(m.S, model.S)
    # a direct conversion and a detour agree bit for bit too
    direct = convert_tide_system(model, "mean_tide")
    detour = model
    for system in ("zero_tide", "tide_free", "zero_tide", "mean_tide"):
        detour = convert_tide_system(detour, system)
    if start != "mean_tide":
        assert detour.C[2, 0] == direct.C[2, 0]
        assert direct.C[2, 0] != model.C[2, 0]


def test_only_c20_changes_and_the_file_model_is_untouched():
    base = load_model("eigen-6s", lmax=30)
    c20 = float(base.C[2, 0])
    z = convert_tide_system(base, "zero_tide")
    assert base.C[2, 0] == c20 and base.tide_system == "tide_free"  # the cached model kept
    diff = z.C - base.C
    diff[2, 0] = 0.0
    assert not diff.any()
    assert z.C[2, 0] - c20 == pytest.approx(IERS2010.k20 * IERS2010.direct, rel=1e-9)
    assert convert_tide_system(base, "tide_free") is base  # already there


def test_load_model_tide_system():
    m = load_model("eigen-6s", lmax=4, tide_system="mean_tide")
    assert m.tide_system == "mean_tide"
    assert m.C[2, 0] - load_model("eigen-6s", lmax=4).C[2, 0] == pytest.approx(
        IERS2010.level("mean_tide"), rel=1e-9
    )


def test_bad_tide_system_and_unknown_model_system():
    with pytest.raises(InputError, match="tide_free, zero_tide, mean_tide"):
        load_model("eigen-6s", lmax=4, tide_system="tidefree")
    with pytest.raises(InputError, match="tide system is unknown"):
        convert_tide_system(kaula_model(4), "zero_tide")


def test_geoid_term_derived_vs_ekman():
    """R·A0H0·P̄20 (derived) against Ekman (1989) (9.9 − 29.6 sin²φ) cm.

    Ekman's coefficients come from other constants of the permanent tide (0.6 % apart from
    A0H0 of IERS 2010 at the poles): they agree within 0.2 cm, at every latitude.
    """
    lat = np.linspace(-90.0, 90.0, 181)
    derived = 100.0 * mean_minus_zero_geoid(lat, 3.986004418e14, 6378137.0)
    s2 = np.sin(np.radians(lat)) ** 2
    ekman = EKMAN1989_CM[0] + EKMAN1989_CM[1] * s2
    np.testing.assert_allclose(derived, ekman, rtol=0, atol=0.2)
    assert np.max(np.abs(derived - ekman)) > 0.1  # not the same formula
    # zero where P̄20 = 0: sin²φ = 1/3
    zero_lat = math.degrees(math.asin(math.sqrt(1.0 / 3.0)))
    assert abs(mean_minus_zero_geoid(zero_lat, 3.986004418e14, 6378137.0)) < 1e-15


def test_geoid_term_against_the_geoid_of_converted_models():
    """The geoid heights (fieldmap.field.geodesy) of a mean- and a zero-tide model differ by it."""
    from fieldmap.field.geodesy import geoid_height

    zero = load_model("eigen-6s", lmax=8, tide_system="zero_tide")
    mean = load_model("eigen-6s", lmax=8, tide_system="mean_tide")
    lat = np.array([-90.0, -45.0, 0.0, 35.26, 60.0, 90.0])
    lon = np.array([0.0, 10.0, 20.0, 30.0, 40.0, 50.0])
    dn = geoid_height(lat, lon, model=mean, device="cpu") - geoid_height(
        lat, lon, model=zero, device="cpu"
    )
    want = mean_minus_zero_geoid(lat, zero.gm, zero.radius)
    # the geoid is on the ellipsoid (r and γ vary by 0.3 % and 0.5 %): 1 % of 20 cm
    np.testing.assert_allclose(dn, want, rtol=0, atol=2e-3)


def test_cli_map_records_the_tide_system(tmp_path, capsys):
    out = tmp_path / "o"
    args = ["map", "--step-deg", "30", "--lmax", "6", "--no-plots", "--out", str(out)]
    assert main([*args, "--tide-system", "zero_tide"]) == 0
    err = capsys.readouterr().err
    assert "EIGEN-6S: converted from tide_free to zero_tide" in err
    (nc,) = out.glob("*.nc")
    (js,) = out.glob("*.json")
    import xarray as xr

    with xr.open_dataset(nc) as ds:
        assert ds.attrs["model_tide_system"] == "zero_tide"
        assert ds.attrs["model_tide_system_of_file"] == "tide_free"
        assert "converted from tide_free to zero_tide" in ds.attrs["history"]
    assert json.loads(js.read_text())["tide_system"] == "zero_tide"


def test_cli_bad_tide_system_writes_nothing(tmp_path, capsys):
    out = tmp_path / "o"
    with pytest.raises(SystemExit) as exc:  # argparse's choices: one line, status 2
        main(["map", "--step-deg", "30", "--lmax", "6", "--tide-system", "free", "--out", str(out)])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "tide_free" in err[0] and "mean_tide" in err[0]
    assert not out.exists()


def test_cli_unknown_model_system_refused(tmp_path, capsys):
    from fieldmap.models.icgem import write_icgem

    path = tmp_path / "k.gfc"
    write_icgem(path, kaula_model(6))
    out = tmp_path / "o"
    rc = main(
        ["map", "--step-deg", "30", "--model", str(path), "--tide-system", "mean_tide",
         "--out", str(out)]
    )  # fmt: skip
    assert rc == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "tide system is unknown" in err[0]
    assert not out.exists()


def test_navigation_truth_in_the_tables_system(tmp_path, capsys):
    """A flight's truth is converted to the system its compensation tables were built in."""
    from fieldmap.cli.model_options import in_tables_system
    from fieldmap.models.registry import announce
    from fieldmap.products.tables.build import build_table
    from fieldmap.products.tables.files import write_table
    from fieldmap.products.tables.model import load_table

    names = {}
    for system in ("mean_tide", "zero_tide"):
        m = load_model("eigen-6s", lmax=8, tide_system=system)
        tab, rep = build_table((6.8, 8.1, 44.8, 45.5), (2.5, 5.5), 5.0, model=m)
        assert rep["tide_system"] == system
        (nc, *_) = write_table(tab, rep, tmp_path / system)
        assert load_table(str(nc)).meta["tide_system"] == system  # read back from the NetCDF
        names[system] = f"table:{nc}"
    truth = load_model("eigen-6s", lmax=8)
    got = in_tables_system(truth, ["j4", names["mean_tide"]], None)
    assert got.tide_system == "mean_tide"
    assert got.C[2, 0] == convert_tide_system(truth, "mean_tide").C[2, 0]
    announce(got)
    assert "converted from tide_free to mean_tide" in capsys.readouterr().err
    assert in_tables_system(truth, ["j4", "sh8"], None) is truth  # no table: as it is
    with pytest.raises(InputError, match="several tide systems"):
        in_tables_system(truth, list(names.values()), None)
    with pytest.raises(InputError, match="compared in one system"):
        in_tables_system(truth, [names["mean_tide"]], "zero_tide")


def test_cli_zarr_records_the_tide_system(tmp_path):
    pytest.importorskip("zarr")
    import xarray as xr

    out = tmp_path / "z"
    args = ["map", "--step-deg", "30", "--lmax", "6", "--no-plots", "--format", "zarr"]
    assert main([*args, "--tide-system", "mean_tide", "--out", str(out)]) == 0
    (store,) = out.glob("*.zarr")
    with xr.open_zarr(store) as ds:
        assert ds.attrs["model_tide_system"] == "mean_tide"
        assert ds.attrs["model_tide_system_of_file"] == "tide_free"

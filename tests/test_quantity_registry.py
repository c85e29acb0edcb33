"""The registry of map quantities (issue 35): one entry drives a quantity's product.

Through the public API (``fieldmap.quantity_map``, ``fieldmap.disturbance_map``, ``fieldmap
map`` via :func:`fieldmap.cli.main`): every product's variables, units, long and standard names
are its entry's, and an entry changed changes the product; the radial component, added as one
entry, works end to end and is the disturbance vector projected on the geocentric radius
(checked through ECEF, an independent path from the entry's rotation by φ − ψ).
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import fieldmap
from fieldmap.cli import main
from fieldmap.field.frames import geodetic_to_ecef
from fieldmap.models.registry import load_model
from fieldmap.products import quantities
from fieldmap.products.variables import summary

SMALL = {"step_deg": 45.0, "height_km": 20.0}


@pytest.fixture(scope="module")
def model8():
    return load_model("eigen-6s", lmax=8)


def _product(name, model):
    if name == "disturbance":
        return fieldmap.disturbance_map(model=model, **SMALL)
    if name == "ewh":
        from fieldmap.field.water import field_difference

        diff = field_difference(load_model("eigen-6s", lmax=8, epoch=2012.0), model)
        return fieldmap.quantity_map("ewh", model=diff, step_deg=45.0)
    q = quantities.quantity(name)
    options = {"step_deg": 45.0} if q.surface else dict(SMALL)
    return fieldmap.quantity_map(name, model=model, **options)


@pytest.mark.parametrize("name", quantities.MAP_QUANTITIES)
def test_every_product_holds_its_entrys_variables(name, model8):
    """Names (in order), units, long names and CF standard names: the entry's, none other."""
    ds = _product(name, model8)
    entry = quantities.quantity(name)
    maps = [v for v in ds.data_vars if ds[v].dims[-2:] == ("latitude", "longitude")]
    assert maps == list(entry.names)
    for var in entry.variables:
        attrs = ds[var.name].attrs
        want_units = var.units or "mGal"  # the disturbance vector: the units asked (mGal)
        assert attrs["units"] == want_units, var.name
        assert attrs["long_name"] == var.long_name, var.name
        assert attrs.get("standard_name") == var.standard_name, var.name
    if name != "disturbance":
        assert ds.attrs["definition"] == entry.definition(False)
        summ = summary(ds)
        assert [summ[v.name]["units"] for v in entry.variables] == [
            v.units for v in entry.variables
        ]


def test_an_entry_changed_changes_the_product(monkeypatch, model8):
    """The product reads the registry: an entry edited (units, names) is what comes out."""
    geoid = quantities.quantity("geoid")
    edited = dataclasses.replace(
        geoid,
        variables=(
            quantities.Variable("geoid", "cm", "a long name of the test", "test_standard_name"),
        ),
        frame="a frame of the test",
    )
    monkeypatch.setitem(quantities._BY_NAME, "geoid", edited)
    ds = fieldmap.quantity_map("geoid", model=model8, step_deg=45.0)
    attrs = ds["geoid"].attrs
    assert (attrs["units"], attrs["long_name"], attrs["standard_name"]) == (
        "cm",
        "a long name of the test",
        "test_standard_name",
    )
    assert ds.attrs["frame"] == "a frame of the test"
    assert summary(ds)["geoid"]["units"] == "cm"


def test_cli_quantity_choices_are_the_registrys(capsys):
    with pytest.raises(SystemExit):
        main(["map", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for name in quantities.MAP_QUANTITIES:
        assert name in text
    assert "radial (geocentric) component" in text


def _radial_through_ecef(ds_m_s2):
    """δg · r/|r| (mGal) of a disturbance map in m/s², the vector taken to ECEF."""
    lat = np.radians(ds_m_s2["latitude"].values)[:, None]
    lon = np.radians(ds_m_s2["longitude"].values)[None, :]
    e, n, u = (ds_m_s2[c].values for c in ("east", "north", "up"))
    gx = -np.sin(lon) * e - np.sin(lat) * np.cos(lon) * n + np.cos(lat) * np.cos(lon) * u
    gy = np.cos(lon) * e - np.sin(lat) * np.sin(lon) * n + np.cos(lat) * np.sin(lon) * u
    gz = np.cos(lat) * n + np.sin(lat) * u
    lat2, lon2 = np.meshgrid(ds_m_s2["latitude"].values, ds_m_s2["longitude"].values, indexing="ij")
    x, y, z = geodetic_to_ecef(lat2, lon2, float(ds_m_s2["height"]))
    r = np.sqrt(x * x + y * y + z * z)
    return (gx * x + gy * y + gz * z) / r / 1e-5


def test_radial_is_the_disturbance_on_the_geocentric_radius():
    opts = {"lmax": 30, "step_deg": 10.0, "height_km": 20.0}
    ds = fieldmap.quantity_map("radial", **opts)
    vec = fieldmap.disturbance_map(units="m/s2", **opts)
    want = _radial_through_ecef(vec)
    got = ds["radial"].values
    # rounding of two rotations of a ~1e-3 m/s² vector: 1e-9 mGal is 1e-14 m/s²
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
    # it is not the up component: they differ by ~δg_north (φ − ψ), up to 0.19° of tilt
    assert np.abs(got - vec["up"].values / 1e-5).max() > 1e-3
    assert ds["radial"].attrs["units"] == "mGal"


def test_radial_end_to_end_on_the_command_line(tmp_path, capsys):
    out = tmp_path / "o"
    argv = ["map", "--quantity", "radial", "--lmax", "12", "--step-deg", "30", "--out", str(out)]
    assert main(argv) == 0
    names = sorted(p.name for p in out.iterdir())
    stem = "radial_eigen-6s_L12_h20km_latmax60_step30"
    assert names == [f"{stem}.json", f"{stem}.nc", f"{stem}_radial.png"]
    js = json.loads((out / f"{stem}.json").read_text())
    assert js["product"] == "radial" and js["radial"]["units"] == "mGal"
    import xarray as xr

    with xr.open_dataset(out / f"{stem}.nc") as ds:
        api = fieldmap.quantity_map("radial", lmax=12, step_deg=30.0)
        assert np.array_equal(ds["radial"].values, api["radial"].values)
    assert "radial (mGal) h = 20 km" in capsys.readouterr().out

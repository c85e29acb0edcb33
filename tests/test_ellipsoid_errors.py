"""An unknown ellipsoid name is one InputError that lists the known ones, on every path.

``get_ellipsoid("nope")`` says ``unknown ellipsoid 'nope' (known: WGS84, GRS80)``; the point
functions of :mod:`fieldmap.field` and the grid functions of :mod:`fieldmap.grids` and
:mod:`fieldmap.field` raise that same error (an ``AttributeError`` on a string, or a message
without the list, would leave the user guessing).
"""

from __future__ import annotations

import numpy as np
import pytest

from fieldmap.errors import InputError
from fieldmap.field import commission, geodesy, gradient, gravity, normal
from fieldmap.field.commission_grid import grid_commission
from fieldmap.field.ellipsoid import ELLIPSOIDS, get_ellipsoid
from fieldmap.grids import synthesis
from fieldmap.grids.spec import make_grid
from fieldmap.models.registry import kaula_model, load_model
from fieldmap.models.shmodel import SHModel

KNOWN = f"(known: {', '.join(ELLIPSOIDS)})"
P = ([10.0], [20.0], [100.0])


def _grid():
    return make_grid(step_deg=45.0, lat_max=45.0, heights_m=[0.0])


MODEL = kaula_model(4, seed=1)

CALLS = {
    "get_ellipsoid": lambda e: get_ellipsoid(e),
    "gravitation": lambda e: gravity.gravitation(*P, model=MODEL, ellipsoid=e, device="cpu"),
    "gravity": lambda e: gravity.gravity(*P, model=MODEL, ellipsoid=e, device="cpu"),
    "disturbance": lambda e: gravity.disturbance(*P, model=MODEL, ellipsoid=e, device="cpu"),
    "normal_gravity": lambda e: normal.normal_gravity(*P, ellipsoid=e, device="cpu"),
    "normal_gravitation_ecef": lambda e: normal.normal_gravitation_ecef(
        6.4e6, 0.0, 0.0, ellipsoid=e, device="cpu"
    ),
    "somigliana": lambda e: normal.somigliana([10.0], ellipsoid=e),
    "normal_params": lambda e: normal.normal_params(e),
    "disturbing_potential": lambda e: geodesy.disturbing_potential(
        *P, model=MODEL, ellipsoid=e, device="cpu"
    ),
    "gravity_anomaly": lambda e: geodesy.gravity_anomaly(
        *P, model=MODEL, ellipsoid=e, device="cpu"
    ),
    "geoid_height": lambda e: geodesy.geoid_height(
        [10.0], [20.0], model=MODEL, ellipsoid=e, device="cpu"
    ),
    "disturbing_model": lambda e: geodesy.disturbing_model(MODEL, e),
    "gradient_tensor": lambda e: gradient.gradient_tensor(
        *P, model=MODEL, ellipsoid=e, device="cpu"
    ),
    "commission_sigma": lambda e: commission.commission_sigma(
        [10.0], [20.0], model="eigen-6s", lmax=4, ellipsoid=e
    ),
    "grid_quantities": lambda e: geodesy.grid_quantities(
        MODEL, _grid(), "anomaly", ellipsoid=e, device="cpu"
    ),
    "grid_gradient": lambda e: gradient.grid_gradient(
        MODEL, _grid(), "gradient", ellipsoid=e, device="cpu"
    ),
    "grid_commission": lambda e: grid_commission(
        load_model("eigen-6s", lmax=4),
        _grid(),
        "disturbance-sigma",
        ellipsoid=e,
    ),
    "synthesize": lambda e: synthesis.synthesize(MODEL, _grid(), e, device="cpu"),
    "normal_rows": lambda e: synthesis.normal_rows(_grid(), e, device="cpu"),
    "centrifugal_rows": lambda e: synthesis.centrifugal_rows(_grid(), e),
}


@pytest.mark.parametrize("name", sorted(CALLS))
def test_unknown_ellipsoid_lists_the_known(name):
    with pytest.raises(InputError) as exc:
        CALLS[name]("nope")
    text = str(exc.value)
    assert "unknown ellipsoid 'nope'" in text and KNOWN in text, text
    assert "\n" not in text


def _arrays(result) -> list:
    if isinstance(result, dict):
        return list(result.values())
    if isinstance(result, SHModel):
        return [result.C, result.S]
    if isinstance(result, tuple):
        return list(result)
    return [result]


@pytest.mark.parametrize("name", sorted(CALLS))
def test_names_and_objects_give_the_same_result(name):
    """A name is resolved to the very object (same bits as passing it)."""
    if name in ("get_ellipsoid", "normal_params"):
        assert get_ellipsoid("grs80") is ELLIPSOIDS["GRS80"]
        return
    by_name = CALLS[name]("GRS80")
    by_obj = CALLS[name](ELLIPSOIDS["GRS80"])
    flat, ref = _arrays(by_name), _arrays(by_obj)
    assert len(flat) == len(ref) > 0
    for a, b in zip(flat, ref):
        np.testing.assert_array_equal(a, b)

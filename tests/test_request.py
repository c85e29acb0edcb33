"""A map product is one frozen MapRequest, validated once at construction; the engine trusts it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import fieldmap
from fieldmap.errors import InputError
from fieldmap.products.request import Execution, MapRequest, Output


def test_build_validates_and_freezes():
    req = MapRequest.build(lmax=12, height_km=[10, 20], step_deg=30.0, stacked=True, units="mg")
    assert req.model.lmax == 12 and req.grid.heights.tolist() == [1e4, 2e4]
    assert req.output.units == "mg" and req.output.thresholds_mg == (0.02, 0.05, 0.06, 0.1)
    with pytest.raises(dataclasses.FrozenInstanceError):
        req.output = Output()  # type: ignore[misc]
    np.testing.assert_array_equal(
        req.compute()["modulus"].values,
        fieldmap.altitude_sweep(lmax=12, height_km=[10, 20], step_deg=30.0, units="mg")[
            "modulus"
        ].values,
    )


@pytest.mark.parametrize(
    ("options", "words"),
    [
        (dict(units="furlong"), "furlong"),
        (dict(thresholds_mg=[0.1, 0.1]), "distinct"),
        (dict(percentile_method="median"), "median"),
        (dict(quantity="curvature"), "quantity must be one of"),
        (dict(height_km=[10, 20]), "one height"),
        (dict(scheduler="local:0"), "local:N"),
        (dict(chunks=4, rows_per_block=2), "rows_per_block"),
        (dict(quantity="truncation", orders=(2, 3)), "3"),
        (dict(quantity="anomaly", degree0=True, chunks=4, scheduler="threads"), "client="),
        (dict(ellipsoid="mars"), "known: "),
    ],
)
def test_bad_options_are_one_line(options, words):
    with pytest.raises(InputError, match=words) as err:
        MapRequest.build(lmax=4, step_deg=30.0, **options)
    assert "\n" not in str(err.value)


def test_unknown_options_are_type_errors():
    with pytest.raises(TypeError, match="colour"):
        MapRequest.build(colour="red")
    with pytest.raises(TypeError, match="colour"):
        fieldmap.disturbance_map(colour="red")
    with pytest.raises(TypeError, match="thresholds_mg"):  # not an option of a quantity map
        fieldmap.quantity_map("anomaly", thresholds_mg=[0.1])


def test_parts_must_belong_together():
    from fieldmap.models.registry import kaula_model

    req = MapRequest.build(model=kaula_model(4), step_deg=30.0)  # no coefficient sigma
    with pytest.raises(InputError, match="carries no coefficient standard deviations"):
        req.replace(output=Output(quantity="anomaly-sigma", stacked=True))
    with pytest.raises(InputError, match="property of the surface"):
        req.replace(output=Output(quantity="geoid", stacked=True))
    with pytest.raises(InputError, match="one height"):
        MapRequest.build(lmax=4, step_deg=30.0, height_km=[1, 2], stacked=True).replace(
            output=Output()
        )
    assert req.executing(executor="threads").execution == Execution(executor="threads")

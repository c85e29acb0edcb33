"""The gravity budget of a flight study: (a) model difference, (b) omission, (c) commission."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from fieldmap.errors import InputError
from fieldmap.field.commission import commission_draws, commission_sigma
from fieldmap.models.registry import load_model
from fieldmap.nav.study import FlightStudy, run_flight


def test_commission_draws_have_the_propagated_sigma():
    # the realisations (random coefficient sets through the Warp point engine) against the
    # diagonal propagation of commission_sigma (NumPy Legendre rows): no code in common
    model = load_model("eigen-6s", lmax=90)
    lat = np.array([0.0, 45.0, 89.9, -60.0, 12.0])
    lon = np.array([10.0, 200.0, 5.0, -70.0, 33.0])
    h = np.array([0.0, 10_000.0, 500.0, 30_000.0, 100.0])
    draws = 1200
    d = commission_draws(model, lat, lon, h, draws, seed=11)
    got = d.std(axis=0)
    want = commission_sigma(lat, lon, h, model=model)[:, [1, 0, 2]] / 1e5  # ENU mGal -> NED
    # the sample σ of n Gaussian draws errs by σ/√(2n) (2 % here): four of those
    np.testing.assert_allclose(got, want, rtol=4 / np.sqrt(2 * draws))
    again = commission_draws(model, lat, lon, h, draws, seed=11)
    np.testing.assert_array_equal(d, again)


@pytest.fixture(scope="module")
def low_flight():
    study = FlightStudy(
        "47,8,500;47.3,9,500", speed_mps=120, imu="tactical", models="j4,sh40,sh80",
        truth_lmax=80, draws=2, seed=5, omission_model=None,
    )  # fmt: skip
    return run_flight(study)


def test_the_truth_model_contributes_exactly_zero(low_flight):
    g = low_flight.summary["models"]["sh80"]["gravity"]
    assert g["horizontal_terms_m"]["model_difference"] == 0.0
    assert g["vertical_terms_m"]["model_difference"] == 0.0
    assert np.all(low_flight.budget.model_difference["sh80"] == 0.0)
    # its whole contribution is the commission alone; the nonlinear Monte Carlo difference of
    # two runs is not zero (the spread the budget avoids)
    assert g["horizontal_m"] == g["horizontal_terms_m"]["commission"] > 0.0
    assert low_flight.summary["models"]["sh80"]["added_horizontal_error_m"] > 0.0


def test_terms_add_draw_by_draw(low_flight):
    b = low_flight.budget
    tot = b.total("j4")
    np.testing.assert_allclose(tot, b.model_difference["j4"][None] - b.commission, rtol=1e-15)
    # the dataset carries each term's curve
    ds = low_flight.to_dataset()
    assert list(ds["gravity_term_label"].values) == ["total", "model_difference", "omission",
                                                     "commission"]  # fmt: skip
    assert np.all(np.isnan(ds["gravity_contribution"].sel(gravity_term_label="omission")))


def test_commission_refused_without_sigma(tmp_path):
    model = load_model("eigen-6s", lmax=20)
    bare = type(model)(model.name, model.gm, model.radius, model.C, model.S, model.lmax)
    with pytest.raises(InputError, match="no coefficient standard deviations"):
        FlightStudy("47,8,500;47.3,9,500", speed_mps=120, truth=bare, commission=True,
                    omission_model=None, models="j4")  # fmt: skip
    # left to itself the study turns it off, and says so
    study = FlightStudy("47,8,500;47.3,9,500", speed_mps=120, truth=bare, models="j4",
                        omission_model=None)  # fmt: skip
    assert study.gravity_terms.commission is False


def test_low_flight_names_the_field_above_the_truth():
    # a few hundred metres up, a navigation-grade IMU: the truth model itself is no longer free,
    # the field above its degree is what remains, and the recommendation says so
    study = FlightStudy(
        "47,7,300;47.05,8,300", speed_mps=150, imu="navigation", models="j4,sh", draws=2,
        rate_hz=50, seed=2,
    )  # fmt: skip
    res = run_flight(study)
    doc = res.summary
    g = doc["models"]["sh240"]["gravity"]
    terms = g["horizontal_terms_m"]
    assert terms["model_difference"] == 0.0
    assert terms["omission"] > terms["commission"] > 0.0
    assert g["dominant"] == "omission"
    assert g["horizontal_m"] == pytest.approx(np.hypot(terms["omission"], terms["commission"]))
    meta = doc["meta"]["gravity_terms"]
    assert meta["omission_model"] == "tscherning-rapp" and meta["omission_degrees"][0] == 241
    # the omission's σ at 300 m is tens of mGal (TR model 4 above degree 240)
    assert 10.0 < meta["omission_sigma_max_mgal"]["down"] < 60.0
    # the IMU-only error is about 100 m here: even the truth's own 19 m is above 10 % of it
    assert doc["recommended_model"] is None
    assert "The field above degree 240 (omission) dominates" in doc["recommendation"]
    assert "a higher-degree model, or a table built from one, is needed" in doc["recommendation"]
    # off: the budget holds the model difference and the commission only
    off = run_flight(replace(study, omission_model="none"))
    assert off.summary["models"]["sh240"]["gravity"]["horizontal_terms_m"]["omission"] is None
    assert off.summary["meta"]["gravity_terms"]["omission_model"] is None

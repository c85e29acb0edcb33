"""The linear error model (fieldmap.nav.linear) against closed forms and the strapdown runs."""

from __future__ import annotations

import numpy as np
import pytest

from fieldmap.field.ellipsoid import WGS84
from fieldmap.nav.linear import position_response


def test_schuler_at_the_equator_closed_form():
    # at rest on the equator a north gravity error excites the Schuler loop alone: north is
    # the rotation axis there, so neither Coriolis nor centrifugal terms act on it, and
    # δr_N = δg/ω²(1 − cos ωt) with ω² = GM/r³ exactly (the model's point-mass gradient)
    t = np.arange(0.0, 3 * 3600.0 + 1.0, 2.0)
    track = np.zeros((t.size, 3))
    dg = np.zeros((t.size, 3))
    dg[:, 0] = 1e-4  # 10 mGal north
    x = position_response(t, track, dg, WGS84)
    w2 = WGS84.GM / WGS84.a**3
    expect = 1e-4 / w2 * (1.0 - np.cos(np.sqrt(w2) * t))
    np.testing.assert_allclose(x[:, 0], expect, rtol=0, atol=1e-6 * expect.max())
    assert np.abs(x[:, 1:]).max() < 1e-9 * expect.max()
    period = 2 * np.pi / np.sqrt(w2) / 60.0
    assert 84.0 < period < 85.0  # the Schuler period


def test_short_time_half_g_t_squared():
    # well inside the Schuler period the error grows as ½ δg t² in every horizontal direction;
    # the Coriolis term turns it by about Ω t sin φ (3e-3 at 60 s), the Schuler term by (ωt)²/12
    t = np.arange(0.0, 61.0, 1.0)
    track = np.column_stack([np.full(t.size, 47.0), np.full(t.size, 8.0), np.full(t.size, 900.0)])
    dg = np.tile([2e-5, -3e-5, 0.0], (t.size, 1))
    x = position_response(t, track, dg, WGS84)
    np.testing.assert_allclose(x[-1, :2], 0.5 * dg[0, :2] * 60.0**2, rtol=5e-3)


def test_zero_input_gives_exactly_zero_and_inputs_add():
    t = np.arange(0.0, 600.0, 5.0)
    track = np.column_stack([np.linspace(40, 41, t.size), np.linspace(0, 2, t.size),
                             np.full(t.size, 3000.0)])  # fmt: skip
    rng = np.random.default_rng(3)
    a, b = rng.normal(0, 1e-4, (2, t.size, 3))
    gains = (0.03, 3e-4 + 2 * 9.8 / 6.378e6, 1e-6)
    x = position_response(t, track, np.stack([np.zeros_like(a), a, b, a + b]), WGS84, gains)
    assert np.all(x[0] == 0.0)
    np.testing.assert_allclose(x[3], x[1] + x[2], rtol=0, atol=1e-9 * np.abs(x[3]).max())


@pytest.mark.parametrize(("frame", "aiding"), [("ned", "none"), ("ned", "baro"), ("lci", "none")])
def test_agrees_with_the_strapdown_mechanization(frame, aiding):
    # an ideal IMU: the only error of a run is its gravity model's; the nonlinear mechanization
    # (Warp kernels) and the linear model share no code
    from fieldmap.nav.mechanize import baro_gains
    from fieldmap.nav.study import FlightStudy, run_flight

    study = FlightStudy(
        "47,8,3000;49,14,3000", speed_mps=200, imu="ideal", models="j2,sh12", truth_lmax=30,
        frame=frame, altitude_aiding=aiding, duration=1200, rate_hz=100, omission_model=None,
        commission=False,
    )  # fmt: skip
    res = run_flight(study)
    ell = study.flight.frame.ellipsoid
    gains = baro_gains(study.baro.loop_tau_s, ell) if aiding == "baro" else None
    models = np.array(res.models)
    ref = res.dpos[models == "imu_only"][0]
    for m in ("j2", "sh12"):
        nonlinear = res.dpos[models == m][0] - ref
        linear = position_response(res.t, res.track, res.dg[m], ell, gains)
        scale = np.abs(nonlinear).max()
        assert scale > 10.0  # a real effect, not noise
        assert np.abs(linear - nonlinear).max() < 5e-3 * scale
        # and the study's own budget is this response (other columns beside it in one pass)
        np.testing.assert_allclose(res.budget.model_difference[m], linear, rtol=1e-12, atol=1e-12)


def test_lci_flight_velocity_error_is_earth_relative():
    # an ideal IMU in the launch-centred inertial frame: the velocity error is zero, not the
    # Earth's ω × r (400 m/s east here: it was subtracted twice before issue 26)
    from fieldmap.nav.study import FlightStudy, run_flight
    from fieldmap.nav.trajectory import BoostGlide

    study = FlightStudy(
        BoostGlide(), imu="ideal", models="sh", frame="lci", draws=1, duration=100,
        truth_lmax=20, omission_model=None, commission=False,
    )  # fmt: skip
    res = run_flight(study)
    assert np.abs(res.dpos).max() < 0.05
    assert np.abs(res.dvel).max() < 1e-3

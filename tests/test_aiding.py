"""GNSS-aided navigation through outages (fieldmap.nav.aiding): covariance against Monte Carlo.

The Monte Carlo runs are the strapdown kernels with the sensor draws of fieldmap.nav.sensors,
stopped at every fix and corrected by the filter (feedback); the covariance analysis is the
linear error-state model in NumPy with Joseph-form updates. They share the filter's gains (a
simulation's filter, designed on the true trajectory) but not the errors: the Monte Carlo's are
those of the nonlinear strapdown, measured against the truth.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from refusals import refused

from fieldmap.cli import main
from fieldmap.errors import InputError
from fieldmap.nav.aiding import GnssSpec, parse_outages
from fieldmap.nav.covariance import covariance_analysis
from fieldmap.nav.study import FlightStudy, run_flight

ROUTE = "47,8,3000;49,20,3000"


def _study(**kw):
    opts = dict(
        speed_mps=200, imu="tactical", models="j4", truth_lmax=10, altitude_aiding="none",
        duration=800.0, rate_hz=10, draws=200, seed=5, omission_model=None, commission=False,
        gnss=GnssSpec(rate_hz=1.0, sigma_m=2.0, velocity_sigma_mps=0.05,
                      outages="100:300,450:300", bias_m=1.0, bias_tau_s=300.0),
    )  # fmt: skip
    opts.update(kw)
    return FlightStudy(ROUTE, **opts)


@pytest.fixture(scope="module")
def aided():
    study = _study()
    return study, run_flight(study)


def _mc_h(res):
    d = res.dpos[np.array(res.models) == "imu_only"]
    return np.sqrt(np.mean(d[..., 0] ** 2 + d[..., 1] ** 2, 0))


def test_covariance_agrees_with_monte_carlo_through_two_outages(aided):
    # 200 draws: the horizontal RMS errs by about 1/√(4·200) = 3.5 % (1σ); the bound
    # is 10 % over the whole flight (the first seconds, errors of centimetres, left out)
    study, res = aided
    cov = covariance_analysis(study, res.t)
    mc = _mc_h(res)
    late = res.t > 30.0
    ratio = mc[late] / cov.horizontal()[late]
    assert np.all(np.abs(ratio - 1.0) < 0.10), (ratio.min(), ratio.max())
    # the coasting error at the end of each outage: tens of metres, against ~0.5 m aided
    for end in (400.0, 750.0):
        i = int(np.searchsorted(res.t, end))
        assert cov.horizontal()[i] > 20.0 * cov.horizontal()[i - 301]
        assert mc[i] / cov.horizontal()[i] == pytest.approx(1.0, abs=0.10)
    doc = res.summary["gnss"]
    assert [o["end_s"] for o in doc["outages"]] == [400.0, 750.0]
    assert doc["outages"][1]["imu_only_horizontal_error_m"] == pytest.approx(mc[750], rel=1e-12)


def test_filter_is_consistent(aided):
    # NEES of position and velocity (6 states) over 200 draws: its mean at each fix lies within
    # the χ²(1200)/200 bounds at about 95 % of the fixes when the filter is consistent; a filter
    # whose covariance is off by 20 % leaves them (bounds ±8 %)
    nees = aided[1].summary["gnss"]["nees"]
    assert nees["fixes"] == 200  # at 1..800 s, less two outages of 300 s
    assert nees["mean"] == pytest.approx(6.0, rel=0.08)
    assert nees["fraction_within"] > 0.85


def test_feedback_matters():
    # without the filter's corrections (a fix noise so large the gains vanish) the errors grow
    # as free inertial: the aided run must be far below that
    aided = covariance_analysis(_study(draws=1))
    loose = covariance_analysis(
        _study(draws=1, gnss=GnssSpec(rate_hz=1.0, sigma_m=1e6, velocity_sigma_mps=None))
    )
    assert aided.horizontal()[-1] < 0.02 * loose.horizontal()[-1]


def test_covariance_sources_add_up_to_the_filter():
    # each source through the filter's gains (Joseph form) adds up to the filter's own P
    study = _study(draws=1, imu="navigation", altitude_aiding="baro",
                   gnss=GnssSpec(outages="100:300,450:300"))  # fmt: skip
    cov = covariance_analysis(study)
    P = cov.design.P
    from fieldmap.nav.frames import C_n_to_e
    from fieldmap.nav.trajectory import geodetic_state

    lat, lon, *_ = geodetic_state(study.flight, cov.t)
    ned = np.swapaxes(C_n_to_e(lat, lon), -1, -2)
    sig = np.sqrt(np.einsum("nij,njk,nik->ni", ned, P[:, 0:3, 0:3], ned))
    np.testing.assert_allclose(cov.total(), sig, rtol=1e-6, atol=1e-9)
    assert "GNSS noise" in cov.sources and "baro noise" in cov.sources
    assert "GNSS bias" not in cov.sources
    biased = covariance_analysis(_study(draws=1))  # the module's study: a GNSS bias
    assert "GNSS bias" in biased.sources


def test_outage_forms():
    assert parse_outages("600:300, 20min:5min") == (((600.0, 300.0), (1200.0, 300.0)), None)
    assert parse_outages("every 30min:5min") == ((), (1800.0, 300.0))
    g = GnssSpec(outages="every 30min:5min")
    np.testing.assert_array_equal(
        g.intervals(3 * 3600.0), [[1800, 2100], [3600, 3900], [5400, 5700], [7200, 7500],
                                  [9000, 9300]]
    )  # fmt: skip
    t = np.arange(0.0, 3000.0)
    up = g.updates(t)
    assert not up[0] and up[1] and not up[1800] and not up[2099] and up[2100]


@pytest.mark.parametrize(
    ("kw", "words"),
    [
        ({"sigma_m": 0.0}, "gnss.sigma_m must be a positive number"),
        ({"sigma_m": -1.0}, "gnss.sigma_m must be a positive number"),
        ({"velocity_sigma_mps": -0.1}, "gnss.velocity_sigma_mps"),
        ({"outages": "100:300,300:100"}, "overlap"),
        ({"outages": "100:-5"}, "duration > 0"),
        ({"outages": "every 5min:5min"}, "overlap"),
        ({"outages": "abc"}, "START:DURATION"),
        ({"bias_m": -1.0}, "gnss.bias_m must be a number >= 0"),
        ({"bias_m": 1.0, "bias_tau_s": 0.0}, "gnss.bias_tau_s must be a positive number"),
    ],
)
def test_bad_spec(kw, words):
    with pytest.raises(InputError, match=words):
        GnssSpec(**kw)


@pytest.mark.parametrize(
    ("gnss", "words"),
    [
        (GnssSpec(outages="700:300"), "ends after the flight"),
        (GnssSpec(rate_hz=20.0), "above the IMU rate"),
        (GnssSpec(rate_hz=3.0), "whole number of IMU samples"),
    ],
)
def test_bad_for_the_flight(gnss, words):
    with pytest.raises(InputError, match=words):
        _study(draws=1, gnss=gnss)


# ------------------------------------------------------------------------------ command line
FAST = ["navsim", "--route", "47,8,800;47.3,8.8,800", "--speed-mps", "150", "--imu", "tactical",
        "--lmax", "10", "--models", "j4", "--rate", "10", "--no-timing"]  # fmt: skip


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--gnss-outage", "400:100"], ("--gnss-outage", "ends after the flight")),
        (["--gnss-outage", "100:100,150:100"], ("--gnss-outage", "overlap")),
        (["--gnss-sigma", "0"], ("--gnss-sigma", "positive")),
        (["--gnss-sigma", "-2"], ("--gnss-sigma", "positive")),
        (["--gnss-rate", "50"], ("--gnss-rate", "above the IMU rate", "(--rate)")),
        (["--gnss-velocity-sigma", "fast"], ("--gnss-velocity-sigma",)),
        (["--gnss-bias", "-1"], ("--gnss-bias", ">= 0")),
        (["--gnss-bias", "1:x"], ("--gnss-bias", "M[:TAU_S]")),
    ],
)
def test_bad_gnss_options(args, words, tmp_path, capsys):
    refused([*FAST, *args], tmp_path, capsys, *words)


def test_gnss_options_refused_in_the_papers_studies(tmp_path, capsys):
    refused(["navsim", "--study", "table1", "--gnss-rate", "1"], tmp_path, capsys,
            "--gnss-rate", "flight studies")  # fmt: skip


def test_aided_covariance_study_from_the_command_line(tmp_path, capsys):
    out = tmp_path / "out"
    rc = main([*FAST, "--method", "covariance", "--gnss-outage", "60:60,200:100",
               "--out", str(out)])  # fmt: skip
    assert rc == 0
    text = capsys.readouterr().out
    assert "coasting" in text and "GNSS aiding" in text
    doc = json.loads((out / "navsim_flight.json").read_text())
    ends = [o["end_s"] for o in doc["gnss"]["outages"]]
    assert ends == [120.0, 300.0]
    assert doc["recommendation"].startswith("coasting through the outage ending at")
    import xarray as xr

    with xr.open_dataset(out / "navsim_flight.nc") as ds:
        assert ds["coasting_horizontal_error"].shape == (2, 2)
        assert ds["outage_end"].values.tolist() == ends


# ----------------------------------------------------------------------------------- pyins
@pytest.mark.slow
def test_coasting_error_matches_pyins_feedback_filter():
    # pyins (1.0) run_feedback_filter on the same IMU increments (fieldmap's synthesis with the
    # draw's biases applied by fieldmap.nav.sensors.apply, then pyins' own coning/sculling
    # preparation, compute_increments_from_imu) and the same position fixes (the truth plus
    # GnssSpec.fix_noise): the horizontal error at the end of a 5-minute outage after 60 s of
    # fixes. Observed: 302.57 m (fieldmap) against 302.30 m (pyins), 0.1 %; the bound
    # is 10 %. (A 10 deg/h gyro bias on a straight flight leaves the heading nearly
    # unobservable and the two filters' estimates differ by up to 8 %.)
    pd = pytest.importorskip("pandas")
    pyins = pytest.importorskip("pyins")
    from pyins import filters, inertial_sensor, measurements, strapdown, transform
    from pyins.util import ACCEL_COLS, GYRO_COLS

    from fieldmap.field.frames import ecef_to_geodetic
    from fieldmap.nav import sensors
    from fieldmap.nav.imu import Gravitation, ImuSampling, synthesize
    from fieldmap.nav.sensors import ImuErrorSpec
    from fieldmap.nav.trajectory import geodetic_state

    assert pyins.__version__ == "1.0"
    rate, seed, (t0, dur) = 5.0, 7, (60.0, 300.0)
    end = t0 + dur
    spec = ImuErrorSpec(accel_bias_ug=1000.0, gyro_bias_deg_per_h=1.0)
    gnss = GnssSpec(rate_hz=1.0, sigma_m=0.5, velocity_sigma_mps=None, outages=f"{t0:g}:{dur:g}")
    study = FlightStudy(
        "47,8,500;47.5,9,500", speed_mps=150, imu=spec, models="j4", truth_lmax=10,
        altitude_aiding="none", duration=end, rate_hz=rate, draws=1, seed=seed,
        omission_model=None, commission=False, gnss=gnss,
    )  # fmt: skip
    res = run_flight(study)
    i = int(np.searchsorted(res.t, end))
    assert res.t[i] == end
    d = res.dpos[np.array(res.models) == "imu_only"][0, i]
    ours = float(np.hypot(d[0], d[1]))

    traj = study.flight
    ell = traj.frame.ellipsoid
    dt = 1.0 / rate
    inc = synthesize(traj, ImuSampling(rate, 3), Gravitation("j4", ellipsoid=ell), duration=end)
    th, dv = sensors.apply(inc.dtheta, inc.dv, dt, sensors.draw(spec, 1, seed=seed), 0)
    t = dt * np.arange(th.shape[0] + 1)
    # raw increments over (t_{k-1}, t_k]; the row at t = 0 only seeds the two-sample corrections
    raw = pd.DataFrame(np.column_stack([np.r_[th[:1], th], np.r_[dv[:1], dv]]), index=t,
                       columns=GYRO_COLS + ACCEL_COLS)  # fmt: skip
    increments = strapdown.compute_increments_from_imu(raw, "increment")
    tf = np.arange(0.0, end + 0.5)  # the output grid (1 s): fix k at index k
    lat, lon, h, v, C = geodetic_state(traj, tf)
    rph = transform.mat_to_rph(C[0])
    pva0 = pd.Series(
        {"lat": lat[0], "lon": lon[0], "alt": h[0], "VN": v[0, 0], "VE": v[0, 1],
         "VD": v[0, 2], "roll": rph[0], "pitch": rph[1], "heading": rph[2]},
        name=0.0,
    )  # fmt: skip
    r = traj.kinematics(tf).r_e + np.stack([gnss.fix_noise(seed, k, 1)[0] for k in range(tf.size)])
    flat, flon, fh = ecef_to_geodetic(r[:, 0], r[:, 1], r[:, 2], ell)
    on = gnss.updates(tf)
    fixes = pd.DataFrame({"lat": flat[on], "lon": flon[on], "alt": fh[on]}, index=tf[on])
    out = filters.run_feedback_filter(
        pva0, 1e-3, 1e-4, 1e-5, 1e-5, increments,
        gyro_model=inertial_sensor.EstimationModel(
            bias_sd=spec.gyro_bias_deg_per_h * sensors.DEG_H
        ),
        accel_model=inertial_sensor.EstimationModel(bias_sd=spec.accel_bias_ug * sensors.UG),
        measurements=[measurements.Position(fixes, gnss.sigma_m)], time_step=1.0,
    )  # fmt: skip
    row = out.trajectory.loc[end, ["lat", "lon", "alt"]].to_numpy(dtype=float)
    dn = transform.compute_lla_difference(row, np.array([lat[-1], lon[-1], h[-1]]))
    theirs = float(np.hypot(dn[0], dn[1]))
    assert theirs > 100.0  # a coasting error, not the fixes' noise
    assert ours == pytest.approx(theirs, rel=0.03)


def test_fixes_must_fall_on_stored_states():
    with pytest.raises(InputError, match="must fall on stored states"):
        _study(draws=1, output_dt=2.0, gnss=GnssSpec(rate_hz=1.0))
    with pytest.raises(InputError, match="frame='ned'"):
        _study(draws=1, frame="lci", gnss=GnssSpec())
    # the default output interval (1 s for 800 s) shortened, where needed, to divide the fixes'
    # interval (0.4 Hz at 10 Hz: 25 samples apart, stored every 5)
    assert _study(draws=1, gnss=GnssSpec(rate_hz=0.2)).output_dt_s == 1.0
    assert _study(draws=1, gnss=GnssSpec(rate_hz=0.4)).output_dt_s == 0.5

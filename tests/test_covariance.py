"""Linear covariance analysis (fieldmap.nav.covariance) against Monte Carlo and closed forms.

The Monte Carlo runs are the strapdown kernels with the sensor draws of fieldmap.nav.sensors;
the covariance analysis shares no code with them (its own error-state model in NumPy).
"""

from __future__ import annotations

import numpy as np
import pytest

from fieldmap.errors import InputError
from fieldmap.nav.covariance import covariance_analysis
from fieldmap.nav.sensors import ImuErrorSpec
from fieldmap.nav.study import FlightStudy, run_flight


def _mc_sigma(res):
    """RMS over the draws of the IMU-only runs: horizontal and down (n,)."""
    d = res.dpos[np.array(res.models) == "imu_only"]
    return np.sqrt(np.mean(d[..., 0] ** 2 + d[..., 1] ** 2, 0)), np.sqrt(np.mean(d[..., 2] ** 2, 0))


@pytest.mark.parametrize(
    ("imu", "aiding", "duration"), [("tactical", "none", 1800.0), ("navigation", "baro", 10800.0)]
)
def test_agrees_with_monte_carlo(imu, aiding, duration):
    # the cases: a tactical IMU free-inertial for 30 min, a navigation IMU with baro for
    # 3 h (measured: 0.986..1.013 and 0.969..1.034); 200 draws: the RMS of n draws errs by
    # about 1/√(2n) per axis (5 %), the horizontal one by 1/√(4n) (3.5 %); 10 % is the issue's
    # bound
    study = FlightStudy(
        "45,-5,3000;50,30,3000", speed_mps=200, imu=imu, models="j4", truth_lmax=10,
        altitude_aiding=aiding, duration=duration, rate_hz=25, draws=200, seed=3,
        omission_model=None, commission=False,
    )  # fmt: skip
    res = run_flight(study)
    cov = covariance_analysis(study, res.t)
    mc_h, mc_v = _mc_sigma(res)
    late = res.t > 60.0  # the first seconds: errors of millimetres
    ratio = mc_h[late] / cov.horizontal()[late]
    assert np.all(np.abs(ratio - 1.0) < 0.10), (ratio.min(), ratio.max())
    ratio_v = mc_v[late] / cov.total()[late, 2]
    assert np.all(np.abs(ratio_v - 1.0) < 0.15), (ratio_v.min(), ratio_v.max())


def _stationary(spec: ImuErrorSpec, duration: float, lat: float = 0.0):
    from fieldmap.nav.frames import LaunchFrame
    from fieldmap.nav.trajectory import Stationary

    traj = Stationary(LaunchFrame(10.0, lat, 0.0, 0.0), duration, lat=lat, lon=10.0, h=0.0)
    return FlightStudy(traj, imu=spec, models="j4", altitude_aiding="none", draws=1,
                       omission_model=None, commission=False)  # fmt: skip


def test_accelerometer_bias_half_b_t_squared_and_schuler():
    # at rest on the equator, a constant accelerometer bias b (σ per axis): each horizontal
    # axis errs by b/ω²(1 − cos ωt), ω² = GM/r³ (½ b t² early on); north is the Earth's axis
    # there, so its channel is the pure Schuler loop
    b = 100e-6 * 9.80665
    study = _stationary(ImuErrorSpec(accel_bias_ug=100.0), 2.0 * 3600.0)
    cov = covariance_analysis(study)
    ell = study.flight.frame.ellipsoid
    w = np.sqrt(ell.GM / ell.a**3)
    sig_n = cov.position["accelerometer bias"][:, 0]
    want = b / w**2 * (1.0 - np.cos(w * cov.t))
    np.testing.assert_allclose(sig_n[1:], want[1:], rtol=2e-3)
    early = cov.t < 120.0
    np.testing.assert_allclose(sig_n[early][1:], 0.5 * b * cov.t[early][1:] ** 2, rtol=5e-3)


def test_sources_are_those_of_the_spec():
    spec = ImuErrorSpec(gyro_bias_deg_per_h=1.0, accel_vrw_ug_per_sqrt_hz=50.0)
    cov = covariance_analysis(_stationary(spec, 600.0, lat=45.0))
    assert cov.sources == ["gyro bias", "velocity random walk"]
    tot2 = sum(v**2 for v in cov.position.values())
    np.testing.assert_allclose(cov.total() ** 2, tot2)


def test_covariance_study_from_the_command_line(tmp_path, capsys):
    from fieldmap import cli

    out = tmp_path / "out"
    rc = cli.main([
        "navsim", "--route", "47,8,800;47.3,8.8,800", "--speed-mps", "150", "--imu", "tactical",
        "--models", "j4,sh60", "--lmax", "60", "--rate", "20", "--method", "covariance",
        "--out", str(out),
    ])  # fmt: skip
    assert rc == 0
    text = capsys.readouterr().out
    assert "linear covariance analysis" in text and "gyro bias" in text
    assert sorted(p.name for p in out.iterdir()) == [
        "navsim_flight.csv", "navsim_flight.json", "navsim_flight.nc", "navsim_flight.png",
        "navsim_flight_budget.png",
    ]  # fmt: skip
    import json

    doc = json.loads((out / "navsim_flight.json").read_text())
    assert doc["meta"]["method"] == "covariance"
    assert doc["models"]["sh60"]["gravity"]["horizontal_terms_m"]["model_difference"] == 0.0


def test_bad_method():
    with pytest.raises(InputError, match="method must be"):
        FlightStudy("47,8,800;47.3,8.8,800", speed_mps=150, method="kalman")


def test_ideal_imu_has_no_sources():
    cov = covariance_analysis(_stationary(ImuErrorSpec(), 300.0))
    assert cov.sources == [] and np.all(cov.total() == 0.0) and np.all(cov.horizontal() == 0.0)

"""Truth gravitation interpolated along the path vs the full SH evaluation (issue 16).

The reference here is the SH model evaluated at every point, independent of the interpolation;
the paths are the paper's boost-glide (the field changes fastest there) and an airliner route.
"""

from __future__ import annotations

import numpy as np
import pytest

from fieldmap.nav.gravity import TrackGravitation
from fieldmap.nav.imu import Gravitation, ImuSampling, load_truth_model, synthesize
from fieldmap.nav.trajectory import BoostGlide, FlightTrajectory, route_flight

MGAL = 1e-5


@pytest.fixture(scope="module")
def model():
    return load_truth_model(lmax=120)


def _paths():
    return {
        "boost-glide": BoostGlide(),
        "airliner": FlightTrajectory(route_flight("47,8,500;48.5,12,11000;50,16,11000", 230.0)),
    }


@pytest.mark.parametrize("name", ["boost-glide", "airliner"])
def test_interpolated_disturbance_within_its_stated_bound(model, name):
    traj = _paths()[name]
    tg = TrackGravitation(model, traj, device="cpu")
    assert tg.max_error_mgal <= 1e-4
    rng = np.random.default_rng(1)
    t = np.sort(rng.uniform(0.0, traj.duration, 400))
    r = traj.kinematics(t).r_e
    sh = Gravitation("sh", model=model, device="cpu")
    full = sh(r) - Gravitation("exact", device="cpu")(r)
    err = np.linalg.norm(tg.disturbance_at(t) - full, axis=1) / MGAL
    assert err.max() < 1e-3  # random points, not only the checked midpoints
    got = tg.at_times(t, r)
    assert np.max(np.abs(got - sh(r))) / MGAL < 1e-3


def test_same_bits_whatever_the_pieces(model):
    traj = _paths()["airliner"]
    t = np.linspace(0.0, traj.duration, 3001)
    whole = TrackGravitation(model, traj, device="cpu").disturbance_at(t)
    tg = TrackGravitation(model, traj, device="cpu")
    parts = np.concatenate([tg.disturbance_at(p) for p in np.array_split(t[::-1], 7)])[::-1]
    assert np.array_equal(whole, parts)


def test_increments_agree_with_the_full_synthesis(model):
    traj = _paths()["boost-glide"]
    full = synthesize(
        traj, ImuSampling(100.0), Gravitation("sh", model=model, device="cpu"), duration=200.0
    )
    fast = synthesize(
        traj, ImuSampling(100.0), TrackGravitation(model, traj, device="cpu"), duration=200.0
    )
    assert np.array_equal(full.dtheta, fast.dtheta)
    # dv error / dt: the specific-force error in mGal
    assert np.max(np.abs(full.dv - fast.dv)) / full.dt / MGAL < 1e-4


def test_flight_study_same_answer_as_the_full_evaluation(model):
    from fieldmap.nav import study
    from fieldmap.nav.sensors import load_imu

    ft = _paths()["airliner"]
    name, imu = load_imu("navigation")
    kw = dict(
        imu=imu, imu_name=name, models=["j4", "exact", "sh60"], draws=2, rate_hz=50.0,
        truth_lmax=120, duration=600.0, output_dt=10.0,
    )  # fmt: skip
    fast = study.run_flight(study.FlightStudy(ft, **kw), device="cpu")
    full = study.run_flight(study.FlightStudy(ft, **kw, truth_evaluation="full"), device="cpu")
    assert fast.summary["meta"]["truth_interpolation_max_error_mgal"] <= 1e-4
    for m, e in full.summary["models"].items():
        a = e["final_horizontal_error_m"]["rms"]
        b = fast.summary["models"][m]["final_horizontal_error_m"]["rms"]
        assert abs(a - b) <= 1e-3 * abs(a) + 1e-6, m


@pytest.mark.parametrize("frame", ["ned", "lci"])
def test_navigation_gravity_rate_agrees_with_every_step(model, frame):
    """SH navigation at the default gravity rate vs the full model every step (issue 16).

    The added error of each SH model (its final error minus the normal model's: the model's
    own effect) agrees within 1 % between the two.
    """
    from fieldmap.nav import study

    ft = _paths()["airliner"]
    kw = dict(
        models=["exact", "sh60", "sh"], rate_hz=50.0, truth_lmax=120, duration=900.0,
        output_dt=10.0, frame=frame, altitude_aiding="none",
    )  # fmt: skip
    fast = study.run_flight(study.FlightStudy(ft, **kw), device="cpu")
    full = study.run_flight(study.FlightStudy(ft, **kw, gravity_rate_hz="full"), device="cpu")
    assert fast.summary["meta"]["gravity_update_every_samples"] > 20
    assert full.summary["meta"]["gravity_update_every_samples"] == 1
    i_norm = fast.models.index("exact")
    for m in ("sh60", "sh120"):
        i = fast.models.index(m)
        own = full.dpos[i, -1] - full.dpos[i_norm, -1]
        diff = fast.dpos[i, -1] - full.dpos[i, -1]
        assert np.linalg.norm(diff) <= 0.01 * np.linalg.norm(own), (m, diff, own)


def test_gravity_rate_bad_values():
    from fieldmap.errors import InputError
    from fieldmap.nav.gravity import gravity_update_every

    traj = _paths()["airliner"]
    assert gravity_update_every(traj, 240, 200.0, "full") == 1
    assert gravity_update_every(traj, 240, 200.0, 10.0) == 20
    for bad in (-1.0, float("nan"), "fast"):
        with pytest.raises(InputError, match="gravity rate"):
            gravity_update_every(traj, 240, 200.0, bad)

"""Sensor noise keyed on (run seed, global IMU sample index): the same whatever the blocking.

The white noise, Gauss–Markov bias-instability and baro noise/drift draws of IMU sample j come
from ``wp.rand_init(seed, j)`` (``kernels.strapdown.sample_rng``), so a flight propagated in
one, three or fifteen time blocks, or a record propagated in two halves, gives the same bits.
"""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from fieldmap.nav.imu import ImuSampling
from fieldmap.nav.mechanize import (
    Baro,
    LciStart,
    NavConfig,
    NedStart,
    baro_gains,
    dcm_to_quat,
    propagate_lci,
    propagate_ned,
)
from fieldmap.nav.sensors import ImuErrorSpec
from fieldmap.nav.study import BaroSpec, FlightStudy, run_flight
from fieldmap.nav.trajectory import FlightTrajectory, route_flight

ROUTE = "45,7,3000;45.3,7.4,5000;45.1,7.9,5000"

#: every noise source on (white noise, bias instability with a short τ), plus biases
NOISY = ImuErrorSpec(
    accel_bias_ug=100.0,
    accel_vrw_ug_per_sqrt_hz=50.0,
    gyro_bias_deg_per_h=1.0,
    gyro_arw_deg_per_sqrt_h=0.1,
    accel_bias_instability_ug=50.0,
    accel_bias_instability_tau_s=60.0,
    gyro_bias_instability_deg_per_h=0.5,
    gyro_bias_instability_tau_s=60.0,
)


@pytest.fixture(scope="module")
def flight():
    return FlightTrajectory(route_flight(ROUTE, 200.0))


def _study(ft, frame, block_s, seed=3):
    kw = {"altitude_aiding": "baro", "baro": BaroSpec()} if frame == "ned" else {}
    return run_flight(
        FlightStudy(
            ft,
            imu=NOISY,
            models=["j4", "exact"],
            draws=2,
            seed=seed,
            rate_hz=50.0,
            truth_lmax=30,
            output_dt=2.0,
            duration=120.0,
            block_s=block_s,
            frame=frame,
            **kw,
        ),
        device="cpu",
    )


@pytest.mark.parametrize("frame", ["ned", "lci"])
def test_flight_errors_do_not_depend_on_the_blocking(flight, frame):
    """Noise, bias instability and baro noise on: 1, 3 and 15 blocks give the same bits.

    Before the draws were keyed on the sample index (noise of block b seeded ``seed + 7919 b``)
    the blockings differed by 8-26 m here.
    """
    one = _study(flight, frame, 120.0)
    assert one.summary["meta"]["block_s"] == 120.0
    for block_s in (40.0, 8.0):
        other = _study(flight, frame, block_s)
        assert other.summary["meta"]["block_s"] == block_s
        np.testing.assert_array_equal(other.t, one.t)
        for key in ("dpos", "dvel", "datt"):
            assert np.array_equal(getattr(other, key), getattr(one, key)), (block_s, key)
    # the noise is there: another seed draws other errors (metres apart)
    assert np.abs(_study(flight, frame, 120.0, seed=4).dpos - one.dpos).max() > 1.0
    assert np.abs(one.dpos).max() > 10.0


def _motion(n, dt):
    """Smooth aircraft-like increments (body rates and specific force): (dθ, dv, q0)."""
    t = (np.arange(n) + 0.5) * dt
    w = np.stack([0.05 * np.sin(0.7 * t), 0.03 * np.cos(0.3 * t), 0.02 + 0 * t], -1)
    f = np.stack([2 + 0.5 * np.sin(t), 0.3 * np.cos(2 * t), -9.8 + 0.2 * np.sin(0.5 * t)], -1)
    C0 = Rotation.from_euler("ZYX", [40, 3, -2], degrees=True).as_matrix()
    return w * dt, f * dt, dcm_to_quat(C0)


#: per-run noise of four runs (different seeds), every source on
ERRORS = {
    "acc_noise": 2e-4,
    "gyro_noise": 3e-6,
    "acc_gm_sigma": 5e-4,
    "acc_gm_tau": 20.0,
    "gyro_gm_sigma": 2e-6,
    "gyro_gm_tau": 20.0,
    "acc_gm": np.full((4, 3), 1e-4),
    "gyro_gm": np.full((4, 3), -1e-6),
    "seed": np.array([5, 6, 7, 123456]),
}


def test_propagate_ned_in_two_halves_equals_one_call():
    """sample0 = 0 then n/2, all states carried (position in radians): one call's bits."""
    n, dt, every = 2000, 0.01, 50
    dth, dv, q0 = _motion(n, dt)
    h_ref = 1000.0 - 5.0 * dt * np.arange(n)
    k1, k2, k3 = baro_gains(30.0)

    def run(sl, lat, lon, h, v, q, err, baro_state, sample0, degrees=True):
        baro = Baro(h_ref[sl], k1, k2, k3, bias=2.0, noise=0.5, gm_sigma=3.0, gm_tau=50.0,
                    state=baro_state)  # fmt: skip
        return propagate_ned(
            dth[sl],
            dv[sl],
            dt,
            NedStart(lat, lon, h, v, q, degrees=degrees),
            NavConfig("j4", errors=err, output_every=every, baro=baro, sample0=sample0),
            device="cpu",
        )

    v0 = np.array([150.0, 80.0, -5.0])
    whole = run(slice(0, n), 30.0, 100.0, 1000.0, v0, q0, ERRORS, None, 0)
    h = n // 2
    a = run(slice(0, h), 30.0, 100.0, 1000.0, v0, q0, ERRORS, None, 0)
    err_b = {**ERRORS, "acc_gm": a.final["acc_gm"], "gyro_gm": a.final["gyro_gm"]}
    L = a.final["llh"]
    b = run(slice(h, n), L[:, 0], L[:, 1], L[:, 2], a.v_ned[:, -1], a.q[:, -1], err_b,
            a.final["baro"], h, degrees=False)  # fmt: skip
    for key in ("lat", "lon", "h", "v_ned", "q"):
        joined = np.concatenate([getattr(a, key), getattr(b, key)[:, 1:]], axis=1)
        assert np.array_equal(joined, getattr(whole, key)), key
    for key in ("acc_gm", "gyro_gm", "baro", "llh"):
        assert np.array_equal(b.final[key], whole.final[key]), key
    # four seeds, four different noise histories
    assert len({float(x) for x in whole.lat[:, -1]}) == 4
    # the second half alone from sample 0 would draw the first half's noise again: other bits
    c = run(slice(h, n), L[:, 0], L[:, 1], L[:, 2], a.v_ned[:, -1], a.q[:, -1], err_b,
            a.final["baro"], 0, degrees=False)  # fmt: skip
    assert not np.array_equal(c.lat, b.lat)


def test_propagate_lci_in_two_halves_equals_one_call():
    """LCI: sample0 = n/2 and t0 = n/2 dt for the second half, states carried: one call's bits."""
    from fieldmap.nav.frames import LaunchFrame

    n, dt, every = 2000, 0.01, 25
    dth, dv, q0 = _motion(n, dt)
    frame = LaunchFrame(105.3, 27.1, 63.0, 1000.0)
    P0, V0 = np.zeros(3), np.array([100.0, 50.0, 0.0])

    def run(sl, P, V, q, err, sample0):
        return propagate_lci(
            dth[sl],
            dv[sl],
            dt,
            LciStart(P, V, q, frame),
            NavConfig("j4", errors=err, t0=sample0 * dt, output_every=every, sample0=sample0),
            device="cpu",
        )

    whole = run(slice(0, n), P0, V0, q0, ERRORS, 0)
    h = n // 2
    a = run(slice(0, h), P0, V0, q0, ERRORS, 0)
    err_b = {**ERRORS, "acc_gm": a.final["acc_gm"], "gyro_gm": a.final["gyro_gm"]}
    b = run(slice(h, n), a.P[:, -1], a.V[:, -1], a.q[:, -1], err_b, h)
    assert np.array_equal(np.concatenate([a.t, b.t[1:]]), whole.t)
    for key in ("P", "V", "q"):
        joined = np.concatenate([getattr(a, key), getattr(b, key)[:, 1:]], axis=1)
        assert np.array_equal(joined, getattr(whole, key)), key
    for key in ("acc_gm", "gyro_gm"):
        assert np.array_equal(b.final[key], whole.final[key]), key


def test_noise_free_runs_are_unchanged_by_sample0():
    """Without a noise source no draw is made: sample0 changes nothing (NED, no time origin)."""
    n, dt = 400, 0.01
    dth, dv, q0 = _motion(n, dt)
    err = {"acc_bias": [1e-3, 0.0, 0.0], "gyro_bias": [0.0, 1e-6, 0.0]}
    runs = [
        propagate_ned(
            dth,
            dv,
            dt,
            NedStart(30.0, 100.0, 1000.0, [150.0, 80.0, -5.0], q0),
            NavConfig("j4", errors=err, output_every=100, sample0=s0),
            device="cpu",
        )
        for s0 in (0, 12345)
    ]
    assert np.array_equal(runs[0].lat, runs[1].lat) and np.array_equal(runs[0].h, runs[1].h)


def test_sample0_is_checked():
    from fieldmap.errors import InputError

    dth, dv, q0 = _motion(10, 0.01)
    start = NedStart(30.0, 100.0, 1000.0, [150.0, 80.0, -5.0], q0)
    for bad, msg in ((-1, "sample0 must lie"), (2**31 - 5, "sample0 must lie"), (1.5, "integer")):
        with pytest.raises(InputError, match=msg):
            propagate_ned(dth, dv, 0.01, start, NavConfig(sample0=bad), device="cpu")


def test_per_sample_streams_give_the_gauss_markov_and_white_noise_statistics():
    """The per-sample streams are independent normals: stationary Gauss–Markov σ, white noise.

    512 runs from zero Gauss–Markov states over 20 s = 4 τ: var β = s² (1 − e^(−2t/τ)) per axis
    (accelerometer, gyro, baro drift); the gyro's angle random walk gives the attitude a
    variance σ_g² t per axis (the accelerometer's noise is tested in test_strapdown.py).
    1536 values per check: ±7 % at 2σ.
    """
    m, n, dt, tau = 512, 2000, 0.01, 5.0
    dth, dv, q0 = _motion(n, dt)
    s_a, s_g, s_b, arw = 1e-3, 1e-5, 2.0, 1e-4
    err = {
        "acc_gm_sigma": s_a, "acc_gm_tau": tau, "gyro_gm_sigma": s_g, "gyro_gm_tau": tau,
        "acc_gm": np.zeros((m, 3)), "seed": np.arange(m) * 7 + 1,
    }  # fmt: skip
    baro = Baro(1000.0 - 5.0 * dt * np.arange(n), 0.0, 0.0, 0.0, gm_sigma=s_b, gm_tau=tau)
    args = (dth, dv, dt, NedStart(30.0, 100.0, 1000.0, [150.0, 80.0, -5.0], q0))
    nav = NavConfig("j4", errors=err, output_every=n, baro=baro, sample0=77)
    res = propagate_ned(*args, nav, device="cpu")
    shrink = 1.0 - np.exp(-2.0 * n * dt / tau)
    for key, s in (("acc_gm", s_a), ("gyro_gm", s_g)):
        np.testing.assert_allclose(np.mean(res.final[key] ** 2), s * s * shrink, rtol=0.12)
    drift = res.final["baro"][:, 1]
    np.testing.assert_allclose(np.mean(drift**2), s_b * s_b * shrink, rtol=0.2)  # 512 values
    # white gyro noise: attitude random walk against a noise-free run
    ref = propagate_ned(*args, NavConfig("j4", output_every=n), device="cpu")
    white = {"gyro_noise": arw, "seed": np.arange(m) + 3}
    noisy = propagate_ned(*args, NavConfig("j4", errors=white, output_every=n), device="cpu")
    from scipy.spatial.transform import Rotation as R

    from fieldmap.nav.mechanize import quat_to_dcm

    C = quat_to_dcm(noisy.q[:, -1]) @ quat_to_dcm(ref.q[0, -1]).T
    psi = R.from_matrix(C).as_rotvec()
    np.testing.assert_allclose(np.mean(psi**2), arw**2 * n * dt, rtol=0.12)


def test_results_as_datasets_over_run_and_time():
    """Flight and paper studies hand their results over as xarray Datasets with units."""
    from fieldmap.nav import paper, study
    from fieldmap.nav.trajectory import FlightTrajectory, route_flight

    ft = FlightTrajectory(route_flight("45,7,9000;45.2,7.3,9500", 200.0))
    res = study.run_flight(
        study.FlightStudy(
            ft, models=["j4"], rate_hz=20.0, truth_lmax=10, duration=20.0, output_dt=2.0
        ),
        device="cpu",
    )
    ds = res.to_dataset()
    assert ds["position_error"].dims == ("run", "time", "axis")
    assert ds["position_error"].attrs["units"] == "m"
    assert ds.sizes["run"] == len(res.labels) and ds.sizes["time"] == res.t.size
    sc = study.build_scenario(
        truth_lmax=10, duration=10.0, sampling=ImuSampling(50.0), device="cpu"
    )
    st = paper.table1(sc, models=["j2", "j4"], timing=False)
    sd = st.to_dataset()
    assert sd["position_error"].dims == ("run", "time")
    assert sd["velocity_error"].attrs["units"] == "m s-1"


def test_lci_and_ned_results_share_one_time_base():
    """A piece of a record starting at global sample 100: both results' t start at 100 dt."""
    from fieldmap.nav.frames import LaunchFrame
    from fieldmap.nav.mechanize import LciStart, NavConfig, NedStart, propagate_lci, propagate_ned

    dt, n = 0.01, 40
    dth = np.zeros((n, 3))
    dv = np.tile([0.0, 0.0, -9.8 * dt], (n, 1))
    q = [1.0, 0.0, 0.0, 0.0]
    lci = propagate_lci(
        dth,
        dv,
        dt,
        LciStart([0.0, 0.0, 0.0], [0.0, 0.0, 0.0], q, LaunchFrame(7, 45, 0)),
        NavConfig(t0=100 * dt, sample0=100, output_every=5),
        device="cpu",
    )
    ned = propagate_ned(
        dth,
        dv,
        dt,
        NedStart(45.0, 7.0, 0.0, [0.0, 0.0, 0.0], q),
        NavConfig(sample0=100, output_every=10),
        device="cpu",
    )
    np.testing.assert_allclose(lci.t, ned.t, rtol=0, atol=1e-12)
    assert lci.t[0] == pytest.approx(1.0) and lci.t[-1] == pytest.approx(1.4)

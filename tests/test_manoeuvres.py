"""A manoeuvre flown as it was flown: the height's heavy-tailed jerk (nav.logs.motion).

A synthetic turboprop log (fixes every 5 s, altitudes quantised to 25 ft, as the calibration
flights of the corpus) flies level, climbs away at 12 m/s after a level-off that takes 3 s
(a go-around) and levels off again as briefly. Its truth is built here, with its own
geodesy. A jerk of one intensity all flight long lags such a manoeuvre by tens of metres;
the Student-t jerk of the model follows it, and stays quiet where the flight is level.

The selected inversion that the weights of the jerk need is checked against NumPy's dense
inverse.
"""

from __future__ import annotations

import numpy as np
import pytest
from log_tracks import raw_track

from fieldmap.nav.logs.condition import Conditioning, condition

A_WGS, F_WGS = 6378137.0, 1.0 / 298.257223563
E2 = F_WGS * (2.0 - F_WGS)
FT = 0.3048


def _ramp(t: np.ndarray, t0: float, dur: float) -> np.ndarray:
    """0 before t0, 1 after t0 + dur, a smooth (C²) step between."""
    x = np.clip((t - t0) / dur, 0.0, 1.0)
    return x**3 * (10.0 - 15.0 * x + 6.0 * x * x)


def _go_around(dt: float = 0.01):
    """Return the dense truth ``t, lat, lon, h`` of the go-around.

    80 m/s north at 47°N, level at 600 m, 12 m/s climbs from 300 s and 600 s (each begun and
    ended within 3 s), level between.
    """
    t = np.arange(0.0, 1200.0 + dt / 2, dt)
    vz = 12.0 * (_ramp(t, 300.0, 3.0) - _ramp(t, 420.0, 3.0))
    vz += 12.0 * (_ramp(t, 600.0, 3.0) - _ramp(t, 700.0, 3.0))
    h = 600.0 + np.concatenate([[0.0], np.cumsum(0.5 * (vz[1:] + vz[:-1]) * dt)])
    m_lat = A_WGS * (1.0 - E2) / (1.0 - E2 * np.sin(np.radians(47.0)) ** 2) ** 1.5
    lat = 47.0 + np.degrees(80.0 * t / m_lat)
    return t, lat, np.full(t.size, 8.0), h


@pytest.fixture(scope="module")
def flown():
    td, lat, lon, h = _go_around()
    step = int(round(5.0 / (td[1] - td[0])))
    t, la, lo, hh = td[::step], lat[::step], lon[::step], h[::step]
    h_log = np.round(hh / (25 * FT)) * 25 * FT  # 25 ft altitude quantisation
    track = raw_track(t, la, lo, h_log, source="go_around.csv")
    cf = condition(track, Conditioning(vehicle="turboprop"))
    return (td, h), (t, h_log), cf


def test_path_follows_the_go_around(flown):
    """Within 9 m of the true height everywhere, level-offs included.

    A 3 s level-off between fixes 5 s apart, heights rounded to 7.6 m: 7.5 m at worst (a
    Gaussian jerk: 11.3 m).
    """
    (td, h), _, cf = flown
    s = cf.samples
    truth = np.interp(s.t_start + s.t, td, h)
    assert np.abs(s.h - truth).max() < 9.0


def test_heights_within_three_sigma_of_the_log(flown):
    """The corpus's heights check (a Gaussian jerk: 97.9 % within)."""
    (_, _), (t, h_log), cf = flown
    s = cf.samples
    sigma = max(cf.report["fit"]["sigma_v_m"], 1.0)
    path = np.interp(t, s.t_start + s.t, s.h)
    assert np.mean(np.abs(path - h_log) <= 3.0 * sigma) >= 0.99


def test_level_flight_stays_level(flown):
    """Between the manoeuvres the path neither climbs nor sinks.

    Under 0.25 m/s (0.06 m/s; a Gaussian jerk, whose intensity the manoeuvres set: 0.46 m/s).
    """
    (td, h), _, cf = flown
    s = cf.samples
    tt = s.t_start + s.t
    level = ((tt > 100.0) & (tt < 290.0)) | ((tt > 440.0) & (tt < 590.0))
    vz = np.gradient(s.h, tt)
    assert np.abs(vz[level]).max() < 0.25


def test_block_covariances_match_the_dense_inverse():
    from fieldmap.nav.logs.motion import (
        BAND,
        NS,
        MotionModel,
        _block_covariances,
        _factor,
        _process_band,
    )

    rng = np.random.default_rng(2)
    n = 30
    F, Q = MotionModel(tau_s=20.0, beta=0.01).transition(5.0, 0.3)
    P = np.linalg.inv(Q)
    lam = np.exp(rng.uniform(-4.0, 1.0, n - 1))
    ab = _process_band(0.5 * (P + P.T), F, n, lam)
    ab[BAND, ::NS] += np.exp(rng.uniform(-3.0, 3.0, n))  # fixes of the positions
    ab[BAND, 2] += 1.0
    N = NS * n
    A = np.zeros((N, N))
    for o in range(BAND + 1):
        for j in range(o, N):
            A[j - o, j] = A[j, j - o] = ab[BAND - o, j]
    C, C1 = _block_covariances(*_factor(ab))
    inv = np.linalg.inv(A)
    for k in range(n):
        blk = inv[NS * k : NS * k + NS, NS * k : NS * k + NS]
        np.testing.assert_allclose(C[k], blk, rtol=1e-10, atol=1e-12 * abs(blk).max())
    for k in range(n - 1):
        blk = inv[NS * k : NS * k + NS, NS * k + NS : NS * k + 2 * NS]
        np.testing.assert_allclose(C1[k], blk, rtol=1e-10, atol=1e-12 * abs(blk).max())

"""The positions' noise level is the log's, on a log whose fixes are sparse in its turns (issue 34).

A synthetic tanker log in ``traffic``'s CSV layout: it orbits a fire at 75 m/s in 2-minute
circles (3 °/s, a standard-rate turn) for an hour, a row every 20 s (60° of turn between
rows, as the corpus's CAL FIRE pieces are logged), its positions with 10 m of noise per axis
and its ground speed and track as fresh as its positions. Its truth is built here, with the
tests' own geodesy (``log_tracks``).

Between fixes 20 s apart the motion model's spread is hundreds of metres: whether a fix's 10 m
departure from a smooth orbit is noise or motion, the data cannot tell, and the positions' σ
is not identified by the marginal likelihood alone. Today it takes 72 m (7 × the noise; the
path still flies within 7 m RMS of the fixes, carried by the velocities). The likelihood
counts the determinants of the 3 ECEF axes of the surface point but normalises the
positions' 2 measured degrees of freedom (``fieldmap.nav.logs.motion``, "Noise levels"); the
radial axis rewards a wide σ that nothing pays for, and on the corpus's CAL FIRE pieces it
takes the σ to its ceiling, about 1 km, with the path hundreds of metres off the fixes.
Counted over the measured axes only (branch ``likelihood-wip``), this log's σ goes to its
floor instead (0.01 m: the path through every noisy fix). What is missing is the sensor's
own accuracy as a prior on σ where the fixes cannot tell, and a motion model that holds a
turn; until then this test records the defect (strict: it fails the suite when it starts to
pass).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from fieldmap.nav.logs import load_flight
from fieldmap.nav.logs.condition import Conditioning

sys.path.insert(0, str(Path(__file__).parent))
from log_tracks import local_to_lat_lon, write_traffic_csv  # noqa: E402

KT = 1852.0 / 3600.0
LAT0, LON0, V, RATE, NOISE = 34.0, -117.0, 75.0, np.radians(3.0), 10.0


def _truth(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """North and east (m) and the track (degrees) of the orbit at ``t`` (s)."""
    r = V / RATE
    phase = RATE * t
    return r * np.sin(phase), r * (1.0 - np.cos(phase)), np.degrees(phase) % 360.0


@pytest.fixture(scope="module")
def orbit(tmp_path_factory):
    rng = np.random.default_rng(11)
    t = np.arange(0.0, 3600.0 + 0.5, 20.0)
    north, east, track = _truth(t)
    lat, lon = local_to_lat_lon(
        north + rng.normal(0.0, NOISE, t.size), east + rng.normal(0.0, NOISE, t.size), LAT0, LON0
    )
    rows = [
        f"a51d5f,N429DF,{la:.7f},{lo:.7f},6000,{V / KT:.0f},{tr:.1f},0"
        for la, lo, tr in zip(lat, lon, track)
    ]
    path = write_traffic_csv(tmp_path_factory.mktemp("orbit") / "orbit.csv", t, rows)
    _, cf = load_flight(path, Conditioning(vehicle="turboprop"), height_ref="pressure")
    return cf


@pytest.mark.xfail(
    strict=True,
    reason="the positions' σ is not identified on sparse fixes and has no prior (module docstring)",
)
def test_positions_noise_is_the_logs_on_a_sparse_orbit(orbit):
    ch = orbit.report["channels"]["position"]
    assert NOISE / 3.0 < ch["noise_sigma"] < 3.0 * NOISE, ch
    assert ch["residual_rms"] < 3.0 * NOISE, ch


def test_sparse_orbit_is_flown_at_its_speed(orbit):
    """Whatever the positions' σ, the orbit is flown at the speed its log reports."""
    s = orbit.samples
    north = np.radians(s.lat) * 6_371_000.0
    east = np.radians(s.lon) * 6_371_000.0 * np.cos(np.radians(LAT0))
    speed = np.hypot(np.diff(north), np.diff(east)) / np.diff(s.t)
    assert abs(float(np.median(speed)) - V) < 0.03 * V


CORPUS = Path(__file__).parent / "data" / "corpus"


def test_report_says_where_a_noise_estimate_stopped_at_its_bound(tmp_path):
    """A σ left at the bound of its search is said so, where the user reads the σ.

    A log without noise (straight and level at 100 m/s, its positions printed to 1e-8°): every
    channel's σ goes to its floor, and the report says so; munich (a calibration flight logged
    every 5 s) has no σ at a bound; a σ the user gives is not estimated, so no bound is
    reported for it.
    """
    t = np.arange(0.0, 900.0, 1.0)
    lat, lon = local_to_lat_lon(100.0 * t, 0.0 * t, 45.0, 7.0)
    rows = [
        f"abc123,TEST01,{la:.8f},{lo:.8f},10000,{100.0 / KT:.1f},0.0,0" for la, lo in zip(lat, lon)
    ]
    path = write_traffic_csv(tmp_path / "straight.csv", t, rows)
    _, cf = load_flight(path, height_ref="pressure")
    ch = cf.report["channels"]["position"]
    assert ch["noise_sigma_at_bound"] == "floor", ch
    text = cf.format_report()
    assert f"the estimate stopped at its floor, {ch['noise_sigma_bounds'][0]:.4g} m" in text

    _, cf = load_flight(path, Conditioning(position_noise_m=0.01), height_ref="pressure")
    assert cf.report["channels"]["position"]["noise_sigma_at_bound"] is None

    _, cf = load_flight(CORPUS / "calibration" / "munich.csv.gz", height_ref="pressure")
    assert all(c["noise_sigma_at_bound"] is None for c in cf.report["channels"].values())
    assert "the estimate stopped" not in cf.format_report()

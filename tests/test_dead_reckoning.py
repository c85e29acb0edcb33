"""Positions a receiver extrapolates from its last fix are no measurements (issue 34).

A synthetic glider log in ``traffic``'s CSV layout, a row every 12 s, latitudes and
longitudes printed to 1e-4 degree (as the corpus's glider pieces): it flies north at 30 m/s,
then turns right through 90° at 1.5 °/s and flies east. While it turns the receiver has lost
it and sends its last state again (ground speed, track, altitude and vertical rate held),
advancing the last fix north at the last velocity: ten rows of dead reckoning. The next real
fix is kilometres off that line. Its truth is built here, with the tests' own geodesy
(``log_tracks``).

Taken for measurements, the extrapolated positions pull the path up the dead-reckoned line
before it turns to the real fix (51 m/s, the smoother rejecting the end of the line); left
out (:func:`fieldmap.nav.logs.faults.extrapolated`: the next fix is 4 km from the line's end,
12 s later, and 3.5 km from the last real fix, 132 s later), the path bridges from the last
real fix to the next one at the glider's speed. Flown from fixes only, the same turn keeps
every position (a straight run at a held state that reaches the next fix is no dead
reckoning).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from fieldmap.nav.logs import load_flight
from fieldmap.nav.logs.condition import Conditioning

sys.path.insert(0, str(Path(__file__).parent))
from corpus_checks import path_kinematics  # noqa: E402
from log_tracks import local_to_lat_lon, write_traffic_csv  # noqa: E402

KT, FT = 1852.0 / 3600.0, 0.3048
LAT0, LON0, V = 46.0, 10.0, 30.0
TURN_AT, RATE = 600.0, np.radians(1.5)  # the turn: from 600 s, 1.5 °/s for 60 s


def _truth(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """North and east (m) and the track (degrees) of the flight at ``t`` (s)."""
    r = V / RATE  # the turn's radius
    turn_end = TURN_AT + 0.5 * np.pi / RATE
    north = np.where(t <= TURN_AT, V * t, V * TURN_AT + r * np.sin(RATE * (t - TURN_AT)))
    east = np.where(t <= TURN_AT, 0.0, r * (1.0 - np.cos(RATE * (t - TURN_AT))))
    after = t > turn_end
    north = np.where(after, V * TURN_AT + r, north)
    east = np.where(after, r + V * (t - turn_end), east)
    track = np.degrees(np.clip(RATE * (t - TURN_AT), 0.0, 0.5 * np.pi))
    return north, east, track


def _write(path: Path, held: bool) -> Path:
    t = np.arange(0.0, 1200.0 + 0.5, 12.0)
    north, east, track = _truth(t)
    lost = (t > TURN_AT) & (t <= TURN_AT + 120.0)  # ten rows while it turns
    last = np.flatnonzero(t <= TURN_AT)[-1]
    if held:  # the last state sent again, the position advanced at the last velocity
        north = np.where(lost, north[last] + V * (t - t[last]), north)
        east = np.where(lost, east[last], east)
        track = np.where(lost, track[last], track)
    lat, lon = local_to_lat_lon(north, east, LAT0, LON0)
    rows = [
        f"3ed6a0,D-KXYZ,{la:.4f},{lo:.4f},6000,{round(V / KT)},{tr:.0f},0"
        for la, lo, tr in zip(lat, lon, track)
    ]
    return write_traffic_csv(path, t, rows)


@pytest.mark.parametrize("held", [False, True], ids=["fixes", "dead-reckoned"])
def test_the_turn_is_flown_at_the_gliders_speed(tmp_path, held):
    """The flown path's ground speed stays within 15 % of the glider's 30 m/s."""
    _, cf = load_flight(_write(tmp_path / "glider.csv", held), Conditioning(vehicle="glider"))
    s = cf.samples
    k = path_kinematics(s.t, s.lat, s.lon, s.h)
    assert k.max_ground_speed_m_s <= 1.15 * V, k
    assert cf.report["samples"]["interpolated_positions"] >= (9 if held else 0)


def test_a_fix_before_a_stale_position_is_no_dead_reckoning():
    """A fix that a stale position follows is kept; the run before it is no dead reckoning.

    A log resampled to 1 s between fixes (``traffic``'s featured samples) at a held state,
    flying at 0.0018°/s (~220 m/s) with positions printed to 1e-4°, whose row 2 s after the
    fix at 33 s is an earlier position sent again (the one of 0 s, 7 km back), with the rows
    after it interpolated from there to the next fix (``dreamliner_airfrance_39c424``, line
    2405). The row after the fix is kilometres off in 1 s and reachable from the run's start,
    as after dead reckoning; but it returns to no track the vehicle flies (the row after it
    is as far again): the jump is the fault, and the fix before it is kept.
    """
    from fieldmap.nav.logs.faults import extrapolated

    t = np.arange(101.0)
    knots_t = np.array([0.0, 33.0, 35.0, 70.0, 100.0])  # fixes at 0, 33, 70 and 100 s
    knots = np.array([0.0, 33.0, 0.0, 70.0, 100.0]) * 0.0018  # 35 s: the position of 0 s
    lat = np.round(LAT0 + np.interp(t, knots_t, knots), 4)
    lon = np.round(LON0 + 0.5 * (lat - LAT0), 4)
    state = np.tile([15260.0, 386.0, 30.0, 0.0], (t.size, 1))  # altitude, speed, track, rate
    xyz = np.stack([(lat - LAT0) * 111_132.0, (lon - LON0) * 77_330.0, np.zeros_like(t)], -1)
    out = extrapolated(t, lat, lon, state, np.zeros(4), xyz, 270.0)
    assert not out.any(), np.flatnonzero(out)

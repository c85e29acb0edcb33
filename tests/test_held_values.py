"""A rate the log holds or interpolates is a copy or a computation, not a measurement (issue 34).

A synthetic airliner log in ``traffic``'s CSV layout, one row a second (a log resampled to a
clock and filled forward, as the corpus's ADS-B pieces): it climbs at 15 ± 2 m/s, then
eases to 5 m/s over 20 s and climbs on for two minutes. Its ``vertical_rate`` column (0.3 m/s
of noise, 64 ft/min steps) stops being updated at the ease: it holds the last climb to the
end (what the corpus's ``quickstart_3944e1_02`` does for 140 s). The altitudes (25 ft
steps) are fresh all along. Its truth is built here, with its own geodesy.

The smoother's mixture (``fieldmap.nav.logs.motion``, "Held values") takes the held rates for
copies of the last fresh one: the path follows the heights, and the report counts the copies.
Taken as 120 measurements of a 15 m/s climb they would pull the path hundreds of metres above
the heights. A rate held at its value because the value does not change (the ground speed of
straight and level flight, repeated row after row) stays a measurement: the copies' share of
the repeats goes to zero there.

The same log resampled to a clock with its rates interpolated between fixes: the values off
the column's 64 ft/min steps are computed, not measured, and left out.
"""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import numpy as np
import pytest

from fieldmap.nav.logs import load_flight
from fieldmap.nav.logs.condition import Conditioning
from fieldmap.nav.logs.read import read_track

FT, KT, FPM = 0.3048, 1852.0 / 3600.0, 0.3048 / 60.0
A_WGS, F_WGS = 6378137.0, 1.0 / 298.257223563
E2 = F_WGS * (2.0 - F_WGS)
SPEED = 200.0  # m/s north


def _ramp(t: np.ndarray, t0: float, dur: float) -> np.ndarray:
    """0 before t0, 1 after t0 + dur, a smooth (C²) step between."""
    x = np.clip((t - t0) / dur, 0.0, 1.0)
    return x**3 * (10.0 - 15.0 * x + 6.0 * x * x)


def _truth(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Latitude, height and climb rate at ``t`` (s): 15 ± 2 m/s, then 5 m/s from 300 s."""

    def climb(t: np.ndarray) -> np.ndarray:
        ease = _ramp(t, 300.0, 20.0)
        return (15.0 + 2.0 * np.sin(2.0 * np.pi * t / 60.0)) * (1.0 - ease) + 5.0 * ease

    vz = climb(t)
    # the height: the integral of vz (fine sampling, trapezoids)
    tf = np.arange(0.0, t.max() + 0.005, 0.01)
    vf = climb(tf)
    hf = 3000.0 + np.concatenate([[0.0], np.cumsum(0.5 * (vf[1:] + vf[:-1]) * 0.01)])
    h = np.interp(t, tf, hf)
    m_lat = A_WGS * (1.0 - E2) / (1.0 - E2 * np.sin(np.radians(47.0)) ** 2) ** 1.5
    return 47.0 + np.degrees(SPEED * t / m_lat), h, vz


@pytest.fixture(scope="module")
def flown(tmp_path_factory):
    t = np.arange(0.0, 440.0 + 0.5, 1.0)
    lat, h, vz = _truth(t)
    alt_ft = np.round(h / FT / 25.0) * 25.0
    rng = np.random.default_rng(34)
    vr_fpm = np.round((vz + 0.3 * rng.standard_normal(t.size)) / FPM / 64.0) * 64.0
    vr_fpm[t >= 300.0] = vr_fpm[t < 300.0][-1]  # held from the ease on
    t0 = dt.datetime(2024, 5, 1, 12, 0, 0, tzinfo=dt.timezone.utc)
    rows = ["timestamp,icao24,callsign,latitude,longitude,altitude,groundspeed,track,vertical_rate"]
    for ti, la, al, vr in zip(t, lat, alt_ft, vr_fpm):
        stamp = (t0 + dt.timedelta(seconds=float(ti))).strftime("%Y-%m-%dT%H:%M:%SZ")
        rows.append(
            f"{stamp},abc123,TEST1,{la:.6f},8.000000,{al:.0f},{round(SPEED / KT)},0,{vr:.0f}"
        )
    path = tmp_path_factory.mktemp("held") / "held_climb.csv"
    path.write_text("\n".join(rows) + "\n")
    _, cf = load_flight(path, height_ref="pressure")
    return path, h, cf


def test_path_follows_the_heights_not_the_held_rate(flown):
    """Within 3σ of the 25 ft steps of every height (the held rate: 400 m above them).

    The log's heights as the conditioning reads them (pressure altitudes plus the geoid);
    each is its true height rounded to 7.6 m, so within 3σ = 6.6 m of the path (σ = 7.6/√12)
    where the path is within 2.8 m of the truth.
    """
    path, h, cf = flown
    log = read_track(path, height_ref="pressure")
    s = cf.samples
    err = np.abs(np.interp(log.t, s.t_start + s.t, s.h) - log.h)
    sigma = 25.0 * FT / np.sqrt(12.0)
    assert err.max() <= 3.0 * sigma, f"worst {err.max():.1f} m at line {log.lines[np.argmax(err)]}"
    # and against the truth: the log's conversion adds the geoid, a few metres' trend here
    assert np.sqrt(np.mean(err**2)) < 3.0


def test_held_rates_are_reported_as_copies(flown):
    _, _, cf = flown
    ch = cf.report["channels"]["vertical rate"]
    # the 140 rows from the ease on repeat the last fresh rate: copies (and, of the rates
    # before it that repeat the one before them, those that the noise explains no better)
    assert ch["copies"] >= 130, ch
    assert ch["rejected"] < 10, ch
    note = [str(n) for n in cf.report["notes"] if "copies of it" in str(n)]
    assert note and "of the log's vertical rates (" in note[0], cf.report["notes"]


def test_a_steady_ground_speed_stays_a_measurement(flown):
    """Straight and level at 200 m/s: every ground speed repeats, none is a copy."""
    _, _, cf = flown
    assert cf.report["channels"]["velocity"]["copies"] == 0


def test_vertical_rates_between_the_steps_are_no_measurements(tmp_path):
    """A log resampled to a clock: its vertical rates between fixes are interpolated.

    Two rows in three of the synthetic climb keep their measured rate (a whole number of
    64 ft/min steps); the third holds a rate interpolated linearly between its neighbours,
    mostly off the steps.
    Those are computed, not measured: left out of the vertical rate channel, and said so. A
    column whose non-zero values are mostly off the steps (finer, or another source's units)
    is kept whole.
    """
    t = np.arange(0.0, 300.0 + 0.5, 1.0)
    lat, h, vz = _truth(t)
    measured = np.round(vz / FPM / 64.0) * 64.0
    fixes = np.flatnonzero(np.arange(t.size) % 3 != 2)
    vr = np.interp(t, t[fixes], measured[fixes])  # resampled: linear between the fixes
    off = np.abs(vr / 64.0 - np.round(vr / 64.0)) > 1e-6
    assert off.sum() > t.size / 5  # the test's premise: many rows between the steps

    def fly(rates: np.ndarray) -> dict:
        t0 = dt.datetime(2024, 5, 1, 12, 0, 0, tzinfo=dt.timezone.utc)
        rows = [
            "timestamp,icao24,callsign,latitude,longitude,altitude,groundspeed,track,vertical_rate"
        ]
        for ti, la, hh, r in zip(t, lat, h, rates):
            stamp = (t0 + dt.timedelta(seconds=float(ti))).strftime("%Y-%m-%dT%H:%M:%SZ")
            rows.append(
                f"{stamp},abc123,TEST1,{la:.6f},8.000000,{round(hh / FT / 25) * 25},"
                f"{round(SPEED / KT)},0,{r:.4f}"
            )
        path = tmp_path / f"resampled_{len(list(tmp_path.iterdir()))}.csv"
        path.write_text("\n".join(rows) + "\n")
        return load_flight(path, height_ref="pressure")[1].report

    rep = fly(vr)
    assert rep["channels"]["vertical rate"]["samples"] == t.size - off.sum()
    assert any("off the column's resolution" in str(n) for n in rep["notes"])
    # a column printed finer than the steps (every value off them): all kept
    rep = fly(vr + 0.37)
    assert rep["channels"]["vertical rate"]["samples"] == t.size


CORPUS = Path(__file__).parent / "data" / "corpus" / "quickstart"


def _offsets_at_every_row(piece: Path, samples) -> np.ndarray:
    """Horizontal distances (m) of the log's positions from the flown path at their times.

    Every row the reader keeps within the flown span, those without an altitude included (a
    taxi's surface reports), each against the path interpolated linearly in time.
    """
    log = read_track(piece, height_ref="pressure", alt_units="ft")
    t = samples.t_start + samples.t
    m = (log.t >= t[0]) & (log.t <= t[-1])
    lat = np.interp(log.t[m], t, samples.lat)
    lon = np.interp(log.t[m], t, samples.lon)
    north = np.radians(log.lat[m] - lat) * 6_371_000.0
    east = np.radians(log.lon[m] - lon) * 6_371_000.0 * np.cos(np.radians(lat))
    return np.hypot(north, east)


def test_a_taxi_under_a_held_ground_speed_follows_its_positions():
    """``quickstart_344695`` (a corpus piece): 103 kt held from the landing through the taxi.

    After touching down at Paris-Orly (line 932) the aircraft taxis at a few m/s for 5
    minutes while its ``groundspeed`` and ``track`` columns hold 103 kt and 254°, row after
    row: ADS-B's last airborne velocity, filled forward. An EM whose first path weighed those
    repeats followed them, took the taxi's positions for faults and flew a 4 km loop at
    53 m/s beside the airport (the fixes' 95th-percentile distance from it 3.8 km). The
    horizontal EM now has a second start, the fresh samples' path, kept by the mixture's
    likelihood (``fieldmap.nav.logs.condition._horizontal``).
    """
    from corpus_checks import check_piece

    piece = CORPUS / "quickstart_344695.csv.gz"
    _, cf = load_flight(piece, height_ref="pressure")
    c = check_piece(piece, cf.samples, sigma_h=7.62)
    assert c.horizontal_offset_p95_m < 100.0, c.horizontal_offset_p95_m
    log = read_track(piece, height_ref="pressure", alt_units="ft")
    s = cf.samples
    taxi = (log.lines > 1000) & (log.t <= s.t_start + s.t[-1])
    speed = np.hypot(np.gradient(s.lat) * 111_195.0, np.gradient(s.lon) * 73_400.0)
    after = np.interp(log.t[taxi] - s.t_start, s.t, speed / np.gradient(s.t))
    assert np.all(after < 20.0), after.max()  # a taxi, not 53 m/s
    assert np.percentile(_offsets_at_every_row(piece, s), 95) < 100.0


@pytest.mark.parametrize(
    "name, line",
    [
        # 102 kt and 61° held from line 963 to the log's end, 503 s later (a taxi at Orly)
        ("quickstart_344487", 963),
        # 103 kt and 63° held from line 975 to the log's end, 542 s later (a taxi at Orly)
        ("quickstart_49514e", 975),
    ],
)
def test_other_taxis_under_a_held_ground_speed_follow_their_positions(name, line):
    """Two more arrivals whose last airborne ground speed is held through the taxi.

    Each was flown as a loop 8-10 km across at the held speed while the log's positions (a
    row a second, most without an altitude: surface reports) taxi at walking pace.
    """
    piece = CORPUS / f"{name}.csv.gz"
    log = read_track(piece, height_ref="pressure", alt_units="ft")
    v = log.velocity
    held = log.lines >= line
    assert np.ptp(v.speed[held]) == 0.0 and np.ptp(v.track[held]) == 0.0  # the data's fact
    _, cf = load_flight(piece, height_ref="pressure")
    off = _offsets_at_every_row(piece, cf.samples)
    assert np.percentile(off, 95) < 150.0, np.percentile(off, 95)
    assert np.max(off) < 500.0, np.max(off)


def test_noise_levels_of_a_start_that_rejects_its_positions_are_estimated_again():
    """``zurich_airport_0083c3``: a landing and a 7-minute taxi, velocities held in the taxi.

    The EM's first start (every repeat weighed) takes half of the positions for faults, and
    its positions' σ runs to its 1 km ceiling. The second start (the fresh samples' path) wins
    by the likelihood; judged at the first's noise levels alone, it flew the positions at
    1 km of σ, by the held velocities, and cut the taxi's turns (half of the rows 37 m or more
    off the path, the 95th percentile 185 m). Those noise levels are no estimate of the
    positions' noise: the EM goes on from the second start with them estimated again, and the
    path flies the rows as the positions alone fly them.
    """
    piece = Path(__file__).parent / "data" / "corpus" / "onground" / "zurich_airport_0083c3.csv.gz"
    _, cf = load_flight(piece, height_ref="pressure")
    _, alone = load_flight(piece, Conditioning(log_velocities=False), height_ref="pressure")
    assert cf.report["channels"]["position"]["noise_sigma_at_bound"] is None
    off = _offsets_at_every_row(piece, cf.samples)
    off_alone = _offsets_at_every_row(piece, alone.samples)
    assert np.median(off) < 1.2 * np.median(off_alone) + 1.0, (np.median(off), np.median(off_alone))
    p95, p95_alone = np.percentile(off, 95), np.percentile(off_alone, 95)
    assert p95 < 1.2 * p95_alone + 1.0, (p95, p95_alone)

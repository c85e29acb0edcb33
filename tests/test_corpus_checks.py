"""The corpus checks (tests/corpus_checks.py) measure what they say, and the corpus is as listed."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from corpus_checks import check_piece, path_kinematics, reported_max_ground_speed

from fieldmap.nav.logs.read import read_track
from fieldmap.nav.trajectory import FlightSamples

CORPUS = Path(__file__).parent / "data" / "corpus"
MANIFEST = json.loads((CORPUS / "manifest.json").read_text())


def _circle(v: float, radius: float, h: float = 3000.0, dt: float = 1.0):
    """Return a level turn at constant speed round (45° N, 5° E), a small circle."""
    t = np.arange(0.0, 2 * np.pi * radius / v, dt)
    ang = v * t / radius
    r_n = 6_378_137.0 * (1 - 0.00669438) / (1 - 0.00669438 * np.sin(np.radians(45)) ** 2) ** 1.5
    r_e = 6_378_137.0 / np.sqrt(1 - 0.00669438 * np.sin(np.radians(45)) ** 2)
    lat = 45.0 + np.degrees(radius * np.sin(ang) / (r_n + h))
    lon = 5.0 + np.degrees(radius * (1 - np.cos(ang)) / ((r_e + h) * np.cos(np.radians(45))))
    return t, lat, lon, np.full_like(t, h)


def test_level_turn_speed_and_specific_force():
    # 100 m/s round a 2 km circle: centripetal v²/R = 5 m/s², so |f| = √(g² + 25) = 1.126 g
    # (normal gravity at 45°, 3 km: 9.797 m/s²); Coriolis (2Ωv ≤ 0.015 m/s²) and the Earth's
    # curvature under a level path (v²/R_E ≈ 0.0016 m/s²) stay within the tolerance
    k = path_kinematics(*_circle(100.0, 2000.0))
    assert k.max_ground_speed_m_s == pytest.approx(100.0, rel=2e-3)
    expected = np.hypot(9.7974, 5.0) / 9.80665
    assert k.specific_force_max_g == pytest.approx(expected, abs=3e-3)
    assert k.specific_force_min_g == pytest.approx(expected, abs=3e-3)


def test_straight_level_flight_is_one_g():
    t = np.arange(0.0, 600.0, 5.0)
    lat, lon, h = 45.0 + 0.001 * t / 1.11, np.full_like(t, 5.0), np.full_like(t, 3000.0)
    k = path_kinematics(t, lat, lon, h)
    assert k.specific_force_min_g == pytest.approx(0.999, abs=3e-3)
    assert k.specific_force_max_g == pytest.approx(0.999, abs=3e-3)


@pytest.mark.parametrize("piece", ["calibration/munich", "gliders/cevennes"])
def test_a_log_flown_through_its_own_fixes_meets_the_checks(piece):
    path = CORPUS / f"{piece}.csv.gz"
    log = read_track(path, height_ref="pressure", alt_units="ft")
    t, first = np.unique(log.t, return_index=True)
    s = FlightSamples(
        t - t[0], log.lat[first], log.lon[first], log.h[first], None, "test", log.lines[first], t[0]
    )
    c = check_piece(path, s, sigma_h=1.0)
    assert c.flown_fraction == 1.0
    assert c.fixes_outside_flown == 0
    # every fix with a time of its own is on the path; repeated times may not be
    assert c.heights_within >= first.size / log.t.size
    assert c.horizontal_offset_p95_m < 1e-3
    # cut the last quarter: a quarter of the span is not flown
    n = int(0.75 * t.size)
    cut = FlightSamples(s.t[:n], s.lat[:n], s.lon[:n], s.h[:n], None, "test", s.lines[:n], t[0])
    c = check_piece(path, cut, sigma_h=1.0)
    assert c.flown_fraction == pytest.approx((t[n - 1] - t[0]) / (t[-1] - t[0]))
    # a fix is a sample with a height of its own (munich's surface reports have none)
    has = np.ones(log.t.size, bool) if log.no_height is None else ~log.no_height
    assert c.fixes_outside_flown == int(((log.t > t[n - 1]) & has).sum())
    assert any("of the log flown" in w for w in c.suspect())


def test_corpus_reasons_name_each_check_the_test_applies():
    """The corpus test's reasons: speed, force, the span under 95 % and the heights under 99 %.

    munich's raw fixes flown as they are (their noise makes them fast and jerky: the issue's
    reasons), then cut to 93 % of the span, then 5 m low against 1 m of σ.
    """
    path = CORPUS / "calibration/munich.csv.gz"
    log = read_track(path, height_ref="pressure", alt_units="ft")
    t, first = np.unique(log.t, return_index=True)

    def flown(n: int, dh: float = 0.0) -> FlightSamples:
        i = first[:n]
        return FlightSamples(
            t[:n] - t[0], log.lat[i], log.lon[i], log.h[i] + dh, None, "test", log.lines[i], t[0]
        )

    envelope = (-1.0, 2.5)
    whole = check_piece(path, flown(t.size), sigma_h=1.0)
    assert whole.heights_within >= 0.99 and whole.flown_fraction == 1.0
    # the same two reasons: the speed judged where it is flown, then the force
    assert whole.suspect(envelope)[0].startswith("ground speed 256 m/s = 2.18 x reported 118")
    assert whole.corpus_reasons(envelope)[0].startswith("ground speed 256 m/s at t = ")
    assert " = 2.18 x the larger of the speed reported there (" in whole.corpus_reasons(envelope)[0]
    assert whole.corpus_reasons(envelope)[1:] == whole.suspect(envelope)[1:]
    n = int(np.searchsorted(t, t[0] + 0.93 * (t[-1] - t[0])))
    short = check_piece(path, flown(n), sigma_h=1.0)
    assert not any("flown" in w for w in short.suspect(envelope))  # the 90 % is met
    # (the fixes past its end are not within either)
    assert "93 % of the log flown" in short.corpus_reasons(envelope)
    low = check_piece(path, flown(t.size, dh=-5.0), sigma_h=1.0)
    assert low.corpus_reasons(envelope)[-1] == (
        f"0.0 % of the heights within 3σ (1.0 m; worst {low.worst_height_offset_m:.0f} m at "
        f"line {low.worst_height_line})"
    )


def test_manifest_lists_every_piece_with_its_robust_maximum():
    listed = {(e["category"], e["name"]) for e in MANIFEST["pieces"]}
    on_disk = {(p.parent.name, p.name[: -len(".csv.gz")]) for p in CORPUS.glob("*/*.csv.gz")}
    assert listed == on_disk
    for e in MANIFEST["pieces"][::10]:
        gs = reported_max_ground_speed(CORPUS / e["category"] / f"{e['name']}.csv.gz")
        assert gs == pytest.approx(e["gs_p995_m_s"], abs=1e-3)


def test_horizontal_offset_of_a_path_beside_the_fixes():
    """The path flown 250 m east of the fixes (and 40 m above them) is 250 m off them."""
    path = CORPUS / "calibration/munich.csv.gz"
    log = read_track(path, height_ref="pressure", alt_units="ft")
    t, first = np.unique(log.t, return_index=True)
    lat = log.lat[first]
    # 250 m east on the parallel: the prime vertical radius of curvature, cos(lat)
    s2 = np.sin(np.radians(lat)) ** 2
    n = 6_378_137.0 / np.sqrt(1.0 - 0.0066943799901 * s2)
    lon = log.lon[first] + np.degrees(250.0 / ((n + log.h[first] + 40.0) * np.cos(np.radians(lat))))
    s = FlightSamples(t - t[0], lat, lon, log.h[first] + 40.0, None, "test", log.lines[first], t[0])
    c = check_piece(path, s, sigma_h=1.0)
    assert c.horizontal_offset_median_m == pytest.approx(250.0, abs=0.01)
    assert c.horizontal_offset_p95_m == pytest.approx(250.0, abs=0.01)


def _north_at(speed: np.ndarray, dt: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return times, latitudes, longitudes of a flight north from 45° N at ``speed`` (m/s)."""
    h, a, e2 = 3000.0, 6_378_137.0, 0.0066943799901
    t = np.arange(speed.size) * dt
    north = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * dt)])
    lat = 45.0
    for _ in range(3):  # the meridian radius of curvature at the latitude reached
        m = a * (1 - e2) / (1 - e2 * np.sin(np.radians(lat)) ** 2) ** 1.5
        lat = 45.0 + np.degrees(north / (m + h))
    return t, lat, np.full_like(t, 5.0)


def _write_log(path: Path, t, lat, lon, h_ft: float, groundspeed_kt: np.ndarray) -> None:
    from datetime import datetime, timezone

    rows = ["timestamp,icao24,latitude,longitude,altitude,groundspeed,track,vertical_rate"]
    for ti, la, lo, gs in zip(t, lat, lon, groundspeed_kt, strict=True):
        stamp = datetime.fromtimestamp(1.6e9 + ti, timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
        rows.append(f"{stamp},abc123,{la:.8f},{lo:.8f},{h_ft:.0f},{gs:.3f},0,0")
    path.write_text("\n".join(rows) + "\n")


def test_a_top_speed_flown_where_it_was_reported_meets_the_speed_rule(tmp_path):
    """A dive to 130 m/s for 0.35 % of the log: the issue's 99.5th percentile is 100 m/s.

    The path that flies exactly the reports is suspect by the issue's rule (1.30 × its robust
    maximum) but meets the corpus test's, which judges each instant against what was reported
    then. The same positions with the dive left out of the groundspeed column (the aircraft
    reporting 100 m/s while its path flies 130) fail it, at the dive, by 1.30 ×.
    """
    t = np.arange(4000.0)
    bump = np.where(np.abs(t - 2000.0) <= 10.0, 0.5 * (1 + np.cos(np.pi * (t - 2000.0) / 10)), 0.0)
    speed = 100.0 + 30.0 * bump
    t, lat, lon = _north_at(speed)
    kt = 1852.0 / 3600.0
    samples = FlightSamples(t, lat, lon, np.full_like(t, 3000.0 * 0.3048), None, "test",
                            np.arange(t.size) + 2, 1.6e9)  # fmt: skip
    reported = tmp_path / "dive.csv"
    _write_log(reported, t, lat, lon, 3000.0, speed / kt)
    c = check_piece(reported, samples, sigma_h=1000.0)
    assert c.reported_gs_max_m_s == pytest.approx(100.0, abs=0.01)
    assert c.speed_ratio_p995 == pytest.approx(1.30, abs=0.01)
    assert c.speed_ratio == pytest.approx(1.0, abs=0.01)
    assert any("x reported 100" in w for w in c.suspect(None))
    assert not any("ground speed" in w for w in c.corpus_reasons((0.0, 9.0)))
    hidden = tmp_path / "hidden.csv"
    _write_log(hidden, t, lat, lon, 3000.0, np.full_like(t, 100.0 / kt))
    c = check_piece(hidden, samples, sigma_h=1000.0)
    assert c.speed_ratio == pytest.approx(1.30, abs=0.01)
    assert c.speed_worst_t_s == pytest.approx(2000.0, abs=1.0)
    assert any(w.startswith("ground speed 130 m/s at t = 2000 s = 1.30 x the larger") for w in
               c.corpus_reasons((0.0, 9.0)))  # fmt: skip
    # the dive reported, but 1000 s before it is flown: no report of its time excuses it
    early = tmp_path / "early.csv"
    _write_log(early, t, lat, lon, 3000.0, np.roll(speed, -1000) / kt)
    c = check_piece(early, samples, sigma_h=1000.0)
    assert c.speed_ratio == pytest.approx(1.30, abs=0.01)
    assert c.speed_worst_t_s == pytest.approx(2000.0, abs=1.0)
    assert np.mean(speed > 105.0) < 0.005  # under the percentile


def test_one_bad_speed_report_sets_nothing():
    """The reported speed at a time: the running median of three, interpolated in time."""
    from corpus_checks import reported_speed_at

    t = np.arange(10.0)
    v = np.full(10, 100.0)
    v[4] = 900.0  # one bad report
    v[7:] = 120.0  # a real change, reported twice or more
    got = reported_speed_at(t, v, np.array([0.0, 4.0, 6.5, 7.0, 9.0, 12.0]))
    assert got.tolist() == [100.0, 100.0, 110.0, 120.0, 120.0, 120.0]
    # a bad first or last report sets nothing either (take-off and landing)
    v = np.full(10, 100.0)
    v[0] = v[-1] = 900.0
    assert reported_speed_at(t, v, np.array([-5.0, 0.0, 9.0, 15.0])).tolist() == [100.0] * 4
    # fewer than three reports: none can be told bad; none at all: NaN
    assert reported_speed_at(t[:2], v[:2], np.array([0.5])).tolist() == [500.0]
    assert np.isnan(reported_speed_at(t[:0], v[:0], np.array([0.5]))).all()


def _write_velocity_log(path: Path, t, lat, lon, speed_m_s, track_deg) -> None:
    from datetime import datetime, timezone

    kt = 1852.0 / 3600.0
    rows = ["timestamp,icao24,latitude,longitude,altitude,groundspeed,track,vertical_rate"]
    for ti, la, lo, gs, tr in zip(t, lat, lon, speed_m_s, track_deg, strict=True):
        stamp = datetime.fromtimestamp(1.6e9 + ti, timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
        rows.append(f"{stamp},abc123,{la:.8f},{lo:.8f},3000,{gs / kt:.4f},{tr:.4f},0")
    path.write_text("\n".join(rows) + "\n")


def test_specific_force_against_the_log_s_own_velocities(tmp_path):
    """A level turn at 100 m/s round 2 km, reported by its ground speed and track.

    Differenced over ±10 s, the reported velocity turns by ωw = 0.5 rad each way: the chord
    gives |a| = (v²/R) sin(ωw)/(ωw) = 4.794 m/s², so n = √(γ² + a²)/g0 = 1.1123 (γ = 9.7974
    m/s² at 45°, 3 km). The path that flies the circle has that load factor at every row; a
    path flown straight north through the same times departs by n - 1 (the turn it left out).
    """
    from corpus_checks import force_against_log

    t, lat, lon, h = _circle(100.0, 2000.0)
    ang = 100.0 * t / 2000.0
    track = np.degrees(np.arctan2(np.sin(ang), np.cos(ang)))  # east of north: the turn to the east
    log = tmp_path / "turn.csv"
    _write_velocity_log(log, t, lat, lon, np.full_like(t, 100.0), track % 360.0)
    samples = FlightSamples(t, lat, lon, h, None, "test", np.arange(t.size) + 2, 1.6e9)
    a = 5.0 * np.sin(0.5) / 0.5
    expected = np.hypot(9.7974, a) / 9.80665
    c = force_against_log(log, samples)
    assert c.rows == t.size - 22
    assert c.log_max_g == pytest.approx(expected, abs=1e-3)
    assert c.log_min_g == pytest.approx(expected, abs=1e-3)
    assert c.departure_p95_g < 3e-3
    tn, latn, lonn = _north_at(np.full(t.size, 100.0))
    straight = FlightSamples(tn, latn, lonn, h, None, "test", np.arange(t.size) + 2, 1.6e9)
    c = force_against_log(log, straight)
    assert c.departure_p95_g == pytest.approx(expected - 0.999, abs=3e-3)


def test_a_frozen_end_is_no_part_of_the_log_s_span(tmp_path):
    """Rows repeating every value of the row before them at the end are no fixes.

    A path that stops at the last new row flies the whole span and every fix; counted as
    fixes, the 100 frozen rows would leave a third of the span unflown.
    """
    from corpus_checks import last_new_row_time

    speed = np.full(200, 100.0)
    t, lat, lon = _north_at(speed)
    kt = 1852.0 / 3600.0
    lat[200 - 100 :], lon[200 - 100 :] = lat[99], lon[99]
    log = tmp_path / "frozen.csv"
    _write_log(log, t, lat, lon, 3000.0, speed / kt)
    assert last_new_row_time(log) == pytest.approx(1.6e9 + 99.0)
    # the frozen rows without their altitude (an ADS-B table's empty cells): an empty cell is
    # no new value, so the end is still the last row with one
    text = log.read_text().splitlines()
    blank = tmp_path / "blank.csv"
    cut = [",".join(r.split(",")[:4] + [""] + r.split(",")[5:]) for r in text[1 + 120 :]]
    blank.write_text("\n".join(text[: 1 + 120] + cut) + "\n")
    assert last_new_row_time(blank) == pytest.approx(1.6e9 + 99.0)
    flown = FlightSamples(t[:100], lat[:100], lon[:100], np.full(100, 3000.0 * 0.3048), None,
                          "test", np.arange(100) + 2, 1.6e9)  # fmt: skip
    c = check_piece(log, flown, sigma_h=1000.0)  # (the heights are not the point)
    assert c.flown_fraction == pytest.approx(1.0)
    assert c.fixes == 100 and c.heights_within == 1.0
    moving = tmp_path / "moving.csv"
    _write_log(moving, t, lat, lon, 3000.0, (speed + np.arange(200)) / kt)  # new speeds: fixes
    assert last_new_row_time(moving) == np.inf
    c = check_piece(moving, flown, sigma_h=1000.0)
    assert c.flown_fraction == pytest.approx(99.0 / 199.0)

"""Conditioning of raw flight logs (fieldmap.nav.logs.condition): faults, noise, gaps, ground.

The synthetic airliner here is built independently of the implementation: its own WGS84
geodesy, its own dead reckoning and its own true kinematics (finite differences of a dense
path); the artefacts of real ADS-B logs are added by hand and their lines recorded.
"""

from __future__ import annotations

import csv
import gzip
import json
import math
from datetime import datetime
from pathlib import Path

import numpy as np
import pytest
from log_tracks import raw_track

from fieldmap.errors import InputError
from fieldmap.nav.logs.condition import (
    Conditioning,
    Stretch,
    condition,
    height_quantum,
    recordings_apart,
    unfixed_stretches,
)
from fieldmap.nav.logs.read import RawTrack, read_track
from fieldmap.nav.logs.report import OUTLIER_H, OUTLIER_HV, OUTLIER_V, plot_conditioning
from fieldmap.nav.trajectory import FlightTrajectory

A_WGS, F_WGS = 6378137.0, 1.0 / 298.257223563
E2 = F_WGS * (2.0 - F_WGS)
FT = 0.3048
G = 9.80665


def ecef(lat, lon, h):
    la, lo = np.radians(lat), np.radians(lon)
    n = A_WGS / np.sqrt(1.0 - E2 * np.sin(la) ** 2)
    return np.stack(
        [
            (n + h) * np.cos(la) * np.cos(lo),
            (n + h) * np.cos(la) * np.sin(lo),
            (n * (1.0 - E2) + h) * np.sin(la),
        ],
        -1,
    )


def enu_offsets(lat, lon, h, lat0, lon0, h0):
    """East, north, up offsets (m) of points from reference points (same shapes)."""
    d = ecef(lat, lon, h) - ecef(lat0, lon0, h0)
    la, lo = np.radians(lat0), np.radians(lon0)
    e = -np.sin(lo) * d[..., 0] + np.cos(lo) * d[..., 1]
    n = -np.sin(la) * np.cos(lo) * d[..., 0] - np.sin(la) * np.sin(lo) * d[..., 1]
    n = n + np.cos(la) * d[..., 2]
    u = np.cos(la) * np.cos(lo) * d[..., 0] + np.cos(la) * np.sin(lo) * d[..., 1]
    u = u + np.sin(la) * d[..., 2]
    return e, n, u


def smoothstep(t, t0, dur):
    x = np.clip((t - t0) / dur, 0.0, 1.0)
    return x**3 * (10.0 - 15.0 * x + 6.0 * x * x)


def airliner(duration=2400.0, dt=0.05):
    """Dense truth of an airliner: 120 -> 230 m/s, climb at 10 m/s to ~9 km and two turns.

    A standard-rate turn (3 °/s, 8 s roll-in) and a 1.5 °/s turn. Returns t, lat, lon, h and
    the true peak acceleration (g) of the path relative to the Earth.
    """
    t = np.arange(0.0, duration + dt / 2, dt)
    speed = 120.0 + 110.0 * smoothstep(t, 60.0, 600.0)
    vz = 10.0 * (smoothstep(t, 30.0, 20.0) - smoothstep(t, 900.0, 30.0))
    rate = np.radians(3.0) * (smoothstep(t, 300.0, 8.0) - smoothstep(t, 330.0, 8.0))
    rate -= np.radians(1.5) * (smoothstep(t, 1500.0, 10.0) - smoothstep(t, 1560.0, 10.0))

    def integral(x):
        return np.concatenate([[0.0], np.cumsum(0.5 * (x[1:] + x[:-1]) * dt)])

    psi = np.radians(60.0) + integral(rate)
    h = 300.0 + integral(vz)
    vh = np.sqrt(speed**2 - vz**2)
    lat = np.full(t.size, np.radians(47.0))
    for _ in range(3):  # meridian radius at the running latitude
        w = 1.0 - E2 * np.sin(lat) ** 2
        lat = np.radians(47.0) + integral(vh * np.cos(psi) / (A_WGS * (1 - E2) / w**1.5 + h))
    w = 1.0 - E2 * np.sin(lat) ** 2
    lon = np.radians(8.0) + integral(vh * np.sin(psi) / ((A_WGS / np.sqrt(w) + h) * np.cos(lat)))
    lat, lon = np.degrees(lat), np.degrees(lon)
    r = ecef(lat, lon, h)
    acc = np.linalg.norm(r[2:] - 2.0 * r[1:-1] + r[:-2], axis=1) / dt**2
    return t, lat, lon, h, float(acc.max() / G)


def adsb_log(seed=1, duration=2400.0):
    """1 Hz ADS-B-like log of the airliner with known artefacts. Returns the track and truth."""
    td, lat_d, lon_d, h_d, g_true = airliner(duration)
    step = int(round(1.0 / (td[1] - td[0])))
    t, lat, lon, h = td[::step], lat_d[::step], lon_d[::step], h_d[::step]
    n = t.size
    rng = np.random.default_rng(seed)
    m_lat = math.radians(1.0) * 6.37e6
    m_lon = m_lat * np.cos(np.radians(lat))
    lat_n = lat + rng.normal(0.0, 5.0, n) / m_lat
    lon_n = lon + rng.normal(0.0, 5.0, n) / m_lon
    h_n = np.round(h / (25 * FT)) * 25 * FT  # 25 ft altitude quantisation
    bad_h, bad_v = [], []
    bursts = [(200, 1, 2.4), (700, 2, 1.5), (1100, 3, 3.0), (1800, 1, 1.0), (2100, 2, 2.0)]
    bursts += [(305, 1, 1.2), (1520, 3, 1.8)]
    for start, length, km in bursts:
        ang = rng.uniform(0.0, 2.0 * np.pi)
        for i in range(start, start + length):
            lat_n[i] += km * 1e3 * np.cos(ang) / m_lat
            lon_n[i] += km * 1e3 * np.sin(ang) / m_lon[i]
            bad_h.append(i)
    for start, length, dz in [
        (400, 1, 300.0),
        (1300, 2, -150.0),
        (2000, 1, 5000.0),
        (950, 1, 60.0),
    ]:
        h_n[start : start + length] += dz
        bad_v.extend(range(start, start + length))
    keep = np.ones(n, bool)
    for a, b in [(500, 512), (1400, 1440), (1900, 1925)]:  # gaps of 12, 40 and 25 s
        keep[a:b] = False
    lines = np.arange(n) + 2  # a header line, then one line per sample
    order = np.flatnonzero(keep)
    for i in (800, 1600, 1700):  # swapped neighbours
        j = int(np.searchsorted(order, i))
        order[j], order[j + 1] = order[j + 1], order[j]
    for d in (600, 1200, 2200):  # repeated samples (same time)
        order = np.insert(order, int(np.searchsorted(order, d)), d)
    track = raw_track(t[order], lat_n[order], lon_n[order], h_n[order], lines[order])
    truth = {
        "t": td,
        "lat": lat_d,
        "lon": lon_d,
        "h": h_d,
        "g": g_true,
        "bad_h": set(lines[bad_h].tolist()),
        "bad_v": set(lines[bad_v].tolist()),
        "gaps": 3,
        "n_in": int(order.size),
    }
    return track, truth


@pytest.fixture(scope="module")
def synthetic():
    track, truth = adsb_log()
    return track, truth, condition(track)


def rejected_lines(cf, codes):
    raw = cf.raw
    return set(raw["lines"][np.isin(raw["status"], codes)].tolist())


def test_every_injected_outlier_is_rejected(synthetic):
    _, truth, cf = synthetic
    rej_h = rejected_lines(cf, (OUTLIER_H, OUTLIER_HV))
    rej_v = rejected_lines(cf, (OUTLIER_V, OUTLIER_HV))
    assert truth["bad_h"] <= rej_h and truth["bad_v"] <= rej_v
    false = (rej_h | rej_v) - (truth["bad_h"] | truth["bad_v"])
    assert len(false) < 0.01 * truth["n_in"]
    # each injected burst is one fault run in the report, with its lines
    runs = {tuple(f["lines"]) for f in cf.report["faults"]["list"]}
    assert (2002, 2002) in runs  # the 5 km height spike (line = index + 2)
    worst = max(cf.report["faults"]["list"], key=lambda f: f["offset"])
    assert worst["offset"] > 4000.0 and worst["channel"] == "height"


def test_path_within_a_few_sigma_of_the_truth(synthetic):
    _, truth, cf = synthetic
    s = cf.samples
    tt = s.t + s.t_start
    ref = [np.interp(tt, truth["t"], truth[k]) for k in ("lat", "lon", "h")]
    e, n, u = enu_offsets(s.lat, s.lon, s.h, *ref)
    dh = np.hypot(e, n)
    assert np.sqrt(np.mean(dh**2)) < 5.0 and dh.max() < 25.0
    assert np.sqrt(np.mean(u**2)) < 5.0 and np.abs(u).max() < 20.0
    assert s.t[0] == 0.0 and np.allclose(np.diff(s.t), 1.0)
    assert s.attitude is None and s.lines.size == s.t.size


def test_kinematics_close_to_the_truth(synthetic):
    _, truth, cf = synthetic
    k = cf.report["kinematics"]
    assert abs(k["peak_acceleration_g"] - truth["g"]) < 0.15
    assert 2.7 < k["peak_turn_rate_deg_s"] < 3.6
    assert 9.0 < k["peak_climb_rate_m_s"] < 11.5
    assert 225.0 < k["max_speed_m_s"] < 235.0
    assert k["peak_jerk_m_s3"] < 5.0
    assert 0.9 < k["min_specific_force_g"] and k["peak_specific_force_g"] < 1.6
    FlightTrajectory(cf.samples)  # refuses paths beyond 100 g


def test_report_counts(synthetic):
    _, truth, cf = synthetic
    r = cf.report
    json.dumps(r)  # JSON-ready
    assert r["samples"]["in"] == truth["n_in"]
    assert r["order"]["duplicates"] == 3
    assert r["order"]["reordered"] == 3
    assert [g["duration_s"] for g in r["gaps"]["list"]] == []  # none over 60 s
    f = r["fit"]
    assert f["sigma_estimated"] and 4.0 < f["sigma_h_m"] < 6.0
    assert abs(f["height_quantum_m"] - 25 * FT) < 0.05
    assert 3.5 < f["residual_rms_h_m"] < 6.0
    assert f["residual_all_max_v_m"] > 4000.0  # the worst residual is given beside the RMS
    assert r["vehicle"]["class"] == "airliner" and r["vehicle"]["how"].startswith("guessed")
    text = cf.format_report()
    assert "faults:" in text and "peak acceleration" in text and "largest" in text


def test_height_quantum_of_resampled_altitudes():
    """25 ft steps found where a third of the changes are interpolated between them.

    Not in a continuous climb; 100 ft steps (Mode C) as themselves.
    """
    rng = np.random.default_rng(7)
    steps = rng.choice([-1, 0, 1, 1, 2], size=3000).astype(float)
    # resampled to a clock: a third of the changes are a third or half of a step
    steps[::3] *= rng.choice([1 / 3, 1 / 2], size=steps[::3].size)
    alt_ft = 5000.0 + 25.0 * np.cumsum(steps)
    geoid = 47.0 + 1e-4 * np.arange(alt_ft.size)  # the conversion adds a smooth term
    assert abs(height_quantum(alt_ft * FT + geoid) - 25 * FT) < 0.02
    assert abs(height_quantum(4.0 * alt_ft * FT + geoid) - 100 * FT) < 0.05
    climb = 300.0 + np.cumsum(rng.uniform(2.0, 12.0, size=3000))  # GNSS heights, continuous
    assert height_quantum(climb) == 0.0


def test_height_quantum_of_a_level_flight():
    """A level flight's few 25 ft steps are its quantum when too many agree for chance.

    Five changes, all one step (by chance: 0.25⁴ = 0.4 %), are quantised; three are not
    (6 %); nor are five changes of continuous heights between 2 and 12 m.
    """
    geoid = 47.0 + 1e-4 * np.arange(70)  # the conversion adds a smooth term
    level = np.full(70, 33975.0)
    for i in (10, 30, 50):  # a step up and back, three times: 6 changes, 1 step each
        level[i : i + 5] += 25.0
    h = level * FT + geoid
    assert abs(height_quantum(h) - 25 * FT) < 0.05
    assert abs(height_quantum(h[:52]) - 25 * FT) < 0.05  # 5 changes
    assert height_quantum(h[:32]) == 0.0  # 3 changes
    rng = np.random.default_rng(3)
    gnss = np.repeat(3000.0 + np.cumsum(rng.uniform(2.0, 12.0, size=6)), 10)
    assert height_quantum(gnss) == 0.0


def test_height_quantum_of_a_cruise_logged_every_10_s():
    """25 ft steps found where the geoid adds more per fix than the steps are in number.

    Fixes 2.5 km apart (10 s at 250 m/s) gain 0.06 m of geoid height each (a slope of
    2.4e-5, 5"): without the distances flown the conversion's 0.06 m changes are the most
    common "step" of a level cruise with six 25 ft steps.
    """
    geoid = 47.0 + 0.06 * np.arange(120)
    level = np.full(120, 37000.0)
    for i in (20, 60, 100):  # up one step and back, three times
        level[i : i + 6] -= 25.0
    h = level * FT + geoid
    assert abs(height_quantum(h, distance=np.full(119, 2500.0)) - 25 * FT) < 0.1
    # a climb's continuous heights are no steps, whatever the distances
    rng = np.random.default_rng(5)
    climb = 3000.0 + np.cumsum(rng.uniform(2.0, 12.0, size=120))
    assert height_quantum(climb, distance=np.full(119, 2500.0)) == 0.0


def test_quantised_cruise_of_a_real_log_found():
    """A real cruise logged every 10 s (traffic's switzerland collection) is quantised at 25 ft.

    Its altitudes are whole multiples of 25 ft; the report's quantum says so, and so the
    heights' σ is no less than a 25 ft step's rounding error, 7.62 m / √12.
    """
    corpus = Path(__file__).parent / "data" / "corpus"
    path = corpus / "switzerland" / "switzerland_44083b_02.csv.gz"
    cf = condition(read_track(path, height_ref="pressure"))
    r = cf.report
    assert abs(r["fit"]["height_quantum_m"] - 25 * FT) < 0.1
    assert r["channels"]["height"]["noise_sigma"] >= 25 * FT / math.sqrt(12.0) - 1e-9


def test_plot(synthetic):
    fig = plot_conditioning(synthetic[2])
    assert len(fig.axes) == 4


def test_given_noise_and_exact_mode(synthetic):
    track, _, _ = synthetic
    cf = condition(track, Conditioning(position_noise_m=(5.0, 2.2)))
    assert not cf.report["fit"]["sigma_estimated"]
    assert cf.report["fit"]["sigma_h_m"] == 5.0
    ex = condition(track, Conditioning(smooth=False))
    s = ex.samples
    assert s.t.size == track.t.size - 3  # repeated times dropped
    assert np.all(np.diff(s.t) > 0)
    i = int(np.flatnonzero(track.lines == 1000)[0])
    j = int(np.flatnonzero(s.lines == 1000)[0])
    assert s.lat[j] == track.lat[i] and s.h[j] == track.h[i]


def quiet_track(t, lat, lon, h, source="quiet.csv"):
    return raw_track(t, lat, lon, h, np.arange(t.size) + 2, source=source)


def straight(t, v=200.0, lat0=40.0, lon0=-3.0, h0=3000.0, vz=0.0, heading=90.0):
    m = math.radians(1.0) * 6.37e6
    d = v * t
    lat = lat0 + d * math.cos(math.radians(heading)) / m
    lon = lon0 + d * math.sin(math.radians(heading)) / (m * math.cos(math.radians(lat0)))
    return lat, lon, h0 + vz * t


@pytest.mark.parametrize("step_ft", [25, 100])
def test_quantised_heights_are_not_outliers(step_ft):
    t = np.arange(0.0, 1200.0)
    vz = 12.0 * (smoothstep(t, 100, 20) - smoothstep(t, 700, 20))
    h = 2000.0 + np.concatenate([[0.0], np.cumsum(vz[1:])])
    lat, lon, _ = straight(t)
    hq = np.round(h / (step_ft * FT)) * step_ft * FT
    cf = condition(quiet_track(t, lat, lon, hq))
    assert cf.report["faults"]["samples"]["height"] == 0
    assert cf.report["kinematics"]["peak_acceleration_g"] < 0.2


def test_conditioning_options_validated_once():
    """Options are one frozen Conditioning, checked on construction, errors naming the option."""
    import dataclasses

    for bad in (
        {"max_gap_s": 0.0},
        {"position_noise_m": (1.0, -2.0)},
        {"vehicle": "zeppelin"},
        {"dt_out": float("nan")},
        {"smooth": "yes"},
    ):
        with pytest.raises(InputError) as e:
            Conditioning(**bad)
        assert e.value.param == next(iter(bad))
    opts = Conditioning(max_gap_s=400.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        opts.max_gap_s = 1.0  # type: ignore[misc]
    t = np.arange(0.0, 600.0)
    cf = condition(quiet_track(t, *straight(t)), opts)
    assert cf.report["options"] == opts.as_dict()


def test_long_gap_flown_as_prediction_with_its_sigma():
    """A 5-minute gap is flown across, its σ stated; nothing is dropped."""
    t = np.concatenate([np.arange(0.0, 600.0), np.arange(900.0, 1200.0)])
    tr = quiet_track(t, *straight(t), source="gappy.csv")
    cf = condition(tr)
    assert cf.samples.t[-1] == pytest.approx(1199.0)
    (b,) = cf.report["gaps"]["list"]
    assert b["lines"] == [601, 602] and b["duration_s"] == 301.0
    assert 0.0 < b["sigma_h_m"] < 1e4 and 0.0 < b["sigma_v_m"] < 1e4
    assert "gap: lines 601..602 (301 s" in cf.format_report()
    # straight and level on both sides: the bridge is the straight line, within its σ
    s = cf.samples
    lat, lon, h = straight(s.t + s.t_start)
    mid = (s.t > 650) & (s.t < 850)
    dn = (s.lat[mid] - lat[mid]) * math.radians(1.0) * 6.37e6
    assert np.abs(dn).max() < 3.0 * b["sigma_h_m"] and np.abs(dn).max() < 20.0
    assert np.abs(s.h[mid] - h[mid]).max() < 20.0


def test_log_ending_in_stale_values_is_flown_to_its_last_new_row():
    """A log's last 150 s of stale values: not flown past its last new row, and reported so.

    A transponder's last rows (after a landing, say) repeat its last position (no new fix)
    and, from t = 450 s, an altitude 30 km off, beyond any climb (rejected). From t = 451 s
    every value repeats the row before: nothing more is measured, and a path there would be
    the model's prediction from one side (before, 150 s of it were flown, with a σ growing
    past a fix's). The path ends at t = 450 s; the 149 rows after it are trimmed and named.
    """
    t = np.arange(0.0, 600.0)
    lat, lon, h = straight(t)
    stale = t >= 450.0
    lat[stale], lon[stale] = lat[449], lon[449]
    h = h.copy()
    h[stale] = 33000.0
    cf = condition(quiet_track(t, lat, lon, h, source="stale.csv"))
    assert cf.samples.t[-1] == pytest.approx(450.0)
    (note,) = [n for n in cf.report["notes"] if "the log froze there" in n]
    assert "last 149 rows (lines 453..601, 149 s) repeat every value of line 452" in note
    raw = cf.raw
    assert np.all(raw["status"][raw["lines"] >= 453] == 5)  # trimmed
    assert cf.report["channels"]["height"]["rejected"] == 1  # the stale altitude at 450 s
    assert "end of the flight with no fix" not in cf.format_report()  # 1 s: under max_gap_s


def test_unfixed_stretches_of_each_channel():
    """Stretches without kept positions, without kept heights, and at the ends.

    Overlapping ones of the two channels are one, over their union.
    """
    t = np.arange(0.0, 1000.0)
    lines = np.arange(t.size) + 2
    pos = np.ones(t.size, bool)
    hgt = np.ones(t.size, bool)
    pos[200:300] = False  # a gap in the positions alone
    hgt[500:650] = False  # in the heights alone
    pos[800:] = False  # the end: no position kept after t = 799, no height after t = 819
    hgt[820:] = False
    kept = {"positions": pos, "heights": hgt}
    got = unfixed_stretches(t, lines, kept, (0.0, 999.0), (2, 1001), 60.0)
    assert got == [
        Stretch(199.0, 300.0, (201, 302), "positions", None),
        Stretch(499.0, 650.0, (501, 652), "heights", None),
        Stretch(799.0, 999.0, (801, 1001), "positions and heights", "end"),
    ]
    # shorter than the limit: none
    assert unfixed_stretches(t, lines, kept, (0.0, 999.0), (2, 1001), 250.0) == []
    # a flown span trimmed to t = 250..700 (airborne_only): the positions' gap began on the
    # ground at t = 199, beside the span, with a fix on both sides: a gap, not the start
    got = unfixed_stretches(t, lines, kept, (250.0, 700.0), (252, 702), 40.0)
    assert got == [
        Stretch(250.0, 300.0, (201, 302), "positions", None),
        Stretch(499.0, 650.0, (501, 652), "heights", None),
    ]


def test_a_time_tag_from_another_day_is_dropped_and_reported():
    """One row stamped 1970 (a receiver's clock reset) in a 20-minute log is a recording apart.

    Flown, it would be a gap of 49 years; sorted, it is dropped and named, and the rest is
    flown as it was, whatever its place in the file and with reorder=False.
    """
    t = np.arange(1.6e9, 1.6e9 + 1200.0)
    lat, lon, h = straight(t - t[0])
    tt = t.copy()
    tt[700] = 0.0
    for opts in (Conditioning(), Conditioning(reorder=False)):
        cf = condition(quiet_track(tt, lat, lon, h, source="clock.csv"), opts)
        (a,) = cf.report["order"]["apart"]
        assert a["samples"] == 1 and a["lines"] == [702, 702] and a["gap_s"] > 1e9
        assert cf.report["kinematics"]["duration_s"] == pytest.approx(1199.0)
        assert "1 dropped at line 702, 51 years from the rest of the log" in cf.format_report()


def test_two_recordings_days_apart_fly_the_larger():
    """Two flights 30 days apart in one file: the one with more samples is flown.

    The other is named as a recording apart; a 3-hour coverage gap inside a 7-hour flight
    stays a gap.
    """
    t1 = np.arange(0.0, 1800.0, 5.0)
    t2 = 30 * 86400.0 + np.arange(0.0, 3600.0, 5.0)
    t = np.concatenate([t1, t2])
    lat, lon, h = straight(np.concatenate([t1, t2 - t2[0]]))
    cf = condition(quiet_track(t, lat, lon, h, source="two.csv"))
    (a,) = cf.report["order"]["apart"]
    assert a["samples"] == t1.size and a["lines"] == [2, t1.size + 1]
    assert cf.report["kinematics"]["duration_s"] == pytest.approx(3595.0)
    t = np.concatenate([np.arange(0.0, 7200.0, 10.0), np.arange(18000.0, 25200.0, 10.0)])
    kept, parts = recordings_apart(t)
    assert parts == [] and kept.size == t.size
    # short logs: a gap shorter than APART_S never splits them, however long the rest
    t = np.concatenate([np.arange(0.0, 40.0), np.arange(140.0, 180.0)])
    assert recordings_apart(t)[1] == []


def test_times_going_back_refused_naming_the_line():
    t = np.arange(0.0, 100.0)
    t[40], t[41] = t[41], t[40]
    tr = quiet_track(t, *straight(t), source="back.csv")
    with pytest.raises(InputError, match=r"back.csv line 43: time 40.000 s goes back") as e:
        condition(tr, Conditioning(reorder=False))
    assert "\n" not in str(e.value) and e.value.param == "reorder"
    assert condition(tr).report["order"]["first_reordered_line"] == 43


def test_nothing_left():
    t = np.arange(0.0, 600.0)
    ground = quiet_track(t, *straight(t, v=8.0, h0=400.0), source="taxi.csv")
    with pytest.raises(InputError, match=r"taxi.csv .*no airborne part") as e:
        condition(ground, Conditioning(airborne_only=True))
    assert "\n" not in str(e.value)
    assert condition(ground).samples.t[-1] == pytest.approx(599.0)  # the whole log by default
    t3 = np.arange(3.0)
    with pytest.raises(InputError, match=r"three.csv: 3 usable samples"):
        condition(quiet_track(t3, *straight(t3), source="three.csv"))
    still = quiet_track(t, np.full(t.size, 40.0), np.full(t.size, 8.0), np.full(t.size, 500.0))
    with pytest.raises(InputError, match="not a flight"):
        condition(still)


def test_ground_movement_flown_or_trimmed():
    t = np.arange(0.0, 1500.0)
    v = 5.0 + 195.0 * smoothstep(t, 300.0, 120.0) - 195.0 * smoothstep(t, 1100.0, 120.0)
    m = math.radians(1.0) * 6.37e6
    lat = 40.0 + np.cumsum(v) / m
    vz = 8.0 * (smoothstep(t, 400.0, 20) - smoothstep(t, 600, 20))
    vz -= 8.0 * (smoothstep(t, 800.0, 20) - smoothstep(t, 1000, 20))
    h = 600.0 + np.cumsum(vz)
    track = quiet_track(t, lat, np.full(t.size, -3.0), h)
    cf = condition(track, Conditioning(airborne_only=True))
    s = cf.samples
    # trimmed where the path is slower than min_speed_mps (30 m/s): t ≈ 330 s and 1170 s
    assert 300.0 < s.t_start < 360.0 and 1140.0 < s.t_start + s.t[-1] < 1200.0
    assert cf.report["kinematics"]["max_speed_m_s"] > 190.0
    assert any("trimmed" in n for n in cf.report["notes"])
    whole = condition(track)
    assert whole.samples.t[-1] == pytest.approx(1499.0)
    k = whole.report["kinematics"]
    assert 0.8 <= k["min_specific_force_g"] and k["peak_specific_force_g"] <= 1.2
    # the ground at either end: slower than the airliner's stall speed (50 m/s)
    assert 600.0 < whole.report["ground"]["duration_s"] < 800.0


def test_three_hours():
    """A three-hour log is conditioned whole (its speed: benchmarks/bench_conditioning.py)."""
    track, _ = adsb_log(seed=3, duration=10800.0)
    cf = condition(track)
    assert cf.samples.t.size > 10000


# -- real ADS-B logs ------------------------------------------------------------------------


ADSB = Path(__file__).parent / "data" / "adsb"
#: real flights (tests/data/adsb/README.md): long-haul 747s, take-off, landing, gliders with long
#: gaps, a calibration flight, air-to-air refuelling orbits, a log with stale and jumping positions
ADSB_FLIGHTS = (
    "noisy_landing", "noisy_takeoff", "noisy_time_issue", "qantas747", "elal747", "munich",
    "sisteron", "inflight_refuelling",
)  # fmt: skip


def _load_adsb(path: Path) -> RawTrack:
    """Read an excerpt (traffic layout: ISO UTC times, degrees, ft) as the raw fields, no reader."""
    with gzip.open(path, "rt", newline="") as f:
        rows = list(csv.DictReader(f))

    def arr(k):
        return np.array([float(r[k]) if r[k] else np.nan for r in rows])

    t = np.array([datetime.fromisoformat(r["timestamp"].replace("Z", "+00:00")).timestamp()
                  for r in rows])  # fmt: skip
    lat, lon, alt = arr("latitude"), arr("longitude"), arr("altitude")
    return raw_track(t, lat, lon, alt * FT, np.arange(t.size) + 2, source=str(path))


@pytest.mark.parametrize("name", ADSB_FLIGHTS)
def test_traffic_samples(name):
    cf = condition(_load_adsb(ADSB / f"{name}.csv.gz"))
    k = cf.report["kinematics"]
    assert k["peak_acceleration_g"] < 3.0
    s = cf.samples
    assert all(np.all(np.isfinite(x)) for x in (s.t, s.lat, s.lon, s.h))
    assert s.t.size > 100
    FlightTrajectory(s)


def test_flight_files_in_tests_data():
    """The real logs of tests/data/flights, read by the reader, then conditioned."""
    folder = Path(__file__).parent / "data" / "flights"
    files = sorted(folder.glob("*.csv.gz"))
    assert files, f"no real flight logs in {folder}: they ship with the tests"
    for f in files:
        cf = condition(read_track(f))
        assert cf.report["kinematics"]["peak_acceleration_g"] < 3.0, f
        assert np.all(np.isfinite(cf.samples.lat)) and np.all(np.isfinite(cf.samples.h))
        FlightTrajectory(cf.samples)


def test_fault_lines_name_their_samples_in_words():
    """The report's fault lines count samples as a reader writes them, not "velocitys"."""
    from fieldmap.nav.logs.faults import Fault

    assert (
        "6 velocities off the path"
        in Fault("velocity", "displaced", (3, 8), 0.0, 5.0, 6, 14.0).text()
    )
    assert (
        "1 position with wrong time tags"
        in Fault("position", "time-shifted", (3, 3), 0.0, 5.0, 1, 90.0, -3.0).text()
    )
    assert (
        "2 vertical rates re-timed"
        in Fault("vertical rate", "re-timed", (3, 4), 0.0, 5.0, 2, 1.0, 1.5).text()
    )

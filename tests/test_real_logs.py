"""Real logs flown as they were flown (issues 26, 34): gaps, velocities, time errors, faults.

A smooth synthetic airliner is built here with its own geodesy (WGS84 formulas written out, dead
reckoning on the ellipsoid, specific force from finite differences of a dense ECEF path and
Somigliana's normal gravity), made into an ADS-B log in the ``traffic`` layout (1 Hz, positions
late or early by a random time, 25 ft altitude steps, outliers, 3-minute gaps, ground speed in
whole knots, track in whole degrees, vertical rate in 64 ft/min steps), read by the reader and
conditioned. The real excerpts of ``tests/data/adsb`` (the ``traffic`` package's samples) are
flown whole, at the speeds the aircraft reported; faults of real logs (a stretch sent again with
old positions, altitude glitches) are rejected and reported, never a reason to refuse the log;
a paraglider's hillside launch and a GPX track's gaps follow the log's own heights.
"""

from __future__ import annotations

import gzip
import math
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import pytest
from corpus_checks import check_piece

from fieldmap.cli import main
from fieldmap.nav.logs.condition import Conditioning, condition
from fieldmap.nav.logs.read import read_track
from fieldmap.nav.trajectory import FlightTrajectory

A_WGS, F_WGS = 6378137.0, 1.0 / 298.257223563
E2 = F_WGS * (2.0 - F_WGS)
OMEGA = 7.292115e-5
G0 = 9.80665
FT, KT, FPM = 0.3048, 1852.0 / 3600.0, 0.3048 / 60.0
ADSB = Path(__file__).parent / "data" / "adsb"
T0 = datetime(2024, 5, 1, 10, 0, 0, tzinfo=timezone.utc).timestamp()
#: the 3-minute gaps of the synthetic log (s from its start), in level flight before and after
#: the turn (a manoeuvre wholly inside a gap is not in the log: no fit can fly it)
GAPS = ((700.0, 880.0), (1450.0, 1630.0))


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


def up_vector(lat, lon):
    la, lo = np.radians(lat), np.radians(lon)
    return np.stack([np.cos(la) * np.cos(lo), np.cos(la) * np.sin(lo), np.sin(la)], -1)


def somigliana(lat, h):
    """Return normal gravity (m/s²): Somigliana's formula, the free-air gradient (WGS84)."""
    s2 = np.sin(np.radians(lat)) ** 2
    g = 9.7803253359 * (1.0 + 0.00193185265241 * s2) / np.sqrt(1.0 - E2 * s2)
    return g - 3.086e-6 * h


def smoothstep(t, t0, dur):
    x = np.clip((t - t0) / dur, 0.0, 1.0)
    return x**3 * (10.0 - 15.0 * x + 6.0 * x * x)


def airliner(duration=2100.0, dt=0.05):
    """Dense truth: climb to cruise at 235 m/s, a 25° bank turn (1.14 °/s) of 90°, a descent.

    Returns t, lat, lon, h, ground speed, track (degrees), vertical speed and the specific
    force magnitude (g) of the path, from finite differences of its ECEF positions.
    """
    t = np.arange(0.0, duration + dt / 2, dt)
    vz = 8.0 * (smoothstep(t, 60.0, 30.0) - smoothstep(t, 500.0, 30.0))
    vz -= 6.0 * (smoothstep(t, 1700.0, 30.0) - smoothstep(t, 1950.0, 30.0))
    speed = 200.0 + 35.0 * smoothstep(t, 100.0, 300.0)
    rate_turn = G0 * math.tan(math.radians(25.0)) / 235.0
    t_turn = math.radians(90.0) / rate_turn
    rate = rate_turn * (smoothstep(t, 1300.0, 8.0) - smoothstep(t, 1300.0 + t_turn, 8.0))

    def integral(x):
        return np.concatenate([[0.0], np.cumsum(0.5 * (x[1:] + x[:-1]) * dt)])

    psi = np.radians(30.0) + integral(rate)
    h = 2000.0 + integral(vz)
    vh = np.sqrt(speed**2 - vz**2)
    lat = np.full(t.size, np.radians(45.0))
    for _ in range(3):  # radii of curvature at the running latitude
        w = 1.0 - E2 * np.sin(lat) ** 2
        lat = np.radians(45.0) + integral(vh * np.cos(psi) / (A_WGS * (1 - E2) / w**1.5 + h))
    w = 1.0 - E2 * np.sin(lat) ** 2
    lon = np.radians(6.0) + integral(vh * np.sin(psi) / ((A_WGS / np.sqrt(w) + h) * np.cos(lat)))
    lat, lon = np.degrees(lat), np.degrees(lon)
    r = ecef(lat, lon, h)
    v = np.gradient(r, dt, axis=0)
    a = np.gradient(v, dt, axis=0)
    w_e = np.array([0.0, 0.0, OMEGA])
    # f = a + 2 Ω × v − γ, γ (with the centrifugal part) = −|γ| up
    f = a + 2.0 * np.cross(w_e, v) + somigliana(lat, h)[:, None] * up_vector(lat, lon)
    sf = np.linalg.norm(f, axis=1)[40:-40] / G0  # the finite differences' ends left out
    return t, lat, lon, h, vh, np.degrees(psi) % 360.0, vz, sf


def adsb_csv(
    path: Path, seed=7, jitter_s=0.5, noise_m=5.0, shared_stamp=False, height_jitter_s=0.0
):
    """Write the airliner as a traffic-layout ADS-B log; return the truth (dense) and the path.

    ``shared_stamp``: the altitude is that of the position's time (one message, one stamp, one
    time error); else of the row's own time (on a clock of its own), late or early by a
    random time of σ ``height_jitter_s`` of its own.
    """
    t_d, lat_d, lon_d, h_d, gs_d, trk_d, vz_d, sf = airliner()
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, t_d[-1] - 5.0, 1.0)
    keep = np.ones(t.size, bool)
    for a, b in GAPS:
        keep &= ~((t > a) & (t < b))
    t = t[keep]
    n = t.size
    # the position is that of a time late or early by the jitter: along-track noise of 120 m
    te = np.clip(t + rng.normal(0.0, jitter_s, n), 0.0, t_d[-1])
    m_lat = math.radians(1.0) * 6.37e6
    lat = np.interp(te, t_d, lat_d) + rng.normal(0.0, noise_m, n) / m_lat
    m_lon = m_lat * np.cos(np.radians(lat))
    lon = np.interp(te, t_d, lon_d) + rng.normal(0.0, noise_m, n) / m_lon
    t_alt = te if shared_stamp else t
    if height_jitter_s > 0.0:
        t_alt = np.clip(t + rng.normal(0.0, height_jitter_s, n), 0.0, t_d[-1])
    alt_ft = np.round(np.interp(t_alt, t_d, h_d) / FT / 25.0) * 25.0
    for i, km in ((150, 2.0), (151, 2.0), (1000, -1.5), (1600, 3.0)):  # position outliers
        lat[i] += km * 1e3 / m_lat
    for i, dft in ((400, 1000.0), (1100, -600.0), (1101, -600.0)):  # altitude spikes
        alt_ft[i] += dft
    gs = np.round(np.interp(t, t_d, gs_d) / KT)
    trk = np.round(np.degrees(np.unwrap(np.radians(np.interp(t, t_d, np.unwrap(trk_d, 180.0)))))
                   ) % 360.0  # fmt: skip
    vr = np.round(np.interp(t, t_d, vz_d) / FPM / 64.0) * 64.0
    rows = ["timestamp,icao24,latitude,longitude,altitude,groundspeed,track,vertical_rate"]
    for k in range(n):
        stamp = datetime.fromtimestamp(T0 + t[k], timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
        rows.append(
            f"{stamp},4ca000,{lat[k]:.7f},{lon[k]:.7f},{alt_ft[k]:.0f},{gs[k]:.0f},"
            f"{trk[k]:.0f},{vr[k]:.0f}"
        )
    path.write_text("\n".join(rows) + "\n")
    truth = {"t": t_d, "lat": lat_d, "lon": lon_d, "h": h_d, "sf_max": float(sf.max())}
    return path, truth


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory):
    path, truth = adsb_csv(tmp_path_factory.mktemp("adsb") / "airliner.csv")
    tr = read_track(path, height_ref="ellipsoid")
    return tr, truth, condition(tr)


def _errors(cf, truth):
    """Offsets (m) of the conditioned samples from the truth: horizontal, vertical, along."""
    s = cf.samples
    tt = s.t + s.t_start - T0
    ref = [np.interp(tt, truth["t"], truth[k]) for k in ("lat", "lon", "h")]
    r_ref = ecef(*ref)
    d = ecef(s.lat, s.lon, s.h) - r_ref
    u = up_vector(ref[0], ref[1])
    dv = np.sum(d * u, axis=1)
    dh = np.linalg.norm(d - dv[:, None] * u, axis=1)
    v = np.gradient(r_ref, tt, axis=0)
    v -= np.sum(v * u, axis=1)[:, None] * u
    along = np.sum(d * v, axis=1) / np.linalg.norm(v, axis=1)
    return tt, dh, dv, along


def test_synthetic_adsb_log_flown_whole(synthetic):
    tr, truth, cf = synthetic
    k = cf.report["kinematics"]
    assert k["duration_s"] >= np.ptp(tr.t) - 1.0  # the whole span, across both 3-minute gaps
    assert len(cf.report["gaps"]["list"]) == len(GAPS)
    assert cf.report["vehicle"]["class"] == "airliner"
    FlightTrajectory(cf.samples)


def test_synthetic_adsb_path_within_the_noise(synthetic):
    """Within the noise of the fixes where there are fixes; within 3 stated σ across the gaps.

    The fixes are off by 5 m per axis and, along the track, by the 0.5 s jitter (117 m at 235
    m/s); the ground speeds are whole knots.
    """
    _, truth, cf = synthetic
    tt, dh, dv, along = _errors(cf, truth)
    in_gap = np.zeros(tt.size, bool)
    for b in cf.report["gaps"]["list"]:
        t_a, t_b = (b[k] + cf.samples.t_start - T0 for k in ("t_from_s", "t_to_s"))
        inside = (tt > t_a) & (tt < t_b)
        in_gap |= inside
        assert dh[inside].max() < 3.0 * math.sqrt(2.0) * b["sigma_h_m"], b
        assert np.abs(dv[inside]).max() < 3.0 * b["sigma_v_m"] + 8.0, b
    assert in_gap.sum() > 300
    across = np.sqrt(np.maximum(dh**2 - along**2, 0.0))[~in_gap]
    assert np.sqrt(np.mean(across**2)) < 5.0 and across.max() < 30.0
    # along the track a quarter of one fix's jitter (without the time errors: 146 m RMS)
    assert np.sqrt(np.mean(along[~in_gap] ** 2)) < 0.25 * 0.5 * 235.0
    assert np.sqrt(np.mean(dv[~in_gap] ** 2)) < 5.0 and np.abs(dv[~in_gap]).max() < 15.0


def test_synthetic_adsb_specific_force_as_flown(synthetic):
    _, truth, cf = synthetic
    k = cf.report["kinematics"]
    assert abs(k["peak_specific_force_g"] - truth["sf_max"]) < 0.05
    assert k["min_specific_force_g"] > 0.85  # gentle climb and descent entries only


def test_synthetic_adsb_velocities_and_time_errors_reported(synthetic):
    _, _, cf = synthetic
    v = cf.report["velocity"]
    assert v["columns"] == ["groundspeed", "track", "vertical_rate"]
    # the flown velocity within the log's rounding (1 kt, 1°, 64 ft/min) and little more
    assert v["groundspeed_rms_m_s"] < 1.0 and v["track_rms_deg"] < 1.0
    assert v["vertical_rate_rms_m_s"] < 1.0
    tm = cf.report["timing"]
    assert tm is not None and 0.25 < tm["sigma_s"] < 1.0  # 0.5 s injected
    text = cf.format_report()
    assert "flown − log's velocities" in text and "time errors of the fixes" in text


def _heights_within_their_sigma(path: Path, cf) -> float:
    """Return the fraction of the log's heights within 3 of the σ the fit gives each."""
    fit = cf.report["fit"]
    return check_piece(
        path,
        cf.samples,
        sigma_h=max(fit["sigma_v_m"], 1.0),
        height_time_sigma=fit["height_time_sigma_s"],
        height_ref="ellipsoid",
    ).heights_within


def test_heights_stamped_with_their_fixes_time_carry_its_time_errors(tmp_path):
    """Altitudes in the positions' messages: 0.5 s of time error is 4 m in an 8 m/s climb.

    Each height's σ at its stamped time is √(s² + (ż σ_τ)²) with the positions' σ_τ: the
    climbs' heights are within 3 of it (3 altitude spikes aside), and the path flies the
    climb as the truth does, not the time errors' zig-zag.
    """
    path, truth = adsb_csv(tmp_path / "shared.csv", shared_stamp=True)
    cf = condition(read_track(path, height_ref="ellipsoid"))
    fit = cf.report["fit"]
    assert 0.25 < fit["height_time_sigma_s"] < 1.0  # 0.5 s injected
    assert _heights_within_their_sigma(path, cf) >= 0.99
    _, _, dv, _ = _errors(cf, truth)
    assert np.sqrt(np.mean(dv**2)) < 5.0


def test_heights_on_a_clock_of_their_own_within_their_sigma(synthetic):
    """The positions late or early, the heights on their rows' clock: within 3σ as given."""
    tr, _, cf = synthetic
    assert _heights_within_their_sigma(Path(tr.source), cf) >= 0.99


def test_heights_with_time_errors_of_their_own_carry_them(tmp_path):
    """Altitudes late or early by 1 s (σ) of their own, the positions by 0.1 s.

    The heights' σ_τ exceeds the positions' (their own residuals in the climbs say so, by the
    mixture's likelihood), and the climbs' heights are within 3 of their σ.
    """
    path, truth = adsb_csv(tmp_path / "own.csv", jitter_s=0.1, height_jitter_s=1.0)
    cf = condition(read_track(path, height_ref="ellipsoid"))
    fit = cf.report["fit"]
    positions = cf.report["timing"]["sigma_s"] if cf.report["timing"] else 0.0
    assert 0.5 < fit["height_time_sigma_s"] < 2.0 and fit["height_time_sigma_s"] > positions
    assert _heights_within_their_sigma(path, cf) >= 0.99
    _, _, dv, _ = _errors(cf, truth)
    assert np.sqrt(np.mean(dv**2)) < 5.0


def _contradicting(tmp_path: Path, scale: float, rotate: float) -> Path:
    path, _ = adsb_csv(tmp_path / "bad.csv")
    lines = path.read_text().splitlines()
    out = [lines[0]]
    for row in lines[1:]:
        f = row.split(",")
        f[5] = f"{float(f[5]) * scale:.0f}"
        f[6] = f"{(float(f[6]) + rotate) % 360.0:.0f}"
        out.append(",".join(f))
    path.write_text("\n".join(out) + "\n")
    return path


def test_tracks_off_the_positions_keep_their_speeds(tmp_path):
    """Tracks a quarter turn off (another convention): the speeds are used along the positions."""
    path = _contradicting(tmp_path, 1.0, 90.0)
    track = read_track(path, height_ref="ellipsoid")
    cf = condition(track)
    assert any("tracks" in n and "off the direction" in n for n in cf.report["notes"])
    k = cf.report["kinematics"]
    assert k["duration_s"] >= np.ptp(track.t) - 1.0
    assert 225.0 < k["max_ground_speed_m_s"] < 245.0  # the positions' speed, 235 m/s
    assert cf.report["velocity"]["groundspeed_rms_m_s"] < 2.0


def test_velocities_in_another_unit_left_out(tmp_path):
    """Ground speeds in m/s under a knots column: a constant factor, the velocities left out.

    The speeds say nothing of the path then, not even its top speed (at 0.51 × they would
    hold it to half the aircraft's): the positions alone fly it, at the aircraft's speed, and
    the note gives the factor. The CLI flies it too.
    """
    path = _contradicting(tmp_path, KT, 0.0)
    cf = condition(read_track(path, height_ref="ellipsoid"))
    (note,) = [n for n in cf.report["notes"] if "× its positions' throughout" in n]
    assert "(groundspeed, track) are 0.515 ×" in note  # whole m/s over the path's speed
    assert "velocity" not in cf.report["channels"]
    assert 225.0 < cf.report["kinematics"]["max_ground_speed_m_s"] < 245.0
    # its speeds (121 "m/s") are no evidence of the vehicle either: guessed from the positions
    assert cf.report["vehicle"]["class"] == "airliner", cf.report["vehicle"]
    argv = ["navsim", "--lmax", "20", "--models", "j4", "--rate", "10", "--no-timing"]
    out = tmp_path / "out"
    rc = main([*argv, "--trajectory", str(path), "--height-ref", "ellipsoid", "--out", str(out)])
    assert rc == 0


def test_velocities_left_out_on_request(tmp_path):
    """log_velocities=False: the velocity columns are not used, and the report says so."""
    path, _ = adsb_csv(tmp_path / "a.csv")
    track = read_track(path, height_ref="ellipsoid")
    cf = condition(track, Conditioning(log_velocities=False))
    assert cf.report["options"]["log_velocities"] is False
    assert cf.report["velocity"] is None and "velocity" not in cf.report["channels"]
    assert any("not used (log_velocities=False)" in n for n in cf.report["notes"])
    assert cf.report["kinematics"]["duration_s"] >= 0.95 * (track.t[-1] - track.t[0])


def _rewrite(path: Path, edit) -> Path:
    lines = path.read_text().splitlines()
    rows = [r.split(",") for r in lines[1:]]
    edit(rows)
    path.write_text("\n".join([lines[0], *(",".join(r) for r in rows)]) + "\n")
    return path


def test_a_stretch_sent_again_with_old_positions_is_a_fault_not_a_refusal(tmp_path):
    """The dreamliner's fault: 14 positions jump back and repeat the previous 14 s.

    The log is flown whole at the speed reported; the stretch is rejected (or re-timed) and
    reported with its lines.
    """
    path, truth = adsb_csv(tmp_path / "a.csv")

    def repeat(rows):
        for i in range(1200, 1214):
            rows[i][2], rows[i][3] = rows[i - 14][2], rows[i - 14][3]

    _rewrite(path, repeat)
    track = read_track(path, height_ref="ellipsoid")
    cf = condition(track)
    k = cf.report["kinematics"]
    assert k["duration_s"] >= np.ptp(track.t) - 1.0
    assert k["max_ground_speed_m_s"] < 1.05 * 240.0
    assert 0.85 < k["min_specific_force_g"] and k["peak_specific_force_g"] < 1.3
    lines = [tuple(f["lines"]) for f in cf.report["faults"]["list"] if f["channel"] == "position"]
    # the file's lines 1202..1215 (a header, then one row a line), in one or two runs
    hit = [ln for ln in lines if ln[0] <= 1215 and ln[1] >= 1202]
    assert hit and min(a for a, _ in hit) <= 1204 and max(b for _, b in hit) >= 1213
    assert "positions" in cf.format_report()


def test_altitude_glitches_rejected_not_refused(tmp_path):
    """Runs of 5 altitudes 30,000 ft too high (a TV relay helicopter's glitches): rejected."""
    path, truth = adsb_csv(tmp_path / "a.csv")

    def glitch(rows):
        for start in (300, 900, 1500):
            for i in range(start, start + 5):
                rows[i][4] = f"{float(rows[i][4]) + 30000:.0f}"

    _rewrite(path, glitch)
    track = read_track(path, height_ref="ellipsoid")
    cf = condition(track)
    heights = [f for f in cf.report["faults"]["list"] if f["channel"] == "height"]
    assert {(f["lines"][0], f["lines"][1]) for f in heights} >= {(302, 306), (902, 906)}
    tt, dh, dv, along = _errors(cf, truth)
    assert np.abs(dv).max() < 30.0


# -- the real excerpts ---------------------------------------------------------------------

REAL = ["elal747", "qantas747", "noisy_landing", "noisy_takeoff", "noisy_time_issue", "munich"]


def _reported_max_groundspeed(path: Path) -> float:
    """Return the log's robust top ground speed: the 99.5th percentile of its column (m/s)."""
    with gzip.open(path, "rt") as f:
        rows = f.read().splitlines()
    col = rows[0].split(",").index("groundspeed")
    gs = [float(r.split(",")[col]) for r in rows[1:] if r.split(",")[col]]
    return float(np.percentile(gs, 99.5)) * KT


def _file_span(path: Path) -> float:
    """Return the log's span (s): its first fix to its last, as the file holds them."""
    with gzip.open(path, "rt") as f:
        rows = f.read().splitlines()
    col = rows[0].split(",").index("timestamp")
    t = [
        datetime.fromisoformat(r.split(",")[col].replace("Z", "+00:00")).timestamp()
        for r in rows[1:]
    ]
    return max(t) - min(t)


def _fresh_groundspeed_rms(cf, track) -> float:
    """RMS (m/s) of the flown ground speed against the log's, at its fresh reports.

    A row whose ground speed and track repeat the row's before may be a copy (a value held
    or filled forward: noisy_time_issue holds 102 kt through its landing roll and taxi),
    which the path does not fly: the rows where either changes are the aircraft's reports.
    """
    s = cf.samples
    north = np.gradient(np.radians(s.lat)) * 6_371_000.0
    east = np.gradient(np.radians(s.lon)) * 6_371_000.0 * np.cos(np.radians(s.lat))
    speed = np.hypot(north, east) / np.gradient(s.t)
    v = track.velocity
    fresh = np.r_[True, (v.speed[1:] != v.speed[:-1]) | (v.track[1:] != v.track[:-1])]
    fresh &= np.isfinite(v.speed) & np.isfinite(v.track)
    flown = np.interp(track.t[fresh] - s.t_start, s.t, speed)
    return float(np.sqrt(np.mean((flown - v.speed[fresh]) ** 2)))


@pytest.mark.parametrize("name", REAL)
def test_real_adsb_flown_whole_at_the_reported_speeds(name):
    """The whole file is flown (the ground movement too), at the speeds the aircraft reported."""
    path = ADSB / f"{name}.csv.gz"
    cf = condition(read_track(path, height_ref="pressure"))
    k = cf.report["kinematics"]
    assert k["duration_s"] >= 0.99 * _file_span(path)
    ratio = k["max_ground_speed_m_s"] / _reported_max_groundspeed(path)
    assert ratio <= 1.05, ratio
    assert 0.3 <= k["min_specific_force_g"] and k["peak_specific_force_g"] <= 1.8
    v = cf.report["velocity"]
    if v["velocity_used"]:
        assert _fresh_groundspeed_rms(cf, read_track(path, height_ref="pressure")) < 3.0
    else:  # munich: its track column is not the track the positions fly (80 % off by ~100°)
        assert any("contradict its positions" in n for n in cf.report["notes"])


def test_real_log_with_stale_velocities_flown_on_its_positions():
    """inflight_refuelling: its velocity columns are stale; its orbits are flown all the same.

    To its last new row: its last rows repeat every value of the row before them (a frozen
    end, not flown).
    """
    track = read_track(ADSB / "inflight_refuelling.csv.gz", height_ref="pressure")
    for cf in (condition(track), condition(track, Conditioning(log_velocities=False))):
        k = cf.report["kinematics"]
        frozen = [n for n in cf.report["notes"] if "the log froze there" in n]
        last = cf.raw["t"][cf.raw["status"] != 5][-1]  # the last row not trimmed
        assert len(frozen) == 1 and last == pytest.approx(k["duration_s"], abs=1.0)
        assert k["duration_s"] >= 0.95 * (track.t[-1] - track.t[0])
        assert 0.3 <= k["min_specific_force_g"] and k["peak_specific_force_g"] <= 1.8


# -- other vehicles, other formats -----------------------------------------------------------


def _igc(path: Path, t, lat, lon, h) -> Path:
    """Write an IGC file of fixes (GNSS altitude on the ellipsoid, pressure altitude the same)."""
    out = ["AXXX001", "HFDTE150724", "HFALGALG:ELL"]
    for k in range(t.size):
        s = int(t[k])
        la, lo = abs(lat[k]), abs(lon[k])
        out.append(
            f"B{s // 3600:02d}{s // 60 % 60:02d}{s % 60:02d}"
            f"{int(la):02d}{(la - int(la)) * 60000:05.0f}{'N' if lat[k] >= 0 else 'S'}"
            f"{int(lo):03d}{(lo - int(lo)) * 60000:05.0f}{'E' if lon[k] >= 0 else 'W'}"
            f"A{h[k]:05.0f}{h[k]:05.0f}"
        )
    path.write_text("\n".join(out) + "\n")
    return path


def test_paraglider_launch_and_landing_flown_at_the_logs_heights(tmp_path):
    """A hillside launch running down the slope, a flight, a landing in a valley: no levelling.

    The log's heights are followed within 3σ at every fix, the launch's 40 m descent and the
    landing included, and the vehicle is guessed to be a paraglider.
    """
    rng = np.random.default_rng(5)
    t = np.arange(36000.0, 36000.0 + 1800.0)
    # on the hill: running 60 s at 4 m/s down a 20 % slope (635 -> 587 m), then flying at 10 m/s
    # ground speed, circling in a thermal, gliding down to land at 20 m, standing 60 s
    x = np.zeros(t.size)
    y = np.zeros(t.size)
    h = np.zeros(t.size)
    tt = t - t[0]
    run = tt < 60.0
    x[run] = 4.0 * tt[run]
    h[run] = 635.0 - 0.8 * tt[run]
    fly = ~run & (tt < 1680.0)
    tf = tt[fly] - 60.0
    ang = 2.0 * np.pi * tf / 25.0
    x[fly] = 240.0 + 10.0 * tf * 0.3 + 40.0 * np.sin(ang)
    y[fly] = 40.0 * (1.0 - np.cos(ang))
    h[fly] = (
        587.0
        + 1.5 * tf * (tf < 600)
        + (900.0 - 1.6 * (tf - 600.0)) * (tf >= 600)
        - (900.0 * (tf >= 600) - 0.0)
    )
    h[fly] = np.where(tf < 600, 587.0 + 1.5 * tf, 1487.0 - 1.45 * (tf - 600.0))
    end = tt >= 1680.0
    x[end], y[end], h[end] = x[fly][-1], y[fly][-1], h[fly][-1]
    lat = 46.0 + (y + rng.normal(0, 2.0, t.size)) / 111195.0
    lon = 7.0 + (x + rng.normal(0, 2.0, t.size)) / (111195.0 * math.cos(math.radians(46.0)))
    hn = np.round(h + rng.normal(0.0, 1.5, t.size))
    track = read_track(_igc(tmp_path / "hike_and_fly.igc", t, lat, lon, hn))
    cf = condition(track)
    assert cf.report["vehicle"]["class"] == "paraglider", cf.report["vehicle"]
    s = cf.samples
    flown_h = np.interp(track.t - s.t_start, s.t, s.h)
    sig = cf.report["fit"]["sigma_v_m"]
    off = np.abs(flown_h - track.h)
    assert np.mean(off <= 3.0 * sig) >= 0.99 and sig < 3.0
    # the launch's descent (635 -> 587 m) and the landing at ~20 m, as logged
    assert np.all(off[:60] <= 3.0 * sig + 1.0) and np.all(off[-60:] <= 3.0 * sig + 1.0)
    assert cf.report["fit"]["residual_all_max_v_m"] < 10.0


def _gpx(path: Path, t, lat, lon, h) -> Path:
    pts = "".join(
        f'<trkpt lat="{lat[k]:.7f}" lon="{lon[k]:.7f}"><ele>{h[k]:.1f}</ele>'
        f"<time>{datetime.fromtimestamp(t[k], timezone.utc).strftime('%Y-%m-%dT%H:%M:%SZ')}"
        "</time></trkpt>"
        for k in range(t.size)
    )
    path.write_text(
        '<?xml version="1.0"?><gpx version="1.1" creator="test" '
        'xmlns="http://www.topografix.com/GPX/1/1"><trk><trkseg>'
        f"{pts}</trkseg></trk></gpx>"
    )
    return path


def test_gpx_gaps_bridged_within_the_neighbours_heights(tmp_path):
    """A car's GNSS track with two 10-minute gaps: no invented height swings across them."""
    rng = np.random.default_rng(11)
    t = T0 + np.arange(0.0, 3600.0)
    keep = ~(((t - T0 > 900) & (t - T0 < 1514)) | ((t - T0 > 2400) & (t - T0 < 3243)))
    v = 20.0 + 5.0 * np.sin((t - T0) / 200.0)
    d = np.cumsum(v)
    h = 570.0 + 25.0 * np.sin((t - T0) / 400.0)  # rolling country: 545..595 m
    lat = 45.0 + d / 111195.0 + rng.normal(0, 3.0, t.size) / 111195.0
    lon = 14.0 + 300.0 * np.sin(d / 5000.0) / 78000.0
    hn = h + rng.normal(0.0, 6.0, t.size)
    track = read_track(_gpx(tmp_path / "drive.gpx", t[keep], lat[keep], lon[keep], hn[keep]))
    cf = condition(track)
    assert cf.report["vehicle"]["class"] == "car", cf.report["vehicle"]
    assert len(cf.report["gaps"]["list"]) == 2
    s = cf.samples
    for g in cf.report["gaps"]["list"]:
        inside = (s.t > g["t_from_s"]) & (s.t < g["t_to_s"])
        near = (track.t - s.t_start > g["t_from_s"] - 300) & (
            track.t - s.t_start < g["t_to_s"] + 300
        )
        lo, hi = track.h[near].min(), track.h[near].max()
        assert lo - 20.0 < s.h[inside].min() and s.h[inside].max() < hi + 20.0, (lo, hi)
        assert g["sigma_v_m"] > 0.0


def _with_tail(path: Path, out: Path, seconds: int, vary_speed: bool = False) -> Path:
    """Write ``path`` with ``seconds`` more rows at 1 s repeating its last row's values.

    ``vary_speed``: the repeated rows' ground speed changes (1 kt a row): a new value each.
    """
    rows = path.read_text().splitlines()
    stamp, *values = rows[-1].split(",")
    t_last = datetime.strptime(stamp, "%Y-%m-%dT%H:%M:%SZ").replace(tzinfo=timezone.utc)
    for k in range(1, seconds + 1):
        when = datetime.fromtimestamp(t_last.timestamp() + k, timezone.utc)
        vals = list(values)
        if vary_speed:
            vals[5] = str(int(vals[5]) + k)
        rows.append(when.strftime("%Y-%m-%dT%H:%M:%SZ") + "," + ",".join(vals))
    out.write_text("\n".join(rows) + "\n")
    return out


def test_a_frozen_end_is_not_flown(tmp_path):
    """A log whose last 120 rows repeat every value of the row before them (it froze there).

    Nothing is measured after the last new row: the path ends there, flown exactly as the log
    without the frozen rows is (the same bits), the rows are reported with their lines and
    trimmed, and no 120 s of straight flight at the last velocity (28 km) is invented. Rows
    that repeat the position but report a new ground speed each are measurements: flown.
    """
    path, _ = adsb_csv(tmp_path / "log.csv")
    n_rows = len(path.read_text().splitlines()) - 1
    plain = condition(read_track(path, height_ref="ellipsoid"))
    frozen = _with_tail(path, tmp_path / "frozen.csv", 120)
    cf = condition(read_track(frozen, height_ref="ellipsoid"))
    assert np.array_equal(cf.samples.t, plain.samples.t)
    for k in ("lat", "lon", "h"):
        assert np.array_equal(getattr(cf.samples, k), getattr(plain.samples, k))
    last, first_frozen = n_rows + 1, n_rows + 2  # line 1 is the header
    note = [n for n in cf.report["notes"] if "froze" in n]
    assert len(note) == 1
    assert f"lines {first_frozen}..{first_frozen + 119}" in note[0]
    assert f"line {last}:" in note[0]
    raw = cf.raw
    tail = raw["lines"] >= first_frozen
    assert tail.sum() == 120 and np.all(raw["status"][tail] == 5)  # TRIMMED
    from fieldmap.nav.logs.report import plot_conditioning

    assert plot_conditioning(cf)._suptitle.get_text().endswith(", 120 not flown")
    # the rows keep their heights; no distance from a path that is not flown there
    assert np.all(np.isfinite(raw["h"][tail]))
    assert np.all(np.isnan(raw["offset_h"][tail]) & np.isnan(raw["offset_v"][tail]))
    # a given output interval: the last sample still names the last measured line
    every = condition(read_track(frozen, height_ref="ellipsoid"), Conditioning(dt_out=0.7))
    assert every.samples.lines[-1] == last
    # fixes 10 s apart with the frozen rows at 1 s: the grid is the fixes' (5 s), not 1 s
    rows = path.read_text().splitlines()
    sparse = tmp_path / "sparse.csv"
    sparse.write_text("\n".join([rows[0], *rows[1::10]]) + "\n")
    alone = condition(read_track(sparse, height_ref="ellipsoid"))
    tailed = _with_tail(sparse, tmp_path / "sf.csv", 300)
    cs = condition(read_track(tailed, height_ref="ellipsoid"))
    assert np.array_equal(cs.samples.t, alone.samples.t)
    assert np.array_equal(cs.samples.h, alone.samples.h)
    moving = _with_tail(path, tmp_path / "moving.csv", 120, vary_speed=True)
    cm = condition(read_track(moving, height_ref="ellipsoid"))
    assert cm.samples.t[-1] == pytest.approx(plain.samples.t[-1] + 120.0, abs=1.0)
    assert not any("froze" in n for n in cm.report["notes"])

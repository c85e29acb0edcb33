"""ADS-B logs flown whole, as the vehicle flew (issue 26): gaps, velocities, timing jitter.

A smooth synthetic airliner is built here with its own geodesy (WGS84 formulas written out, dead
reckoning on the ellipsoid, specific force from finite differences of a dense ECEF path and
Somigliana's normal gravity), made into an ADS-B log in the ``traffic`` layout (1 Hz, positions
late or early by a random time, 25 ft altitude steps, outliers, 3-minute gaps, ground speed in
whole knots, track in whole degrees, vertical rate in 64 ft/min steps), read by the reader and
conditioned. The real excerpts of ``tests/data/adsb`` (the ``traffic`` package's samples) are
flown whole, at the speeds the aircraft reported.
"""

from __future__ import annotations

import gzip
import math
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import pytest

from fieldmap.cli import main
from fieldmap.errors import InputError
from fieldmap.nav.logs.condition import JOIN_OVERLAP_S, Conditioning, condition
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


def adsb_csv(path: Path, seed=7, jitter_s=0.5, noise_m=5.0):
    """Write the airliner as a traffic-layout ADS-B log; return the truth (dense) and the path."""
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
    alt_ft = np.round(np.interp(t, t_d, h_d) / FT / 25.0) * 25.0
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
    assert cf.report["segments"]["dropped"] == []
    assert len(cf.report["gaps"]["long_bridged"]) == len(GAPS)
    assert cf.report["vehicle"]["class"] == "airliner"
    FlightTrajectory(cf.samples)


def test_synthetic_adsb_path_within_the_noise(synthetic):
    """Within the noise of the fixes where there are fixes; within 3 stated σ across the gaps.

    The fixes are off by 5 m per axis and, along the track, by the 0.5 s jitter (117 m at 235
    m/s); the ground speeds are whole knots, so that the velocities hold the along-track
    position only to their rounding (0.1 m/s for minutes of steady flight: tens of metres).
    """
    _, truth, cf = synthetic
    tt, dh, dv, along = _errors(cf, truth)
    in_gap = np.zeros(tt.size, bool)
    for b in cf.report["gaps"]["long_bridged"]:
        t_a, t_b = (b[k] + cf.samples.t_start - T0 for k in ("t_from_s", "t_to_s"))
        inside = (tt > t_a) & (tt < t_b)
        in_gap |= inside
        assert dh[inside].max() < 3.0 * math.sqrt(2.0) * b["sigma_h_m"], b
        assert np.abs(dv[inside]).max() < 3.0 * b["sigma_v_m"] + 8.0, b
    assert in_gap.sum() > 300
    across = np.sqrt(np.maximum(dh**2 - along**2, 0.0))[~in_gap]
    # across the track within the 5 m noise (RMS), the largest where the fixes were moved
    # along a turn (measured 22..28 m on three seeds)
    assert np.sqrt(np.mean(across**2)) < 5.0 and across.max() < 30.0
    # along the track a quarter of one fix's jitter (without the jitter model: 146 m RMS)
    assert np.sqrt(np.mean(along[~in_gap] ** 2)) < 0.25 * 0.5 * 235.0
    assert np.sqrt(np.mean(dv[~in_gap] ** 2)) < 5.0 and np.abs(dv[~in_gap]).max() < 15.0


def test_synthetic_adsb_specific_force_as_flown(synthetic):
    _, truth, cf = synthetic
    k = cf.report["kinematics"]
    assert abs(k["peak_specific_force_g"] - truth["sf_max"]) < 0.05
    assert k["min_specific_force_g"] > 0.85  # gentle climb and descent entries only


def test_synthetic_adsb_velocities_and_jitter_reported(synthetic):
    _, _, cf = synthetic
    v = cf.report["velocity"]
    assert v["columns"] == ["groundspeed", "track", "vertical_rate"]
    # the flown velocity within the log's rounding (1 kt, 1°, 64 ft/min) and little more
    assert v["groundspeed_rms_m_s"] < 1.0 and v["track_rms_deg"] < 1.0
    assert v["vertical_rate_rms_m_s"] < 1.0
    tm = cf.report["timing"]
    assert tm is not None and 0.25 < tm["jitter_s"] < 1.0  # 0.5 s injected
    text = cf.format_report()
    assert "velocity residuals, flown − log" in text and "timing jitter of the fixes" in text


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


@pytest.mark.parametrize(("scale", "rotate"), [(KT, 0.0), (1.0, 90.0)])
def test_velocities_contradicting_the_positions_refused(tmp_path, scale, rotate):
    """Ground speeds in m/s under a knots column, or tracks a quarter turn off: one line."""
    path = _contradicting(tmp_path, scale, rotate)
    with pytest.raises(InputError, match="velocities .* contradict its positions") as e:
        condition(read_track(path, height_ref="ellipsoid"))
    assert "\n" not in str(e.value)


def test_velocities_contradicting_refused_on_the_command_line(tmp_path, capsys):
    path = _contradicting(tmp_path, KT, 0.0)
    out = tmp_path / "out"
    argv = ["navsim", "--lmax", "20", "--models", "j4", "--rate", "10", "--no-timing"]
    rc = main([*argv, "--trajectory", str(path), "--height-ref", "ellipsoid", "--out", str(out)])
    cap = capsys.readouterr()
    lines = cap.err.strip().splitlines()
    assert rc == 2 and len(lines) == 1, cap.err
    assert "contradict its positions" in lines[0] and "Traceback" not in cap.err
    assert "give --ignore-log-velocities" in lines[0] and "log_velocities" not in lines[0]
    assert not out.exists()


def test_velocities_left_out_on_request(tmp_path):
    """log_velocities=False: the contradicting velocity columns are not used, the path is flown."""
    path = _contradicting(tmp_path, KT, 0.0)
    track = read_track(path, height_ref="ellipsoid")
    with pytest.raises(InputError) as e:
        condition(track)
    assert e.value.param == "log_velocities" and "log_velocities=False" in str(e.value)
    cf = condition(track, Conditioning(log_velocities=False))
    assert cf.report["options"]["log_velocities"] is False
    assert cf.report["velocity"] is None
    assert any("not used (log_velocities=False)" in n for n in cf.report["notes"])
    assert cf.report["kinematics"]["duration_s"] >= 0.9 * (track.t[-1] - track.t[0])


def test_real_log_flown_without_its_stale_velocities():
    """inflight_refuelling, its velocity columns left out: its orbits flown whole, as flown."""
    track = read_track(ADSB / "inflight_refuelling.csv.gz", height_ref="pressure")
    cf = condition(track, Conditioning(log_velocities=False))
    k = cf.report["kinematics"]
    assert k["duration_s"] >= 0.9 * (track.t[-1] - track.t[0])
    assert 0.3 <= k["min_specific_force_g"] and k["peak_specific_force_g"] <= 1.8


def test_longest_segment_still_on_request(synthetic):
    tr, _, cf = synthetic
    longest = condition(tr, Conditioning(on_long_gap="longest"))
    assert longest.report["kinematics"]["duration_s"] < 0.5 * cf.report["kinematics"]["duration_s"]
    assert len(longest.report["segments"]["dropped"]) == 2


# -- the real excerpts ---------------------------------------------------------------------

#: the excerpts that do not meet the issue's targets yet, and why (strict: a fix shows)
KNOWN = {
    "cevennes": "glider fixes 5-30 s apart, relayed and dead-reckoned: flown 2.0x too fast",
    "sisteron": "glider fixes 5-30 s apart, relayed and dead-reckoned: flown 2.0x too fast",
}
REAL = ["elal747", "qantas747", "noisy_landing", "noisy_takeoff", "noisy_time_issue", "munich",
        "cevennes", "sisteron"]  # fmt: skip


def _reported_max_groundspeed(path: Path) -> float:
    with gzip.open(path, "rt") as f:
        rows = f.read().splitlines()
    col = rows[0].split(",").index("groundspeed")
    gs = [float(r.split(",")[col]) for r in rows[1:] if r.split(",")[col]]
    return max(gs) * KT


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


@pytest.mark.parametrize(
    "name",
    [
        pytest.param(n, marks=pytest.mark.xfail(strict=True, reason=KNOWN[n])) if n in KNOWN else n
        for n in REAL
    ],
)
def test_real_adsb_flown_whole_at_the_reported_speeds(name):
    """The whole file is flown (the ground movement too), at the speeds the aircraft reported."""
    path = ADSB / f"{name}.csv.gz"
    cf = condition(read_track(path, height_ref="pressure"))
    k = cf.report["kinematics"]
    assert k["duration_s"] >= 0.9 * _file_span(path)
    ratio = k["max_ground_speed_m_s"] / _reported_max_groundspeed(path)
    assert 0.95 <= ratio <= 1.05, ratio
    assert 0.3 <= k["min_specific_force_g"] and k["peak_specific_force_g"] <= 1.8
    v = cf.report["velocity"]
    assert v is not None and v["horizontal_count"] > 100
    assert "velocity residuals, flown − log" in cf.format_report()


def test_parked_airliner_flown_whole():
    """elal747 is parked for 42 minutes before it taxis: flown, not trimmed (84.7 % before)."""
    path = ADSB / "elal747.csv.gz"
    cf = condition(read_track(path, height_ref="pressure"))
    span = _file_span(path)
    assert cf.samples.t[-1] >= 0.99 * span
    g = cf.report["ground"]
    assert cf.report["ground_trimmed"] == []
    assert [p["side"] for p in g["flown"]] == ["before", "after"]
    assert g["flown"][0]["t_end_s"] - g["flown"][0]["t_start_s"] >= 40 * 60
    assert 0.1 < g["fraction_of_log"] < 0.2
    assert "ground movement flown as such (before the flight)" in cf.format_report()
    # on the ground: level, at most 0.5 g horizontally (the ground envelope, with its margin)
    s = cf.samples
    before = s.t < g["flown"][0]["t_end_s"] - 60.0
    assert np.ptp(s.h[before]) < 1.0
    from fieldmap.nav.logs.report import kinematics
    from fieldmap.nav.trajectory import FlightSamples

    parked = FlightSamples(
        s.t[before], s.lat[before], s.lon[before], s.h[before], None, "x", s.lines[before], 0.0
    )
    kp = kinematics(parked)
    assert kp["peak_acceleration_g"] <= 0.5 and kp["max_ground_speed_m_s"] < 30.0


@pytest.mark.parametrize("name", ["elal747", "qantas747", "munich", "noisy_takeoff"])
def test_airborne_only_still_trims_the_ground(name):
    """``airborne_only=True`` flies the airborne part only, and it is what the whole log flies."""
    path = ADSB / f"{name}.csv.gz"
    track = read_track(path, height_ref="pressure")
    air = condition(track, Conditioning(airborne_only=True))
    whole = condition(track)
    assert air.report["ground_trimmed"] and air.report["ground"]["flown"] == []
    assert air.samples.t[-1] < 0.97 * _file_span(path) <= whole.samples.t[-1] + 1.0
    # the flight itself is the same path: the ground pieces join it, they do not move it (but
    # for the JOIN_OVERLAP_S seconds next to a piece, fitted again with it)
    k = np.searchsorted(whole.samples.t + whole.samples.t_start, air.samples.t_start)
    n = air.samples.t.size
    over = int(np.ceil(JOIN_OVERLAP_S / (air.samples.t[1] - air.samples.t[0])))
    a, b = over, n - over if air.report["ground_trimmed"][-1]["t_end_s"] > air.samples.t[-1] else n
    assert np.array_equal(whole.samples.lat[k + a : k + b], air.samples.lat[a:b])
    assert np.array_equal(whole.samples.h[k + a : k + b], air.samples.h[a:b])
    assert not np.array_equal(whole.samples.lat[k : k + a], air.samples.lat[:a])


def test_real_log_with_velocities_that_contradict_its_positions_refused():
    """inflight_refuelling: 536 kt on a track of 280.5° for 70 min while flying orbits."""
    with pytest.raises(InputError, match=r"lines 5902\.\.\d+: the log's velocities") as e:
        condition(read_track(ADSB / "inflight_refuelling.csv.gz", height_ref="pressure"))
    assert "0 % agree" in str(e.value) and "\n" not in str(e.value)


# -- fixes another receiver relayed, positions a receiver dead-reckoned ---------------------


def _glider_log(path: Path) -> Path:
    """Write a light aircraft at 40 m/s, fixes 10 s apart, with two kinds of wrong fixes.

    North at 40 m/s from 44° N 6° E at 3000 m for 20 minutes, in the ``traffic`` layout with its
    velocities. Line 31 (t = 290 s) is the fix of another aircraft 1.2 km east of the one 10 s
    before and 10 s ahead (the step into it looks flyable, the step out is not); lines 63..66
    (t = 610..640 s) are dead-reckoned: the receiver lost the aircraft, which turned east at
    t = 600 s for 40 s, and kept moving it north at the last reported state (ground speed, track
    and vertical rate repeated), then jumps back.
    """
    m_lat = math.radians(1.0) * 6.367e6
    m_lon = m_lat * math.cos(math.radians(44.0))
    rows = ["timestamp,icao24,latitude,longitude,altitude,groundspeed,track,vertical_rate"]
    gs = 40.0 / KT
    for k in range(121):
        t = 10.0 * k
        north = 40.0 * min(t, 600.0) + 40.0 * max(t - 640.0, 0.0)
        east = 40.0 * min(max(t - 600.0, 0.0), 40.0)
        trk, spd = (90.0 if 600.0 < t <= 640.0 else 0.0), gs
        if k == 29:  # another aircraft's fix
            north, east = north + 400.0, east + 1200.0
        if 61 <= k <= 64:  # dead reckoning north at the state of t = 600 s
            north, east, trk = 40.0 * t, 0.0, 0.0
        stamp = datetime.fromtimestamp(T0 + t, timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
        rows.append(
            f"{stamp},3c0001,{44.0 + north / m_lat:.6f},{6.0 + east / m_lon:.6f},"
            f"{3000.0 / FT:.0f},{spd:.0f},{trk:.0f},0"
        )
    path.write_text("\n".join(rows) + "\n")
    return path


def test_relayed_and_dead_reckoned_fixes_left_out(tmp_path):
    """The fewest drops that leave a flyable path, whichever side of a fix its jump is."""
    tr = read_track(_glider_log(tmp_path / "glider.csv"), height_ref="pressure")
    cf = condition(tr, Conditioning(vehicle="light-aircraft"))
    rep = cf.report
    dropped = {s["line"] for s in rep["outliers"]["samples"] if s["component"] != "vertical"}
    # the relayed fix, and the dead-reckoned fixes the return jump shows wrong (the first two
    # of the run stay flyable: nothing in the log tells them from real ones)
    assert {31, 65, 66} <= dropped, sorted(dropped)
    # before: only line 31, and 152 m/s flown; the two flyable dead-reckoned fixes still cost
    # a detour (76 m/s), as in the real gliders' logs
    assert rep["kinematics"]["max_ground_speed_m_s"] <= 2.0 * 40.0


# -- positions interpolated between sparse fixes (a track resampled to a clock) --------------


@pytest.mark.parametrize(("name", "before"), [("elal747", 7.18), ("munich", 3.22)])
def test_positions_interpolated_between_fixes_flown_at_the_reported_speed(name, before):
    """The ``traffic`` samples resampled at 10 s (5 s) from fixes about 60 s (10 s) apart.

    Over half their positions lie on the chord between two fixes (collinear at equal time steps
    within 2e-10°, the rounding of the 10 decimals printed): taken for measurements they make the
    fixes' noise look like none and the flown speed follows the chords' stairs (elal747: 237,
    320, 161, 402 m/s where 267 m/s is reported), ``before`` m/s RMS from the reported ground
    speed. As one observation per run, the speed is the reported one: within the velocities' σ
    (0.77 and 0.47 m/s; 0.14 and 0.33 m/s RMS measured).
    """
    path = ADSB / f"{name}.csv.gz"
    cf = condition(read_track(path, height_ref="pressure"))
    interp = cf.report["interpolated"]
    assert interp["positions"] > 0.4 * cf.report["samples"]["in"] and interp["runs"] > 300
    v = cf.report["velocity"]
    assert v["groundspeed_rms_m_s"] < min(v["sigma_h_m_s"], 0.2 * before)
    ratio = cf.report["kinematics"]["max_ground_speed_m_s"] / _reported_max_groundspeed(path)
    assert abs(ratio - 1.0) < 0.01
    assert "interpolated between fixes" in " ".join(cf.report["notes"])


def _resampled_csv(path: Path, seed: int = 1) -> tuple[Path, dict]:
    """Write the airliner as the ``traffic`` package's resampled samples are: piecewise linear.

    Fixes every 60 s (positions late or early by a random time of σ 2 s, 470 m along the track
    at 235 m/s, and 5 m per axis; ground speed and track as reported, with 0.5 m/s and 0.1°
    of noise), resampled to 10 s by linear interpolation between the fixes, and printed with
    10 decimals as those files are: between two fixes a straight chord at the chord's speed,
    10..30 m/s off the speed flown.
    """
    t_d, lat_d, lon_d, h_d, gs_d, trk_d, vz_d, _ = airliner(duration=1260.0)
    rng = np.random.default_rng(seed)
    tf = np.arange(0.0, t_d[-1] - 5.0, 60.0)
    te = np.clip(tf + rng.normal(0.0, 2.0, tf.size), 0.0, t_d[-1])
    m_lat = math.radians(1.0) * 6.37e6
    lat_f = np.interp(te, t_d, lat_d) + rng.normal(0.0, 5.0, tf.size) / m_lat
    m_lon = m_lat * np.cos(np.radians(lat_f))
    lon_f = np.interp(te, t_d, lon_d) + rng.normal(0.0, 5.0, tf.size) / m_lon
    gs_f = (np.interp(tf, t_d, gs_d) + rng.normal(0.0, 0.5, tf.size)) / KT
    trk_f = np.degrees(np.unwrap(np.radians(np.interp(tf, t_d, np.unwrap(trk_d, 180.0)))))
    trk_f += rng.normal(0.0, 0.1, tf.size)
    t = np.arange(0.0, tf[-1] + 5.0, 10.0)
    cols = [
        np.interp(t, tf, x)
        for x in (lat_f, lon_f, np.interp(tf, t_d, h_d) / FT, gs_f, trk_f, 0.0 * tf)
    ]
    cols[5] = np.interp(t, t_d, vz_d) / FPM
    rows = ["timestamp,icao24,latitude,longitude,altitude,groundspeed,track,vertical_rate"]
    for k in range(t.size):
        stamp = datetime.fromtimestamp(T0 + t[k], timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
        la, lo, alt, gs, trk, vr = (c[k] for c in cols)
        rows.append(
            f"{stamp},4ca000,{la:.10f},{lo:.10f},{alt:.10f},{gs:.10f},{trk % 360.0:.10f},{vr:.10f}"
        )
    path.write_text("\n".join(rows) + "\n")
    return path, {"t": t_d, "speed": gs_d}


def test_synthetic_resampled_log_flown_nearer_the_real_speed(tmp_path):
    """Positions interpolated between fixes 60 s apart: the steady flight not flown as stairs.

    From 400 s to 1200 s (steady cruise: the climb and the acceleration before it, whose
    velocities the positions-only fit of fixes 60 s apart cannot resolve, left out) the flown
    speed was 4.8 m/s RMS (12 m/s at most) from the true one, the chords' stairs; with the
    interpolated positions one observation per run, 1.3 m/s (5.8) (seeds 2, 3: 8.1 → 2.8 and
    12.1 → 2.5 m/s RMS). Not yet within the velocities' rounding: the re-timing of the fixes
    (step 6b) still drifts by 1..2 m/s with fixes this sparse.
    """
    path, truth = _resampled_csv(tmp_path / "resampled.csv")
    cf = condition(read_track(path, height_ref="ellipsoid"))
    interp = cf.report["interpolated"]
    assert interp["positions"] == 5 * interp["runs"] and interp["runs"] >= 20
    s = cf.samples
    tt = s.t + s.t_start - T0
    r = ecef(s.lat, s.lon, s.h)
    v = np.gradient(r, tt, axis=0)
    u = up_vector(s.lat, s.lon)
    v -= np.sum(v * u, axis=1)[:, None] * u
    steady = (tt > 400.0) & (tt < 1200.0)
    err = np.linalg.norm(v, axis=1)[steady] - np.interp(tt[steady], truth["t"], truth["speed"])
    assert np.sqrt(np.mean(err**2)) < 2.5 and np.abs(err).max() < 8.0


def test_residuals_against_every_velocity_of_the_log():
    """The report's residuals against all the log's ground speeds, outliers included, as flown.

    Checked by finite differences of the flown samples against the file's own ``groundspeed``
    column (knots): no code shared with the report's spline derivative.
    """
    from fieldmap.field.frames import geodetic_to_ecef

    path = ADSB / "noisy_takeoff.csv.gz"
    track = read_track(path, height_ref="pressure")
    cf = condition(track)
    v = cf.report["velocity"]
    assert v["outliers"] > 0 and v["horizontal_all_count"] > v["horizontal_count"]
    assert v["groundspeed_all_rms_m_s"] > v["groundspeed_rms_m_s"]
    assert "against every velocity of the log, the outliers included" in cf.format_report()
    s = cf.samples
    p = np.stack(geodetic_to_ecef(s.lat, s.lon, s.h), -1)
    vel = np.gradient(p, s.t, axis=0)
    up = p / np.linalg.norm(p, axis=1)[:, None]
    gs = np.linalg.norm(vel - np.sum(vel * up, axis=1)[:, None] * up, axis=1)
    t = track.t - track.t[0]
    ok = np.isfinite(track.velocity.speed) & (t >= s.t[0]) & (t <= s.t[-1])
    d = np.interp(t[ok], s.t, gs) - track.velocity.speed[ok]
    assert d.size == v["horizontal_all_count"]
    rms = float(np.sqrt(np.mean(d**2)))
    assert abs(rms - v["groundspeed_all_rms_m_s"]) < 0.1 * v["groundspeed_all_rms_m_s"], rms

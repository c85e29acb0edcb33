"""Vehicle classes of the flight-log conditioning (fieldmap.nav.logs.vehicles).

The envelope a conditioned log keeps within comes from a vehicle class, named or guessed from the
log and said in the report; an unknown class is refused in one line. The tracks here are built
with their own geodesy (a flat-Earth dead reckoning, accurate to far better than the noise).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from log_tracks import raw_track

from fieldmap.cli import main
from fieldmap.errors import InputError
from fieldmap.nav.logs.condition import Conditioning, condition
from fieldmap.nav.logs.vehicles import VEHICLES, Evidence, guess_vehicle
from fieldmap.nav.logs.vehicles import vehicle_class as vehicle

M_DEG = math.radians(1.0) * 6.371e6


def straight(speed, h0, n=900, dt=1.0, noise=3.0, seed=3, category=None):
    """Return a straight level track east at ``speed`` m/s with ``noise`` m white position noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    lat = 45.0 + rng.normal(0.0, noise, n) / M_DEG
    lon = 5.0 + (speed * t + rng.normal(0.0, noise, n)) / (M_DEG * math.cos(math.radians(45.0)))
    h = h0 + rng.normal(0.0, noise, n)
    return raw_track(t, lat, lon, h, source="vehicle.csv", category=category)


def test_every_class_has_a_sane_envelope():
    for name, v in VEHICLES.items():
        assert v.name == name == vehicle(name.upper()).name
        assert v.n_min < 1.0 < v.n_max and v.speed > 0 and v.climb > 0 and v.accel_h > 0
        lo, hi = v.q_bounds(False)
        # the bound's stationary acceleration is a third of the class's largest
        assert 0 < lo < hi and math.isclose(v.horizontal_model().sigma_accel(hi), v.accel_h / 3)
    # the classes the issue names, and the aliases a user may type
    for name in ("paraglider", "glider", "light-aircraft", "turboprop", "airliner",
                 "helicopter", "fighter", "car", "pedestrian", "ship"):  # fmt: skip
        assert name in VEHICLES
    assert vehicle("hang glider").name == "paraglider" and vehicle("bicycle").name == "pedestrian"
    assert vehicle("business-jet").name == "airliner"


def test_unknown_vehicle_refused_in_python():
    with pytest.raises(InputError, match="vehicle must be one of paraglider, glider") as e:
        Conditioning(vehicle="zeppelin")
    assert e.value.param == "vehicle" and "\n" not in str(e.value)


def test_unknown_vehicle_refused_on_the_command_line(tmp_path, capsys):
    f = tmp_path / "f.csv"
    k = np.arange(121.0)
    rows = ["time_s,lat_deg,lon_deg,height_m"]
    rows += [f"{a:g},{47.0 + a * 200.0 / 111_000.0:.9f},8.0,{1000 + 2 * a:g}" for a in k]
    f.write_text("\n".join(rows) + "\n")
    out = tmp_path / "out"
    argv = ["navsim", "--lmax", "20", "--models", "j4", "--rate", "10", "--no-timing"]
    rc = main([*argv, "--trajectory", str(f), "--vehicle", "zeppelin", "--out", str(out)])
    cap = capsys.readouterr()
    lines = cap.err.strip().splitlines()
    assert rc == 2 and len(lines) == 1, cap.err
    assert "--vehicle" in lines[0] and "zeppelin" in lines[0] and "Traceback" not in cap.err
    assert not out.exists() and cap.out == ""


@pytest.mark.parametrize(
    ("speed", "h0", "category", "expected"),
    [
        (230.0, 11000.0, None, "airliner"),
        (60.0, 1500.0, None, "light-aircraft"),
        (25.0, 200.0, None, "car"),
        (60.0, 1500.0, "B1", "glider"),
        (60.0, 1500.0, "A7", "helicopter"),
        (12.0, 1500.0, "B4", "paraglider"),
        (120.0, 3000.0, "A2", "turboprop"),
    ],
)
def test_guess_said_in_the_report(speed, h0, category, expected):
    cf = condition(straight(speed, h0, category=category), Conditioning(airborne_only=False))
    v = cf.report["vehicle"]
    assert v["class"] == expected and v["how"].startswith("guessed")
    assert f"vehicle: {expected} (guessed" in cf.format_report()
    assert v["evidence"]["speed_m_s"] == pytest.approx(speed, rel=0.2)


def test_named_vehicle_is_used_and_said():
    cf = condition(straight(60.0, 1500.0), Conditioning(vehicle="glider"))
    assert cf.report["vehicle"]["class"] == "glider" and cf.report["vehicle"]["how"] == "given"
    assert cf.report["vehicle"]["load_factor_g"] == [-2.65, 5.3]


def test_guess_from_the_evidence():
    """The evidence picks the class: thermalling, hovering, an IGC file, the cruise speed."""
    base = dict(speed=40.0, climb=3.0, turn_rate=15.0, height_band=1500.0, slow_airborne=0.0)
    assert guess_vehicle(Evidence(**base, circling_climb=0.2))[0].name == "glider"
    slow = dict(base, speed=15.0)
    assert guess_vehicle(Evidence(**slow, circling_climb=0.2))[0].name == "paraglider"
    v, why = guess_vehicle(Evidence(**dict(base, slow_airborne=0.3)))
    assert v.name == "helicopter" and "hovers 30 %" in why
    v, why = guess_vehicle(Evidence(**slow, file_format="igc"))
    assert v.name == "paraglider" and "IGC file" in why
    assert guess_vehicle(Evidence(**base))[0].name == "light-aircraft"
    assert guess_vehicle(Evidence(**dict(base, speed=250.0)))[0].name == "airliner"
    assert guess_vehicle(Evidence(**dict(base, speed=140.0)))[0].name == "turboprop"


def test_a_parabolic_flights_climbs_raise_the_airliners_bound():
    """An airliner flying parabolas climbs at 106 m/s: still an airliner, flown at that climb.

    Its ordinary bound (40 m/s) holds a log with no such climbs; the log's own top climb raises
    it, up to the largest an airliner reaches (130 m/s); a faster climb is no airliner's.
    """
    base = dict(speed=240.0, turn_rate=1.0, height_band=8000.0, slow_airborne=0.0)
    airliner = guess_vehicle(Evidence(**base, climb=107.0))[0]
    assert airliner.name == "airliner"
    assert guess_vehicle(Evidence(**base, climb=200.0))[0].name == "fighter"
    assert airliner.with_log_climb(12.0).climb == 40.0
    assert airliner.with_log_climb(107.0).climb == 107.0
    assert airliner.with_log_climb(500.0).climb == 130.0
    assert VEHICLES["light-aircraft"].with_log_climb(107.0).climb == 20.0
    # a vertical rate the log reports, confirmed by its neighbours, counts as its top climb
    ev = Evidence(**base, climb=20.0, climb_reported=33.0)
    assert ev.top_climb == 33.0
    assert VEHICLES["turboprop"].with_log_climb(ev.top_climb).climb == 33.0


def test_guess_from_robust_speeds_ignores_spikes():
    tr = straight(60.0, 1500.0)
    lon = tr.lon.copy()
    lon[::50] += 0.5  # a wild fix every 50 (40 km off): not a rocket
    cf = condition(raw_track(tr.t, tr.lat, lon, tr.h, tr.lines, source="vehicle.csv"))
    assert cf.report["vehicle"]["class"] == "light-aircraft"
    assert cf.report["faults"]["samples"]["position"] >= tr.t.size // 50


def test_a_hard_pull_up_is_bounded_by_the_airliner_envelope():
    """A 3.5 g pull-up: an airliner's path keeps within its 2.5 g limit load, a fighter flies it."""
    dt, n = 1.0, 900
    t = np.arange(n) * dt
    az = np.where((t >= 400) & (t < 408), 2.5 * 9.80665, 0.0)
    az -= np.where((t >= 408) & (t < 416), 2.5 * 9.80665, 0.0)
    vz = np.cumsum(az) * dt
    h = 9000.0 + np.cumsum(vz) * dt
    base = straight(230.0, 0.0, n=n, dt=dt, noise=1.0)
    tr = raw_track(base.t, base.lat, base.lon, base.h + h, base.lines, source="vehicle.csv")
    air = condition(tr, Conditioning(vehicle="airliner")).report["kinematics"]
    fighter = condition(tr, Conditioning(vehicle="fighter")).report["kinematics"]
    assert air["peak_specific_force_g"] <= 2.5 + 0.05
    assert air["min_specific_force_g"] >= -1.0 - 0.05
    assert fighter["peak_specific_force_g"] > 3.0


def test_vehicle_option_in_params_table():
    from fieldmap.cli import OPTIONS

    assert OPTIONS["vehicle"] == "--vehicle"
    assert Path(__file__).exists()


def _zoom_log(path, spike_only=False):
    """Write an airliner's log (230 m/s east at 9 km, 1 s) with a 20 s zoom climb to 60 m/s.

    ``spike_only``: level all along, the vertical rate reporting 60 m/s at one row only.
    Returns the file and the true heights (m, ISA pressure altitude as written).
    """
    from log_tracks import local_to_lat_lon, write_traffic_csv

    n = 1800
    t = np.arange(float(n))
    vz = np.where((t >= 900) & (t < 920), 60.0 * np.sin(np.pi * (t - 900) / 20.0), 0.0)
    if spike_only:
        vz = np.zeros(n)
    h = 9000.0 + np.concatenate([[0.0], np.cumsum(0.5 * (vz[1:] + vz[:-1]))])
    rate = vz.copy()
    if spike_only:
        rate[900] = 60.0
    lat, lon = local_to_lat_lon(np.zeros(n), 230.0 * t, 45.0, 5.0)
    rows = [
        f"abc123,TEST1,{la:.7f},{lo:.7f},{hi / 0.3048:.0f},{230 / 0.514444:.1f},90.0,"
        f"{r / 0.3048 * 60:.0f}"
        for la, lo, hi, r in zip(lat, lon, h, rate)
    ]
    return write_traffic_csv(path, t, rows), h


def test_a_zoom_climb_the_log_reports_raises_the_climb_bound(tmp_path):
    """The vertical rates of a 20 s zoom to 60 m/s (1.1 % of the log) lift the airliner's bound.

    Its 99th percentile stays under the ordinary 40 m/s; the rates that the neighbours confirm
    reach 60, and the path flies the zoom within metres of the log's heights. One rate of
    60 m/s in level flight is no climb: the ordinary bound holds.
    """
    from fieldmap.nav.logs.read import read_track

    path, h = _zoom_log(tmp_path / "zoom.csv")
    cf = condition(read_track(path, height_ref="pressure"))
    v = cf.report["vehicle"]
    assert v["class"] == "airliner" and v["evidence"]["climb_m_s"] < 40.0
    assert v["evidence"]["climb_reported_m_s"] == pytest.approx(60.0, abs=1.0)
    assert v["max_climb_m_s"] == pytest.approx(60.0, abs=1.0)
    flown = np.interp(np.arange(h.size), cf.samples.t, cf.samples.h)
    log = read_track(path, height_ref="pressure")
    assert np.max(np.abs(flown - log.h)) < 10.0
    spike, _ = _zoom_log(tmp_path / "spike.csv", spike_only=True)
    level = condition(read_track(spike, height_ref="pressure")).report["vehicle"]
    assert level["max_climb_m_s"] == 40.0


def test_rates_computed_between_reports_confirm_no_climb(tmp_path):
    """One wild vertical rate, resampled into its neighbours, is still one report.

    A 120 m/s aircraft (a turboprop) climbing at 384 ft/min (the rates on ADS-B's 64 ft/min
    steps) reports 11,776 ft/min at one row, and the two rows each side hold values
    interpolated towards it (off the steps: computed, not reported). Read as reports, they
    would confirm a climb of 7,851 ft/min (40 m/s, the median of three) and raise the climb
    bound from the turboprop's ordinary 25 m/s to its largest, 40.
    """
    from log_tracks import local_to_lat_lon, write_traffic_csv

    from fieldmap.nav.logs.read import read_track

    n, speed = 1800, 120.0
    t = np.arange(float(n))
    climbing = (t >= 300) & (t < 600)
    rate_fpm = np.where(climbing, 384.0, 0.0)
    h = 1500.0 + np.cumsum(np.r_[0.0, rate_fpm[:-1]]) * 0.3048 / 60.0
    spike = 11776.0
    rate_fpm[1198:1203] = [spike / 3, 2 * spike / 3, spike, 2 * spike / 3, spike / 3]
    lat, lon = local_to_lat_lon(np.zeros(n), speed * t, 45.0, 5.0)
    rows = [
        f"abc123,TEST1,{la:.7f},{lo:.7f},{hi / 0.3048:.0f},{speed / 0.514444:.1f},90.0,{r:.2f}"
        for la, lo, hi, r in zip(lat, lon, h, rate_fpm)
    ]
    path = write_traffic_csv(tmp_path / "computed_rates.csv", t, rows)
    v = condition(read_track(path, height_ref="pressure")).report["vehicle"]
    assert v["evidence"]["climb_reported_m_s"] == pytest.approx(384.0 * 0.3048 / 60.0, rel=1e-6)
    assert v["class"] == "turboprop" and v["max_climb_m_s"] == 25.0

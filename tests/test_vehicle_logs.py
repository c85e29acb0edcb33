"""Vehicle classes of the flight-log conditioning (fieldmap.nav.logs.condition).

The envelope a conditioned log keeps within comes from a vehicle class, named or guessed from the
log and said in the report; an unknown class is refused in one line. The tracks here are built
with their own geodesy (a flat-Earth dead reckoning, accurate to far better than the noise).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from fieldmap.cli import main
from fieldmap.errors import InputError
from fieldmap.nav.logs.condition import (
    VEHICLES,
    Conditioning,
    condition,
    guess_vehicle,
)
from fieldmap.nav.logs.condition import vehicle_class as vehicle

M_DEG = math.radians(1.0) * 6.371e6


@dataclass(frozen=True)
class Track:
    """Stand-in with the fields of fieldmap.nav.logs.read.RawTrack."""

    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    h: np.ndarray
    lines: np.ndarray
    source: str = "vehicle.csv"
    height_ref: str = "ellipsoid"
    notes: tuple = ()
    t0_utc: str | None = None
    category: str | None = None


def straight(speed, h0, n=900, dt=1.0, noise=3.0, seed=3, category=None):
    """Return a straight level track east at ``speed`` m/s with ``noise`` m white position noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    lat = 45.0 + rng.normal(0.0, noise, n) / M_DEG
    lon = 5.0 + (speed * t + rng.normal(0.0, noise, n)) / (M_DEG * math.cos(math.radians(45.0)))
    h = h0 + rng.normal(0.0, noise, n)
    return Track(t, lat, lon, h, np.arange(n) + 2, category=category)


def test_every_class_has_a_sane_envelope():
    for name, v in VEHICLES.items():
        assert v.name == name == vehicle(name.upper()).name
        assert v.n_min < 1.0 < v.n_max and v.jerk > 0 and v.speed > 0 and v.climb > 0
    a = VEHICLES["airliner"]
    # an airliner in service flies about 0.7..1.4 g (issue 26); the limits hold that range
    assert a.n_min <= 0.7 and 1.4 <= a.n_max <= 2.5


def test_unknown_vehicle_refused_in_python():
    with pytest.raises(InputError, match="vehicle must be one of airliner") as e:
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
    ],
)
def test_guess_said_in_the_report(speed, h0, category, expected):
    cf = condition(straight(speed, h0, category=category), Conditioning(airborne_only=False))
    v = cf.report["vehicle"]
    assert v["class"] == expected and v["how"].startswith("guessed")
    assert any(n.startswith(f"vehicle: {expected} (guessed") for n in cf.report["notes"])
    assert f"vehicle: {expected}" in cf.format_report()


def test_named_vehicle_is_used_and_said():
    cf = condition(straight(60.0, 1500.0), Conditioning(vehicle="glider"))
    assert cf.report["vehicle"]["class"] == "glider" and cf.report["vehicle"]["how"] == "given"
    assert cf.report["vehicle"]["load_factor_g"] == [-2.65, 5.3]


def test_guess_from_robust_speeds_ignores_spikes():
    speed = np.full(1000, 60.0)
    speed[::50] = 5000.0  # a wild sample every 50: not a rocket
    v, why = guess_vehicle(speed, np.zeros(1000), np.full(1000, 1000.0))
    assert v.name == "light-aircraft" and "60 m/s" in why


def test_a_hard_pull_up_is_softened_to_the_airliner_envelope():
    """A 2.4 g pull-up: an airliner's path keeps within 1.6 g, a fighter's flies it."""
    dt, n = 1.0, 900
    t = np.arange(n) * dt
    # vertical acceleration +1.4 g for 8 s (a pull-up to 2.4 g), then -1.4 g for 8 s: well
    # above the 1 m noise of the samples, within a fighter's envelope, not an airliner's
    az = np.where((t >= 400) & (t < 408), 1.4 * 9.80665, 0.0)
    az -= np.where((t >= 408) & (t < 416), 1.4 * 9.80665, 0.0)
    vz = np.cumsum(az) * dt
    h = 9000.0 + np.cumsum(vz) * dt
    base = straight(230.0, 0.0, n=n, dt=dt, noise=1.0)
    tr = Track(base.t, base.lat, base.lon, base.h + h, base.lines)
    air = condition(tr, Conditioning(vehicle="airliner")).report["kinematics"]
    fighter = condition(tr, Conditioning(vehicle="fighter")).report["kinematics"]
    assert air["peak_specific_force_g"] <= 1.6 + 0.02
    assert air["min_specific_force_g"] >= 0.5 - 0.02
    assert fighter["peak_specific_force_g"] > 2.0


def test_vehicle_option_in_params_table():
    from fieldmap.cli import OPTIONS

    assert OPTIONS["vehicle"] == "--vehicle"
    assert Path(__file__).exists()

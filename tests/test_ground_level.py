"""An aircraft slower than it can fly is on the ground, whatever its altitude column says.

``zurich_airport_4b1614`` (a corpus piece: an airliner taxiing at Zurich for seven minutes, one
row a second, then its take-off) logs its field's 1,800-1,825 ft on the ground, and between
those rows stale airborne altitudes of 20,650 to 30,825 ft (about 45 % of the taxi's altitude
rows). The height smoother had nothing to tell the two apart: it flew the taxi 6 to 9 km up
and dived to the runway at the take-off.

An aircraft flies at an airspeed of at least its stall speed, so, in a surface wind of at
most 20 m/s, at a ground speed of at least its stall speed less 20 m/s. Slower (by two σ of
the horizontal path's speed), it is on the ground, where its height changes at most at a
runway's slope: a vertical rate 0 measured with the σ of that slope
(:func:`fieldmap.nav.logs.condition.ground_level`). The taxi is now flown level, within 80 m
of the field's heights (no DEM: the level is the one the take-off's heights join).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fieldmap.nav.logs import load_flight
from fieldmap.nav.logs.condition import ground_level
from fieldmap.nav.logs.read import read_track
from fieldmap.nav.logs.vehicles import SURFACE_WIND_MAX, vehicle_class

CORPUS = Path(__file__).parent / "data" / "corpus"
TAXI = CORPUS / "onground" / "zurich_airport_4b1614.csv.gz"
FIRST_AIRBORNE_LINE = 443  # the take-off roll's first row after the last stale altitude
FIELD_FT = (1800.0, 1825.0)  # the ground rows' altitudes


@pytest.fixture(scope="module")
def taxi():
    _, cf = load_flight(TAXI, height_ref="pressure")
    log = read_track(TAXI, height_ref="pressure", alt_units="ft")
    s = cf.samples
    path = np.interp(log.t, s.t_start + s.t, s.h)
    return cf, log, path


def test_the_taxi_is_flown_at_the_fields_heights(taxi):
    """The old path flew the taxi at 6-9 km (7.7 km above the field's rows)."""
    cf, log, path = taxi
    # the rows with an altitude of their own (the others' heights are interpolated)
    has = np.ones(log.t.size, bool) if log.no_height is None else ~log.no_height
    taxiing = (log.lines < FIRST_AIRBORNE_LINE) & has
    field = taxiing & (log.h < 0.3048 * FIELD_FT[1] + 200.0)
    assert field.sum() > 50
    off = np.abs(path[field] - log.h[field])
    assert off.max() < 80.0, f"the taxi flown up to {off.max():.0f} m off the field's heights"
    stale = taxiing & ~field
    assert np.all(path[stale] < log.h[stale] - 5000.0), "a stale altitude flown"


def test_the_report_says_where_the_path_is_held_level(taxi):
    cf, _, _ = taxi
    gr = cf.report["ground"]
    assert gr["level_fixes"] > 20
    assert "level on the ground" not in [f["channel"] for f in cf.report["faults"]["list"]]
    text = cf.format_report()
    assert f"held level at {gr['level_fixes']} fixes slower than the vehicle flies" in text


@pytest.mark.parametrize("piece", ["gliders/sisteron_01", "firefighting/calfire_a53602_04"])
def test_no_ground_where_the_vehicle_flies(piece):
    """None is held level: a glider's stall speed is below the wind's.

    A tanker's fixes 20-200 s apart leave its speed too uncertain (the path's speed dips below
    15 m/s between them, but not by two of its σ).
    """
    _, cf = load_flight(CORPUS / f"{piece}.csv.gz", height_ref="pressure")
    assert cf.report["ground"]["level_fixes"] == 0


def test_the_landing_roll_and_taxi_stay_on_the_runway():
    """``kiruna`` (a corpus piece: a calibration turboprop, one row every 5 s) lands at 1,750 ft.

    Its last 15 rows, the taxi after the landing roll (lines 1678-1692), read 0 ft: ADS-B
    surface reports carry no altitude, and the table holds 0 there. Read as heights, they drew
    the path 530 m down the runway in the landing roll; read as positions without a height
    (the reader's note), the taxi is flown, level, at the heights of the roll before it.
    """
    path = CORPUS / "calibration" / "kiruna.csv.gz"
    _, cf = load_flight(path, height_ref="pressure")
    log = read_track(path, height_ref="pressure", alt_units="ft")
    assert np.array_equal(np.flatnonzero(log.no_height), np.arange(1676, 1691))
    roll = (log.lines >= 1671) & (log.lines <= 1677)  # 98 kt and slower, 1,725-1,750 ft
    s = cf.samples
    assert s.t_start + s.t[-1] == log.t[-1]  # the taxi flown
    path_h = np.interp(log.t, s.t_start + s.t, s.h)
    assert np.all(np.abs(path_h[roll] - log.h[roll]) < 20.0), path_h[roll] - log.h[roll]
    runway = log.h[log.lines == 1677][0]
    taxi = log.lines >= 1678
    assert np.all(np.abs(path_h[taxi] - runway) < 20.0), path_h[taxi] - runway
    assert any("15 rows of 0 read as no altitude" in n for n in cf.report["notes"])


def test_surface_reports_are_on_the_ground_at_any_speed():
    """``munich`` (a corpus piece, one row every 5 s) starts with 68 ADS-B surface reports.

    Their altitude column holds 0 (no altitude); the taxi and the take-off roll, up to 105 kt,
    are on the ground by the transponder's word. Flown level there, joined to the climb's
    first altitudes; without the surface reports' word the taxi was the climb's prediction
    backwards, 300 m below the runway at the log's start.
    """
    path = CORPUS / "calibration" / "munich.csv.gz"
    _, cf = load_flight(path, height_ref="pressure")
    log = read_track(path, height_ref="pressure", alt_units="ft")
    assert log.surface_report is not None
    start = np.flatnonzero(log.surface_report & (log.lines < 100))
    assert start.size == 68
    s = cf.samples
    path_h = np.interp(log.t[start], s.t_start + s.t, s.h)
    assert np.ptp(path_h) < 5.0, np.ptp(path_h)
    first = np.flatnonzero(~log.no_height)[1]  # the climb's first altitude of its own
    assert abs(path_h[-1] - log.h[first]) < 60.0


def test_a_vehicle_slower_than_the_wind_has_no_ground():
    """Stall ≤ the wind: a glider, a helicopter or a car may be slow in flight or on the road."""
    for name in ("glider", "helicopter", "paraglider", "car"):
        assert vehicle_class(name).stall <= SURFACE_WIND_MAX
        assert ground_level(None, None, vehicle_class(name)) is None  # type: ignore[arg-type]

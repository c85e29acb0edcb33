"""Real flight logs as they come, flown end to end (issue 16): reader -> conditioning -> study.

The checks share no code with the conditioning: a smooth synthetic flight is built here, spoilt
with ADS-B artefacts, and the navigation errors of the conditioned log are compared with those
of the clean flight; real ADS-B logs (``tests/data/flights``) are flown through the CLI.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from fieldmap.cli import main
from fieldmap.nav import study
from fieldmap.nav.logs import load_flight
from fieldmap.nav.trajectory import FlightTrajectory, geodetic_state, route_flight

DATA = Path(__file__).parent / "data" / "flights"
ROUTE = "46.0,7.0,9000;46.6,7.9,10000;47.0,9.0,10000"


def _clean():
    return FlightTrajectory(route_flight(ROUTE, 220.0))


def _log(traj, rng, noise_m=5.0, artefacts=True):
    """1 Hz samples of ``traj`` as an ADS-B receiver gives them (fieldmap CSV columns)."""
    t = np.arange(0.0, traj.duration, 1.0)
    lat, lon, h, _, _ = geodetic_state(traj, t)
    lat, lon, h = lat.copy(), lon.copy(), h.copy()
    if artefacts:
        m_per_deg = 111_320.0
        lat += rng.normal(0.0, noise_m, t.size) / m_per_deg
        lon += rng.normal(0.0, noise_m, t.size) / (m_per_deg * np.cos(np.radians(lat)))
        h = 7.62 * np.round(h / 7.62)  # 25 ft steps
        for i, km in ((150, 2.4), (151, 2.4), (400, -1.5), (650, 3.0)):  # outliers, a burst
            lat[i] += km / 111.32
        h[500] += 800.0  # an altitude spike
        keep = np.ones(t.size, bool)
        keep[300:330] = False  # a 30 s gap
        keep[700:712] = False
        t, lat, lon, h = t[keep], lat[keep], lon[keep], h[keep]
    return {"time_s": t, "lat_deg": lat, "lon_deg": lon, "height_m": h}


def _csv(path, cols):
    keys = list(cols)
    rows = [",".join(keys)] + [
        ",".join(f"{cols[k][i]:.10f}" for k in keys) for i in range(cols[keys[0]].size)
    ]
    path.write_text("\n".join(rows) + "\n")
    return path


def _study(traj):
    return study.run_flight(
        study.FlightStudy(
            traj,
            models=["j4", "exact"],
            rate_hz=50.0,
            truth_lmax=60,
            output_dt=10.0,
            altitude_aiding="none",
        ),
        device="cpu",
    )


def test_spoilt_log_flies_like_the_clean_flight(tmp_path):
    clean = _clean()
    rng = np.random.default_rng(7)
    traj, cf = load_flight(_csv(tmp_path / "log.csv", _log(clean, rng)))
    rep = cf.report
    assert rep["kinematics"]["peak_acceleration_g"] < 3.0
    ref = _study(clean)
    got = _study(traj)
    # the same question, the same answer: the J4 and exact models' effect within a few %
    for m in ("j4", "exact"):
        a = ref.summary["models"][m]["added_horizontal_error_m"]
        b = got.summary["models"][m]["added_horizontal_error_m"]
        assert abs(b - a) <= 0.05 * a, (m, a, b)


@pytest.mark.parametrize("name", sorted(p.name for p in DATA.glob("*.csv.gz")))
def test_real_adsb_logs_through_the_cli(tmp_path, capsys, name):
    out = tmp_path / "o"
    argv = ["navsim", "--trajectory", str(DATA / name), "--duration", "300", "--rate", "50",
            "--lmax", "30", "--models", "j4", "--imu", "navigation", "--draws", "2",
            "--out", str(out)]  # fmt: skip
    assert main(argv) in (0, 1)
    printed = capsys.readouterr().out
    assert "Conditioned flight" in printed and "recommended model" in printed
    doc = json.loads((out / "navsim_flight.json").read_text())
    kin = doc["conditioning"]["kinematics"]
    assert kin["peak_acceleration_g"] < 3.0  # an airliner's, not the noise's
    # the readers' notes name the options of the command line, not Python keywords
    notes = " ".join(doc["conditioning"]["notes"])
    assert "height_ref" not in notes and "height_ref" not in printed
    if "geoaltitude: ADS-B geometric altitude" in notes:
        assert "give --height-ref ellipsoid" in notes and "give --height-ref ellipsoid" in printed
    rms = doc["models"]["j4"]["final_horizontal_error_m"]["rms"]
    assert rms is not None and np.isfinite(rms)
    assert (out / "navsim_flight_conditioning.png").is_file()


def test_several_flights_in_one_launch(tmp_path, capsys):
    rng = np.random.default_rng(3)
    a = _csv(tmp_path / "a.csv", _log(_clean(), rng))
    b = _csv(tmp_path / "b.csv", _log(FlightTrajectory(route_flight(ROUTE, 200.0)), rng))
    out = tmp_path / "o"
    argv = ["navsim", "--trajectory", str(a), str(b), "--duration", "120", "--rate", "25",
            "--lmax", "20", "--models", "j4", "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "== a ==" in printed and "== b ==" in printed and "recommended" in printed
    for stem in ("navsim_flight_a", "navsim_flight_b"):
        doc = json.loads((out / f"{stem}.json").read_text())
        assert "conditioning" in doc
        assert (out / f"{stem}_conditioning.png").is_file()


def test_bad_logs_one_line_nothing_written(tmp_path, capsys):
    out = tmp_path / "o"
    notflight = tmp_path / "x.csv"
    notflight.write_text("a,b,c\n1,2,3\n4,5,6\n")
    for argv, words in (
        (["--trajectory", str(notflight)], "columns"),
        (["--trajectory", str(tmp_path / "missing.csv")], "not found"),
        (["--trajectory", str(notflight), "--position-noise-m", "x"], "--position-noise-m"),
    ):
        rc = main(["navsim", *argv, "--out", str(out)])
        err = capsys.readouterr().err.strip().splitlines()
        assert rc == 2 and len(err) == 1 and words in err[0], err
        assert not out.exists()

"""What a user of the flight study types: option names, durations, output options, Python calls.

``fieldmap navsim`` names the truth model ``--truth-model`` (the old ``--model``, one letter from
the navigation models' ``--models``, is refused naming both); a duration takes a unit wherever a
duration is read (:mod:`fieldmap.durations`); ``--no-plots`` as for the maps; ``--help`` opens
with the flight study. From Python, a flight log's path is a flight (``FlightStudy("f.gpx")``),
and ``FlightStudy``, ``load_flight`` and ``GnssSpec`` come from the top level. Tiny runs: a
2-minute route, a 10 Hz IMU, a degree-10 truth.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import fieldmap
from fieldmap.cli import main
from fieldmap.durations import seconds
from fieldmap.errors import InputError

ROUTE = ["--route", "47,8,500;47.2,8,500", "--speed-mps", "200"]
FAST = ["--rate", "10", "--lmax", "10", "--models", "j4", "--no-timing"]


def _refused(capsys, argv, *words):
    """Exit 2, one line on stderr holding ``words``, nothing on stdout; return the line."""
    rc = main(argv)
    err = capsys.readouterr()
    assert rc == 2 and err.out == "", err
    lines = err.err.strip().splitlines()
    assert len(lines) == 1 and all(w in lines[0] for w in words), lines
    return lines[0]


def _files(folder):
    return sorted(p.name for p in folder.iterdir())


# ----------------------------------------------------------------------------- output options
def test_no_plots_writes_the_same_numbers_without_figures(tmp_path, capsys):
    """``navsim --no-plots`` as ``map --no-plots``: CSV, JSON and NetCDF, no PNG, same files."""
    both, bare = tmp_path / "both", tmp_path / "bare"
    assert main(["navsim", *ROUTE, *FAST, "--out", str(both)]) == 0
    assert main(["navsim", *ROUTE, *FAST, "--no-plots", "--out", str(bare)]) == 0
    capsys.readouterr()
    pngs = [n for n in _files(both) if n.endswith(".png")]
    assert pngs and set(_files(bare)) == set(_files(both)) - set(pngs)
    for name in _files(bare):
        assert (bare / name).read_bytes() == (both / name).read_bytes(), name
    paper = tmp_path / "paper"
    argv = ["navsim", "--study", "table1", "--duration", "2", "--rate", "20", "--lmax", "10"]
    assert main([*argv, "--models", "j2", "--no-timing", "--no-plots", "--out", str(paper)]) == 0
    assert _files(paper) == ["navsim_table1.csv", "navsim_table1.json", "navsim_table1.nc"]
    allan = tmp_path / "allan"
    assert main(["imu", "allan", "--duration", "20", "--rate", "10", "--no-plots",
                 "--out", str(allan)]) == 0  # fmt: skip
    assert _files(allan) == ["imu_allan_tactical.csv", "imu_allan_tactical.json"]


# ----------------------------------------------------------------------------------- names
def test_truth_model_is_named_for_what_it_is(tmp_path, capsys):
    out = tmp_path / "o"
    argv = ["navsim", *ROUTE, *FAST, "--no-plots"]
    assert main([*argv, "--truth-model", "eigen-6s", "--out", str(out)]) == 0
    capsys.readouterr()
    meta = json.loads((out / "navsim_flight.json").read_text())["meta"]
    assert meta["truth_model"].lower().startswith("eigen-6s") and meta["truth_degree"] == 10


@pytest.mark.parametrize(
    "value, words",
    [
        # a navigation model where the truth's option was: says where it goes
        ("j2", ("--model j2", "--models j2", "--truth-model")),
        # the truth model by its old option: says the new one
        ("eigen-6s", ("--model eigen-6s", "--truth-model eigen-6s", "--models")),
    ],
)
def test_the_old_model_option_is_refused_naming_both(tmp_path, capsys, value, words):
    out = tmp_path / "o"
    with pytest.raises(SystemExit) as exit_:
        main(["navsim", *ROUTE, *FAST, "--model", value, "--out", str(out)])
    assert exit_.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and all(w in err[0] for w in words), err
    assert not out.exists()


def test_a_navigation_model_as_the_truth_says_models(tmp_path, capsys):
    out = tmp_path / "o"
    line = _refused(capsys, ["navsim", *ROUTE, *FAST, "--truth-model", "sh12", "--out", str(out)],
                    "--truth-model sh12", "navigation gravity model", "--models sh12")  # fmt: skip
    assert "unknown model" not in line and not out.exists()


def test_help_describes_the_flight_study_first(capsys):
    with pytest.raises(SystemExit):
        main(["navsim", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    description = text[text.index("Flight study") :]
    first = description.split(". ")[0]
    assert "--trajectory" in first and "--models" in first and "--imu" in first
    assert "Boost-glide" not in text and description.index("--study") > len(first)
    assert "--truth-model MODEL" in text and "--no-plots" in text


# ------------------------------------------------------------------------------- durations
@pytest.mark.parametrize(
    "text, s",
    [("90", 90.0), ("90s", 90.0), ("5min", 300.0), ("5 min", 300.0), ("1.5h", 5400.0),
     (" 2 h ", 7200.0), (120, 120.0), (2.5, 2.5), ("1e3s", 1000.0)],
)  # fmt: skip
def test_one_duration_parser(text, s):
    assert seconds(text) == s


@pytest.mark.parametrize("text", ["5x", "min", "5 mins", "", "5ms", "five min", "True"])
def test_a_duration_without_a_number_or_with_an_unknown_unit_is_refused(text):
    with pytest.raises(InputError, match="is no time") as e:
        seconds(text, param="duration")
    assert e.value.param == "duration"


def test_durations_with_units_on_the_command_line(tmp_path, capsys):
    """``--duration 1min`` is ``--duration 60``, file for file; a bad unit is one line."""
    a, b = tmp_path / "a", tmp_path / "b"
    argv = ["navsim", *ROUTE, *FAST, "--no-plots"]
    assert main([*argv, "--duration", "60", "--output-dt", "2", "--out", str(a)]) == 0
    assert main([*argv, "--duration", "1min", "--output-dt", "2s", "--out", str(b)]) == 0
    capsys.readouterr()
    for name in _files(a):
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
    assert json.loads((b / "navsim_flight.json").read_text())["meta"]["duration_s"] == 60.0
    with pytest.raises(SystemExit) as exit_:
        main([*argv, "--duration", "5x", "--out", str(tmp_path / "c")])
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and "--duration" in err and "'5x' is no time" in err
    # the paper's studies and imu allan read the same durations
    argv = ["navsim", "--study", "table1", "--rate", "20", "--lmax", "10", "--models", "j2"]
    assert main([*argv, "--duration", "0.05min", "--no-timing", "--no-plots",
                 "--out", str(tmp_path / "p")]) == 0  # fmt: skip
    meta = json.loads((tmp_path / "p" / "navsim_table1.json").read_text())["meta"]
    assert meta["duration_s"] == pytest.approx(3.0, rel=1e-15)
    gnss = tmp_path / "gnss"
    assert (
        main(
            [
                "navsim",
                *ROUTE,
                *FAST,
                "--imu",
                "tactical",
                "--draws",
                "2",
                "--no-plots",
                "--gnss-bias",
                "1:10min",
                "--gnss-outage",
                "0.5min:20s",
                "--out",
                str(gnss),
            ]
        )
        == 0
    )
    meta = json.loads((gnss / "navsim_flight.json").read_text())["meta"]["gnss"]
    assert meta["bias_tau_s"] == 600.0 and meta["outages"] == [[30.0, 20.0]]
    allan = tmp_path / "allan"
    assert main(["imu", "allan", "--duration", "0.5min", "--rate", "10", "--no-plots",
                 "--out", str(allan)]) == 0  # fmt: skip
    assert json.loads((allan / "imu_allan_tactical.json").read_text())["duration_s"] == 30.0
    capsys.readouterr()


def test_durations_with_units_in_python():
    route = fieldmap.route_flight("47,8,500;47.2,8,500", speed_mps=200.0)
    study = fieldmap.FlightStudy(route, models="j4", truth_lmax=10, rate_hz=10.0,
                                 duration="1min", output_dt="2s")  # fmt: skip
    assert (study.duration_s, study.output_dt_s) == (60.0, 2.0)
    with pytest.raises(InputError, match="is no time") as e:
        fieldmap.FlightStudy(route, models="j4", truth_lmax=10, duration="1 fortnight")
    assert e.value.param == "duration"
    spec = fieldmap.GnssSpec(outages="20s:0.5min")
    assert spec.intervals(100.0).tolist() == [[20.0, 50.0]]


# -------------------------------------------------------------------------------- Python
def _gpx(path, n=121):
    """Write a GPX track of ``n`` 1-s fixes flying north at 60 m/s, climbing 1 m/s."""
    pts = "".join(
        f'<trkpt lat="{45.8 + k * 60.0 / 111_000.0:.7f}" lon="14.3"><ele>{1000.0 + k:.1f}</ele>'
        f"<time>2024-05-01T10:{k // 60:02d}:{k % 60:02d}Z</time></trkpt>"
        for k in range(n)
    )
    path.write_text(
        '<?xml version="1.0"?><gpx version="1.1" creator="test" '
        'xmlns="http://www.topografix.com/GPX/1/1"><trk><trkseg>'
        f"{pts}</trkseg></trk></gpx>"
    )
    return path


def test_a_file_path_is_a_flight_file(tmp_path):
    """``FlightStudy("track.gpx")`` reads and conditions the log, as ``--trajectory`` does."""
    from pathlib import Path

    gpx = _gpx(tmp_path / "track.gpx")
    kw = dict(imu="navigation", models="j4", draws=2, rate_hz=10.0, truth_lmax=10)
    study = fieldmap.FlightStudy(str(gpx), **kw)
    traj, cf = fieldmap.load_flight(gpx, model=study.truth)
    assert study.flight.duration == traj.duration == 120.0
    assert study.conditioning is not None
    assert study.conditioning.report == cf.report
    assert fieldmap.FlightStudy(Path(gpx), **kw).flight.duration == 120.0  # a Path too
    res = fieldmap.run_flight(study)
    assert res.summary["conditioning"]["notes"] == cf.report["notes"]
    # a route stays a route; a file that is not there is named
    route = fieldmap.FlightStudy("45.8,14.3,1000;45.9,14.3,1000", speed_mps=60.0, **kw)
    assert route.conditioning is None and route.flight.duration > 100
    with pytest.raises(InputError, match="nope.gpx: flight file not found"):
        fieldmap.FlightStudy(str(tmp_path / "nope.gpx"), **kw)
    with pytest.raises(InputError, match="speed_mps applies to a route") as e:
        fieldmap.FlightStudy(str(gpx), speed_mps=60.0, **kw)
    assert e.value.param == "speed_mps"


def test_the_flight_workflow_from_the_top_level():
    for name in ("FlightStudy", "load_flight", "GnssSpec", "run_flight", "FlightTrajectory"):
        assert name in fieldmap.__all__ and callable(getattr(fieldmap, name)), name
    from fieldmap.nav.aiding import GnssSpec
    from fieldmap.nav.logs import load_flight
    from fieldmap.nav.study import FlightStudy

    assert (fieldmap.FlightStudy, fieldmap.load_flight, fieldmap.GnssSpec) == (
        FlightStudy,
        load_flight,
        GnssSpec,
    )


def test_a_route_string_is_a_route_not_a_file():
    """The route string and the waypoints fly the same path (no file is looked for)."""
    kw = dict(models="j4", truth_lmax=10, rate_hz=10.0)
    a = fieldmap.FlightStudy("47,8,500;47.2,8,500", speed_mps=200.0, **kw)
    b = fieldmap.FlightStudy([(47, 8, 500), (47.2, 8, 500)], speed_mps=200.0, **kw)
    assert a.flight.duration == b.flight.duration
    t = np.linspace(0.0, a.flight.duration, 7)
    np.testing.assert_array_equal(np.array(a.flight.geodetic(t)), np.array(b.flight.geodetic(t)))

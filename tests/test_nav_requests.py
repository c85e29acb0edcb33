"""The flight study as one request, and the navigation defects of issue 25.

:class:`fieldmap.nav.study.FlightStudy`; each defect test here failed on the code before its fix.
"""

from __future__ import annotations

import inspect
import pathlib
import re

import numpy as np
import pytest

import fieldmap
from fieldmap.errors import InputError

PKG = pathlib.Path(fieldmap.__file__).parent
ROUTE = [(49.0, 2.55, 10000.0), (48.9, 2.9, 10000.0)]
#: a small, fast flight study: 20 s at 20 Hz, truth to degree 10
SMALL = dict(models=["j4"], duration=20.0, rate_hz=20.0, truth_lmax=10, output_dt=2.0)


def test_run_flight_takes_the_samples_of_route_flight():
    """``run_flight(FlightStudy(route_flight(...)))`` runs.

    It failed with "'FlightSamples' object has no attribute 'duration'" (the CLI wrapped the
    samples in a FlightTrajectory; Python users had to).
    """
    samples = fieldmap.route_flight(ROUTE, speed_mps=230)
    res = fieldmap.run_flight(fieldmap.FlightStudy(samples, **SMALL), device="cpu")
    assert res.t[-1] == pytest.approx(20.0)  # s
    assert res.summary["meta"]["imu"] == "ideal"  # the default IMU


def test_run_flight_takes_a_preset_name():
    """``imu="tactical"`` failed: 'str' object has no attribute 'is_ideal' (the CLI loaded it)."""
    traj = fieldmap.FlightTrajectory(fieldmap.route_flight(ROUTE, speed_mps=230))
    study = fieldmap.FlightStudy(traj, imu="tactical", draws=2, **SMALL)
    res = fieldmap.run_flight(study, device="cpu")
    assert res.summary["meta"]["imu"] == "tactical"
    assert res.dpos.shape[0] == 2 * 2  # imu_only and j4, two draws each


def test_flight_study_takes_what_the_cli_takes():
    """A route as text, a preset name, model names as one string: as ``fieldmap navsim``."""
    from fieldmap.nav.sensors import PRESETS
    from fieldmap.nav.study import FlightStudy, run_flight

    study = FlightStudy(
        "49,2.55,10000;48.9,2.9,10000",
        speed_mps=230,
        imu="tactical",
        models="j4,exact",
        draws=2,
        duration=20.0,
        rate_hz=20.0,
        truth_lmax=10,
        output_dt=2.0,
    )
    assert study.models == ("j4", "exact") and study.imu == PRESETS["tactical"]
    assert study.imu_name == "tactical" and study.n_draws == 2 and study.aiding == "none"
    objects = FlightStudy(
        fieldmap.FlightTrajectory(fieldmap.route_flight(ROUTE, speed_mps=230)),
        imu=PRESETS["tactical"], imu_name="tactical", models=["j4", "exact"], draws=2,
        duration=20.0, rate_hz=20.0, truth_lmax=10, output_dt=2.0,
    )  # fmt: skip
    ref = run_flight(objects, device="cpu")
    new = run_flight(study, device="cpu")
    for k in ("t", "dpos", "dvel", "datt", "track"):  # the same bits by either spelling
        assert np.array_equal(getattr(ref, k), getattr(new, k)), k
    with pytest.raises(TypeError, match="draws"):
        run_flight(study, draws=3)
    with pytest.raises(TypeError, match="takes a FlightStudy"):
        run_flight(objects.flight)


@pytest.mark.parametrize(
    "change, words",
    [
        ({"draws": 0}, "draws must be within 1..10000"),
        ({"seed": -1}, "seed must be >= 0"),
        ({"n_gauss": 0}, "n_gauss must be in 1..16"),
        ({"frame": "ecef"}, "frame must be 'ned' or 'lci'"),
        ({"models": "j9"}, "unknown navigation gravity model 'j9'"),
        ({"imu": "gyroscope-of-dreams"}, "unknown IMU"),
        ({"duration": 1e6}, "does not fit the flight"),
        ({"rate_hz": 1e7, "block_s": 1e3}, "lower rate_hz or block_s"),
    ],
)
def test_flight_study_refuses_bad_input_when_built(change, words):
    """Validated once, at construction: a bad study never starts."""
    from fieldmap.nav.study import FlightStudy

    kw = dict(SMALL, speed_mps=230) | change
    with pytest.raises(InputError, match=re.escape(words)):
        FlightStudy(ROUTE, **kw)


def test_python_errors_name_python_keywords():
    """``flightsim.py`` said "needs --frame ned" to a Python caller."""
    traj = fieldmap.FlightTrajectory(fieldmap.route_flight(ROUTE, speed_mps=230))
    with pytest.raises(InputError) as err:
        fieldmap.FlightStudy(traj, **SMALL, frame="lci", altitude_aiding="baro")
    assert "frame='ned'" in str(err.value) and "--" not in str(err.value)


def test_cli_checks_model_names_and_tables_once(monkeypatch, tmp_path, capsys):
    """``check_tables_cover`` and ``check_model_names`` ran in the CLI and again in run_flight."""
    from fieldmap.cli import main
    from fieldmap.nav import study

    calls = {"check_model_names": 0, "check_tables_cover": 0}
    for name in calls:
        real = getattr(study, name)

        def counted(*a, _real=real, _name=name, **k):
            calls[_name] += 1
            return _real(*a, **k)

        monkeypatch.setattr(study, name, counted)
    argv = [
        "navsim", "--route", "49,2.55,10000;48.9,2.9,10000", "--speed-mps", "230",
        "--models", "j4", "--rate", "20", "--lmax", "10", "--duration", "20",
        "--output-dt", "2", "--no-timing", "--device", "cpu", "--out", str(tmp_path),
    ]  # fmt: skip
    assert main(argv) == 0
    capsys.readouterr()
    assert calls == {"check_model_names": 1, "check_tables_cover": 1}


def test_gravity_device_error_is_not_rewrapped():
    """A missing device raises ``DeviceError`` (an ``InputError``) from the gravitation.

    ``nav/imu.py`` caught it and raised a bare ``InputError``: the caller lost the type.
    """
    from fieldmap._warp import DeviceError
    from fieldmap.nav.imu import Gravitation

    with pytest.raises(DeviceError):
        Gravitation("j4", device="cuda:97")


def test_one_standard_gravity():
    """Standard gravity is ``fieldmap.units.STANDARD_GRAVITY`` alone.

    9.80665 was defined in units.py, imu_errors.py, flightsamples.py and written as a literal
    in strapdown_ned.py (numbers in the code, not the words of docstrings and messages).
    """
    import ast

    found = [
        p.relative_to(PKG).as_posix()
        for p in sorted(PKG.rglob("*.py"))
        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8")))
        if isinstance(node, ast.Constant) and node.value == 9.80665
    ]
    assert found == ["units.py"], found


def test_one_lowest_height_for_flights():
    """A flight at -10.5 km passed (flights had -11 km, the models -10 km): now one limit."""
    from fieldmap.limits import MIN_HEIGHT

    assert MIN_HEIGHT == -10e3
    with pytest.raises(InputError, match=r"height -10500 m is outside .*\(-10 km \.\."):
        fieldmap.route_flight("47,8,1000;47.1,8.1,-10500", 200.0)


def test_compensation_table_builder_is_public():
    """The builder of ``fieldmap table`` was not in the public API."""
    assert "build_table" in fieldmap.__all__
    assert callable(fieldmap.build_table)
    assert "FlightStudy" in fieldmap.__all__


def test_track_map_has_coastlines_and_equal_aspect():
    """The flight track map had no coastlines; its aspect is cos-latitude scaled."""
    import matplotlib

    matplotlib.use("Agg")
    from types import SimpleNamespace

    from fieldmap.nav.plots import track_figure

    track = np.array([[49.0, 2.55, 1e4], [48.7, 3.4, 1e4]])
    fig = track_figure(SimpleNamespace(track=track))
    (ax,) = fig.axes
    assert len(ax.lines) == 4  # track, start, end, coastline
    coast = np.asarray(ax.lines[3].get_xdata())
    assert coast.size > 1000 and np.isnan(coast).any()
    y0, y1 = ax.get_ylim()
    assert ax.get_aspect() == pytest.approx(1.0 / np.cos(np.radians(0.5 * (y0 + y1))), rel=1e-12)


def test_every_strapdown_kernel_variant_the_factory_can_build_is_built():
    """Of the four variants ``_make_*_kernel(errors, sh_gravity)`` could build, two were."""
    import fieldmap.kernels.strapdown as ksd

    for frame in ("lci", "ned"):
        factory = getattr(ksd, f"_make_{frame}_kernel")
        variants = 2 ** len(inspect.signature(factory).parameters)
        built = {getattr(ksd, f"{frame}_kernel"), getattr(ksd, f"{frame}_kernel_plain")}
        assert variants == len(built) == 2

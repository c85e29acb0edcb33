"""Errors that know their keyword, and the one table the command line words them with.

The library words its messages for a Python caller and builds those that name a keyword from
parts (:mod:`fieldmap.errors`: ``Keyword``, ``Label``, ``Setting``, ``Advice``, ``Pass``);
an :class:`~fieldmap.errors.InputError` about one carries it as ``param``.
:mod:`fieldmap.cli` maps keywords to options (:data:`fieldmap.cli.OPTIONS`) and the message
words itself with that table: nothing is searched for in its text. A keyword a message can name
but the table does not know would reach a command-line user as a Python keyword: the walks below
fail on it.
"""

from __future__ import annotations

import ast
import inspect
import pickle
from pathlib import Path

import numpy as np
import pytest

import fieldmap.nav
from fieldmap.cli import ADVICE, OPTIONS, wording_of
from fieldmap.errors import (
    PYTHON,
    Advice,
    InputError,
    Keyword,
    Label,
    Message,
    Metavar,
    Pass,
    Setting,
    Wording,
    worded,
)

NAV = Path(fieldmap.nav.__file__).parent
NAVSIM, TABLE = wording_of("navsim"), wording_of("table")
REFERENCES = ("Keyword", "Label", "Setting", "Pass")


def _param_names(tree: ast.AST) -> set[str]:
    """Return the keywords a module names: ``param=`` strings and keyword references' names."""

    def values(e: ast.expr) -> set[str]:
        if isinstance(e, ast.IfExp):
            return values(e.body) | values(e.orelse)
        if isinstance(e, ast.Constant) and isinstance(e.value, str):
            return {e.value}
        return set()  # a variable: its keywords are checked by the signature walk below

    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            out |= {v for kw in node.keywords if kw.arg == "param" for v in values(kw.value)}
            if getattr(node.func, "id", None) in REFERENCES and node.args:
                out |= values(node.args[0])
    return out


def _params_used() -> set[str]:
    """Return every keyword named by a message in :mod:`fieldmap.nav` (its packages too)."""
    used: set[str] = set()
    for path in sorted(NAV.rglob("*.py")):
        used |= _param_names(ast.parse(path.read_text(encoding="utf-8")))
    return used


def test_every_param_raised_in_nav_is_in_the_table():
    used = _params_used()
    assert used, "no param= found: the walk is broken"
    assert {"alt_units", "airborne_only", "reorder", "log_velocities"} <= used  # nav.logs
    assert {"frame", "output_dt", "block_s", "models", "draws"} <= used  # study, propagator
    assert {"min_speed_mps", "height_ref", "time_format", "vehicle", "rate_hz"} <= used  # parts
    assert not used - set(OPTIONS), f"keywords missing from cli.OPTIONS: {used - set(OPTIONS)}"


def test_every_keyword_of_the_log_functions_is_in_the_table():
    """A new keyword of a reader or of the conditioning must be added to the table."""
    from fieldmap.nav.logs import load_flight
    from fieldmap.nav.logs.condition import condition
    from fieldmap.nav.logs.read import read_track

    for func in (read_track, condition, load_flight):
        for p in inspect.signature(func).parameters.values():
            if p.kind is p.KEYWORD_ONLY:
                assert p.name in OPTIONS, f"{func.__name__}({p.name}=) missing from OPTIONS"


def test_every_keyword_of_the_flight_study_is_in_the_table():
    """A new keyword of :class:`~fieldmap.nav.study.FlightStudy` must be added to the table."""
    import dataclasses

    from fieldmap.nav.study import FlightStudy

    names = [f.name for f in dataclasses.fields(FlightStudy) if f.init]
    assert {"frame", "output_dt", "block_s", "models"} <= set(names)
    missing = [n for n in names if n not in OPTIONS]
    assert not missing, f"FlightStudy keywords missing from cli.OPTIONS: {missing}"


def test_the_table_names_real_options_and_settings():
    """Every option of the table is an option of ``fieldmap navsim``; advice keys are settings."""
    from fieldmap.cli import build_parser

    parser = build_parser("navsim")
    sub = next(a for a in parser._actions if getattr(a, "choices", None) and "navsim" in a.choices)
    navsim = {s for a in sub.choices["navsim"]._actions for s in a.option_strings}
    assert {o for o in OPTIONS.values() if o} <= navsim
    for key, text in ADVICE.items():
        name, _, value = key.partition("=")
        assert name in OPTIONS and value in ("True", "False"), key
        assert any(o in text for o in navsim), text


def test_input_error_param():
    assert InputError("x").param is None
    e = InputError("max_gap_s must be a positive number", param="max_gap_s")
    assert e.param == "max_gap_s" and str(e) == "max_gap_s must be a positive number"
    back = pickle.loads(pickle.dumps(e))  # through a Dask worker
    assert back.param == "max_gap_s" and str(back) == str(e)
    e = InputError("over 60 s", Label("max_gap_s"), Advice(": raise ", Keyword("max_gap_s")),
                   param="max_gap_s")  # fmt: skip
    back = pickle.loads(pickle.dumps(e))  # the parts travel with it
    assert str(back) == "over 60 s (max_gap_s): raise max_gap_s"
    assert back.worded(NAVSIM) == "over 60 s (--max-gap-s): raise --max-gap-s"


class _Track:
    def __init__(self, t, lat, h, source):
        self.t, self.lat, self.lon, self.h = t, lat, np.full(t.size, 8.0), h
        self.lines, self.source = np.arange(t.size) + 2, source


def _raised(func, *args, **kw) -> InputError:
    with pytest.raises(InputError) as e:
        func(*args, **kw)
    return e.value


def test_conditioning_errors_carry_their_keyword():
    from fieldmap.nav.logs.condition import Conditioning, condition

    k = np.arange(121.0)
    lat = 47.0 + k * 200.0 / 111_000.0
    assert _raised(Conditioning, max_gap_s=-1.0).param == "max_gap_s"
    t = k.copy()
    t[[1, 2]] = t[[2, 1]]
    e = _raised(condition, _Track(t, lat, 1e3 + k, "back.csv"), Conditioning(reorder=False))
    assert e.param == "reorder" and "pass reorder=True to sort the log" in str(e)
    taxi = _Track(k, 47.0 + k * 8.0 / 111_000.0, np.full(121, 400.0), "taxi.csv")
    e = _raised(condition, taxi, Conditioning(airborne_only=True))
    assert e.param == "airborne_only"
    assert "30 m/s (min_speed_mps)" in str(e) and "pass airborne_only=False" in str(e)


def test_worded_for_navsim_and_for_table():
    """The navsim wording names options; table (no such options) leaves the advice out."""
    from fieldmap.nav.logs.condition import Conditioning, condition

    k = np.arange(120.0)
    taxi = _Track(k, 47.0 + k * 5.0 / 111e3, np.full(120, 500.0) + 0.0 * k, "taxi.csv")
    e = _raised(condition, taxi, Conditioning(airborne_only=True))
    python = str(e)
    assert python.endswith("pass airborne_only=False to fly the ground movement")
    assert e.worded(PYTHON) == python
    navsim = e.worded(NAVSIM)
    assert "airborne_only" not in navsim and "leave out --airborne-only" in navsim
    assert "airborne_only" not in e.worded(TABLE)


@pytest.mark.parametrize(
    "parts, python, navsim, table",
    [
        # an advice by a switch (ADVICE), a label without an option
        (("x: slower than 30 m/s", Label("min_speed_mps"), " (2 of 9)",
          Advice("; ", Pass("airborne_only", False), " to keep it")),
         "x: slower than 30 m/s (min_speed_mps) (2 of 9); pass airborne_only=False to keep it",
         "x: slower than 30 m/s (2 of 9); leave out --airborne-only to keep it",
         "x: slower than 30 m/s (2 of 9)"),
        # a setting by an option with a value; two advices, each left out on its own
        (("feet read as metres?", Advice(" ", Pass("alt_units", "ft")),
          Advice(", or ", Pass("alt_units", "m"), " if these are metres")),
         "feet read as metres? pass alt_units='ft', or pass alt_units='m' if these are metres",
         "feet read as metres? give --alt-units ft, or give --alt-units m if these are metres",
         "feet read as metres?"),
        # an advice inside parentheses
        (("read as MSL (it is above the ellipsoid", Advice(": ", Pass("height_ref", "ellipsoid")),
          ")"),
         "read as MSL (it is above the ellipsoid: pass height_ref='ellipsoid')",
         "read as MSL (it is above the ellipsoid: give --height-ref ellipsoid)",
         "read as MSL (it is above the ellipsoid)"),
        # an advice with a keyword named in it
        (("t is late", Advice(": give their units with ", Keyword("time_format"), " (s, epoch)")),
         "t is late: give their units with time_format (s, epoch)",
         "t is late: give their units with --time-format (s, epoch)",
         "t is late"),
        # an advice without an option anywhere is left out; text without keywords stays
        (("more than 60 s", Label("max_gap_s"), ": raise the limit",
          Advice("; ", Pass("on_long_gap", "longest"), " to fly")),
         "more than 60 s (max_gap_s): raise the limit; pass on_long_gap='longest' to fly",
         "more than 60 s (--max-gap-s): raise the limit",
         "more than 60 s: raise the limit"),
        # keywords in a sentence: an option where there is one, the Python name where none
        ((Keyword("alt_units"), ": 'km' is not one of m, ft"),
         "alt_units: 'km' is not one of m, ft", "--alt-units: 'km' is not one of m, ft",
         "alt_units: 'km' is not one of m, ft"),
        ((Keyword("threshold"), " must be a positive number"),
         "threshold must be a positive number", "threshold must be a positive number",
         "threshold must be a positive number"),
        # settings outside an advice; a placeholder value
        (("baro altitude aiding needs ", Setting("frame", "ned")),
         "baro altitude aiding needs frame='ned'", "baro altitude aiding needs --frame ned",
         "baro altitude aiding needs frame='ned'"),
        (("vehicle: airliner (guessed", Advice("; ", Pass("vehicle", Metavar("CLASS")),
                                                " to choose"), ")"),
         "vehicle: airliner (guessed; pass vehicle=CLASS to choose)",
         "vehicle: airliner (guessed; give --vehicle CLASS to choose)",
         "vehicle: airliner (guessed)"),
        # an option named otherwise than the keyword
        ((Keyword("n_gauss"), " must be in 1..16, got 0"), "n_gauss must be in 1..16, got 0",
         "--gauss must be in 1..16, got 0", "n_gauss must be in 1..16, got 0"),
    ],
)  # fmt: skip
def test_wording(parts, python, navsim, table):
    msg = Message(*parts)
    assert str(msg) == python and msg == python  # a str: the Python wording
    assert msg.worded(NAVSIM) == navsim
    assert msg.worded(TABLE) == table
    e = InputError(*parts)
    assert str(e) == python and e.worded(NAVSIM) == navsim and e.worded(TABLE) == table


def test_text_is_never_searched():
    """Only keyword references are worded, never names found in the text.

    The same name in plain text (a path, a column header, a plain word) stays as written, even
    where it is the error's own keyword.
    """
    text = "flights/max_gap_s/columns.csv: column alt_units of table:models.bin"
    e = InputError(text, param="alt_units")
    assert e.worded(NAVSIM) == text
    e = InputError(f"{text}; ", Keyword("alt_units"), " given", param="alt_units")
    assert e.worded(NAVSIM) == f"{text}; --alt-units given"
    assert worded(text, NAVSIM) == text  # notes that are plain text


def test_substitute_replaces_advice_about_one_keyword_with_another():
    msg = Message("line 4 goes back", Advice("; ", Pass("reorder", True), " to sort"))
    new = msg.substitute(Pass("reorder", True), Pass("smooth", True))
    assert str(new) == "line 4 goes back; pass smooth=True to sort"
    assert new.worded(NAVSIM) == "line 4 goes back; leave out --no-smooth to sort"


def test_a_wording_of_its_own():
    """Another front end (a GUI, a config file) gives its own names for the keywords."""
    gui = Wording({"max_gap_s": "'largest gap'"})
    msg = Message("over 60 s", Label("max_gap_s"), Advice(": raise ", Keyword("max_gap_s")))
    assert msg.worded(gui) == "over 60 s ('largest gap'): raise 'largest gap'"


@pytest.mark.parametrize(
    "kw, param, navsim",
    [
        (dict(frame="lci", altitude_aiding="baro"), "frame",
         "baro altitude aiding needs --frame ned"),
        (dict(frame="x"), "frame", "--frame must be 'ned' or 'lci', got 'x'"),
        (dict(output_dt=0.0033), "output_dt",
         "output interval 0.0033 s is not a whole number of IMU samples at 200 Hz"),
        (dict(rate_hz=-1.0), "rate_hz", "--rate must be a positive number, got -1.0"),
        (dict(duration=1e9), "duration", "--duration 1e+09 s does not fit the flight (201 s)"),
        (dict(draws=0), "draws", "--draws must be within 1..10000, got 0"),
        (dict(n_gauss=0), "n_gauss", "--gauss must be in 1..16, got 0"),
        (dict(rate_hz=1e7, block_s=201.0), "block_s",
         "a block of 201 s at 1e+07 Hz is 2.01e+09 IMU samples, more than 2000000: lower --rate "
         "or --block-s"),
    ],
)  # fmt: skip
def test_flight_study_errors_carry_their_keyword(kw, param, navsim):
    """FlightStudy words its refusals in Python; ``fieldmap navsim`` shows them with options."""
    from fieldmap.cli import _worded
    from fieldmap.nav.study import FlightStudy
    from fieldmap.nav.trajectory import FlightTrajectory, route_flight

    traj = FlightTrajectory(route_flight("47,8,1000;47.3,8.3,1000", 200.0))
    kw = dict(imu="tactical", models="j4", draws=2, truth_lmax=20) | kw
    e = _raised(FlightStudy, traj, **kw)
    assert e.param == param
    assert _worded(e, "navsim") == navsim
    # table has none of these options: keywords keep their Python names, advice is left out
    assert _worded(e, "table") == str(e).replace(": lower rate_hz or block_s", "")


def test_conditioning_notes_leave_no_python_advice_on_the_command_line():
    """Every note of a conditioned real log, as navsim prints it, gives options, not keywords."""
    from fieldmap.nav.logs.condition import condition
    from fieldmap.nav.logs.read import read_track

    adsb = Path(__file__).parent / "data" / "adsb"
    cf = condition(read_track(adsb / "noisy_takeoff.csv.gz", height_ref="pressure"))
    notes = [worded(n, NAVSIM) for n in cf.report["notes"]]
    assert any("give --vehicle CLASS" in n for n in notes), notes
    assert not [n for n in notes if "pass " in n and "=" in n], notes
    python = " ".join(cf.report["notes"])
    assert "pass vehicle=CLASS" in python

"""Bad flight input to ``fieldmap navsim`` and ``fieldmap table --corridor``: one line, exit 2.

The cases of the CLI audit (``/tmp/audit_cli.md``, items 1.2, 2.1, 2.2, 2.7, 2.8, 3.5, 3.6, 4.2,
4.5, 4.6 and 5): a flight that is no flight, impossible values, duplicates, options that do
nothing where they are given, and messages that must name the file, line and column, the units
guessed, and the CLI options (never Python keywords). Each CLI case runs ``fieldmap.cli.main``
in this process (fast: Warp and the model are loaded once) on tiny logs written to ``tmp_path``
and asserts: exit status 2, exactly one line on stderr holding the key words, nothing on stdout,
no output folder. One case runs the real program (``python -m fieldmap``).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from refusals import refused

from fieldmap.cli import main
from fieldmap.errors import InputError

HEADER = "time_s,lat_deg,lon_deg,height_m"
ROUTE = "47,8,1000;47.1,8.1,1000"
#: a tiny flight study: truth degree 20, one model, a low IMU rate
FAST = ["--lmax", "20", "--models", "j4", "--rate", "10", "--no-timing"]


def _flight(path: Path, n: int = 121, *, t=None, lat=None, h=None, extra: str = "") -> Path:
    """Write a 1 Hz flight north at 200 m/s climbing 2 m/s (fieldmap CSV) and return its path.

    ``t``, ``lat``, ``h``: arrays replacing the times, latitudes, heights; ``extra``: more
    columns (header and a constant value, ``"roll_deg,pitch_deg,heading_deg|0,0,0"``).
    """
    k = np.arange(n, dtype=np.float64)
    t = k if t is None else t
    lat = 47.0 + k * 200.0 / 111_000.0 if lat is None else lat
    h = 1000.0 + 2.0 * k if h is None else h
    head, value = extra.split("|") if extra else ("", "")
    rows = [HEADER + (f",{head}" if head else "")]
    rows += [f"{a:.17g},{b:.12f},8.0,{c:.17g}" + (f",{value}" if value else "")
             for a, b, c in zip(t, lat, h)]  # fmt: skip
    path.write_text("\n".join(rows) + "\n")
    return path


def _navsim(*args) -> list[str]:
    return ["navsim", *FAST, *args]


# ------------------------------------------------------------------------------------ 1.2
def test_times_read_as_epoch_ms_beyond_year_9999(tmp_path, capsys):
    """``time_s`` ~1e15 was taken for epoch ms and then failed with a ValueError (exit 3)."""
    f = _flight(tmp_path / "huge_t.csv", t=1e15 + np.arange(121.0))
    refused(
        _navsim("--trajectory", str(f)),
        tmp_path,
        capsys,
        "huge_t.csv line 2 column time_s",
        "epoch milliseconds",
        "guessed",
        "year 9999",
        "--time-format",
        absent=("time_format",),
    )


# ------------------------------------------------------------------------------ 2.1, 2.2
@pytest.mark.parametrize(
    "option",
    [["--max-gap-s", "10"], ["--position-noise-m", "5"], ["--keep-ground"], ["--airborne-only"]],
)
def test_conditioning_options_refused_with_no_smooth(tmp_path, capsys, option):
    """``--no-smooth`` turns the conditioning off: its options did nothing (exit 0)."""
    f = _flight(tmp_path / "good.csv")
    argv = _navsim("--trajectory", str(f), "--no-smooth", *option)
    refused(argv, tmp_path, capsys, option[0], "--no-smooth")


def _netcdf_flight(path: Path) -> Path:
    import xarray as xr

    k = np.arange(61.0)
    cols = {"time_s": k, "lat_deg": 47.0 + k * 200.0 / 111_000.0, "lon_deg": np.full(61, 8.0)}
    cols["height_m"] = 1000.0 + 2.0 * k
    xr.Dataset({c: ("time", v) for c, v in cols.items()}).to_netcdf(path)
    return path


@pytest.mark.parametrize(
    "option",
    [
        ["--no-smooth"],
        ["--max-gap-s", "10"],
        ["--position-noise-m", "5"],
        ["--keep-ground"],
        ["--airborne-only"],
    ],
)
@pytest.mark.parametrize("kind", ["attitude-csv", "netcdf"])
def test_conditioning_options_refused_for_flights_flown_as_recorded(tmp_path, capsys, option, kind):
    """A fieldmap CSV with attitude columns or a NetCDF flight is not conditioned."""
    if kind == "netcdf":
        f = _netcdf_flight(tmp_path / "flight.nc")
    else:
        f = _flight(tmp_path / "att.csv", n=61, extra="roll_deg,pitch_deg,heading_deg|0,0,0")
    argv = _navsim("--trajectory", str(f), *option)
    refused(argv, tmp_path, capsys, option[0], f.name, "flown as recorded")


# ------------------------------------------------------------------------------------ 2.7
def test_empty_imurefused(tmp_path, capsys):
    """``--imu ""`` silently flew the ideal IMU."""
    argv = _navsim("--route", ROUTE, "--speed-mps", "200", "--imu", "")
    refused(argv, tmp_path, capsys, "--imu", "empty")


# ------------------------------------------------------------------------------------ 2.8
def _table(tmp_path: Path) -> Path:
    """Write a table of zeros around the flights here (45..50 N, 6..10 E, 0..4 km)."""
    from fieldmap.products.tables.files import binary_bytes
    from fieldmap.products.tables.model import CompensationTable

    tab = CompensationTable(
        lat0=45.0, dlat=1.0, lon0=6.0, dlon=1.0, h0=0.0, dh=2000.0, data=np.zeros((3, 6, 5, 3))
    )
    path = tmp_path / "table.bin"
    path.write_bytes(binary_bytes(tab))
    return path


@pytest.mark.parametrize(
    "models, words",
    [
        ("j4,j4", ("'j4' given twice",)),
        ("j4,J4", ("given twice",)),
        ("table:{t},table:{t}", ("given twice",)),
        ("table:{t},table:{d}/./table.bin", ("the same model",)),
    ],
)
def test_models_named_twicerefused(tmp_path, capsys, models, words):
    """``--models j4,j4`` and one table twice were flown (twice) without a word."""
    t = _table(tmp_path)
    f = _flight(tmp_path / "good.csv")
    models = models.format(t=t, d=tmp_path)
    argv = ["navsim", "--lmax", "20", "--rate", "10", "--models", models, "--trajectory", str(f)]
    refused(argv, tmp_path, capsys, *words)


def test_one_column_for_two_fieldsrefused(tmp_path, capsys):
    """``--columns ...,lat=LA,lon=LA`` flew the latitudes as longitudes."""
    f = _flight(tmp_path / "good.csv")
    cols = "time=time_s,lat=lat_deg,lon=lat_deg,alt=height_m"
    argv = _navsim("--trajectory", str(f), "--columns", cols)
    refused(argv, tmp_path, capsys, "--columns", "'lat_deg'", "lat and lon")


def test_header_repeating_a_columnrefused(tmp_path, capsys):
    """A header naming ``height_m`` twice is refused (which one is the height?)."""
    f = _flight(tmp_path / "dup.csv", extra="height_m|5000")
    argv = _navsim("--trajectory", str(f))
    refused(argv, tmp_path, capsys, "dup.csv", "'height_m' more than once", "fields 4, 5")


def test_repeated_columns_that_are_not_read_are_fine(tmp_path):
    """Only a column read is ambiguous: ``note,note`` flies; ``lat_deg,LAT_DEG`` does not."""
    from fieldmap.nav.logs.read import read_track

    f = _flight(tmp_path / "notes.csv", extra="note|a")
    text = f.read_text().splitlines()
    text = [text[0] + ",note"] + [r + ",b" for r in text[1:]]
    f.write_text("\n".join(text) + "\n")
    assert read_track(f).t.size == 121
    g = tmp_path / "lat.csv"
    rows = f.read_text().splitlines()
    g.write_text("\n".join([rows[0] + ",LAT_DEG"] + [r + ",1.0" for r in rows[1:]]) + "\n")
    with pytest.raises(InputError, match="column .lat_deg. more than once .fields 2, 7."):
        read_track(g)


# ------------------------------------------------------------------------------------ 3.5
@pytest.mark.parametrize("option", [["--no-smooth"], ["--keep-ground"], []])
def test_vehicle_that_never_moves_is_no_flight(tmp_path, capsys, option):
    """121 identical positions were simulated with ``--no-smooth`` or ``--keep-ground``."""
    f = _flight(tmp_path / "still.csv", lat=np.full(121, 47.0), h=np.full(121, 1000.0))
    argv = _navsim("--trajectory", str(f), *option)
    refused(argv, tmp_path, capsys, "still.csv lines 2..122", "not a flight", "never moves")


# ------------------------------------------------------------------------------------ 3.6
def test_corridor_table_must_hold_its_flight(tmp_path, capsys):
    """A corridor table at 10..20 km for a flight at 1000..1240 m, refused later by navsim."""
    f = _flight(tmp_path / "good.csv")
    argv = ["table", "--lmax", "20", "--corridor", str(f), "--height-km", "10,20"]
    line = refused(
        [*argv, "--max-error-mgal", "5"],
        tmp_path,
        capsys,
        "--height-km 10,20",
        "--corridor",
        "at t = 0 s",
        "as navsim flies it",
        "give at least --height-km 0.9,20",
    )
    assert "height_ref" not in line


def test_corridor_heights_are_checked_on_the_path_navsim_flies(tmp_path, capsys, monkeypatch):
    """One altitude spike, removed by the conditioning, asks for no taller table."""
    from fieldmap.cli import table as cli_table

    h = 1000.0 + 2.0 * np.arange(121.0)
    h[60] = 9000.0  # an ADS-B altitude glitch
    f = _flight(tmp_path / "spike.csv", h=h)
    cli_table._check_corridor_heights(f, [800.0, 1400.0])  # accepted, as navsim would
    with pytest.raises(InputError, match="give at least --height-km 0.9,1.4"):
        cli_table._check_corridor_heights(f, [1000.0, 1400.0])


def test_corridor_flight_refusal_advises_no_option_table_lacks(tmp_path, capsys):
    """``table --corridor`` reads its flight with the defaults: no advice to set a keyword."""
    k = np.arange(121.0)
    f = _flight(tmp_path / "still.csv", lat=np.full(121, 47.0), h=np.full(121, 1000.0) + 0 * k)
    argv = ["table", "--lmax", "20", "--corridor", str(f), "--height-km", "0,5"]
    refused(
        [*argv, "--max-error-mgal", "5"],
        tmp_path,
        capsys,
        "still.csv lines 2..122",
        "not a flight",
        absent=("airborne_only", "--airborne-only", "pass "),
    )


# ------------------------------------------------------------------------------------ 4.2
def test_going_back_with_no_smooth_names_the_option(tmp_path, capsys):
    """The advice was "pass reorder=True to sort the log": there is no such option."""
    t = np.arange(121.0)
    t[[1, 2]] = t[[2, 1]]
    f = _flight(tmp_path / "back.csv", t=t)
    argv = _navsim("--trajectory", str(f), "--no-smooth")
    refused(argv, tmp_path, capsys, "back.csv line 4", "leave out --no-smooth", absent=("reorder",))


def test_library_messages_name_its_keywords(tmp_path):
    """From Python the same refusals name the keywords of the function called."""
    from fieldmap.errors import InputError
    from fieldmap.nav.logs import load_flight
    from fieldmap.nav.logs.condition import Conditioning

    t = np.arange(121.0)
    t[[1, 2]] = t[[2, 1]]
    f = _flight(tmp_path / "back.csv", t=t)
    with pytest.raises(InputError, match=r"back.csv line 4: .*; pass smooth=True to sort"):
        load_flight(f, Conditioning(smooth=False))  # unsmoothed, reorder= is off: smooth= sorts
    k = np.arange(121.0)
    taxi = _flight(tmp_path / "taxi.csv", lat=47.0 + k * 8.0 / 111_000.0, h=np.full(121, 400.0))
    with pytest.raises(InputError, match=r"30 m/s \(min_speed_mps\).*pass airborne_only=False"):
        load_flight(taxi, Conditioning(airborne_only=True))
    assert load_flight(taxi)[0] is not None  # the whole log is flown by default


def test_ground_only_log_names_airborne_only(tmp_path, capsys):
    """The advice "pass airborne_only=False" is to leave out --airborne-only."""
    k = np.arange(121.0)
    f = _flight(tmp_path / "taxi.csv", lat=47.0 + k * 8.0 / 111_000.0, h=np.full(121, 400.0))
    argv = _navsim("--trajectory", str(f), "--airborne-only")
    refused(
        argv,
        tmp_path,
        capsys,
        "no airborne part",
        "leave out --airborne-only",
        absent=("airborne_only", "min_speed_mps"),
    )


def test_keep_ground_and_airborne_only_refused_together(tmp_path, capsys):
    """--keep-ground (the default now) flies the ground, --airborne-only trims it."""
    f = _flight(tmp_path / "good.csv")
    argv = _navsim("--trajectory", str(f), "--keep-ground", "--airborne-only")
    refused(argv, tmp_path, capsys, "--keep-ground", "--airborne-only", "give one")


def test_sparse_log_flown_with_its_gaps_listed(tmp_path, capsys):
    """Twelve fixes 100 s apart: flown (gaps are the model's prediction), each gap listed."""
    k = np.arange(12.0)
    f = _flight(tmp_path / "sparse.csv", n=12, t=100.0 * k, lat=47.0 + k * 0.18)
    rc = main([*_navsim("--trajectory", str(f)), "--out", str(tmp_path / "out")])
    out = capsys.readouterr().out
    assert rc == 0 and "gap: lines 2..3 (100 s" in out and out.count("gap: lines") == 11


def test_reader_notes_name_the_cli_options(tmp_path):
    """An IGC note said "give height_ref='msl'"; from the CLI it names --height-ref msl."""
    from fieldmap.cli import wording_of
    from fieldmap.errors import worded
    from fieldmap.nav.logs.read import read_track

    rows = ["AXXX001", "HFDTE010124"]
    rows += [
        f"B1200{s:02d}47{int(s * 108):05d}N00800000EA01000{1000 + 2 * s:05d}" for s in range(30)
    ]
    igc = tmp_path / "f.igc"
    igc.write_text("\n".join(rows) + "\n")
    python = " ".join(read_track(igc).notes)
    cli = " ".join(worded(note, wording_of("navsim")) for note in read_track(igc).notes)
    table = " ".join(worded(note, wording_of("table")) for note in read_track(igc).notes)
    assert "pass height_ref='msl'" in python
    assert "give --height-ref msl" in cli and "height_ref" not in cli
    assert table.endswith("no HFALG header)") and "height_ref" not in table


# ------------------------------------------------------------------------------------ 4.5
def test_no_smooth_across_a_long_gap_names_the_lines(tmp_path, capsys):
    """The quintic across a 100,000 s gap dives 300 km: "ECEF point more than 10000 m below".

    The log goes on for 160,000 s after the gap (one recording, not two: see
    ``condition.recordings_apart``).
    """
    n = 221
    t = np.arange(float(n))
    t[61:] = 100_060.0 + 1000.0 * np.arange(n - 61)
    f = _flight(tmp_path / "gap.csv", n=n, t=t)
    argv = _navsim("--trajectory", str(f), "--no-smooth")
    refused(argv, tmp_path, capsys, "gap.csv lines 62..63", "without samples", absent=("ECEF",))


def test_impossible_height_names_file_line_and_column(tmp_path, capsys):
    """``height_m`` = -50000 m gave "launch height h0 must be ..." without file or line."""
    h = 1000.0 + 2.0 * np.arange(121.0)
    h[60] = -50_000.0
    f = _flight(tmp_path / "deep.csv", h=h)
    argv = _navsim("--trajectory", str(f))
    refused(argv, tmp_path, capsys, "deep.csv line 62 column height_m", "-50000 m", absent=("h0",))


# ------------------------------------------------------------------------------------ 4.6
def test_route_climbing_on_the_spot_is_worded_for_what_it_is(tmp_path, capsys):
    """Waypoints at one place but different heights were said to "coincide"."""
    argv = _navsim("--route", "47,8,1000;47,8,5000", "--speed-mps", "200")
    refused(argv, tmp_path, capsys, "waypoints 1 and 2", "same point", absent=("coincide",))


def test_route_too_fast_is_worded_for_a_route(tmp_path, capsys):
    """A route is no file: "route line 2 column lat_deg" named neither line nor column."""
    argv = _navsim("--route", "0,0,1000;0,180,1000", "--speed-mps", "200000")
    refused(argv, tmp_path, capsys, "route:", "ground speed", absent=("line", "column"))


def test_failure_after_a_guess_of_the_time_units_says_so(tmp_path, capsys):
    """Times 1.7e12 + i are read as epoch ms; the failure that follows must say so."""
    f = _flight(tmp_path / "ms.csv", t=1.7e12 + np.arange(121.0))
    argv = _navsim("--trajectory", str(f))
    refused(argv, tmp_path, capsys, "ms.csv", "epoch milliseconds", "guessed", "--time-format s")


# -------------------------------------------------------------------------------------- 5
@pytest.mark.parametrize(
    "args, words",
    [
        (["--route", ROUTE, "--speed-mps", "200", "--models", "j4", "--rate", "1e7"],
         ("--rate", "--block-s")),
        (["--study", "table1", "--models", "j2", "--duration", "10", "--rate", "20",
          "--output-dt", "3"], ("--output-dt",)),
        (["--route", ROUTE, "--speed-mps", "200", "--models", "exact", "--draws", "3"],
         ("--draws",)),
    ],
)  # fmt: skip
def test_refusal_is_the_only_line(tmp_path, capsys, args, words):
    """No progress bar, no warning before the refusal: it comes before any work."""
    refused(["navsim", "--lmax", "20", *args], tmp_path, capsys, *words)


def test_two_tables_refused_before_any_work(tmp_path, capsys):
    """Two different tables were refused after the progress bar had started."""
    a = _table(tmp_path)
    b = tmp_path / "b.bin"
    b.write_bytes(a.read_bytes())
    f = _flight(tmp_path / "good.csv")
    models = f"j4,table:{a},table:{b}"
    argv = ["navsim", "--lmax", "20", "--rate", "10", "--models", models, "--trajectory", str(f)]
    refused(argv, tmp_path, capsys, "--models", "one compensation table per launch")


# ---------------------------------------------------------------------------- the program
def test_the_program_itself(tmp_path):
    """``python -m fieldmap``: the refusal is one line on stderr and exit status 2."""
    f = _flight(tmp_path / "good.csv")
    out = tmp_path / "out"
    argv = [sys.executable, "-m", "fieldmap", *_navsim("--trajectory", str(f)), "--no-smooth"]
    run = subprocess.run(
        [*argv, "--keep-ground", "--out", str(out)], capture_output=True, text=True, timeout=300
    )
    assert run.returncode == 2, run.stderr
    assert run.stderr.strip().splitlines() == [
        "fieldmap navsim: error: --keep-ground applies to the conditioning of the log, which "
        "--no-smooth turns off (the samples are flown as they are)"
    ]
    assert run.stdout == "" and not out.exists()


def test_corrupt_gzip_flight_log(tmp_path, capsys):
    """A gzip header followed by no deflate stream (zlib.error) was an internal error."""
    bad = tmp_path / "bad.csv.gz"
    bad.write_bytes(b"\x1f\x8b\x08\x00garbagegarbage")
    refused(_navsim("--trajectory", str(bad)), tmp_path, capsys, "bad.csv.gz", "broken gzip")


def test_flight_height_limits_are_not_rounded_onto(tmp_path):
    """A route height just past the limit is named as it is (not "-11000 m is outside -11 km")."""
    from fieldmap.errors import InputError
    from fieldmap.nav.trajectory import route_flight

    with pytest.raises(InputError, match=r"height -11000.0004 m is outside"):
        route_flight("47,8,1000;47.1,8.1,-11000.0004", 200.0)

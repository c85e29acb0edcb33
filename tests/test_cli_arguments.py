"""The command line as the shell hands it over, and write errors that name their file.

Repeated options, value lists starting with a minus sign, a missing command, closed standard
output.
CLI cases run ``fieldmap.cli.main`` in this process from an empty working folder and check the
exit status, one line on stderr and no file written (as ``test_bad_input_cli.py``); the real
console script runs where the process itself matters (no command, stdout closed).
"""

from __future__ import annotations

import errno
import subprocess
import sys

import pytest

from fieldmap import cli
from fieldmap.products import io


def _run(argv, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    rc = cli.main(argv)
    out, err = capsys.readouterr()
    return rc, out, err


@pytest.mark.parametrize(
    "argv, first",
    [
        (["map", "--height-km", "20", "--height-km", "50", "--step-deg", "30"], "--height-km"),
        (["map", "--step-deg", "30", "--step-deg=20"], "--step-deg"),
        (["navsim", "--models", "j2", "--models", "j4"], "--models"),
        (["sweep", "--region", "0", "10", "0", "10", "--region", "5", "15", "5", "15"], "--region"),
        (["point", "--lmax", "10", "--lmax", "240"], "--lmax"),
        (["navsim", "--alt-units", "m", "--alt-units", "ft"], "--alt-units"),  # in a group
    ],
)
def test_an_option_given_twice_is_refused(argv, first, capsys, tmp_path, monkeypatch):
    """The second value would silently replace the first: one line, exit 2, nothing written."""
    with pytest.raises(SystemExit) as exc:
        _run(argv, capsys, tmp_path, monkeypatch)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{first} given again" in err and "once" in err
    assert list(tmp_path.iterdir()) == []


def test_every_value_option_of_every_command_is_given_once():
    """Options added in argument groups too: each value option of each sub-command is wrapped."""
    import argparse

    parser = cli.build_parser()
    subs = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    plain = []
    for name, sub in subs.choices.items():
        for action in sub._actions:
            if action.option_strings and action.nargs != 0:
                if not isinstance(action, argparse._AppendAction):
                    if not getattr(type(action), "_once", False):
                        plain.append(f"{name} {action.option_strings[0]}")
    assert plain == []


def test_flags_and_single_options_still_parse():
    """Flags may repeat (nothing is dropped); every value option given once parses as before."""
    parser = cli.build_parser("map")
    args = cli._parse(parser, ["map", "--no-plots", "--no-plots", "--height-km", "20"])
    assert args.no_plots is True and args.height_km == ["20"]
    assert not hasattr(args, cli._SEEN)
    assert cli.given_options(["map", "--height-km", "20"]) >= {"height_km"}


@pytest.mark.parametrize(
    "argv, joined",
    [
        (["navsim", "--route", "-33.9,151.2,1000;-33.8,151.3,1000"], "--route=-33.9,151.2,"),
        (["sweep", "--height-km", "-5,10"], "--height-km=-5,10"),
        (["map", "--thresholds-mg", "-.1,0.2"], "--thresholds-mg=-.1,0.2"),
        (["navsim", "--route", "-33.9 151.2 1000;-33.8 151.3 1000"], "--route=-33.9 151.2"),
    ],
)
def test_value_lists_starting_with_a_minus_sign(argv, joined):
    """A list whose first number is negative is the option's value, not an unknown option."""
    parser = cli.build_parser(argv[0])
    out = cli._joined_negative_values(parser, argv)
    assert len(out) == 2 and out[1].startswith(joined)


def test_minus_tokens_that_stay_as_they_are():
    """A lone negative number (argparse reads it), a flag, an option name, text after ``--``."""
    parser = cli.build_parser("sweep")
    for argv in (
        ["sweep", "--height-km", "-5"],
        ["sweep", "--no-plots", "-5,10"],
        ["sweep", "--height-km", "--step-deg"],
        ["sweep", "--", "--height-km", "-5,10"],
    ):
        assert cli._joined_negative_values(parser, argv) == argv


def test_sweep_from_below_the_ellipsoid(capsys, tmp_path, monkeypatch):
    """``--height-km -5,10`` runs (README: lists take spaces or commas)."""
    argv = ["sweep", "--step-deg", "45", "--lmax", "4", "--height-km", "-5,10", "--no-plots"]
    rc, out, err = _run([*argv, "--out", str(tmp_path / "o")], capsys, tmp_path, monkeypatch)
    assert rc == 0, err
    assert "-5" in out and len(list((tmp_path / "o").glob("sweep_*.nc"))) == 1


def test_gradient_normal_refuses_model_options(capsys, tmp_path, monkeypatch):
    """No model enters the exact normal gravity: --lmax (or --model...) would do nothing."""
    argv = ["map", "--step-deg", "45", "--quantity", "gradient-normal", "--lmax", "20"]
    rc, out, err = _run(argv, capsys, tmp_path, monkeypatch)
    assert rc == 2 and err.count("\n") == 1
    assert "--lmax" in err and "gradient-normal" in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "line, words",
    [
        ("3_0 0 0", "latitude '3_0' is not a number"),
        ("0 0 -10000.001", "height -10000.001 m is below -10000 m"),
        ("0 -540.0000001 0", "got -540.0000001"),
        ("0 0 100000001", "height 100000001.0 m is above 1e+08 m"),
    ],
)
def test_point_lines_named_exactly(line, words, capsys, tmp_path, monkeypatch):
    """Underscores are no digits; a value just past a limit is not rounded onto it."""
    monkeypatch.setattr(sys, "stdin", __import__("io").StringIO(line + "\n"))
    rc, out, err = _run(["point", "--lmax", "2"], capsys, tmp_path, monkeypatch)
    assert rc == 1
    assert out.startswith("ERROR: ") and words in out and words in err  # line, summary


def _script(*args, **kw):
    return subprocess.run(
        [sys.executable, "-m", "fieldmap", *args], capture_output=True, text=True, **kw
    )


def test_no_command_is_one_line_on_stderr():
    proc = _script()
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and "a command is needed" in proc.stderr


def test_closed_stdout_is_one_line():
    proc = subprocess.run(
        f"echo '30 0 0' | {sys.executable} -m fieldmap point --lmax 2 >&-",
        shell=True,
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == ["fieldmap point: error: standard output is closed"]


def test_write_errors_name_the_file(tmp_path):
    """A full disk (no file name in the error) and the NetCDF library's error name the file."""
    final = tmp_path / "map.nc"
    with pytest.raises(OSError) as exc, io.writing(final):
        raise OSError(errno.ENOSPC, "No space left on device")
    assert exc.value.filename == str(final) and exc.value.errno == errno.ENOSPC
    with pytest.raises(OSError) as exc, io.writing(final):
        raise OSError(errno.ENOSPC, "No space left on device", str(tmp_path / ".map.nc.x.tmp"))
    assert exc.value.filename == str(final)
    with pytest.raises(OSError) as exc, io.writing(final):
        raise RuntimeError("NetCDF: HDF error")
    assert exc.value.filename == str(final) and "disk full" in exc.value.strerror
    with pytest.raises(OSError) as exc, io.writing(final):
        raise FileNotFoundError(errno.ENOENT, "No such file or directory", "/elsewhere")
    assert exc.value.filename == "/elsewhere"  # a file of its own: kept
    with pytest.raises(OSError) as exc, io.writing(final):  # inside a temporary zarr folder
        raise OSError(errno.ENOSPC, "No space left on device", str(tmp_path / ".m.zarr.x.tmp/up/0"))
    assert exc.value.filename == str(final)
    with pytest.raises(TimeoutError) as exc, io.writing(final):  # not a write: as it is
        raise TimeoutError("Timed out trying to connect to tcp://10.0.0.1:8786")
    assert exc.value.filename is None
    with pytest.raises(ConnectionResetError), io.writing(final):
        raise ConnectionResetError(errno.ECONNRESET, "Connection reset by peer")
    with pytest.raises(RuntimeError, match="other"), io.writing(final):
        raise RuntimeError("other")


def test_figure_view_keeps_the_products_step(tmp_path):
    """A thinned view for figures keeps the product's grid_step_deg (its JSON summary says it)."""
    import numpy as np
    import xarray as xr

    from fieldmap.products import sinks
    from fieldmap.products.plots import node_step

    lat, lon = np.arange(-60.0, 60.01, 0.5), np.arange(-180.0, 180.0, 0.5)
    ds = xr.Dataset(
        {"up": (("latitude", "longitude"), np.zeros((lat.size, lon.size)))},
        coords={"latitude": lat, "longitude": lon},
        attrs={"grid_step_deg": 0.5},
    )
    ds.to_netcdf(tmp_path / "p.nc")
    view = sinks.decimated(tmp_path / "p.nc", "netcdf", max_nodes=10_000)
    s = view.attrs["figure_decimation"]
    assert s == 5 and view.attrs["grid_step_deg"] == 0.5  # ceil(sqrt(241 * 720 / 1e4))
    assert node_step(view) == 2.5 == float(view["longitude"][1] - view["longitude"][0])
    full = sinks.decimated(tmp_path / "p.nc", "netcdf")
    assert "figure_decimation" not in full.attrs and node_step(full) == 0.5


def test_table_with_nan_values_is_named(tmp_path):
    """A table.bin holding NaN: the one line names the file."""
    import numpy as np

    from fieldmap.errors import InputError
    from fieldmap.products.tables import files as table_io
    from fieldmap.products.tables import model as table_model

    good = table_model.CompensationTable(
        0.0, 1.0, 0.0, 1.0, 0.0, 1000.0, np.zeros((2, 4, 4, 3)), {"lmax": 10}
    )
    raw = bytearray(table_io.binary_bytes(good))
    raw[-4:] = np.array([np.nan], dtype="<f4").tobytes()
    path = tmp_path / "table.bin"
    path.write_bytes(bytes(raw))
    with pytest.raises(InputError, match=rf"^{path}: compensation table: values not finite"):
        table_model.load_table(path)


@pytest.mark.parametrize(
    "argv, unknown",
    [
        # --height is a prefix of --height-km: once taken as 10,000 km
        (["map", "--height", "10000", "--step-deg", "5"], "--height"),
        # --speed is a prefix of --speed-mps
        (["navsim", "--speed", "200"], "--speed"),
        (["point", "--quant", "gravity"], "--quant"),
        (["imu", "allan", "--dur", "10"], "--dur"),
    ],
)
def test_an_abbreviated_option_is_refused(argv, unknown, capsys, tmp_path, monkeypatch):
    """A prefix of an option is an unknown option: one line naming it, exit 2, nothing written."""
    with pytest.raises(SystemExit) as exc:
        _run(argv, capsys, tmp_path, monkeypatch)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "unrecognized arguments" in err, err
    assert f"{unknown} " in err
    assert list(tmp_path.iterdir()) == []


def _all_parsers(parser):
    import argparse

    yield parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in {id(p): p for p in action.choices.values()}.values():
                yield from _all_parsers(sub)


def test_every_parser_refuses_abbreviations():
    """``allow_abbrev`` is False on the top parser and on every sub-command, nested ones too."""
    parsers = list(_all_parsers(cli.build_parser()))
    names = {p.prog for p in parsers}
    assert {"fieldmap", "fieldmap map", "fieldmap navsim", "fieldmap imu allan"} <= names
    assert [p.prog for p in parsers if p.allow_abbrev] == []
